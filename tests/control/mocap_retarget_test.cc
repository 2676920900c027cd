// Retargeting a BVH clip onto an existing model through a YAML joint map: exact on the clip's
// own character (identity map: yaw 0, scale 1, every rotation and the root reproduced), the same
// table on MuJoCo and DART, and tracking MuJoCo's humanoid.xml in the three root modes.
#include "control/mocap_retarget_tracker.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <map>
#include <numbers>

#include "control/auto_joint_map.h"
#include "control/retarget.h"
#include "core/error.h"
#include "engine/world_spec.h"
#include "math/rotations.h"
#include "model/bvh_to_mjcf.h"
#include "motion/clip_conventions.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

// the synthetic walk, its bvh2mjcf character, and a map of every segment onto its own body
struct OwnCharacter {
  BvhClip clip = make_synthetic_walk_clip();
  std::string xml;
  std::unique_ptr<ReferenceMotion> reference;
  JointMap map;

  explicit OwnCharacter(const std::string& height_offset, BvhClip from = make_synthetic_walk_clip(),
                        bool loop = true)
      : clip(std::move(from)) {
    BvhCharacterOptions o;
    BvhCharacter c = make_bvh_character(clip, o);
    xml = test::write_temp_file("retarget_own.xml", c.mjcf);
    ReferenceOptions ro;
    ro.loop = loop;
    reference = std::make_unique<ReferenceMotion>(clip, c.skeleton, ro);
    std::string text = "height_offset: " + height_offset + "\njoints:\n";
    for (const auto& s : c.skeleton.segments) text += "  " + s.name + ": " + s.name + "\n";
    map = parse_joint_map(YAML::Load(text), "own.yaml");
  }
};

std::unique_ptr<Engine> engine_of(const std::string& engine_name, const std::string& file) {
  WorldSpec spec;
  spec.models.push_back({file});
  return make_engine(engine_name, spec);
}

TEST(Retarget, IdentityMapOnTheClipsOwnCharacterIsExact) {
  OwnCharacter own("0");
  auto probe = engine_of("mujoco", own.xml);
  RetargetedMotion motion(*own.reference, own.map, *probe, 2.5);
  EXPECT_NEAR(motion.yaw_rad(), 0.0, 1e-9);
  EXPECT_NEAR(motion.scale(), 1.0, 1e-9);
  EXPECT_LT(motion.max_fit_error_deg(), 1e-6);
  // longer than a pass: the table runs on through the loop
  EXPECT_GE(motion.duration_s(), 2.5);
  ReferencePose pose = own.reference->make_pose();
  const MotionSkeleton& sk = own.reference->skeleton();
  std::vector<Eigen::Vector3d> pos(sk.segment_count());
  std::vector<Eigen::Quaterniond> rot(sk.segment_count());
  for (int f : {0, 17, 66, 100, motion.frame_count() - 1}) {
    probe->set_positions(motion.frame(f));
    probe->forward();
    own.reference->sample(f * motion.frame_time_s(), pose);
    own.reference->forward_kinematics(pose, pos, rot);
    for (int k = 0; k < sk.segment_count(); ++k) {
      BodyPose b = probe->body_pose(probe->body_index(sk.segments[k].name));
      EXPECT_LT(geodesic_angle(b.quat, rot[k]), 1e-9) << sk.segments[k].name << " frame " << f;
      EXPECT_LT((b.pos - pos[k]).norm(), 1e-9) << sk.segments[k].name << " frame " << f;
    }
  }
}

