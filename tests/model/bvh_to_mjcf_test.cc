// BVH -> MJCF characters: they load, weigh the total mass, and their "start" keyframe puts the
// bodies where the reference motion's forward kinematics does.
#include "model/bvh_to_mjcf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/mujoco/mujoco_engine.h"
#include "engine/world_spec.h"
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

}  // namespace
}  // namespace stance
