// The joint map found from the model's tree (bvh track without --map): the same map as the
// hand-written one on MuJoCo's humanoid.xml, complete legs on DART's Atlas (hinge chains: three
// bodies at each hip, two at each ankle) and fullbody1 (Y-up), a clear error without legs, and
// a YAML file that reads back as the same map.
#include "control/auto_joint_map.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>

#include "core/error.h"
#include "engine/world_spec.h"
#include "motion/bvh.h"
#include "motion/clip_conventions.h"
#include "test_support.h"

namespace stance {
namespace {

MotionSkeleton synthetic_walk_skeleton() {
  return make_motion_skeleton(make_synthetic_walk_clip(), MotionSkeletonOptions{});
}

std::unique_ptr<Engine> load(const std::string& engine, const std::string& file) {
  WorldSpec spec;
  spec.models.push_back({file});
  auto e = make_engine(engine, spec);
  e->forward();
  return e;
}

std::map<std::string, std::string> pairs_of(const JointMap& map) {
  std::map<std::string, std::string> out;
  for (const JointMapEntry& j : map.joints) out[j.segment] = j.body;
  return out;
}

TEST(AutoJointMap, HumanoidMatchesTheHandWrittenMap) {
  auto model = load("mujoco", test::kHumanoidXml);
  AutoJointMap found = find_joint_map(synthetic_walk_skeleton(), "walk", *model, "humanoid");
  const JointMap hand = read_joint_map("models/maps/synthetic_walk_to_humanoid.yaml");
  EXPECT_EQ(pairs_of(found.map), pairs_of(hand));
  EXPECT_EQ(found.map.model_up, 'z');
  // the humanoid's legs are longer than the synthetic walker's
  EXPECT_GT(*found.map.scale, 0.5);
  EXPECT_LT(*found.map.scale, 2.0);
}

// Bandai Namco's arms run Shoulder_L (a collar), UpperArm_L, LowerArm_L: the upper arm is
// UpperArm_L (before: the side suffix hid the collar, and every arm role was one joint up)
TEST(AutoJointMap, BandaiNamcosCollarIsNoUpperArm) {
  const std::string bvh = test::shared_bvh("bandai/dataset-1_walk_active_001.bvh");
  if (!std::filesystem::exists(bvh)) GTEST_SKIP() << bvh << " is absent";
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  auto pairs = pairs_of(find_joint_map_of_files(bvh, test::kHumanoidXml, "mujoco").map);
  EXPECT_EQ(pairs["UpperArm_L"], "left_upper_arm");
  EXPECT_EQ(pairs["LowerArm_L"], "left_lower_arm");
  EXPECT_EQ(pairs["UpperArm_R"], "right_upper_arm");
  EXPECT_EQ(pairs["LowerArm_R"], "right_lower_arm");
  EXPECT_EQ(pairs.count("Shoulder_L"), 0u);
}

// a rest pose that does not stand (Bandai Namco's lies along X) tells no height: the head, the
// highest leaf above the chest, is found in the first frame's pose (before: not at all)
TEST(AutoJointMap, BandaiNamcosHeadIsFoundInTheFirstFrame) {
  const std::string bvh = test::shared_bvh("bandai/dataset-1_walk_active_001.bvh");
  if (!std::filesystem::exists(bvh)) GTEST_SKIP() << bvh << " is absent";
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  const AutoJointMap found = find_joint_map_of_files(bvh, test::kHumanoidXml, "mujoco");
  EXPECT_EQ(pairs_of(found.map)["Neck"], "head");
  EXPECT_EQ(found.map.joints.size(), 14u);
  EXPECT_NEAR(found.clip_leg_length_m, 0.80, 0.02);  // the bones' lengths: pose-free
}

// LaFAN1's convention (tests/motion/clip_conventions.h: a rest pose along X, toes, hands and
// head as joints with zero End Sites, Z-Y-X rotations, 30 Hz): the map onto humanoid.xml is the
// plain walk's, under LaFAN1's names, at the same scale
TEST(AutoJointMap, LaFan1sClipMapsAsThePlainWalk) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "no " << test::kHumanoidXml;
  const BvhClip plain = make_synthetic_walk_clip();
  const std::string plain_file = test::write_temp_file("plain_walk.bvh", format_bvh(plain));
  const std::string lafan_file =
      test::write_temp_file("lafan1_walk.bvh", format_bvh(test::lafan1_like(plain)));
  const AutoJointMap want = find_joint_map_of_files(plain_file, test::kHumanoidXml, "mujoco");
  const AutoJointMap got = find_joint_map_of_files(lafan_file, test::kHumanoidXml, "mujoco");
  std::map<std::string, std::string> renamed;
  for (auto [segment, body] : pairs_of(want.map))
    renamed[segment == "Head" ? "Neck" : segment == "Chest" ? "Spine1" : segment] = body;
  EXPECT_EQ(pairs_of(got.map), renamed);
  EXPECT_EQ(got.map.joints.size(), 14u);
  EXPECT_NEAR(*got.map.scale, *want.map.scale, 0.01 * *want.map.scale);
}

// sides from the rest pose where names give none: humanoid.xml with left_/right_ renamed a_/b_
TEST(AutoJointMap, SidesWithoutSideNamesComeFromTheRestPose) {
  std::ifstream in(test::kHumanoidXml);
  std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (auto [from, to] : {std::pair<std::string, std::string>{"left_", "a_"}, {"right_", "b_"}})
    for (size_t at; (at = xml.find(from)) != std::string::npos;) xml.replace(at, from.size(), to);
  auto model = load("mujoco", test::write_temp_file("humanoid_unsided.xml", xml));
  AutoJointMap found = find_joint_map(synthetic_walk_skeleton(), "walk", *model, "unsided");
  auto pairs = pairs_of(found.map);
  // the humanoid faces +x: its left (+y) side is the one once named left_
  EXPECT_EQ(pairs["LeftUpLeg"], "a_thigh");
  EXPECT_EQ(pairs["RightFoot"], "b_foot");
  EXPECT_EQ(pairs["LeftForeArm"], "a_lower_arm");
  EXPECT_EQ(pairs["RightArm"], "b_upper_arm");
  EXPECT_EQ(found.map.joints.size(), 14u);
}

TEST(AutoJointMap, TheWrittenFileReadsBackAsTheSameMap) {
  auto model = load("mujoco", test::kHumanoidXml);
  AutoJointMap found = find_joint_map(synthetic_walk_skeleton(), "walk", *model, "humanoid");
  const std::string path =
      test::write_temp_file("auto_map.yaml", joint_map_yaml(found, "walk.bvh", "humanoid.xml"));
  const JointMap back = read_joint_map(path);
  EXPECT_EQ(pairs_of(back), pairs_of(found.map));
  EXPECT_NEAR(*back.scale, *found.map.scale, 1e-5 * *found.map.scale);
  EXPECT_EQ(back.model_up, found.map.model_up);
}

TEST(AutoJointMap, AtlasHingeChainsGiveCompleteLegs) {
  if (!test::have_atlas()) GTEST_SKIP() << "no dart-doc Atlas";
  auto model = load("dart", "dart://sample/sdf/atlas/atlas_v3_no_head.urdf");
  AutoJointMap found = find_joint_map(synthetic_walk_skeleton(), "walk", *model, "atlas");
  auto pairs = pairs_of(found.map);
  // the thigh is the hip's third hinge body (l_uglut, l_lglut, l_uleg), the foot the ankle's
  // second (l_talus, l_foot)
  EXPECT_EQ(pairs["Hips"], "pelvis");
  EXPECT_EQ(pairs["LeftUpLeg"], "l_uleg");
  EXPECT_EQ(pairs["LeftLeg"], "l_lleg");
  EXPECT_EQ(pairs["LeftFoot"], "l_foot");
  EXPECT_EQ(pairs["RightUpLeg"], "r_uleg");
  EXPECT_EQ(pairs["RightLeg"], "r_lleg");
  EXPECT_EQ(pairs["RightFoot"], "r_foot");
  EXPECT_EQ(pairs["Chest"], "utorso");
  EXPECT_EQ(pairs["LeftArm"], "l_uarm");
  EXPECT_EQ(pairs["RightForeArm"], "r_larm");
  // no head: the light camera frames on the torso are no head
  EXPECT_EQ(pairs.count("Head"), 0u);
}

// a robot's shoulder as three hinges apart, the third a twist down the upper arm: the upper arm
// is the body above the one named an elbow (before: the pitch link, 6 cm long, and the roll link
// as the forearm)
TEST(AutoJointMap, ShoulderHingesApartGiveTheUpperArmAboveTheElbow) {
  auto model = load("mujoco", test::source_dir() + "/tests/models/hinge_arm_robot.xml");
  AutoJointMap found = find_joint_map(synthetic_walk_skeleton(), "walk", *model, "robot");
  auto pairs = pairs_of(found.map);
  EXPECT_EQ(pairs["LeftArm"], "left_shoulder_yaw_link");
  EXPECT_EQ(pairs["LeftForeArm"], "left_elbow_link");
  EXPECT_EQ(pairs["RightArm"], "right_shoulder_yaw_link");
  EXPECT_EQ(pairs["RightForeArm"], "right_elbow_link");
  EXPECT_EQ(pairs["LeftUpLeg"], "left_thigh_link");
}

TEST(AutoJointMap, Fullbody1YUpGivesCompleteLegs) {
  if (!test::have_dart_data()) GTEST_SKIP() << "no dart-doc";
  auto model = load("dart", test::kFullbodySkel);
  AutoJointMap found = find_joint_map(synthetic_walk_skeleton(), "walk", *model, "fullbody1");
  EXPECT_EQ(found.map.model_up, 'y');
  const JointMap hand = read_joint_map("models/maps/synthetic_walk_to_fullbody1.yaml");
  EXPECT_EQ(pairs_of(found.map), pairs_of(hand));
  std::cout << joint_map_report(found);
}

TEST(AutoJointMap, AModelWithoutLegsIsAnErrorNamingItsBodies) {
  const std::string xml = test::write_temp_file("no_legs.xml", test::kFloatingChainMjcf);
  auto model = load("mujoco", xml);
  try {
    find_joint_map(synthetic_walk_skeleton(), "walk", *model, "no_legs.xml");
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("no_legs.xml: found no two legs"), std::string::npos) << what;
    EXPECT_NE(what.find("base, link1, link2"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace stance