// the clip's vertical force on the root (reference_support): on the synthetic run, whose root
// flies ballistically and is carried by a half-sine force of 2.6 g in stance, m (g + a) averages
// to the weight over a step, peaks near 2.6 g and is about zero in mid-flight
TEST(Retarget, BodyAccelerationOfTheRunGivesItsGroundForce) {
  OwnCharacter own("0", make_synthetic_walk_clip(synthetic_run_options()));
  auto probe = engine_of("mujoco", own.xml);
  RetargetedMotion motion(*own.reference, own.map, *probe, 2);
  auto hips = [](const RetargetedMotion& m) {
    for (size_t i = 0; i < m.bodies().size(); ++i)
      if (m.bodies()[i].name.rfind("Hips", 0) == 0) return static_cast<int>(i);
    return -1;
  };
  const int root = hips(motion);
  ASSERT_GE(root, 0);
  const double g = 9.81, step = 0.35;  // s: half the 0.7 s cycle
  const int n = 700;
  double sum = 0, peak = 0, least = 1e9;
  for (int k = 0; k < n; ++k) {
    const double need = motion.sample_body_acceleration(0.5 + step * k / n, root).z() + g;
    sum += need / n;
    peak = std::max(peak, need);
    least = std::min(least, need);
  }
  std::cout << "run: m (g + a) / m g mean " << sum / g << ", peak " << peak / g << ", least "
            << least / g << "\n";
  EXPECT_NEAR(sum, g, 0.03 * g);  // over a whole step the ground carries the weight
  EXPECT_NEAR(peak, 2.6 * g, 0.25 * g);
  EXPECT_NEAR(least, 0, 0.1 * g);  // flight: falling freely
  // and on the walk the clip's vertical force stays near the weight
  OwnCharacter walk("0");
  auto walk_probe = engine_of("mujoco", walk.xml);
  RetargetedMotion walk_motion(*walk.reference, walk.map, *walk_probe, 2);
  for (int k = 0; k < n; ++k) {
    const double need =
        walk_motion.sample_body_acceleration(0.5 + k * 1e-3, hips(walk_motion)).z() + g;
    EXPECT_GT(need, 0.5 * g);
    EXPECT_LT(need, 1.5 * g);
  }
}

TEST(Retarget, AutomaticHeightPutsTheLowestPointOnTheFloor) {
  // the character's feet already stand on the floor at the start: the offset found is ~0
  OwnCharacter own("auto");
  auto probe = engine_of("mujoco", own.xml);
  RetargetedMotion motion(*own.reference, own.map, *probe, 0);
  EXPECT_LT(std::abs(motion.height_offset_m()), 0.01);
  // and a map whose clip is lifted 10 cm is brought back down by the same amount
  OwnCharacter lifted("auto");
  ReferenceOptions ro;
  ro.ground_height_m = 0.1;
  BvhCharacterOptions o;
  lifted.reference = std::make_unique<ReferenceMotion>(
      lifted.clip, make_bvh_character(lifted.clip, o).skeleton, ro);
  RetargetedMotion down(*lifted.reference, lifted.map, *probe, 0);
  EXPECT_NEAR(down.height_offset_m(), motion.height_offset_m() - 0.1, 1e-4);
}

// a clip that stands still on feet pitched 12 degrees toes-down, then lifts the left leg
// (hip and knee flexed: the foot 20 cm up)
BvhClip tilted_feet_clip() {
  BvhClip clip = make_synthetic_walk_clip();
  const int frames = 120, n = clip.joint_count();
  const Eigen::Vector3d root = clip.positions[0];
  clip.frame_count = frames;
  clip.rotations.assign(static_cast<size_t>(frames) * n, Eigen::Quaterniond::Identity());
  clip.positions.assign(static_cast<size_t>(frames) * clip.position_joint_count, root);
  clip.raw.setZero(frames, clip.channel_count);
  auto joint = [&](const char* name) {
    for (int j = 0; j < n; ++j)
      if (clip.joints[j].name == name) return j;
    return -1;
  };
  const double deg = std::numbers::pi / 180;
  for (int f = 0; f < frames; ++f) {
    for (const char* foot : {"LeftFoot", "RightFoot"})
      clip.rotation(f, joint(foot)) = Eigen::AngleAxisd(12 * deg, Eigen::Vector3d::UnitX());
    if (f >= 80) {
      clip.rotation(f, joint("LeftUpLeg")) = Eigen::AngleAxisd(-50 * deg, Eigen::Vector3d::UnitX());
      clip.rotation(f, joint("LeftLeg")) = Eigen::AngleAxisd(60 * deg, Eigen::Vector3d::UnitX());
    }
  }
  return clip;
}

