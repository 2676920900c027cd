// A robot's joint of several one-hinge links (Atlas: hip yaw, roll and pitch on three links; the
// shoulder's two links above the upper arm; the ankle's talus): the links between two mapped
// bodies fold into the lower one's fit, so the map's rotations reach every hinge of the chain.
// Before, only the mapped link's own hinge moved: hip roll and yaw, shoulder and ankle pitch
// stayed at zero and Atlas's arms stood out sideways (fit error 174 deg on the upper arms).
#include <gtest/gtest.h>

#include <cmath>

#include "control/auto_joint_map.h"
#include "control/retarget.h"
#include "engine/world_spec.h"
#include "motion/reference_motion.h"
#include "test_support.h"

namespace stance {
namespace {

TEST(RetargetHingeChain, AtlasLinksBetweenMappedBodiesFoldIntoTheFit) {
  if (!test::have_atlas()) GTEST_SKIP() << "no dart-doc Atlas";
  WorldSpec spec;
  spec.models.push_back({"dart://sample/sdf/atlas/atlas_v3_no_head.urdf"});
  auto probe = make_engine("mujoco", spec);
  probe->forward();
  const BvhClip clip = make_synthetic_walk_clip();
  const MotionSkeleton skeleton = make_motion_skeleton(clip, MotionSkeletonOptions{});
  const JointMap map = find_joint_map(skeleton, "walk", *probe, "atlas").map;
  const ReferenceMotion reference(clip, skeleton, ReferenceOptions{});
  const RetargetedMotion motion(reference, map, *probe, 0);
  // each mapped body's rotation is relative to the body above its folded chain
  auto parent_name = [&](const std::string& body) {
    for (const RetargetBody& b : motion.bodies())
      if (probe->body_name(b.body) == body) return probe->body_name(b.parent);
    return std::string("?");
  };
  EXPECT_EQ(parent_name("l_uleg"), "pelvis");  // l_uglut (hpz), l_lglut (hpx) folded
  EXPECT_EQ(parent_name("r_foot"), "r_lleg");  // r_talus (aky) folded
  EXPECT_EQ(parent_name("l_uarm"), "utorso");  // l_clav (shy), l_scap (shx) folded
  EXPECT_EQ(parent_name("utorso"), "ltorso");  // mtorso (bky) folded
  // the chains reach the clip's rotations (a one-hinge elbow still cannot twist a forearm)
  EXPECT_LT(motion.mean_fit_error_deg(), 5);
  for (int i = 0; i < static_cast<int>(motion.bodies().size()); ++i)
    if (motion.bodies()[i].name.find("ForeArm") == std::string::npos)
      EXPECT_LT(motion.body_fit_error_deg(i), 10) << motion.bodies()[i].name;
  // the folded hinges move: the ankle's pitch and the shoulder's pitch follow the walk
  double ankle_pitch = 0, shoulder_pitch = 0;
  const int aky = probe->joint(probe->joint_index("l_leg_aky")).qpos_adr;
  const int shy = probe->joint(probe->joint_index("l_arm_shy")).qpos_adr;
  for (int f = 0; f < motion.frame_count(); ++f) {
    ankle_pitch = std::max(ankle_pitch, std::abs(motion.frame(f)[aky]));
    shoulder_pitch = std::max(shoulder_pitch, std::abs(motion.frame(f)[shy]));
  }
  EXPECT_GT(ankle_pitch, 0.1);
  EXPECT_GT(shoulder_pitch, 0.1);
}

}  // namespace
}  // namespace stance
