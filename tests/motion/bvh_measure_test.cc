#include "motion/bvh_measure.h"

#include <cmath>
#include <filesystem>
#include <numbers>

#include <gtest/gtest.h>

#include "motion/clip_conventions.h"
#include "motion/reference_motion.h"

namespace stance {
namespace {

// the synthetic walk's skeleton at rest: the head's End Site 12 + 22 + 24 + 20 cm above the
// hips, the toes' 6 + 44 + 42 + 7 cm below
constexpr double kSyntheticHeightM = 0.78 + 0.99;
constexpr double kSyntheticLegM = 0.99;

struct Convention {
  std::string name;
  BvhClip clip;
};

// the synthetic walk as each exporter the docs list writes it (docs/mocap.md, "Other exporters'
// files"), each through the writer and the reader
std::vector<Convention> exporter_conventions() {
  const BvhClip cm = make_synthetic_walk_clip();
  const BvhClip keyed = test::with_bones_in_position_channels(cm, 0.0);
  const BvhClip bandai_bones =
      test::with_bones_along_x(test::with_bones_in_position_channels(cm, 1.0));
  const std::map<std::string, std::string> asf_names = {
      {"LeftUpLeg", "lfemur"},  {"LeftLeg", "ltibia"},  {"LeftFoot", "lfoot"},
      {"RightUpLeg", "rfemur"}, {"RightLeg", "rtibia"}, {"RightFoot", "rfoot"}};
  std::vector<Convention> all = {
      {"centimetres", cm},
      {"metres", test::rescaled(cm, 0.01)},
      {"millimetres", test::rescaled(cm, 10)},
      {"inches", test::rescaled(cm, 1 / 2.54)},
      {"feet", test::rescaled(cm, 1 / 30.48)},
      {"CMU units, ASF names", test::renamed(test::rescaled(cm, 0.01 / 0.056444), asf_names)},
      {"Z-up skeleton", test::written_z_up(cm)},
      {"Z-up by the root's rotation", test::root_turned_z_up(cm)},
      {"Mixamo namespace", test::prefixed(cm, "mixamorig:")},
      {"3ds Max Biped names", test::prefixed(cm, "Bip01 ")},
      {"a leading T-pose (cgspeed CMU)", test::with_leading_t_pose(cm, 1, {0, 200, -300})},
      {"every bone keyed, zero OFFSETs (Blender)", keyed},
      {"LaFAN1: 30 Hz, Z-Y-X, bones along X, toes and hands with zero End Sites",
       test::lafan1_like(cm)},
      {"a moving carrier root", test::with_carrier_root(cm, "joint_Root")},
      {"Bandai: bones along X, 6 channels, a still ground carrier",
       test::renamed(test::with_ground_carrier_root(bandai_bones, "joint_Root", false),
                     test::bandai_names())},
      {"Bandai: bones along X, 6 channels, the translation in the ground carrier",
       test::renamed(test::with_ground_carrier_root(bandai_bones, "joint_Root", true),
                     test::bandai_names())},
      {"Bandai in metres",
       test::rescaled(test::with_ground_carrier_root(bandai_bones, "joint_Root", true), 0.01)},
  };
  for (Convention& c : all) c.clip = parse_bvh(format_bvh(c.clip), c.name);
  return all;
}

// a character of a person's size from every exporter's file, with no setting: the units snap to
// the file's, and the height and legs are the synthetic skeleton's
TEST(BvhMeasure, EveryExporterConventionGivesThePersonsHeight) {
  for (const Convention& c : exporter_conventions()) {
    SCOPED_TRACE(c.name);
    const BvhCharacterMeasures m = measure_bvh_character(c.clip);
    EXPECT_NEAR(m.standing_height_m, kSyntheticHeightM, 0.03);
    EXPECT_NEAR(m.leg_m, kSyntheticLegM, 0.03);
    EXPECT_NEAR(m.mean_speed_mps, 1.27, 0.03);
    EXPECT_TRUE(bvh_character_warnings(c.clip, m).empty());
    // and the skeleton the tracker builds is that tall at rest
    const MotionSkeleton sk = make_motion_skeleton(c.clip, {});
    EXPECT_TRUE(sk.warnings.empty());
    double top = 0, bottom = 0;
    std::vector<Eigen::Vector3d> rest(sk.segment_count(), Eigen::Vector3d::Zero());
    for (int k = 0; k < sk.segment_count(); ++k) {
      if (k > 0) rest[k] = rest[sk.segments[k].parent] + sk.segments[k].offset;
      for (const Eigen::Vector3d& e : sk.segments[k].bone_ends) {
        top = std::max(top, (rest[k] + e).z());
        bottom = std::min(bottom, (rest[k] + e).z());
      }
    }
    if (m.rest_pose_stands) EXPECT_NEAR(top - bottom, kSyntheticHeightM, 0.02);
  }
}

// the units that snap: a rest pose that lies along X is measured in the frames
TEST(BvhMeasure, ARestPoseAlongXIsMeasuredInTheFrames) {
  const BvhClip cm = make_synthetic_walk_clip();
  const BvhClip along_x = parse_bvh(
      format_bvh(test::with_bones_along_x(test::with_bones_in_position_channels(cm, 1.0))), "x");
  EXPECT_FALSE(measure_bvh_character(along_x).rest_pose_stands);
  EXPECT_TRUE(measure_bvh_character(cm).rest_pose_stands);
  EXPECT_EQ(detect_bvh_units(along_x), "centimeters");
  EXPECT_EQ(detect_bvh_scale_to_meters(along_x), 0.01);
  EXPECT_NEAR(bvh_leg_drop(along_x), bvh_leg_drop(cm), 3);
}

// a mis-scaled clip is named with its numbers and the setting that overrides them
TEST(BvhMeasure, AMisScaledClipGetsAWarning) {
  const BvhClip cm = make_synthetic_walk_clip();
  // read at 0.139 m per unit (as Bandai's files were before their legs were measured posed)
  const BvhCharacterMeasures giant = measure_bvh_character(cm, 0.139);
  const std::vector<std::string> w = bvh_character_warnings(cm, giant);
  ASSERT_EQ(w.size(), 2u);  // too tall, and too fast
  EXPECT_NE(w[0].find("synthetic_walk.bvh: the character stands 24.8 m tall"), std::string::npos)
      << w[0];
  EXPECT_NE(w[0].find("scale_to_meters"), std::string::npos) << w[0];
  EXPECT_NE(w[1].find("the root moves at up to 17.6 m/s"), std::string::npos) << w[1];
  EXPECT_NE(w[1].find("scale_to_meters"), std::string::npos) << w[1];
  // too small: millimetres read as centimetres
  const BvhCharacterMeasures small = measure_bvh_character(cm, 0.001);
  ASSERT_EQ(bvh_character_warnings(cm, small).size(), 1u);
  EXPECT_NE(bvh_character_warnings(cm, small)[0].find("stands 0.179 m tall"), std::string::npos);
}

// a root that moves 20 m/s on a person-sized body: the skeleton built with the detected units
// carries the warning; a given scale_to_meters is the user's word and carries none
TEST(BvhMeasure, ARootFasterThanAPersonIsWarnedAboutWhenBuilt) {
  BvhClip fast = make_synthetic_walk_clip();
  for (int f = 0; f < fast.frame_count; ++f)
    fast.positions[static_cast<size_t>(f) * fast.position_joint_count].z() *= 16;
  const MotionSkeleton sk = make_motion_skeleton(fast, {});
  ASSERT_EQ(sk.warnings.size(), 1u);
  EXPECT_NE(sk.warnings[0].find("the root moves at up to 20.3 m/s"), std::string::npos)
      << sk.warnings[0];
  MotionSkeletonOptions given;
  given.scale_to_meters = 0.01;
  EXPECT_TRUE(make_motion_skeleton(fast, given).warnings.empty());
}

// the heading: where the character faces and where it goes, about the file's up axis
TEST(BvhMeasure, HeadingFollowsTheCharacter) {
  const BvhClip walk = make_synthetic_walk_clip();
  const BvhCharacterMeasures m = measure_bvh_character(walk);
  EXPECT_NEAR(bvh_heading_deg(m.facing, m.up_axis), 0, 2);
  EXPECT_NEAR(bvh_heading_deg(m.travel, m.up_axis), 0, 0.1);
  // the whole clip turned 60 deg about +Y: both turn with it
  BvhClip turned = walk;
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(std::numbers::pi / 3, Eigen::Vector3d::UnitY()));
  for (int f = 0; f < turned.frame_count; ++f) {
    turned.rotation(f, 0) = yaw * turned.rotation(f, 0);
    Eigen::Vector3d& root = turned.positions[static_cast<size_t>(f) * turned.position_joint_count];
    root = yaw * root;
  }
  const BvhCharacterMeasures t = measure_bvh_character(turned);
  EXPECT_NEAR(bvh_heading_deg(t.facing, t.up_axis), 60, 2);
  EXPECT_NEAR(bvh_heading_deg(t.travel, t.up_axis), 60, 0.1);
  // walking backwards: it faces one way and goes the other
  BvhClip back = walk;
  for (int f = 0; f < back.frame_count; ++f)
    back.positions[static_cast<size_t>(f) * back.position_joint_count].z() *= -1;
  const BvhCharacterMeasures b = measure_bvh_character(back);
  EXPECT_NEAR(bvh_heading_deg(b.facing, b.up_axis), 0, 2);
  EXPECT_NEAR(std::abs(bvh_heading_deg(b.travel, b.up_axis)), 180, 0.1);
  // Z-up: about +Z from +X; the walk goes along -Y there
  const BvhClip z_up = test::written_z_up(walk);
  const BvhCharacterMeasures z = measure_bvh_character(z_up);
  EXPECT_EQ(z.up_axis, 'z');
  EXPECT_NEAR(bvh_heading_deg(z.travel, 'z'), -90, 0.1);
}

// bvh info's lines
TEST(BvhMeasure, InfoPrintsHeightSpeedAndHeading) {
  const std::string text = bvh_measures_text(make_synthetic_walk_clip());
  EXPECT_NE(text.find("height:      1.79 m standing, legs 0.99 m"), std::string::npos) << text;
  EXPECT_NE(text.find("speed:       1.27 m/s mean"), std::string::npos) << text;
  EXPECT_NE(text.find("heading:     facing 0.0 deg, travelling 0.0 deg"), std::string::npos)
      << text;
  EXPECT_EQ(text.find("warning"), std::string::npos) << text;
  const nlohmann::json j = bvh_measures_json(make_synthetic_walk_clip());
  EXPECT_NEAR(j.at("standing_height_m").get<double>(), 1.79, 0.005);
  EXPECT_TRUE(j.at("warnings").empty());
}

// the real clips, where ../shared is present: every one a person's size, the Bandai Namco four
// (bones along X at rest, 6 channels everywhere, a ground carrier) in centimetres
TEST(BvhMeasure, SharedClipsArePeopleSized) {
  const std::string dir = "../shared/data/bvh/";
  if (!std::filesystem::exists(dir + "mass_walk.bvh")) GTEST_SKIP() << "no ../shared";
  for (const std::string name :
       {"mass_walk.bvh", "cmu_131_01.bvh", "bandai/dataset-1_walk_active_001.bvh",
        "bandai/dataset-1_run_active_001.bvh", "bandai/dataset-1_walk-left_active_001.bvh",
        "bandai/dataset-1_walk-back_active_001.bvh"}) {
    SCOPED_TRACE(name);
    if (!std::filesystem::exists(dir + name)) continue;
    const BvhClip clip = read_bvh(dir + name);
    const BvhCharacterMeasures m = measure_bvh_character(clip);
    EXPECT_GT(m.standing_height_m, 1.3);
    EXPECT_LT(m.standing_height_m, 1.7);
    EXPECT_TRUE(bvh_character_warnings(clip, m).empty());
    if (name.starts_with("bandai/")) {
      EXPECT_EQ(detect_bvh_units(clip), "centimeters");
      EXPECT_FALSE(m.rest_pose_stands);
    }
  }
  EXPECT_EQ(detect_bvh_scale_to_meters(read_bvh(dir + "mass_walk.bvh")), 0.01);
  EXPECT_EQ(detect_bvh_scale_to_meters(read_bvh(dir + "cmu_131_01.bvh")), 0.056444);
}

}  // namespace
}  // namespace stance
