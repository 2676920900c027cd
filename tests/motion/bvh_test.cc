#include "motion/bvh.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "motion/clip_conventions.h"
#include "motion/reference_motion.h"
#include "test_support.h"

namespace stance {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

const std::array<std::string_view, 6> kOrderNames = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string rotation_channels(std::string_view order) {
  std::string out;
  for (char axis : order) out += fmt::format(" {}rotation", axis);
  return out;
}

// Root with 6 channels, two joints with 3, one End Site, all rotations listed in `order`.
// Line numbers matter to the error tests: the rows start at line 24.
//  1 HIERARCHY   5 root CHANNELS   9 LeftUpLeg CHANNELS   13 LeftLeg CHANNELS   21 MOTION
//  22 Frames     23 Frame Time     24.. one row per frame (12 values)
std::string synthetic_bvh(std::string_view order, const std::vector<std::vector<double>>& rows,
                          std::string_view frame_time = "0.0333333") {
  std::string text = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition ROT
  JOINT LeftUpLeg
  {
    OFFSET 10 -5 0
    CHANNELS 3 ROT
    JOINT LeftLeg
    {
      OFFSET 0 -45 0
      CHANNELS 3 ROT
      End Site
      {
        OFFSET 0 -45 0
      }
    }
  }
}
MOTION
)";
  const std::string rot = rotation_channels(order);
  for (size_t at; (at = text.find(" ROT")) != std::string::npos;) text.replace(at, 4, rot);
  text += fmt::format("Frames: {}\nFrame Time: {}\n", rows.size(), frame_time);
  for (const auto& row : rows) {
    for (size_t i = 0; i < row.size(); ++i) text += fmt::format("{}{}", i ? " " : "", row[i]);
    text += "\n";
  }
  return text;
}

const std::vector<std::vector<double>> kRows = {
    {1.5, 95.0, -2.25, 30.0, -45.0, 60.0, 10.0, 20.0, -30.0, 0.0, 0.0, 5.0},
    {1.75, 94.5, -2.0, 170.0, 80.0, -120.0, -10.0, 25.0, 35.0, 45.0, -60.0, 89.0},
    {2.0, 94.0, -1.5, -179.5, 10.0, 179.0, 0.0, 0.0, 0.0, 90.0, 90.0, 90.0},
};

