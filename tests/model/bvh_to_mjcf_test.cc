// BVH -> MJCF characters: they load, weigh the total mass, and their "start" keyframe puts the
// bodies where the reference motion's forward kinematics does.
#include "model/bvh_to_mjcf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/mujoco/mujoco_engine.h"
#include "engine/world_spec.h"
#include "motion/clip_conventions.h"
#include "test_support.h"

namespace stance {
namespace {

// loads the character, applies its start keyframe and checks it against the reference
void check_character(const BvhClip& clip, const BvhCharacterOptions& o, const std::string& tag) {
  BvhCharacter ch = make_bvh_character(clip, o);
  std::string path = test::write_temp_file(tag + ".xml", ch.mjcf);
  WorldSpec spec;
  spec.models.push_back({path});
  auto engine = make_mujoco_engine(spec);
  const MotionSkeleton& sk = ch.skeleton;
  EXPECT_EQ(engine->nbody(), sk.segment_count());
  EXPECT_EQ(engine->nv(), 3 * sk.segment_count() + 3);
  EXPECT_NEAR(engine->total_mass(), o.total_mass_kg, 1e-6 * o.total_mass_kg);
  EXPECT_NEAR(engine->timestep(), o.timestep_s, 1e-15);
  for (const auto& seg : sk.segments) EXPECT_GE(engine->body_index(seg.name), 0) << seg.name;

  auto* mj = dynamic_cast<MujocoEngine*>(engine.get());
  ASSERT_NE(mj, nullptr);
  int key = mj_name2id(mj->model(), mjOBJ_KEY, "start");
  ASSERT_GE(key, 0);
  mj_resetDataKeyframe(mj->model(), mj->data(), key);
  mj->invalidate();
  engine->forward();
  ReferenceMotion ref(clip, sk, o.reference);
  ReferencePose pose = ref.make_pose();
  ref.sample(0, pose);
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  ref.forward_kinematics(pose, pos, rot);
  for (int k = 0; k < sk.segment_count(); ++k) {
    BodyPose b = engine->body_pose(engine->body_index(sk.segments[k].name));
    EXPECT_NEAR((b.pos - pos[k]).norm(), 0, 1e-6) << sk.segments[k].name;
    EXPECT_LT(b.quat.angularDistance(rot[k]), 1e-6) << sk.segments[k].name;
  }
  // nothing starts inside the floor (ground alignment): contacts are at most touching
  for (int i = 0; i < engine->num_contacts(); ++i) EXPECT_GT(engine->contact(i).pos.z(), -0.01);
}

TEST(BvhToMjcf, SyntheticWalkCharacter) {
  BvhClip clip = make_synthetic_walk_clip();
  BvhCharacterOptions o;
  check_character(clip, o, "synthetic_walk");
  o.total_mass_kg = 55;
  o.reference.first_frame = 20;
  check_character(clip, o, "synthetic_walk_55");
  BvhCharacter ch = make_bvh_character(clip, o);
  EXPECT_NE(ch.mjcf.find("type=\"box\""), std::string::npos);      // feet
  EXPECT_NE(ch.mjcf.find("type=\"capsule\""), std::string::npos);  // limbs
  EXPECT_NE(ch.mjcf.find("<freejoint name=\"root\"/>"), std::string::npos);
  o.total_mass_kg = 0;
  EXPECT_THROW(make_bvh_character(clip, o), InputError);
}

// --human-limits: each joint's limit is its group's peak torque per kg times the mass; without it
// the character has no limits. MuJoCo only: DART's backend reads no force limit on a ball joint
// (engine/dart: add_joint gets none for BallJoint)
TEST(BvhToMjcf, HumanLimitsWrittenAndScaledByMass) {
  EXPECT_DOUBLE_EQ(human_peak_torque_nm_per_kg("LeftUpLeg"), 3.5);  // a hip, not a knee
  EXPECT_DOUBLE_EQ(human_peak_torque_nm_per_kg("RightLeg"), 3.3);   // a knee
  EXPECT_DOUBLE_EQ(human_peak_torque_nm_per_kg("LeftForeArm"), 0.9);
  EXPECT_DOUBLE_EQ(human_peak_torque_nm_per_kg("LeftToeBase"), 0.3);  // a toe, not a foot
  EXPECT_DOUBLE_EQ(human_peak_torque_nm_per_kg("Tail"), 0);
  const BvhClip clip = make_synthetic_walk_clip();
  for (const double mass : {50.0, 100.0}) {
    BvhCharacterOptions o;
    o.total_mass_kg = mass;
    o.human_limits = true;
    const std::string path =
        test::write_temp_file("human_limits_" + std::to_string(static_cast<int>(mass)) + ".xml",
                              make_bvh_character(clip, o).mjcf);
    WorldSpec spec;
    spec.models.push_back({path});
    const auto e = make_engine("mujoco", spec);
    const auto limit = [&](const char* joint) {
      return e->joint(e->require_joint(joint)).force_limit;
    };
    EXPECT_NEAR(limit("LeftUpLeg"), 3.5 * mass, 1e-9) << mass;
    EXPECT_NEAR(limit("RightLeg"), 3.3 * mass, 1e-9) << mass;
    EXPECT_NEAR(limit("LeftFoot"), 2.7 * mass, 1e-9) << mass;
    EXPECT_NEAR(limit("LeftForeArm"), 0.9 * mass, 1e-9) << mass;
    EXPECT_TRUE(std::isinf(limit("root"))) << mass;
  }
  BvhCharacterOptions off;
  EXPECT_EQ(make_bvh_character(clip, off).mjcf.find("actuatorfrcrange"), std::string::npos);
}

TEST(BvhToMjcf, FootSegmentNames) {
  EXPECT_TRUE(is_foot_segment_name("Character1_LeftFoot"));
  EXPECT_TRUE(is_foot_segment_name("LeftToe"));
  EXPECT_TRUE(is_foot_segment_name("RightAnkle"));
  EXPECT_FALSE(is_foot_segment_name("LeftKnee"));
}

TEST(BvhToMjcf, SharedFilesBuildLoadableCharacters) {
  for (const char* file : {"mass_walk.bvh", "cmu_131_01.bvh"}) {
    const std::string path = test::shared_bvh(file);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
    SCOPED_TRACE(file);
    BvhClip clip = read_bvh(path);
    BvhCharacterOptions o;
    if (std::string(file) == "cmu_131_01.bvh") o.reference.first_frame = 540;
    check_character(clip, o, std::string(file) + "_char");
  }
}

TEST(BvhToMjcf, WritesTheFile) {
  BvhClip clip = make_synthetic_walk_clip();
  std::string bvh = test::write_temp_file("walk_for_cli.bvh", format_bvh(clip));
  std::string xml =
      (std::filesystem::temp_directory_path() / "stance_tests" / "walk_cli.xml").string();
  write_bvh_character(bvh, xml, {});
  EXPECT_TRUE(std::filesystem::exists(xml));
  EXPECT_THROW(write_bvh_character(bvh + ".missing", xml, {}), InputError);
}

// lowered at its rest pose (joints at zero) until it first touches the floor, a character
// touches with its feet only: a shin's round end must not reach below the sole (it did on
// clips whose foot bone drops little, as CMU's: the character stood on two balls)
std::vector<std::string> first_touching_bodies(const BvhClip& clip, const std::string& tag) {
  BvhCharacter ch = make_bvh_character(clip, BvhCharacterOptions{});
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file(tag + ".xml", ch.mjcf)});
  auto engine = make_mujoco_engine(spec);
  auto* mj = dynamic_cast<MujocoEngine*>(engine.get());
  Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(mj->model()->qpos0, engine->nq());
  std::vector<std::string> touching;
  for (double h = 3; h > -1 && touching.empty(); h -= 0.0005) {
    q[2] = h;  // the free joint's height
    engine->set_positions(q);
    engine->forward();
    for (int i = 0; i < engine->num_contacts(); ++i) {
      const Contact c = engine->contact(i);
      touching.push_back(engine->body_name(c.body1 >= 0 ? c.body1 : c.body2));
    }
  }
  return touching;
}

