// Free-mode tracking on a robot's motors (issue 45): a dof's kp is at most its torque limit /
// limit_gain_error, so a stiffer kp does not make a weak motor saturate at a smaller error. The
// old rule scaled every weak dof's gains by limit / 400 N m at any kp: Atlas's stance hip roll
// (180 N m) got kp 900 at the default 2000 and swung with kp (720 at x0.8, 1080 at x1.2), and the
// synthetic walk fell sideways at the defaults and at x0.8 (docs/robots.md).
#include <gtest/gtest.h>

#include "control/auto_joint_map.h"
#include "control/mocap_retarget_tracker.h"
#include "engine/world_spec.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> atlas() {
  WorldSpec spec;
  spec.models.push_back({"dart://sample/sdf/atlas/atlas_v3_no_head.urdf"});
  return make_engine("mujoco", spec);
}

// the tracker of the synthetic walk on Atlas, its map found from the tree, at kp (kd in ratio)
std::unique_ptr<MocapRetargetTracker> atlas_tracker(const Engine& engine, double kp,
                                                    double limit_gain_error = 0.1,
                                                    double load_gain_margin = 0) {
  const BvhClip clip = make_synthetic_walk_clip();
  const std::string bvh = test::write_temp_file("limit_gains_walk.bvh", format_bvh(clip));
  const MotionSkeleton skeleton = make_motion_skeleton(clip, MotionSkeletonOptions{});
  const AutoJointMap found = find_joint_map(skeleton, "walk", engine, "atlas");
  MocapRetargetParams p;
  p.bvh = bvh;
  p.mode = "free";
  p.joint_map =
      test::write_temp_file("limit_gains_map.yaml", joint_map_yaml(found, "walk", "atlas"));
  p.kp = kp;
  p.kd = 175 * kp / 2000;
  p.limit_gain_error = limit_gain_error;
  p.load_gain_margin = load_gain_margin;
  ControllerContext ctx;
  ctx.duration_s = 0.1;
  ctx.scratch_engine = [] { return atlas(); };
  return std::make_unique<MocapRetargetTracker>(p, ctx, engine);
}

TEST(MocapLimitGains, AWeakDofKeepsItsGainAtStifferKpAndAStrongOneFollows) {
  if (!test::have_atlas()) GTEST_SKIP() << "no dart-doc Atlas";
  const auto engine = atlas();
  const int hip_roll = engine->dof_index("l_leg_hpx");     // 180 N m
  const int knee = engine->dof_index("l_leg_kny");         // 220 N m
  const int ankle_pitch = engine->dof_index("l_leg_aky");  // 700 N m
  const int hip_yaw = engine->dof_index("l_leg_hpz");      // 110 N m
  const auto base = atlas_tracker(*engine, 2000);
  const auto stiff = atlas_tracker(*engine, 2400);
  const auto soft = atlas_tracker(*engine, 1600);
  // at most limit / 0.1 rad: the hip roll at 1800 and the hip yaw at 1100, whatever kp above
  for (const auto* t : {base.get(), stiff.get()}) {
    EXPECT_NEAR(t->kp()[hip_roll], 1800, 1e-9);
    EXPECT_NEAR(t->kp()[hip_yaw], 1100, 1e-9);
    EXPECT_NEAR(t->kd()[hip_yaw] / t->kp()[hip_yaw], 175.0 / 2000, 1e-12);
  }
  // below the cap kp is kept: the knee (2200 allowed) and the strong ankle follow kp
  EXPECT_NEAR(base->kp()[knee], 2000, 1e-9);
  EXPECT_NEAR(stiff->kp()[knee], 2200, 1e-9);
  EXPECT_NEAR(stiff->kp()[ankle_pitch], 2400, 1e-9);
  EXPECT_NEAR(soft->kp()[hip_roll], 1600, 1e-9);
  EXPECT_NEAR(soft->kp()[hip_yaw], 1100, 1e-9);
  // 0 turns the cap off
  EXPECT_NEAR(atlas_tracker(*engine, 2400, 0)->kp()[hip_yaw], 2400, 1e-9);
  // the free root is never driven
  EXPECT_EQ(base->kp()[engine->dof_index("rootJoint_pos_z")], 0);
}

// a leg whose PD is softer than the body's gravity stiffness m g h cannot hold the body over its
// stance foot: Atlas (149.6 kg, COM 1.03 m over the ankles, m g h 1510 N m/rad) at kp 1600 fell
// on DART at seeds 0 and 2 (docs/robots.md). At load_gain_margin 1.25 (off by default) its legs'
// dofs get 1.25 m g h, under the cap; the arms keep kp
TEST(MocapLimitGains, ALegSofterThanTheBodysGravityStiffnessIsRaisedToIt) {
  if (!test::have_atlas()) GTEST_SKIP() << "no dart-doc Atlas";
  const auto engine = atlas();
  const int knee = engine->dof_index("l_leg_kny");         // 220 N m: cap 2200
  const int ankle_pitch = engine->dof_index("r_leg_aky");  // 700 N m: cap 7000
  const int hip_roll = engine->dof_index("l_leg_hpx");     // 180 N m: cap 1800
  const int hip_yaw = engine->dof_index("l_leg_hpz");      // 110 N m: cap 1100
  const int shoulder = engine->dof_index("l_arm_shx");     // 170 N m: cap 1700
  const auto soft = atlas_tracker(*engine, 1600, 0.1, 1.25);
  const double floor = soft->kp()[knee];
  const double m_g = engine->total_mass() * 9.81;
  EXPECT_GT(floor, 1.25 * m_g * 0.95);  // the COM over the ankles: about 1.03 m
  EXPECT_LT(floor, 1.25 * m_g * 1.10);
  EXPECT_NEAR(soft->kp()[ankle_pitch], floor, 1e-9);
  EXPECT_NEAR(soft->kd()[knee] / floor, 175.0 / 2000, 1e-12);
  EXPECT_NEAR(soft->kp()[hip_roll], 1800, 1e-9);  // the cap still bounds it
  EXPECT_NEAR(soft->kp()[hip_yaw], 1100, 1e-9);
  EXPECT_NEAR(soft->kp()[shoulder], 1600, 1e-9);
  // a kp above the floor is kept; 0 turns the floor off
  EXPECT_NEAR(atlas_tracker(*engine, 2000, 0.1, 1.25)->kp()[knee], 2000, 1e-9);
  EXPECT_NEAR(atlas_tracker(*engine, 1600)->kp()[knee], 1600, 1e-9);
}

}  // namespace
}  // namespace stance