// free mode levels the clip's planted feet (near their planted height and slow) and leaves a
// lifted foot, and every other body, as the clip has them
TEST(Retarget, LevelsPlantedFeetAndNothingElse) {
  OwnCharacter own("0", tilted_feet_clip(), false);
  auto probe = engine_of("mujoco", own.xml);
  const MotionSkeleton& sk = own.reference->skeleton();
  const std::vector<int> feet = {sk.find_segment("LeftFoot"), sk.find_segment("RightFoot")};
  RetargetedMotion as_is(*own.reference, own.map, *probe, 0);
  RetargetedMotion level(*own.reference, own.map, *probe, 0, feet);
  ASSERT_EQ(as_is.frame_count(), level.frame_count());
  const double dt = level.frame_time_s();
  auto mapped = [&](int segment) {
    int i = 0;
    while (level.bodies()[i].segment != segment) ++i;
    return i;
  };
  // a foot body's tilt: the angle of its rest up (the sole's normal) from the world's up
  auto tilt_deg = [&](const RetargetedMotion& m, int f, int i) {
    const Eigen::Vector3d up = m.sample_body_pose(f * dt, i).quat * Eigen::Vector3d::UnitZ();
    return std::acos(std::clamp(up.z(), -1.0, 1.0)) * 180 / std::numbers::pi;
  };
  const int left = mapped(feet[0]), right = mapped(feet[1]);
  for (int f = 0; f < level.frame_count(); ++f) {
    SCOPED_TRACE(f);
    EXPECT_NEAR(tilt_deg(as_is, f, right), 12, 0.5);
    EXPECT_LT(tilt_deg(level, f, right), 0.01);
    if (f < 75) {
      EXPECT_NEAR(tilt_deg(as_is, f, left), 12, 0.5);
      EXPECT_LT(tilt_deg(level, f, left), 0.01);
    } else if (f > 85) {  // lifted: as the clip
      EXPECT_GT(
          level.sample_body_pose(f * dt, left).pos.z() - level.sample_body_pose(0, left).pos.z(),
          0.1);
      EXPECT_LT(geodesic_angle(as_is.sample_body_pose(f * dt, left).quat,
                               level.sample_body_pose(f * dt, left).quat),
                1e-9);
    }
    // the bodies above the feet, and the root's path, are the clip's
    for (int i = 0; i < static_cast<int>(level.bodies().size()); ++i) {
      if (i == left || i == right) continue;
      const BodyPose a = as_is.sample_body_pose(f * dt, i), b = level.sample_body_pose(f * dt, i);
      EXPECT_LT(geodesic_angle(a.quat, b.quat), 1e-9) << level.bodies()[i].name;
      EXPECT_LT((a.pos - b.pos).norm(), 1e-9) << level.bodies()[i].name;
    }
  }
}

TEST(Retarget, SameTableOnMujocoAndDart) {
  // DART stores ball and free joints as rotation vectors, MuJoCo as quaternions; the probed
  // frames must give the same bodies in the world
  OwnCharacter own("0");
  auto mj = engine_of("mujoco", own.xml);
  std::unique_ptr<Engine> dart;
  try {
    dart = engine_of("dart", own.xml);
  } catch (const InputError& e) {
    GTEST_SKIP() << "DART cannot load the character: " << e.what();
  }
  RetargetedMotion a(*own.reference, own.map, *mj, 0);
  RetargetedMotion b(*own.reference, own.map, *dart, 0);
  ASSERT_EQ(a.frame_count(), b.frame_count());
  const MotionSkeleton& sk = own.reference->skeleton();
  for (int f = 0; f < a.frame_count(); f += 7) {
    mj->set_positions(a.frame(f));
    mj->forward();
    dart->set_positions(b.frame(f));
    dart->forward();
    for (const auto& seg : sk.segments) {
      BodyPose pa = mj->body_pose(mj->body_index(seg.name));
      BodyPose pb = dart->body_pose(dart->body_index(seg.name));
      EXPECT_LT(geodesic_angle(pa.quat, pb.quat), 1e-8) << seg.name << " frame " << f;
      EXPECT_LT((pa.pos - pb.pos).norm(), 1e-8) << seg.name << " frame " << f;
    }
  }
}

