// The legs of skeletons from other exporters, found without a setting: the side of a joint from
// its name in each naming convention, and the thighs and feet of whole hierarchies (3ds Max's
// Biped hangs the thighs off the spine; Bandai Namco's root is a carrier on the floor).
#include <gtest/gtest.h>

#include <string>

#include "control/mocap_clip.h"
#include "core/error.h"
#include "model/bvh_to_mjcf.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"

namespace stance {
namespace {

TEST(MocapLegs, TheSideOfAJointFromItsName) {
  for (const char* left : {"LeftFoot", "Foot_L", "Bip01 L Foot", "lFoot", "LFoot", "L_Ankle",
                           "foot.l", "mixamorig:LeftToeBase", "Character1_LeftUpLeg", "lfemur",
                           "ltoes", "leftfoot", "LowerLeg_L", "LUpLeg", "Left"})
    EXPECT_EQ(side_of_joint_name(left), -1) << left;
  for (const char* right :
       {"RightFoot", "Foot_R", "Bip01 R Foot", "rFoot", "RFoot", "R_Ankle", "foot.r",
        "mixamorig:RightToeBase", "rfemur", "rtoes", "rightupleg", "LowerArm_R", "RThigh", "Right"})
    EXPECT_EQ(side_of_joint_name(right), 1) << right;
  for (const char* none : {"Hips", "Root", "joint_Root", "LowerLeg", "Reference", "Spine1",
                           "radius", "lowerback", "Bip01 Pelvis", "Head", "rig"})
    EXPECT_EQ(side_of_joint_name(none), 0) << none;
}

// one leg's chain, its thigh `x` to the side (+ left, - right in a Y-up file whose
// toes point at +z)
std::string leg(const std::string& thigh, const std::string& shin, const std::string& foot,
                const std::string& toe, double x) {
  auto n = [](double v) { return std::to_string(v); };
  return "JOINT " + thigh + "\n{\nOFFSET " + n(x) + " -6 0\nCHANNELS 3 Zrotation Xrotation " +
         "Yrotation\nJOINT " + shin + "\n{\nOFFSET 0 -44 0\nCHANNELS 3 Zrotation Xrotation " +
         "Yrotation\nJOINT " + foot + "\n{\nOFFSET 0 -42 0\nCHANNELS 3 Zrotation Xrotation " +
         "Yrotation\nJOINT " + toe + "\n{\nOFFSET 0 -7 12\nCHANNELS 3 Zrotation Xrotation " +
         "Yrotation\nEnd Site\n{\nOFFSET 0 0 5\n}\n}\n}\n}\n}\n";
}

std::string upper_body(const std::string& spine, const std::string& head) {
  return "JOINT " + spine + "\n{\nOFFSET 0 20 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" +
         "JOINT " + head + "\n{\nOFFSET 0 40 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n" +
         "End Site\n{\nOFFSET 0 20 0\n}\n}\n}\n";
}

struct Legs {
  std::string hip[2], foot[2];
};

// a one-frame file of a hierarchy (every channel 0 but the root's height)
BvhClip clip_of(const std::string& hierarchy, int channels) {
  std::string row;
  for (int c = 0; c < channels; ++c) row += c == 1 ? "100 " : "0 ";
  return parse_bvh("HIERARCHY\n" + hierarchy + "MOTION\nFrames: 1\nFrame Time: 0.01\n" + row + "\n",
                   "legs.bvh");
}

MotionSkeleton skeleton_of(const std::string& hierarchy, int channels) {
  return make_motion_skeleton(clip_of(hierarchy, channels), {});
}

Legs legs_of(const std::string& hierarchy, int channels) {
  const MotionSkeleton sk = skeleton_of(hierarchy, channels);
  int hip[2], foot[2];
  find_mocap_legs(sk, {"", "", "", ""}, hip, foot);
  Legs out;
  for (int side = 0; side < 2; ++side) {
    out.hip[side] = hip[side] >= 0 ? sk.segments[hip[side]].name : "-";
    out.foot[side] = foot[side] >= 0 ? sk.segments[foot[side]].name : "-";
  }
  return out;
}

void expect_legs(const Legs& got, const Legs& want) {
  for (int side = 0; side < 2; ++side) {
    EXPECT_EQ(got.hip[side], want.hip[side]) << "side " << side;
    EXPECT_EQ(got.foot[side], want.foot[side]) << "side " << side;
  }
}

const char* kRoot6 = "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n";

TEST(MocapLegs, ThreeDsMaxBipedHangsTheThighsOffTheSpine) {
  std::string h = std::string("ROOT Bip01\n{\nOFFSET 0 0 0\n") + kRoot6 +
                  "JOINT Bip01 Pelvis\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation "
                  "Yrotation\nJOINT Bip01 Spine\n{\nOFFSET 0 8 0\nCHANNELS 3 Zrotation "
                  "Xrotation Yrotation\n" +
                  leg("Bip01 L Thigh", "Bip01 L Calf", "Bip01 L Foot", "Bip01 L Toe0", 9) +
                  leg("Bip01 R Thigh", "Bip01 R Calf", "Bip01 R Foot", "Bip01 R Toe0", -9) +
                  upper_body("Bip01 Spine1", "Bip01 Head") + "}\n}\n}\n";
  expect_legs(legs_of(h, 6 + 3 * 12),
              {{"Bip01 L Thigh", "Bip01 R Thigh"}, {"Bip01 L Foot", "Bip01 R Foot"}});
}

TEST(MocapLegs, BandaiNamcoCarriesItsHipsOnAFloorRoot) {
  std::string h = std::string("ROOT joint_Root\n{\nOFFSET 0 0 0\n") + kRoot6 +
                  "JOINT Hips\n{\nOFFSET -11 91 32\n" + kRoot6 +
                  leg("UpperLeg_R", "LowerLeg_R", "Foot_R", "Toes_R", -9) +
                  leg("UpperLeg_L", "LowerLeg_L", "Foot_L", "Toes_L", 9) +
                  upper_body("Spine", "Head") + "}\n}\n";
  expect_legs(legs_of(h, 12 + 3 * 10), {{"UpperLeg_L", "UpperLeg_R"}, {"Foot_L", "Foot_R"}});
}

TEST(MocapLegs, DazAndAsfNamesPutTheSideFirst) {
  std::string daz = std::string("ROOT hip\n{\nOFFSET 0 0 0\n") + kRoot6 +
                    leg("rThigh", "rShin", "rFoot", "rToe", -9) +
                    leg("lThigh", "lShin", "lFoot", "lToe", 9) + upper_body("abdomen", "head") +
                    "}\n";
  expect_legs(legs_of(daz, 6 + 3 * 10), {{"lThigh", "rThigh"}, {"lFoot", "rFoot"}});
  std::string asf = std::string("ROOT root\n{\nOFFSET 0 0 0\n") + kRoot6 +
                    leg("lfemur", "ltibia", "lfoot", "ltoes", 9) +
                    leg("rfemur", "rtibia", "rfoot", "rtoes", -9) +
                    upper_body("lowerback", "head") + "}\n";
  expect_legs(legs_of(asf, 6 + 3 * 10), {{"lfemur", "rfemur"}, {"lfoot", "rfoot"}});
}

// names that give no side: the left foot is the one on the left of where the toes point
TEST(MocapLegs, WithoutSidesInTheNamesTheToesTell) {
  for (double x : {9.0, -9.0}) {
    SCOPED_TRACE(x);
    std::string h = std::string("ROOT Pelvis\n{\nOFFSET 0 0 0\n") + kRoot6 +
                    leg("Thigh1", "Shin1", "Foot1", "Toe1", x) +
                    leg("Thigh2", "Shin2", "Foot2", "Toe2", -x) + upper_body("Spine", "Head") +
                    "}\n";
    Legs want = x > 0 ? Legs{{"Thigh1", "Thigh2"}, {"Foot1", "Foot2"}}
                      : Legs{{"Thigh2", "Thigh1"}, {"Foot2", "Foot1"}};
    expect_legs(legs_of(h, 6 + 3 * 10), want);
  }
}

// nothing named foot, toe or ankle: the feet are what stands lowest, for the legs and the soles
TEST(MocapLegs, FeetNamedNoFootAreFoundByHeight) {
  for (bool sides : {true, false}) {
    SCOPED_TRACE(sides);
    const std::string l = sides ? "l_" : "", r = sides ? "r_" : "", one = sides ? "" : "1",
                      two = sides ? "" : "2";
    std::string h =
        std::string("ROOT Pelvis\n{\nOFFSET 0 0 0\n") + kRoot6 +
        leg(l + "thigh" + one, l + "shin" + one, l + "pes" + one, l + "digits" + one, 9) +
        leg(r + "thigh" + two, r + "shin" + two, r + "pes" + two, r + "digits" + two, -9) +
        upper_body("Spine", "Head") + "}\n";
    expect_legs(legs_of(h, 6 + 3 * 10),
                {{l + "thigh" + one, r + "thigh" + two}, {l + "pes" + one, r + "pes" + two}});
    const MotionSkeleton sk = skeleton_of(h, 6 + 3 * 10);
    const std::vector<bool> feet = foot_segments(sk);
    for (int k = 0; k < sk.segment_count(); ++k) {
      const std::string& name = sk.segments[k].name;
      const bool want =
          name.find("pes") != std::string::npos || name.find("digits") != std::string::npos;
      EXPECT_EQ(feet[k], want) << name;
    }
  }
  // the soles: as many foot boxes as the same skeleton with foot names gets
  auto boxes = [](const std::string& foot, const std::string& toe) {
    std::string h = std::string("ROOT Pelvis\n{\nOFFSET 0 0 0\n") + kRoot6 +
                    leg("l_thigh", "l_shin", "l_" + foot, "l_" + toe, 9) +
                    leg("r_thigh", "r_shin", "r_" + foot, "r_" + toe, -9) +
                    upper_body("Spine", "Head") + "}\n";
    const BvhClip clip = clip_of(h, 6 + 3 * 10);
    const std::string mjcf = make_bvh_character(clip, {}).mjcf;
    int n = 0;
    for (size_t at = mjcf.find("type=\"box\""); at != std::string::npos;
         at = mjcf.find("type=\"box\"", at + 1))
      ++n;
    return n;
  };
  EXPECT_EQ(boxes("pes", "digits"), boxes("foot", "toe"));
  EXPECT_GE(boxes("pes", "digits"), 2);
}

TEST(MocapLegs, NamesGivenOverrideAndUnknownOnesAreNamed) {
  std::string h = std::string("ROOT Hips\n{\nOFFSET 0 0 0\n") + kRoot6 +
                  leg("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToe", 9) +
                  leg("RightUpLeg", "RightLeg", "RightFoot", "RightToe", -9) +
                  upper_body("Spine", "Head") + "}\n";
  const MotionSkeleton sk = skeleton_of(h, 6 + 3 * 10);
  int hip[2], foot[2];
  find_mocap_legs(sk, {"", "", "LeftToe", ""}, hip, foot);
  EXPECT_EQ(sk.segments[foot[0]].name, "LeftToe");
  EXPECT_EQ(sk.segments[foot[1]].name, "RightFoot");
  EXPECT_EQ(sk.segments[hip[0]].name, "LeftUpLeg");
  try {
    find_mocap_legs(sk, {"LeftHip", "", "", ""}, hip, foot);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("left_hip: unknown joint 'LeftHip'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace stance