TEST(BvhToMjcf, StandsOnItsFeetNotOnItsShins) {
  // a foot bone that drops 2 cm from the ankle to the toe, under a 42 cm shin (capsule radius
  // 5.5 cm): the old shin reached 3 cm below the sole
  const std::string flat_foot =
      "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition "
      "Zrotation Xrotation Yrotation\n JOINT Spine\n {\n  OFFSET 0 30 0\n  CHANNELS 3 Zrotation "
      "Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 30 0\n  }\n }\n"
      " JOINT LeftUpLeg\n {\n  OFFSET 9 -6 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "  JOINT LeftLeg\n  {\n   OFFSET 0 -44 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "   JOINT LeftAnkle\n   {\n    OFFSET 0 -42 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "    End Site\n    {\n     OFFSET 0 -2 14\n    }\n   }\n  }\n }\n"
      " JOINT RightUpLeg\n {\n  OFFSET -9 -6 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "  JOINT RightLeg\n  {\n   OFFSET 0 -44 0\n   CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "   JOINT RightAnkle\n   {\n    OFFSET 0 -42 0\n    CHANNELS 3 Zrotation Xrotation "
      "Yrotation\n"
      "    End Site\n    {\n     OFFSET 0 -2 14\n    }\n   }\n  }\n }\n}\n"
      "MOTION\nFrames: 1\nFrame Time: 0.01\n0 95 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 "
      "0\n";
  std::vector<std::pair<std::string, BvhClip>> clips = {
      {"synthetic_walk", make_synthetic_walk_clip()},
      {"flat_foot", read_bvh(test::write_temp_file("flat_foot.bvh", flat_foot))}};
  for (const char* file : {"mass_walk.bvh", "cmu_131_01.bvh"})
    if (std::filesystem::exists(test::shared_bvh(file)))
      clips.emplace_back(file, read_bvh(test::shared_bvh(file)));
  for (const auto& [tag, clip] : clips) {
    SCOPED_TRACE(tag);
    const std::vector<std::string> touching = first_touching_bodies(clip, tag + "_rest");
    ASSERT_FALSE(touching.empty());
    for (const std::string& body : touching) EXPECT_TRUE(is_foot_segment_name(body)) << body;
  }
}