// fullbody1 (Y-up, euler/universal/revolute joints) on both engines: the same joint angles
TEST(Retarget, Fullbody1AnglesAgreeOnMujocoAndDart) {
  const std::string skel = "/usr/share/doc/dart/data/skel/fullbody1.skel";
  if (!std::filesystem::exists(skel)) GTEST_SKIP() << "no " << skel;
  const char* text = R"(
model_up: y
joints:
  Hips: h_pelvis
  Spine: h_abdomen
  Chest: h_spine
  Head: h_head
  LeftUpLeg: h_thigh_left
  LeftLeg: h_shin_left
  LeftFoot: h_heel_left
  RightUpLeg: h_thigh_right
  RightLeg: h_shin_right
  RightFoot: h_heel_right
  LeftArm: h_bicep_left
  LeftForeArm: h_forearm_left
  RightArm: h_bicep_right
  RightForeArm: h_forearm_right
)";
  JointMap map = parse_joint_map(YAML::Load(text), "fullbody1.yaml");
  BvhClip clip = make_synthetic_walk_clip();
  BvhCharacterOptions o;
  ReferenceMotion reference(clip, make_bvh_character(clip, o).skeleton, ReferenceOptions{});
  auto mj = engine_of("mujoco", skel);
  auto dart = engine_of("dart", skel);
  RetargetedMotion a(reference, map, *mj, 0);
  RetargetedMotion b(reference, map, *dart, 0);
  // the legs' hinge chains reach their targets: the fit error is in the 1-2 dof joints
  EXPECT_LT(a.body_fit_error_deg(4), 0.5);  // h_thigh_left: three hinges
  EXPECT_NEAR(a.mean_fit_error_deg(), b.mean_fit_error_deg(), 1e-6);
  EXPECT_NEAR(a.height_offset_m(), b.height_offset_m(), 2e-3);  // contact models differ
  int compared = 0;
  for (int j = 0; j < mj->njoint(); ++j) {
    const JointInfo& ja = mj->joint(j);
    if (ja.type != JointType::kHinge) continue;
    int jb = dart->joint_index(ja.name);
    ASSERT_GE(jb, 0) << ja.name;
    for (int f = 0; f < a.frame_count(); f += 5)
      EXPECT_NEAR(a.frame(f)[ja.qpos_adr], b.frame(f)[dart->joint(jb).qpos_adr], 1e-6)
          << ja.name << " frame " << f;
    ++compared;
  }
  EXPECT_GT(compared, 20);
}

// a rest pose that does not stand (every bone along X and rolled about it, as Bandai Namco's)
// whose frames pose the synthetic walk: the map's scale and yaw onto fullbody1 are the standing
// rest pose's, from the first frame's pose (before: from the rest pose lying along X); the
// scaled legs within 1 cm
TEST(Retarget, ScaleAndYawOfARestPoseThatDoesNotStandComeFromTheFirstFrame) {
  const std::string skel = "/usr/share/doc/dart/data/skel/fullbody1.skel";
  if (!std::filesystem::exists(skel)) GTEST_SKIP() << "no " << skel;
  const JointMap map = parse_joint_map(YAML::Load(R"(
model_up: y
joints: {Hips: h_pelvis, Spine: h_abdomen, Head: h_head, LeftUpLeg: h_thigh_left,
  LeftLeg: h_shin_left, LeftFoot: h_heel_left, RightUpLeg: h_thigh_right,
  RightLeg: h_shin_right, RightFoot: h_heel_right}
)"),
                                       "fullbody1.yaml");
  const BvhClip plain = make_synthetic_walk_clip();
  const BvhClip bent =
      parse_bvh(format_bvh(test::with_bones_along_x(plain, std::numbers::pi / 2)), "bent.bvh");
  auto engine = engine_of("mujoco", skel);
  const ReferenceMotion plain_ref(plain, make_motion_skeleton(plain, {}), {});
  const ReferenceMotion bent_ref(bent, make_motion_skeleton(bent, {}), {});
  const RetargetedMotion want(plain_ref, map, *engine, 0);
  const RetargetedMotion got(bent_ref, map, *engine, 0);
  const MotionSkeleton& sk = plain_ref.skeleton();
  const double leg_m = sk.segments[sk.find_segment("LeftLeg")].offset.norm() +
                       sk.segments[sk.find_segment("LeftFoot")].offset.norm();
  EXPECT_GT(leg_m, 0.6);
  EXPECT_LT(std::abs(got.scale() - want.scale()) * leg_m, 0.01)
      << got.scale() << " vs " << want.scale();
  EXPECT_LT(std::abs(std::remainder(got.yaw_rad() - want.yaw_rad(), 2 * std::numbers::pi)) * 180 /
                std::numbers::pi,
            3)
      << got.yaw_rad() << " vs " << want.yaw_rad();
}

// the largest angle (deg) between two tables' world rotations of mapped body i over their frames
double largest_turn_apart_deg(const RetargetedMotion& a, const RetargetedMotion& b, int i) {
  std::vector<Eigen::Quaterniond> wa(a.bodies().size()), wb(b.bodies().size());
  double largest = 0;
  for (int f = 0; f < a.frame_count(); ++f) {
    a.sample_world(f * a.frame_time_s(), wa);
    b.sample_world(f * a.frame_time_s(), wb);
    largest = std::max(largest, geodesic_angle(wa[i], wb[i]) * 180 / std::numbers::pi);
  }
  return largest;
}