std::string replace_once(std::string text, std::string_view from, std::string_view to) {
  size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// the InputError message from parsing `text`, or "" when it parses
std::string parse_error(const std::string& text) {
  try {
    parse_bvh(text, "test.bvh");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

Eigen::Quaterniond angle_axis_product(std::string_view order, const Eigen::Vector3d& deg) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (int i = 0; i < 3; ++i) {
    q = q * Eigen::AngleAxisd(deg[i] * kDeg, Eigen::Vector3d::Unit(order[i] - 'X'));
  }
  return q;
}

// same hierarchy, same rotations and positions to `tol`
void expect_same_motion(const BvhClip& a, const BvhClip& b, double tol) {
  ASSERT_EQ(a.joint_count(), b.joint_count());
  ASSERT_EQ(a.frame_count, b.frame_count);
  ASSERT_EQ(a.channel_count, b.channel_count);
  EXPECT_EQ(a.frame_time_s, b.frame_time_s);
  for (int j = 0; j < a.joint_count(); ++j) {
    const BvhJoint& ja = a.joints[j];
    const BvhJoint& jb = b.joints[j];
    EXPECT_EQ(ja.name, jb.name);
    EXPECT_EQ(ja.parent, jb.parent);
    EXPECT_EQ(ja.offset, jb.offset);
    EXPECT_EQ(ja.channels, jb.channels);
    EXPECT_EQ(ja.order, jb.order);
    EXPECT_EQ(ja.has_end_site, jb.has_end_site);
    EXPECT_EQ(ja.end_site_offset, jb.end_site_offset);
  }
  double worst_rot = 0.0, worst_pos = 0.0;
  for (int f = 0; f < a.frame_count; ++f) {
    for (int j = 0; j < a.joint_count(); ++j) {
      worst_rot = std::max(worst_rot, geodesic_angle(a.rotation(f, j), b.rotation(f, j)));
      worst_pos = std::max(worst_pos, (a.translation(f, j) - b.translation(f, j)).norm());
    }
  }
  EXPECT_LT(worst_rot, tol);
  EXPECT_LT(worst_pos, tol);
}

int count_order(const BvhClip& clip, RotationOrder order) {
  int n = 0;
  for (const auto& j : clip.joints) n += (j.order == order);
  return n;
}

// ---------------------------------------------------------------- shared real files

TEST(BvhSharedFiles, MassWalk) {
  const std::string path = test::shared_bvh("mass_walk.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
  BvhClip clip = read_bvh(path);
  // expected values from the file itself:
  //   grep -cE '^\s*(ROOT|JOINT)' -> 37; grep -c 'End Site' -> 21
  //   grep CHANNELS | awk '{s+=$2}' -> 114; "Frames:\t132", "Frame Time:\t0.00833333"
  //   every CHANNELS line lists Zrotation Xrotation Yrotation (root: 6 channels, others 3)
  EXPECT_EQ(clip.joint_count(), 37);
  int end_sites = 0;
  for (const auto& j : clip.joints) end_sites += j.has_end_site;
  EXPECT_EQ(end_sites, 21);
  EXPECT_EQ(clip.channel_count, 114);
  EXPECT_EQ(clip.frame_count, 132);
  EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.00833333);
  EXPECT_EQ(count_order(clip, RotationOrder::kZXY), 37);
  EXPECT_EQ(clip.joints[0].name, "Character1_Hips");
  EXPECT_EQ(clip.joints[0].channels.size(), 6u);
  EXPECT_EQ(clip.position_joint_count, 1);
  // first row starts "-30.5073 104.521 -237.413 3.43058 -2.8926 -8.40971" (awk after Frame Time)
  EXPECT_EQ(clip.raw(0, 1), 104.521);
  EXPECT_EQ(clip.translation(0, 0), Eigen::Vector3d(-30.5073, 104.521, -237.413));
  EXPECT_LT(
      geodesic_angle(clip.rotation(0, 0), angle_axis_product("ZXY", {3.43058, -2.8926, -8.40971})),
      1e-14);
  // last row ends with "-0"
  EXPECT_EQ(clip.raw(131, 113), 0.0);
  EXPECT_EQ(detect_bvh_units(clip), "centimeters");
  EXPECT_EQ(detect_bvh_scale_to_meters(clip), 0.01);
  EXPECT_EQ(detect_bvh_up_axis(clip), 'y');
}

TEST(BvhSharedFiles, CmuMixedOrdersAndLineEndings) {
  const std::string path = test::shared_bvh("cmu_131_01.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
  BvhClip clip = read_bvh(path);
  // from the file: 31 ROOT/JOINT lines, 7 End Sites, 96 channels, "Frames: 994",
  // "Frame Time: .0083333"; CHANNELS lines: ZYX on the root + 18 joints, ZXY on the 12 arm
  // joints from LeftShoulder/RightShoulder down (awk over CHANNELS lines, see the README table)
  EXPECT_EQ(clip.joint_count(), 31);
  int end_sites = 0;
  for (const auto& j : clip.joints) end_sites += j.has_end_site;
  EXPECT_EQ(end_sites, 7);
  EXPECT_EQ(clip.channel_count, 96);
  EXPECT_EQ(clip.frame_count, 994);
  EXPECT_DOUBLE_EQ(clip.frame_time_s, 0.0083333);
  EXPECT_EQ(count_order(clip, RotationOrder::kZYX), 19);
  EXPECT_EQ(count_order(clip, RotationOrder::kZXY), 12);
  EXPECT_EQ(clip.joints[clip.find_joint("LeftElbow")].order, RotationOrder::kZXY);
  EXPECT_EQ(clip.joints[clip.find_joint("LeftKnee")].order, RotationOrder::kZYX);
  EXPECT_EQ(clip.joints[clip.find_joint("LeftKnee")].parent, clip.find_joint("LeftHip"));
  // first row "5.2300 16.9002 -33.8986 -5.4029 9.8098 10.4956 ..."; Hips lists Z Y X
  EXPECT_EQ(clip.translation(0, 0), Eigen::Vector3d(5.23, 16.9002, -33.8986));
  EXPECT_LT(
      geodesic_angle(clip.rotation(0, 0), angle_axis_product("ZYX", {-5.4029, 9.8098, 10.4956})),
      1e-14);
  // last row (no final newline): 96 values ending in 19.734
  EXPECT_EQ(clip.raw(993, 95), 19.734);
  EXPECT_EQ(detect_bvh_units(clip), "cmu");
  EXPECT_NEAR(detect_bvh_scale_to_meters(clip), 0.056444, 1e-12);

  nlohmann::json info = bvh_info_json(clip);
  EXPECT_EQ(info["frames"], 994);
  EXPECT_EQ(info["frame_time"], 0.0083333);
  EXPECT_EQ(info["joints"], 31);
  EXPECT_EQ(info["channels"], 96);
  EXPECT_EQ(info["rotation_orders"]["Hips"], "ZYX");
  EXPECT_EQ(info["rotation_orders"]["RThumb"], "ZXY");
  EXPECT_EQ(info["units"], "cmu");
  EXPECT_EQ(info["up_axis"], "y");
  EXPECT_EQ(info["first_motion_frame"], 0);
  EXPECT_NEAR(info["duration_s"].get<double>(), 994 * 0.0083333, 1e-12);
  std::string text = bvh_info_text(clip);
  EXPECT_NE(text.find("frames:      994"), std::string::npos) << text;
  EXPECT_NE(text.find("ZXY x12"), std::string::npos) << text;
  EXPECT_NE(text.find("ZYX x19"), std::string::npos) << text;
}

TEST(BvhSharedFiles, RoundTripWithin1e9) {
  for (const char* file : {"mass_walk.bvh", "cmu_131_01.bvh"}) {
    const std::string path = test::shared_bvh(file);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
    SCOPED_TRACE(file);
    BvhClip clip = read_bvh(path);
    const std::string out =
        (std::filesystem::temp_directory_path() / fmt::format("stance_bvh_rt_{}", file)).string();
    write_bvh(clip, out);
    BvhClip back = read_bvh(out);
    std::filesystem::remove(out);
    expect_same_motion(clip, back, 1e-9);
    // positions and offsets are written exactly
    for (int f = 0; f < clip.frame_count; ++f) {
      EXPECT_EQ(clip.translation(f, 0), back.translation(f, 0));
    }
    // and a second round is stable text
    EXPECT_EQ(format_bvh(back), format_bvh(parse_bvh(format_bvh(back), "again")));
  }
}

TEST(BvhSharedFiles, RealFileErrorsNameTheRightLine) {
  const std::string path = test::shared_bvh("cmu_131_01.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no " << path;
  const std::string text = slurp(path);
  // corrupt the first value of line 500 (a motion row after the mixed CRLF/LF header)
  size_t at = 0;
  for (int line = 1; line < 500; ++line) at = text.find('\n', at) + 1;
  std::string bad = text;
  bad.insert(at, "x");
  std::string msg = parse_error(bad);
  EXPECT_NE(msg.find("test.bvh:500: bad number 'x"), std::string::npos) << msg;
  // cut after line 1000: 1000 - 187 = 813 rows remain of 994; the next row is line 1001
  at = 0;
  for (int line = 1; line <= 1000; ++line) at = text.find('\n', at) + 1;
  msg = parse_error(text.substr(0, at));
  EXPECT_NE(msg.find("test.bvh:1001: truncated data: 'Frames: 994' (line 186) but only 813"),
            std::string::npos)
      << msg;
}

// ---------------------------------------------------------------- synthetic files

TEST(BvhSynthetic, EveryOrderMatchesAngleAxisComposition) {
  for (std::string_view order : kOrderNames) {
    SCOPED_TRACE(order);
    BvhClip clip = parse_bvh(synthetic_bvh(order, kRows), "synthetic.bvh");
    ASSERT_EQ(clip.joint_count(), 3);
    EXPECT_EQ(clip.channel_count, 12);
    EXPECT_EQ(clip.frame_count, 3);
    for (const auto& j : clip.joints) EXPECT_EQ(rotation_order_name(j.order), order);
    EXPECT_EQ(clip.joints[2].first_column, 9);
    EXPECT_TRUE(clip.joints[2].has_end_site);
    EXPECT_EQ(clip.joints[2].end_site_offset, Eigen::Vector3d(0, -45, 0));
    for (int f = 0; f < 3; ++f) {
      const auto& r = kRows[f];
      EXPECT_EQ(clip.translation(f, 0), Eigen::Vector3d(r[0], r[1], r[2]));
      EXPECT_EQ(clip.translation(f, 1), Eigen::Vector3d(10, -5, 0));  // no position channels
      for (int j = 0; j < 3; ++j) {
        int c = 3 + 3 * j;
        Eigen::Quaterniond expected = angle_axis_product(order, {r[c], r[c + 1], r[c + 2]});
        EXPECT_LT(geodesic_angle(clip.rotation(f, j), expected), 1e-14) << f << " " << j;
      }
    }
    // the known rotation of frame 0, joint 0, worked by hand for ZXY: Rz(30) Rx(-45) Ry(60)
    if (order == "ZXY") {
      Eigen::Matrix3d expected = (Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(-45 * kDeg, Eigen::Vector3d::UnitX()) *
                                  Eigen::AngleAxisd(60 * kDeg, Eigen::Vector3d::UnitY()))
                                     .toRotationMatrix();
      EXPECT_LT((clip.rotation(0, 0).toRotationMatrix() - expected).norm(), 1e-14);
    }
    // round trip through the writer
    BvhClip back = parse_bvh(format_bvh(clip), "written.bvh");
    expect_same_motion(clip, back, 1e-9);
  }
}

TEST(BvhSynthetic, LineEndingsTabsAndSpacingParseIdentically) {
  const std::string lf = synthetic_bvh("ZXY", kRows);
  BvhClip reference = parse_bvh(lf, "lf.bvh");

  std::string crlf;
  for (char c : lf) crlf += (c == '\n') ? std::string("\r\n") : std::string(1, c);
  std::string cr;  // old Mac endings
  for (char c : lf) cr += (c == '\n') ? '\r' : c;
  std::string mixed;
  int line = 0;
  for (char c : lf) {
    if (c == '\n')
      mixed += (line++ % 2) ? "\r\n" : "\n";
    else
      mixed += c;
  }
  std::string tabs;  // tabs for spaces, trailing whitespace, blank lines
  for (char c : lf) {
    if (c == ' ')
      tabs += "\t";
    else if (c == '\n')
      tabs += " \t\n\n";
    else
      tabs += c;
  }
  std::string no_leading_zero = replace_once(lf, "Frame Time: 0.0333333", "Frame Time:\t.0333333");
  std::string no_space = replace_once(lf, "Frames: 3", "Frames:3");

  for (const std::string* text : {&crlf, &cr, &mixed, &tabs, &no_leading_zero, &no_space}) {
    BvhClip clip = parse_bvh(*text, "variant.bvh");
    expect_same_motion(reference, clip, 1e-15);
    EXPECT_EQ(clip.raw, reference.raw);
  }
  EXPECT_EQ(parse_bvh(no_leading_zero, "x").frame_time_s, 0.0333333);

  // error lines count the same way whatever the line endings
  for (std::string text : {crlf, cr, mixed}) {
    size_t at = text.find("94.5");
    text.replace(at, 4, "9x4.5");
    std::string msg = parse_error(text);
    EXPECT_NE(msg.find("test.bvh:25: bad number '9x4.5'"), std::string::npos) << msg;
  }
}

TEST(BvhSynthetic, RootWithThreeChannelsPositionsOnAnyJointAndPartialChannels) {
  const std::string text =
      "HIERARCHY\n"
      "ROOT Pelvis {\n"
      "\tOFFSET 0 90 0\n"
      "\tCHANNELS 3 Yrotation Xrotation Zrotation\n"
      "\tJOINT Slider\n"
      "\t{\n"
      "\t\tOFFSET 0 -10 0\n"
      "\t\tCHANNELS 4 Zposition Xrotation Xposition Zrotation\n"
      "\t\tJOINT Knee\n"
      "\t\t{\n"
      "\t\t\tOFFSET 0 -40 0\n"
      "\t\t\tCHANNELS 1 Xrotation\n"
      "\t\t\tEnd Site\n"
      "\t\t\t{\n"
      "\t\t\t\tOFFSET 0 -40 0\n"
      "\t\t\t}\n"
      "\t\t}\n"
      "\t}\n"
      "}\n"
      "MOTION\n"
      "Frames: 3\n"
      "Frame Time: .01\n"
      "10 20 30   1.5 -100 2.5 7   135\n"
      "-10 0 0   -1.5 170 0 -7   -170\n"
      "0 0 0   0 0 0 0   0\n";
  BvhClip clip = parse_bvh(text, "partial.bvh");
  ASSERT_EQ(clip.joint_count(), 3);
  EXPECT_EQ(clip.channel_count, 8);
  EXPECT_EQ(clip.joints[0].order, RotationOrder::kYXZ);
  EXPECT_FALSE(clip.joints[0].has_position);
  EXPECT_EQ(clip.translation(0, 0), Eigen::Vector3d(0, 90, 0));  // the OFFSET
  // Slider: rotation x then z (y unlisted, appended), position x and z from channels, y offset
  EXPECT_EQ(clip.joints[1].order, RotationOrder::kXZY);
  EXPECT_EQ(clip.joints[1].rotation_channel_count, 2);
  EXPECT_EQ(clip.position_joint_count, 1);
  EXPECT_EQ(clip.translation(0, 1), Eigen::Vector3d(2.5, -10, 1.5));
  EXPECT_EQ(clip.translation(1, 1), Eigen::Vector3d(0, -10, -1.5));
  EXPECT_LT(geodesic_angle(clip.rotation(0, 1), angle_axis_product("XZY", {-100, 7, 0})), 1e-14);
  EXPECT_LT(geodesic_angle(clip.rotation(0, 2), angle_axis_product("XYZ", {135, 0, 0})), 1e-14);
  // the writer puts partial joints back on their own axes, unlisted angles 0
  std::string written = format_bvh(clip);
  BvhClip back = parse_bvh(written, "written.bvh");
  expect_same_motion(clip, back, 1e-9);
  // values agree up to whole turns (the writer keeps each curve continuous: 135 -> 190, not -170)
  for (int f = 0; f < 3; ++f) {
    for (int c = 0; c < clip.channel_count; ++c) {
      EXPECT_NEAR(std::remainder(back.raw(f, c) - clip.raw(f, c), 360.0), 0.0, 1e-8) << written;
    }
  }
  EXPECT_EQ(back.raw(1, 7), 190.0);
}

TEST(BvhSynthetic, WriterKeepsAnglesContinuous) {
  // the root yaws steadily through +180 deg; the written curve must not jump to -180
  std::vector<std::vector<double>> rows;
  for (int f = 0; f < 40; ++f) {
    rows.push_back({0, 95, 0, 150.0 + 2.0 * f, 10, -5, 0, 0, 0, 0, 0, 0});
  }
  BvhClip clip = parse_bvh(synthetic_bvh("ZXY", rows), "spin.bvh");
  BvhClip back = parse_bvh(format_bvh(clip), "written.bvh");
  for (int f = 0; f < 40; ++f) EXPECT_NEAR(back.raw(f, 3), 150.0 + 2.0 * f, 1e-9) << f;
  expect_same_motion(clip, back, 1e-9);
}

TEST(BvhSynthetic, WriteBvhRoundTripsThroughAFile) {
  BvhClip clip = parse_bvh(synthetic_bvh("YZX", kRows), "synthetic.bvh");
  const std::string out =
      (std::filesystem::temp_directory_path() / "stance_bvh_synthetic_rt.bvh").string();
  write_bvh(clip, out);
  BvhClip back = read_bvh(out);
  std::filesystem::remove(out);
  expect_same_motion(clip, back, 1e-9);
  EXPECT_EQ(back.source, out);
  EXPECT_THROW(write_bvh(clip, "/nonexistent-dir/x.bvh"), InputError);
}

TEST(BvhUnits, DetectedFromLegLength) {
  // the synthetic leg drops 5 + 45 + 45 = 95 file units below the root
  std::string cm = synthetic_bvh("ZXY", kRows);
  EXPECT_EQ(detect_bvh_units(parse_bvh(cm, "cm")), "centimeters");
  EXPECT_EQ(detect_bvh_scale_to_meters(parse_bvh(cm, "cm")), 0.01);
  std::string m =
      replace_once(replace_once(replace_once(cm, "OFFSET 10 -5 0", "OFFSET 0.1 -0.05 0"),
                                "OFFSET 0 -45 0", "OFFSET 0 -0.45 0"),
                   "OFFSET 0 -45 0", "OFFSET 0 -0.45 0");
  EXPECT_EQ(detect_bvh_units(parse_bvh(m, "m")), "meters");
  EXPECT_EQ(detect_bvh_scale_to_meters(parse_bvh(m, "m")), 1.0);
  // 37.4 in = 0.95 m
  std::string in = replace_once(replace_once(replace_once(cm, "OFFSET 10 -5 0", "OFFSET 4 -2 0"),
                                             "OFFSET 0 -45 0", "OFFSET 0 -17.7 0"),
                                "OFFSET 0 -45 0", "OFFSET 0 -17.7 0");
  EXPECT_EQ(detect_bvh_units(parse_bvh(in, "in")), "inches");
  EXPECT_EQ(detect_bvh_scale_to_meters(parse_bvh(in, "in")), 0.0254);
  // 6 units fits no unit (cmu would give 0.34 m, feet 1.8 m): scaled so the leg is 0.9 m
  std::string odd = replace_once(replace_once(replace_once(cm, "OFFSET 10 -5 0", "OFFSET 1 -1 0"),
                                              "OFFSET 0 -45 0", "OFFSET 0 -2.5 0"),
                                 "OFFSET 0 -45 0", "OFFSET 0 -2.5 0");
  EXPECT_EQ(detect_bvh_units(parse_bvh(odd, "odd")), "unknown");
  EXPECT_NEAR(detect_bvh_scale_to_meters(parse_bvh(odd, "odd")), 0.15, 1e-15);
}

// cgspeed's CMU release puts a T-pose frame first: it is no part of the motion, wherever its
// root stands; a clip's own fast steps (the run's flight, a 15 fps walk) are
TEST(BvhFirstMotionFrame, LeadingRestFramesAreLeftOut) {
  const BvhClip walk = make_synthetic_walk_clip();
  const BvhClip run = make_synthetic_walk_clip(synthetic_run_options());
  EXPECT_EQ(detect_bvh_first_motion_frame(walk), 0);
  EXPECT_EQ(detect_bvh_first_motion_frame(run), 0);
  for (int count : {1, 2}) {
    SCOPED_TRACE(count);
    for (const BvhClip* clip : {&walk, &run}) {
      EXPECT_EQ(detect_bvh_first_motion_frame(
                    test::with_leading_t_pose(*clip, count, clip->translation(0, 0))),
                count);
      EXPECT_EQ(detect_bvh_first_motion_frame(
                    test::with_leading_t_pose(*clip, count, Eigen::Vector3d::Zero())),
                count);
    }
  }
  // every fourth frame of the walk: 15 fps, larger steps, still all motion
  BvhClip slow = walk;
  slow.frame_count = 0;
  slow.rotations.clear();
  slow.positions.clear();
  for (int f = 0; f < walk.frame_count; f += 4, ++slow.frame_count) {
    for (int j = 0; j < walk.joint_count(); ++j) slow.rotations.push_back(walk.rotation(f, j));
    slow.positions.push_back(walk.translation(f, 0));
  }
  slow.frame_time_s = 4 * walk.frame_time_s;
  EXPECT_EQ(detect_bvh_first_motion_frame(slow), 0);
  EXPECT_EQ(bvh_info_json(
                test::with_leading_t_pose(walk, 1, Eigen::Vector3d::Zero()))["first_motion_frame"],
            1);
  for (const char* name : {"mass_walk.bvh", "cmu_131_01.bvh"}) {
    const std::string path = test::shared_bvh(name);
    if (std::filesystem::exists(path)) EXPECT_EQ(detect_bvh_first_motion_frame(read_bvh(path)), 0);
  }
}

TEST(BvhInfo, JsonKeysOnSyntheticClip) {
  nlohmann::json info = bvh_info_json(parse_bvh(synthetic_bvh("YXZ", kRows), "s.bvh"));
  EXPECT_EQ(info["frames"], 3);
  EXPECT_EQ(info["frame_time"], 0.0333333);
  EXPECT_EQ(info["joints"], 3);
  EXPECT_EQ(info["end_sites"], 1);
  EXPECT_EQ(info["channels"], 12);
  EXPECT_EQ(info["rotation_orders"].size(), 3u);
  EXPECT_EQ(info["rotation_orders"]["LeftLeg"], "YXZ");
  EXPECT_EQ(info["units"], "centimeters");
  EXPECT_EQ(info["up_axis"], "y");
  EXPECT_EQ(info["first_motion_frame"], 0);
  EXPECT_NEAR(info["duration_s"].get<double>(), 0.0999999, 1e-15);
}

// ---------------------------------------------------------------- malformed input

struct BadCase {
  const char* what;
  std::string text;
  const char* expected;  // substring of the message, line number included
};

TEST(BvhErrors, MalformedInputNamesTheLine) {
  const std::string good = synthetic_bvh("ZXY", kRows);
  const std::vector<BadCase> cases = {
      {"truncated data", replace_once(good, "Frames: 3", "Frames: 5"),
       "test.bvh:27: truncated data: 'Frames: 5' (line 22) but only 3 motion rows"},
      {"truncated mid-row", good.substr(0, good.rfind(" 90 90")),
       "test.bvh:26: wrong channel count in motion row: expected 12 values, found 10"},
      {"wrong channel count", replace_once(good, "45 -60 89", "45 -60"),
       "test.bvh:25: wrong channel count in motion row: expected 12 values, found 11"},
      {"too many values", replace_once(good, "45 -60 89", "45 -60 89 1"),
       "test.bvh:25: wrong channel count in motion row: expected 12 values, found 13"},
      {"bad number in a row", replace_once(good, "-179.5", "-17,9.5"),
       "test.bvh:26: bad number '-17,9.5' (value 4 of the motion row)"},
      {"nan in a row", replace_once(good, "-179.5", "nan"), "test.bvh:26: bad number 'nan'"},
      {"bad OFFSET number", replace_once(good, "OFFSET 10 -5 0", "OFFSET 10 -5o 0"),
       "test.bvh:8: bad number '-5o' for an OFFSET value"},
      {"unknown channel name", replace_once(good, "CHANNELS 3 Zrotation", "CHANNELS 3 Zrotaton"),
       "test.bvh:9: unknown channel name 'Zrotaton' (did you mean 'Zrotation'?)"},
      {"too few channel names", replace_once(good, "CHANNELS 6", "CHANNELS 7"),
       "test.bvh:5: bad channel count '7'"},
      {"channel names missing",
       replace_once(good, "CHANNELS 3 Zrotation Xrotation Yrotation\n",
                    "CHANNELS 3 Zrotation Xrotation\n"),
       "test.bvh:9: CHANNELS 3 for joint 'LeftUpLeg' lists only 2 channel names"},
      {"duplicate channel", replace_once(good, "Zposition Zrotation", "Zposition Xrotation"),
       "test.bvh:5: channel 'Xrotation' listed twice"},
      {"missing MOTION", good.substr(0, good.find("MOTION")),
       "test.bvh:21: missing MOTION section"},
      {"missing Frames", replace_once(good, "Frames: 3\n", ""),
       "test.bvh:22: missing 'Frames:' after MOTION"},
      {"missing Frame Time", replace_once(good, "Frame Time: 0.0333333\n", ""),
       "test.bvh:23: missing 'Frame Time:'"},
      {"bad frame time", replace_once(good, "Frame Time: 0.0333333", "Frame Time: 0"),
       "test.bvh:23: bad frame time '0'"},
      {"bad frame count", replace_once(good, "Frames: 3", "Frames: three"),
       "test.bvh:22: bad frame count 'three'"},
      {"extra rows", replace_once(good, "Frames: 3", "Frames: 2"),
       "test.bvh:26: more motion rows than 'Frames: 2' (line 22)"},
      {"unclosed brace", replace_once(good, "    }\n  }\n}\nMOTION", "    }\n  }\nMOTION"),
       "test.bvh:20: unbalanced braces: MOTION inside the block of 'Hips' opened at line 3"},
      {"extra brace", replace_once(good, "}\nMOTION", "}\n}\nMOTION"),
       "test.bvh:21: unbalanced braces: '}' without a matching '{'"},
      {"end of file inside a block", good.substr(0, good.find("    }\n  }\n}")),
       "test.bvh:18: unbalanced braces: end of file inside the block of 'LeftLeg' opened at line "
       "11"},
      {"no HIERARCHY", good.substr(good.find("ROOT")), "test.bvh:1: expected HIERARCHY"},
      {"JOINT outside ROOT", replace_once(good, "ROOT Hips", "JOINT Hips"),
       "test.bvh:2: JOINT outside any ROOT block"},
      {"unknown keyword", replace_once(good, "OFFSET 10 -5 0", "OFSET 10 -5 0"),
       "test.bvh:8: unexpected 'OFSET' in the hierarchy"},
      {"empty file", "",
       "test.bvh:1: expected HIERARCHY at the start of a BVH file, found nothing"},
  };
  for (const BadCase& c : cases) {
    std::string msg = parse_error(c.text);
    EXPECT_NE(msg.find(c.expected), std::string::npos)
        << c.what << "\n  got:      " << msg << "\n  expected: " << c.expected;
  }
}

TEST(BvhErrors, MissingFileIsAnInputError) {
  try {
    read_bvh("/nonexistent/walk.bvh");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/walk.bvh: cannot open BVH file"),
              std::string::npos)
        << e.what();
  }
}

// the issue's second-ROOT file, one token per line: it crashed bvh2mjcf and bvh retarget
// the issue's second-ROOT file: it crashed bvh2mjcf and bvh retarget (second ROOT: line 7)
constexpr const char* kTwoRoots =
    "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nROOT c\n{\nOFFSET 0 0 0\n"
    "CHANNELS 0\nEnd Site\n{\nOFFSET 0 -0.1 0\n}\n}\nMOTION\nFrames: 0\nFrame Time: 1\n";

// a chain of `depth` joints below the root (each nested in the previous), `frames` claimed
std::string nested_bvh(int depth, const std::string& frames = "1") {
  std::string text = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n";
  for (int i = 0; i < depth; ++i) text += fmt::format("JOINT j{}\n{{\nOFFSET 0 1 0\n", i);
  for (int i = 0; i < depth; ++i) text += "}\n";
  return text + "}\nMOTION\nFrames: " + frames + "\nFrame Time: 0.01\n0\n";
}

TEST(BvhErrors, BoundsAndNamesTheWriterCouldNotWriteBack) {
  std::string many = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n";
  for (int i = 0; i < kMaxBvhJoints; ++i)
    many += fmt::format("JOINT j{}\n{{\nOFFSET 0 1 0\n}}\n", i);
  many += "}\nMOTION\nFrames: 0\nFrame Time: 1\n";
  struct Case {
    const char* what;
    std::string text;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"second ROOT", kTwoRoots,
       "test.bvh:7: a second ROOT: stance reads one skeleton per BVH file (the first ROOT 'a' is "
       "at line 2)"},
      {"nesting depth", nested_bvh(kMaxBvhDepth),
       fmt::format("test.bvh:{}: joints nested more than {} deep", 6 + 3 * (kMaxBvhDepth - 1),
                   kMaxBvhDepth)},
      {"joint count", many,
       fmt::format("test.bvh:{}: more than {} joints", 6 + 4 * (kMaxBvhJoints - 1), kMaxBvhJoints)},
      {"non-UTF-8 name", replace_once(synthetic_bvh("ZXY", kRows), "LeftUpLeg", "Left\xff"),
       "test.bvh:6: joint name has a byte that is not UTF-8 (0xff) at column 5 of the name"},
      // UTF-8 that JSON writers refuse: an overlong form (found by fuzz_bvh), a surrogate,
      // above U+10FFFF
      {"overlong UTF-8", replace_once(synthetic_bvh("ZXY", kRows), "LeftUpLeg", "Left\xc1\xb7"),
       "test.bvh:6: joint name has a byte that is not UTF-8 (0xc1) at column 5 of the name"},
      {"UTF-8 surrogate",
       replace_once(synthetic_bvh("ZXY", kRows), "LeftUpLeg", "Left\xed\xa0\x80"),
       "test.bvh:6: joint name has a byte that is not UTF-8 (0xed) at column 5 of the name"},
      {"above U+10FFFF",
       replace_once(synthetic_bvh("ZXY", kRows), "LeftUpLeg", "Left\xf4\x90\x80\x80"),
       "test.bvh:6: joint name has a byte that is not UTF-8 (0xf4) at column 5 of the name"},
      {"brace in a name",
       replace_once(synthetic_bvh("ZXY", kRows), "JOINT LeftUpLeg\n", "JOINT a{ {\n"),
       "test.bvh:6: joint name 'a{' has a character BVH cannot write back (a brace)"},
  };
  for (const Case& c : cases) {
    std::string msg = parse_error(c.text);
    EXPECT_NE(msg.find(c.expected), std::string::npos)
        << c.what << "\n  got:      " << msg << "\n  expected: " << c.expected;
  }
  // a frame count the data cannot hold: bounded poses, else the rows actually present
  std::string msg = parse_error(nested_bvh(1, "40000000"));
  EXPECT_NE(msg.find("test.bvh:12: 'Frames: 40000000' x 2 joints is more than the 33554432 joint "
                     "poses stance holds in memory"),
            std::string::npos)
      << msg;
  msg = parse_error(nested_bvh(1, "10000000"));
  EXPECT_NE(msg.find("truncated data: 'Frames: 10000000' (line 12) but only 1 motion rows"),
            std::string::npos)
      << msg;
  // valid UTF-8 of every length reads, and its JSON summary writes
  const BvhClip utf8 = parse_bvh(replace_once(synthetic_bvh("ZXY", kRows), "LeftUpLeg",
                                              "L\xc3\xa9g\xe2\x82\xac\xf0\x9f\xa6\xb5"),
                                 "test.bvh");
  EXPECT_NO_THROW(bvh_info_json(utf8).dump());
  // at the limits themselves the files read
  EXPECT_EQ(parse_bvh(nested_bvh(kMaxBvhDepth - 1), "test.bvh").joint_count(), kMaxBvhDepth);
}

// one rule for every command that reads a clip: a frame rate of 1 Hz to 10 kHz. 1e-300
// crashed bvh track, 1e-7 ran out of memory, 1e-5 ran and blew up.
TEST(BvhErrors, FrameTimeOutsideCaptureRatesNamesTheLine) {
  const std::string good = synthetic_bvh("ZXY", kRows);
  for (const char* bad : {"1e-300", "1e-7", "1e-5", "0.00009", "1.5", "120", "0", "-0.01"}) {
    const std::string msg = parse_error(synthetic_bvh("ZXY", kRows, bad));
    EXPECT_EQ(msg, fmt::format("test.bvh:23: bad frame time '{}' (expected 0.0001 to 1 s: 10000 "
                               "to 1 frames per second)",
                               bad))
        << bad;
  }
  for (const char* fine : {"0.0001", "0.001", "0.00833333", "0.0333333", "1"}) {
    EXPECT_EQ(parse_error(synthetic_bvh("ZXY", kRows, fine)), "") << fine;
  }
  EXPECT_EQ(parse_bvh(good, "test.bvh").frame_time_s, 0.0333333);
  // the "Frames:" line, for later messages about the frames
  EXPECT_EQ(parse_bvh(good, "test.bvh").frames_line, 22);
}

// two joints of one name made an MJCF that stance then refused, naming the generated file
TEST(BvhErrors, SecondJointOfOneNameNamesBothLines) {
  const std::string twice =
      replace_once(synthetic_bvh("ZXY", kRows), "JOINT LeftLeg\n", "JOINT LeftUpLeg\n");
  EXPECT_EQ(parse_error(twice),
            "test.bvh:10: a second joint named 'LeftUpLeg' (the first is at "
            "line 6): joint names must be unique");
  // End Sites have no names of their own
  EXPECT_EQ(parse_error(synthetic_bvh("ZXY", kRows)), "");
}

// an OFFSET or a position of 1e300 is a corrupt file, not a skeleton; 1e7 file units still read
TEST(BvhErrors, AbsurdOffsetsAndPositionsNameTheLine) {
  const std::string good = synthetic_bvh("ZXY", kRows);
  const std::string beyond = " is beyond the 1e+07 file units a skeleton can span";
  EXPECT_EQ(parse_error(replace_once(good, "OFFSET 10 -5 0", "OFFSET 10 -1e300 0")),
            "test.bvh:8: OFFSET value -1e+300" + beyond);
  const std::string end_site = "OFFSET 0 -45 0\n      }";
  EXPECT_EQ(parse_error(replace_once(good, end_site, "OFFSET 0 -4.5e7 0\n      }")),
            "test.bvh:16: OFFSET value -4.5e+07" + beyond);
  EXPECT_EQ(parse_error(replace_once(good, "1.75 94.5", "1.75 2e8")),
            "test.bvh:25: position 2e+08 (value 2 of the motion row) is beyond the 1e+07 file "
            "units a clip can span");
  // angles are no coordinates: any finite angle reads
  EXPECT_EQ(parse_error(replace_once(good, "1.75 94.5 -2 170", "1.75 94.5 -2 1e300")), "");
  EXPECT_EQ(parse_error(replace_once(good, "OFFSET 10 -5 0", "OFFSET 10 -1e7 0")), "");
}

TEST(BvhEncoding, Utf8ByteOrderMarkIsSkipped) {
  const std::string good = synthetic_bvh("ZXY", kRows);
  const BvhClip plain = parse_bvh(good, "plain.bvh");
  const BvhClip marked = parse_bvh("\xEF\xBB\xBF" + good, "marked.bvh");
  expect_same_motion(plain, marked, 1e-15);
  // line numbers are unchanged after the mark
  EXPECT_EQ(parse_error("\xEF\xBB\xBF" + replace_once(good, "OFFSET 10 -5 0", "OFFSET 10 -5o 0")),
            "test.bvh:8: bad number '-5o' for an OFFSET value");
}

// UTF-16 text, with its byte order mark or without: named as such, not quoted as raw bytes
// cut at the first NUL
TEST(BvhEncoding, Utf16IsNamed) {
  const std::string good = synthetic_bvh("ZXY", kRows);
  auto utf16 = [&](bool big_endian, bool mark) {
    std::string out;
    if (mark) out = big_endian ? "\xFE\xFF" : "\xFF\xFE";
    for (char c : good) {
      out += big_endian ? std::string(1, '\0') + c : std::string(1, c) + '\0';
    }
    return out;
  };
  const std::string hint = "; stance reads BVH as ASCII or UTF-8: convert it, e.g. with iconv -f ";
  EXPECT_EQ(parse_error(utf16(false, true)),
            "test.bvh:1: the file is UTF-16 (little-endian, with a byte order mark)" + hint +
                "UTF-16 -t UTF-8");
  EXPECT_EQ(parse_error(utf16(true, true)),
            "test.bvh:1: the file is UTF-16 (big-endian, with a byte order mark)" + hint +
                "UTF-16 -t UTF-8");
  EXPECT_EQ(parse_error(utf16(false, false)),
            "test.bvh:1: the file is UTF-16 (little-endian)" + hint + "UTF-16LE -t UTF-8");
  EXPECT_EQ(parse_error(utf16(true, false)),
            "test.bvh:1: the file is UTF-16 (big-endian)" + hint + "UTF-16BE -t UTF-8");
  // a stray NUL elsewhere is shown, not left to cut the message
  EXPECT_EQ(parse_error(replace_once(good, "OFFSET 10 -5 0", std::string("OFFSET 10 -5\0 0", 16))),
            "test.bvh:8: bad number '-5\\x00' for an OFFSET value");
}

}  // namespace
}  // namespace stance