// a foot's sole box in the world while the clip has the foot planted (its origin within 2 cm of
// its lowest over the first second): per such frame, the box's up axis, the centre of its bottom
// face and its half sizes, from the character's geom and the reference's forward kinematics
struct WorldSole {
  Eigen::Vector3d up, bottom, half;
  double ankle_z = 0;
};

std::vector<WorldSole> planted_soles(const BvhClip& clip, const std::string& foot,
                                     const std::string& tag) {
  const BvhCharacter ch = make_bvh_character(clip, {});
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file(tag + ".xml", ch.mjcf)});
  auto engine = make_mujoco_engine(spec);
  const mjModel* m = dynamic_cast<MujocoEngine*>(engine.get())->model();
  const int g = mj_name2id(m, mjOBJ_GEOM, (foot + "_0").c_str());
  const int k = ch.skeleton.find_segment(foot);
  EXPECT_TRUE(g >= 0 && k >= 0) << foot;
  if (g < 0 || k < 0) return {};
  const Eigen::Vector3d local_pos(m->geom_pos[3 * g], m->geom_pos[3 * g + 1],
                                  m->geom_pos[3 * g + 2]);
  const Eigen::Quaterniond local_rot(m->geom_quat[4 * g], m->geom_quat[4 * g + 1],
                                     m->geom_quat[4 * g + 2], m->geom_quat[4 * g + 3]);
  const Eigen::Vector3d half(m->geom_size[3 * g], m->geom_size[3 * g + 1], m->geom_size[3 * g + 2]);
  const ReferenceMotion ref(clip, ch.skeleton, {});
  ReferencePose pose = ref.make_pose();
  const int frames = std::min(ref.frame_count(), static_cast<int>(1 / ref.frame_time_s()) + 1);
  std::vector<std::vector<Eigen::Vector3d>> pos(frames);
  std::vector<std::vector<Eigen::Quaterniond>> rot(frames);
  double lowest = INFINITY;
  for (int f = 0; f < frames; ++f) {
    ref.frame_pose(f, pose);
    ref.forward_kinematics(pose, pos[f], rot[f]);
    lowest = std::min(lowest, pos[f][k].z());
  }
  std::vector<WorldSole> soles;
  for (int f = 0; f < frames; ++f) {
    if (pos[f][k].z() > lowest + 0.02) continue;
    WorldSole s;
    s.up = rot[f][k] * local_rot * Eigen::Vector3d::UnitZ();
    s.bottom = pos[f][k] + rot[f][k] * local_pos - half.z() * s.up;
    s.half = half;
    s.ankle_z = pos[f][k].z();
    soles.push_back(s);
  }
  return soles;
}