// the synthetic walk with its rest pose lying along X (every bone along X, rolled a quarter
// turn about it, as Bandai Namco's), its frames posing the same walk, mapped onto humanoid.xml:
// the pelvis turns as the standing clip's does, in every frame, to a few degrees. Before, the
// root had no rest-pose correction and the pelvis kept the rest pose's own turn (90 deg and more)
TEST(Retarget, RootOfARestPoseThatDoesNotStandTurnsAsTheStandingClipsRoot) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  const JointMap map =
      read_joint_map(test::source_dir() + "/models/maps/synthetic_walk_to_humanoid.yaml");
  const BvhClip plain = make_synthetic_walk_clip();
  const BvhClip lying =
      parse_bvh(format_bvh(test::with_bones_along_x(plain, std::numbers::pi / 2)), "lying.bvh");
  auto engine = engine_of("mujoco", test::kHumanoidXml);
  const ReferenceMotion plain_ref(plain, make_motion_skeleton(plain, {}), {});
  const ReferenceMotion lying_ref(lying, make_motion_skeleton(lying, {}), {});
  const RetargetedMotion want(plain_ref, map, *engine, 0);
  const RetargetedMotion got(lying_ref, map, *engine, 0);
  ASSERT_EQ(got.bodies()[0].segment, 0);                 // the map lists the root first
  EXPECT_LT(largest_turn_apart_deg(got, want, 0), 3.0);  // 1.5 deg: the pelvis' best fit
  // the legs below follow it, each swung onto the clip's bone: they turn as the standing clip's
  for (const char* leg : {"LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg"})
    for (size_t i = 0; i < got.bodies().size(); ++i)
      if (got.bodies()[i].segment == lying_ref.skeleton().find_segment(leg))
        EXPECT_LT(largest_turn_apart_deg(got, want, static_cast<int>(i)), 1.0) << leg;
}

// the same lying walk onto fullbody1, whose rest pose stands as the clip's does (arms down,
// elbows and neck straight): the end bodies, with no mapped body below them, turn as the
// standing clip's. The forearms and the head bend against their parents as the clip's bend from
// straight, towards the End Sites the map does not map (before: they followed their parents, the
// forearms 15 deg off and the head 3); the feet, whose rest is no straight line, still follow the
// shins
TEST(Retarget, EndBodiesOfARestPoseThatDoesNotStandTurnAsTheStandingClips) {
  const std::string skel = "/usr/share/doc/dart/data/skel/fullbody1.skel";
  if (!std::filesystem::exists(skel)) GTEST_SKIP() << "no " << skel;
  const JointMap map =
      read_joint_map(test::source_dir() + "/models/maps/synthetic_walk_to_fullbody1.yaml");
  const BvhClip plain = make_synthetic_walk_clip();
  const BvhClip lying =
      parse_bvh(format_bvh(test::with_bones_along_x(plain, std::numbers::pi / 2)), "lying.bvh");
  auto engine = engine_of("mujoco", skel);
  const ReferenceMotion plain_ref(plain, make_motion_skeleton(plain, {}), {});
  const ReferenceMotion lying_ref(lying, make_motion_skeleton(lying, {}), {});
  const RetargetedMotion want(plain_ref, map, *engine, 0);
  const RetargetedMotion got(lying_ref, map, *engine, 0);
  const std::map<std::string, double> bound_deg = {
      {"LeftForeArm", 1}, {"RightForeArm", 1}, {"Head", 2.5}, {"LeftFoot", 6}, {"RightFoot", 6}};
  int checked = 0;
  for (size_t i = 0; i < got.bodies().size(); ++i) {
    const auto it = bound_deg.find(lying_ref.skeleton().segments[got.bodies()[i].segment].name);
    if (it == bound_deg.end()) continue;
    EXPECT_LT(largest_turn_apart_deg(got, want, static_cast<int>(i)), it->second) << it->first;
    ++checked;
  }
  EXPECT_EQ(checked, 5);
}

// a rest pose that does not stand takes `scale: auto` from the legs (thigh, shin, foot) where
// both are mapped: bone lengths, which no pose changes. Before, the first frame's height span
// gave it, which a map that puts the clip's neck on the model's head centre stretches: the Bandai
// walk onto humanoid.xml got 1.196 where its legs give 0.99 (the found map's scale)
TEST(Retarget, ScaleOfARestPoseThatDoesNotStandComesFromTheLegs) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  auto engine = engine_of("mujoco", test::kHumanoidXml);
  auto check = [&](const std::string& bvh, const std::string& map_file) {
    SCOPED_TRACE(bvh);
    const BvhClip clip = read_bvh(bvh);
    const ReferenceMotion reference(clip, make_motion_skeleton(clip, {}), {});
    const JointMap map = read_joint_map(test::source_dir() + "/models/maps/" + map_file);
    const RetargetedMotion got(reference, map, *engine, 0);
    const AutoJointMap found = find_joint_map_of_files(bvh, test::kHumanoidXml, "mujoco");
    EXPECT_NEAR(got.scale(), *found.map.scale, 0.005 * *found.map.scale);
    return got.scale();
  };
  const BvhClip lying = test::with_bones_along_x(make_synthetic_walk_clip(), std::numbers::pi / 2);
  check(test::write_temp_file("lying_walk.bvh", format_bvh(lying)),
        "synthetic_walk_to_humanoid.yaml");  // 0.922 (before: 0.967)
  const std::string bandai = test::shared_bvh("bandai/dataset-1_walk_active_001.bvh");
  if (std::filesystem::exists(bandai))
    EXPECT_NEAR(check(bandai, "bandai_to_humanoid.yaml"), 0.99, 0.01);
}

nlohmann::json run_humanoid(const std::string& mode, double seconds,
                            const std::string& limits = "auto") {
  LoadedScenario loaded =
      load_scenario(test::scenario_path("mocap_retarget.yaml"),
                    {"controllers.0.mode=" + mode, fmt::format("duration={}", seconds),
                     "torque_limits=" + limits});
  Simulation run(loaded, RunOptions{});
  RunResult r = run.run();
  nlohmann::json j = r.metrics["mocap"];
  j["fell"] = r.fell;
  return j;
}

TEST(MocapRetarget, HumanoidKinematicFollowsTheTable) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  // deadbeat torques on every dof measure the table, not the motors: unclamped
  nlohmann::json m = run_humanoid("kinematic", 2.5, "off");
  EXPECT_LT(m["mean_joint_error_deg"].get<double>(), 0.5);
  EXPECT_LT(m["mean_root_error_m"].get<double>(), 1e-3);
  EXPECT_FALSE(m["fell"].get<bool>());
  // three hinges reach any hip rotation; a one-hinge forearm cannot follow the clip's
  EXPECT_LT(m["map_fit_error_deg"]["LeftUpLeg -> left_thigh"].get<double>(), 0.5);
  EXPECT_GT(m["map_fit_error_deg"]["LeftForeArm -> left_lower_arm"].get<double>(), 5.0);
  // the two-hinge shoulder aims the upper arm at the clip's elbow instead of half-fitting its
  // twist (a plain rotation fit leaves the bone 3.7 degrees off)
  for (const char* pair :
       {"LeftArm -> left_upper_arm", "RightArm -> right_upper_arm", "LeftUpLeg -> left_thigh"})
    EXPECT_LT(m["map_aim_error_deg"][pair].get<double>(), 0.5) << pair;
}

TEST(MocapRetarget, HumanoidAssistedStaysUpWithAMeasuredHelper) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  nlohmann::json m = run_humanoid("assisted", 10);
  EXPECT_FALSE(m["fell"].get<bool>());
  EXPECT_TRUE(m["root_fall_time_s"].is_null());
  EXPECT_LT(m["mean_joint_error_deg"].get<double>(), 5.0);
  EXPECT_LT(m["mean_root_error_m"].get<double>(), 0.1);
  EXPECT_GT(m["helper_impulse_Ns"].get<double>(), 0.0);
  // without the helper (and with no balance layer on a mapped model) the humanoid falls
  nlohmann::json f = run_humanoid("free", 3);
  EXPECT_EQ(f["helper_impulse_Ns"].get<double>(), 0.0);
  EXPECT_FALSE(f["root_fall_time_s"].is_null());
}