// a rest pose that does not stand (every bone along X and rolled about it, as Bandai Namco's),
// whose frames pose the synthetic walk: where the walk plants a foot, that foot's box is level
// and under it, at the height and place of the standing rest pose's box, and about as large
// (before: the rest frame's +z was taken for the sole's up, 90 deg off)
TEST(BvhToMjcf, SoleBoxesOfARestPoseThatDoesNotStandLieUnderThePlantedFeet) {
  const BvhClip plain = make_synthetic_walk_clip();
  const std::vector<std::pair<std::string, BvhClip>> bent = {
      {"rolled",
       parse_bvh(format_bvh(test::with_bones_along_x(plain, std::numbers::pi / 2)), "rolled.bvh")},
      {"bandai_like", parse_bvh(format_bvh(test::with_bones_along_x(
                                    test::with_bones_in_position_channels(plain, 1.0), 0.3)),
                                "bandai_like.bvh")}};
  auto tilt_deg = [](const Eigen::Vector3d& up) {
    return std::acos(std::clamp(up.normalized().z(), -1.0, 1.0)) * 180 / std::numbers::pi;
  };
  for (const char* foot : {"LeftFoot", "RightFoot"}) {
    const std::vector<WorldSole> want = planted_soles(plain, foot, "sole_plain");
    ASSERT_GE(want.size(), 5u) << foot;
    for (const auto& [tag, clip] : bent) {
      SCOPED_TRACE(tag + " " + foot);
      const std::vector<WorldSole> got = planted_soles(clip, foot, "sole_" + tag);
      ASSERT_EQ(got.size(), want.size());
      Eigen::Vector3d mean_up = Eigen::Vector3d::Zero();
      for (const WorldSole& sole : got) mean_up += sole.up;
      EXPECT_LT(tilt_deg(mean_up), 2);  // level on the mean while planted
      for (size_t i = 0; i < got.size(); ++i) {
        // the foot rolls while it is down: its box within 8 deg of the standing rest's
        EXPECT_LT(tilt_deg(got[i].up), tilt_deg(want[i].up) + 8);
        EXPECT_NEAR(got[i].bottom.z(), want[i].bottom.z(), 0.015);
        EXPECT_LT((got[i].bottom - want[i].bottom).head<2>().norm(), 0.03);
        EXPECT_LT((got[i].half - want[i].half).cwiseAbs().maxCoeff(), 0.015);
        EXPECT_LT(got[i].bottom.z(), got[i].ankle_z - 0.03);
      }
    }
  }
}

}  // namespace
}  // namespace stance