TEST(MocapRetarget, Fullbody1AssistedAgreesOnMujocoAndDart) {
  if (!std::filesystem::exists("/usr/share/doc/dart/data/skel/fullbody1.skel"))
    GTEST_SKIP() << "no fullbody1.skel";
  nlohmann::json m[2];
  const char* engines[2] = {"mujoco", "dart"};
  for (int e = 0; e < 2; ++e) {
    LoadedScenario loaded = load_scenario(test::scenario_path("mocap_retarget_fullbody1.yaml"),
                                          {"duration=3", std::string("engine=") + engines[e]});
    Simulation run(loaded, RunOptions{});
    RunResult r = run.run();
    EXPECT_FALSE(r.fell) << engines[e];
    m[e] = r.metrics["mocap"];
    EXPECT_TRUE(m[e]["root_fall_time_s"].is_null()) << engines[e];
    EXPECT_LT(m[e]["mean_joint_error_deg"].get<double>(), 5.0) << engines[e];
    // the floor (y = -0.895) was found by contact: the model's lowest point starts on it
    EXPECT_NEAR(m[e]["map_height_offset_m"].get<double>(), -0.889, 0.01) << engines[e];
  }
  EXPECT_NEAR(m[0]["mean_joint_error_deg"].get<double>(),
              m[1]["mean_joint_error_deg"].get<double>(), 0.5);
  EXPECT_NEAR(m[0]["helper_impulse_Ns"].get<double>() / m[1]["helper_impulse_Ns"].get<double>(),
              1.0, 0.1);
}

TEST(MocapRetarget, ExportMapsTheMotionBackOntoTheClip) {
  // the identity map on the clip's own character, tracked kinematically: the exported clip is
  // the source clip up to the tracking error (joint 0, the root, is compared on its own)
  OwnCharacter own("0");
  MocapRetargetParams p;
  p.bvh = test::write_temp_file("retarget_export.bvh", format_bvh(own.clip));
  std::string map_text = "height_offset: 0\njoints:\n";
  for (const auto& s : own.reference->skeleton().segments)
    map_text += "  " + s.name + ": " + s.name + "\n";
  p.joint_map = test::write_temp_file("retarget_export.yaml", map_text);
  p.mode = "kinematic";
  p.export_bvh = "unused";
  auto engine = engine_of("mujoco", own.xml);
  ControllerContext ctx;
  ctx.duration_s = 1.0;
  ctx.scratch_engine = [&] { return engine_of("mujoco", own.xml); };
  MocapRetargetTracker tracker(p, ctx, *engine);
  Eigen::VectorXd q0, v0;
  ASSERT_TRUE(tracker.initial_state(*engine, q0, v0));
  engine->set_positions(q0);
  engine->set_velocities(v0);
  engine->forward();
  std::unique_ptr<ControllerState> state = tracker.make_state(*engine);
  ControlOutput out;
  out.resize(engine->nv(), engine->nu());
  for (int k = 0; k < 500; ++k) {  // 1 s
    engine->forward();
    out.clear();
    tracker.compute(*state, *engine, out);
    engine->set_generalized_forces(out.tau);
    engine->step();
  }
  const std::string file = test::write_temp_file("retarget_exported.bvh", "");
  write_bvh(tracker.recorded_clip(MocapRetargetTracker::cast(*state)), file);
  BvhClip back = read_bvh(file);
  const BvhClip& src = own.clip;
  ASSERT_EQ(back.joints.size(), src.joints.size());
  ASSERT_GE(back.frame_count, 60);
  double worst = 0;
  for (int f = 0; f < 60; ++f) {
    for (size_t j = 1; j < src.joints.size(); ++j)
      worst = std::max(worst, geodesic_angle(back.rotation(f, j), src.rotation(f, j)));
    Eigen::Vector3d moved = back.translation(f, 0) - back.translation(0, 0);
    Eigen::Vector3d want = src.translation(f, 0) - src.translation(0, 0);
    EXPECT_LT((moved - want).norm(), 1.0) << "frame " << f;  // file units: cm
  }
  // the export adds nothing to the tracking error (feet deflected by contacts, which the
  // kinematic mode does not feed back): its worst joint is the tracker's own worst
  nlohmann::json metrics;
  tracker.add_metrics(*state, metrics);
  const double tracked = metrics["mocap"]["max_joint_error_deg"].get<double>();
  EXPECT_LT(worst * 180 / std::numbers::pi, tracked + 1e-6);
  EXPECT_LT(tracked, 3.0);
  // and the root joint's orientation comes back as the clip's
  for (int f = 0; f < 60; ++f)
    EXPECT_LT(geodesic_angle(back.rotation(f, 0), src.rotation(f, 0)), 0.01) << "frame " << f;
}

TEST(MocapRetarget, HumanoidExportReadsBackOnTheClipsSkeleton) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  LoadedScenario loaded =
      load_scenario(test::scenario_path("mocap_retarget.yaml"),
                    {"duration=2", "controllers.0.export_bvh=humanoid_walk.bvh"});
  RunOptions o;
  o.out_dir = (std::filesystem::temp_directory_path() / "stance_tests" / "retarget_run").string();
  o.quiet = true;
  Simulation(loaded, o).run();
  BvhClip back = read_bvh(o.out_dir + "/humanoid_walk.bvh");
  BvhClip src = read_bvh(test::source_dir() + "/models/synthetic_walk.bvh");
  EXPECT_EQ(back.joints.size(), src.joints.size());
  EXPECT_NEAR(back.frame_count, 2.0 / src.frame_time_s, 1.5);
  EXPECT_DOUBLE_EQ(back.frame_time_s, src.frame_time_s);
  // the legs went through the map and back: they move like the clip's, within a few degrees
  // (assisted tracking on a different body), where the clip's own hip swings tens of degrees
  const int hip = src.find_joint("LeftUpLeg");
  ASSERT_GE(hip, 0);
  double sum = 0, swing = 0;
  for (int f = 0; f < 60; ++f) {
    sum += geodesic_angle(back.rotation(f, hip), src.rotation(f, hip));
    swing = std::max(swing, geodesic_angle(src.rotation(f, hip), src.rotation(0, hip)));
  }
  EXPECT_LT(sum / 60, 0.25 * swing);
}

// a clip joint merged into its parent (CMU's zero-length lowerback) is named as such, with the
// segments a map can use
TEST(Retarget, MergedClipJointIsNamed) {
  const std::string cmu = test::shared_bvh("cmu_131_01.bvh");
  if (!std::filesystem::exists(cmu)) GTEST_SKIP() << "no ../shared data";
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  BvhClip clip = read_bvh(cmu);
  ReferenceMotion reference(clip, make_motion_skeleton(clip, MotionSkeletonOptions{}),
                            ReferenceOptions{});
  auto probe = engine_of("mujoco", test::kHumanoidXml);
  JointMap map = parse_joint_map(YAML::Load("joints:\n  Hips: pelvis\n  lowerback: lower_waist\n"),
                                 "cmu.yaml");
  try {
    RetargetedMotion motion(reference, map, *probe, 0);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cmu.yaml:3: clip joint 'lowerback' is no segment of its "
                                         "own"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("Chest, Chest2"), std::string::npos) << e.what();
  }
}

TEST(MocapRetarget, BadMapsAreNamed) {
  OwnCharacter own("0");
  auto probe = engine_of("mujoco", own.xml);
  auto expect_error = [&](const std::string& text, const std::string& want) {
    try {
      JointMap map = parse_joint_map(YAML::Load(text), "bad.yaml");
      RetargetedMotion motion(*own.reference, map, *probe, 0);
      ADD_FAILURE() << "no error for:\n" << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  expect_error("joints:\n  Hips: Hips\n  LeftLegg: LeftLeg\n",
               "bad.yaml:3: the clip has no joint 'LeftLegg' (did you mean 'LeftLeg'?)");
  expect_error("joints:\n  Hips: Hips\n  LeftLeg: LeftLog\n",
               "bad.yaml:3: the model has no body 'LeftLog' (did you mean 'LeftLeg'?)");
  expect_error("joints:\n  LeftLeg: LeftLeg\n", "map the clip's root 'Hips'");
  expect_error("joints:\n  Hips: Hips\n  LeftLeg: Hips\n", "model body 'Hips' is mapped twice");
  expect_error("joint:\n  Hips: Hips\n",
               "bad.yaml:1: unknown key 'joint' (did you mean 'joints'?)");
  expect_error("scale: big\njoints:\n  Hips: Hips\n",
               "bad.yaml:1: scale: expected a number, found 'big'");
  expect_error("model_up: x\njoints:\n  Hips: Hips\n", "model_up: expected y or z");
  // a file that is not YAML names its line
  std::string path = test::write_temp_file("bad_map.yaml", "joints:\n  Hips: [pelvis\n");
  try {
    read_joint_map(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_joint_map("/no/such/map.yaml"), InputError);
}

}  // namespace
}  // namespace stance
