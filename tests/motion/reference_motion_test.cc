// Reference motion: skeleton reduction, units and axes, resampling with slerp, target
// velocities, looping (and the seam blend of a cut that is no cycle), clip ranges, ground
// alignment, and the synthetic run's flight phase.
#include "motion/reference_motion.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <numbers>

#include "core/error.h"
#include "math/rotations.h"
#include "motion/clip_conventions.h"
#include "test_support.h"

namespace stance {
namespace {

ReferenceMotion synthetic_reference(ReferenceOptions ro = {}) {
  BvhClip clip = make_synthetic_walk_clip();
  return ReferenceMotion(clip, make_motion_skeleton(clip, {}), ro);
}

TEST(MotionSkeleton, SyntheticWalkIsCentimetresAndYUp) {
  BvhClip clip = make_synthetic_walk_clip();
  MotionSkeleton sk = make_motion_skeleton(clip, {});
  EXPECT_EQ(sk.segment_count(), clip.joint_count());
  EXPECT_DOUBLE_EQ(sk.scale_to_meters, 0.01);
  // Y-up offsets become Z-up metres: the left thigh's knee offset (0,-44,0) cm -> (0,0,-0.44) m
  int knee = sk.find_segment("LeftLeg");
  ASSERT_GE(knee, 0);
  EXPECT_NEAR(sk.segments[knee].offset.z(), -0.44, 1e-12);
  EXPECT_NEAR(sk.segments[knee].offset.y(), 0.0, 1e-12);
  std::vector<int> ends = sk.end_effectors();
  EXPECT_EQ(ends.size(), 5u);  // head, two forearms, two feet
}

TEST(ReferenceMotion, FramesAreTheClipsRotationsTurnedZUp) {
  BvhClip clip = make_synthetic_walk_clip();
  MotionSkeleton sk = make_motion_skeleton(clip, {});
  ReferenceMotion ref(clip, sk, {});
  ReferencePose pose = ref.make_pose();
  const Eigen::Quaterniond c = sk.to_z_up;
  for (int f : {0, 7, 33, ref.frame_count() - 1}) {
    ref.frame_pose(f, pose);
    for (int k = 0; k < sk.segment_count(); ++k) {
      Eigen::Quaterniond want = c * clip.rotation(f, sk.segments[k].bvh_joint) * c.conjugate();
      EXPECT_LT(geodesic_angle(pose.rotations[k], want), 1e-9) << "frame " << f << " seg " << k;
    }
  }
}

// a Z-up file reads as its Y-up twin: the up axis is found from the legs, whether the skeleton
// is written Z-up or a Y-up skeleton is turned onto Z-up by its root's rotation in every frame
TEST(ReferenceMotion, AZUpFileReadsAsItsYUpTwin) {
  const BvhClip y_up = make_synthetic_walk_clip();
  const BvhClip z_up = test::written_z_up(y_up), turned = test::root_turned_z_up(y_up);
  EXPECT_EQ(detect_bvh_up_axis(y_up), 'y');
  EXPECT_EQ(detect_bvh_up_axis(z_up), 'z');
  EXPECT_EQ(detect_bvh_up_axis(turned), 'z');

  auto positions = [](const BvhClip& clip, char up, double t) {
    MotionSkeletonOptions so;
    so.up_axis = up;
    ReferenceMotion ref(clip, make_motion_skeleton(clip, so), {});
    ReferencePose pose = ref.make_pose();
    ref.sample(t, pose);
    std::vector<Eigen::Vector3d> p;
    std::vector<Eigen::Quaterniond> o;
    ref.forward_kinematics(pose, p, o);
    return p;
  };
  for (double t : {0.0, 0.13, 0.55, 1.0}) {
    SCOPED_TRACE(t);
    const std::vector<Eigen::Vector3d> want = positions(y_up, 0, t);
    for (const BvhClip* clip : {&z_up, &turned}) {
      const std::vector<Eigen::Vector3d> got = positions(*clip, 0, t);
      ASSERT_EQ(got.size(), want.size());
      for (size_t k = 0; k < want.size(); ++k) EXPECT_LT((got[k] - want[k]).norm(), 1e-9) << k;
    }
    // read as Y-up, the Z-up file's character lies on its back: detection is what stands it up
    const std::vector<Eigen::Vector3d> lying = positions(z_up, 'y', t);
    const int head = make_motion_skeleton(y_up, {}).find_segment("Head");
    ASSERT_GE(head, 0);
    EXPECT_GT(want[head].z(), 1.3);
    EXPECT_LT(lying[head].z(), 0.5);
  }
}

// Bandai Namco's files put a ROOT on the floor (joint_Root) above a Hips with position
// channels of its own: the carrier is no body, and every body lands where the plain file puts it
TEST(ReferenceMotion, ACarriedRootReadsAsItsPlainTwin) {
  const BvhClip plain = make_synthetic_walk_clip();
  const BvhClip carried =
      parse_bvh(format_bvh(test::with_carrier_root(plain, "joint_Root")), "carried.bvh");
  ASSERT_EQ(carried.joints[0].name, "joint_Root");
  EXPECT_EQ(detect_bvh_up_axis(carried), 'y');
  EXPECT_EQ(detect_bvh_scale_to_meters(carried), detect_bvh_scale_to_meters(plain));
  const MotionSkeleton sk_plain = make_motion_skeleton(plain, {});
  const MotionSkeleton sk = make_motion_skeleton(carried, {});
  ASSERT_EQ(sk.segment_count(), sk_plain.segment_count());
  EXPECT_EQ(sk.segments[0].name, "Hips");
  EXPECT_EQ(sk.segments[0].rotation_chain, (std::vector<int>{0, 1}));
  EXPECT_EQ(sk.segment_of_joint[0], -1);
  for (int k = 0; k < sk.segment_count(); ++k) {
    EXPECT_EQ(sk.segments[k].name, sk_plain.segments[k].name);
    EXPECT_LT((sk.segments[k].offset - sk_plain.segments[k].offset).norm(), 1e-12) << k;
  }
  for (int f : {0, 7, 40})
    EXPECT_LT((root_chain_translation(carried, sk, f) - plain.translation(f, 0)).norm(), 1e-6);

  ReferenceMotion want(plain, sk_plain, {}), got(carried, sk, {});
  ReferencePose a = want.make_pose(), b = got.make_pose();
  std::vector<Eigen::Vector3d> pa, pb;
  std::vector<Eigen::Quaterniond> oa, ob;
  for (double t : {0.0, 0.13, 0.55, 1.0}) {
    SCOPED_TRACE(t);
    want.sample(t, a);
    got.sample(t, b);
    want.forward_kinematics(a, pa, oa);
    got.forward_kinematics(b, pb, ob);
    for (size_t k = 0; k < pa.size(); ++k) {
      EXPECT_LT((pa[k] - pb[k]).norm(), 1e-8) << k;
      EXPECT_LT(geodesic_angle(oa[k], ob[k]), 1e-8) << k;
    }
  }
}

// position channels on every joint replace the OFFSETs (BVH's rule): files whose OFFSETs are
// zero, or differ from the keyed bones, read as the plain file
TEST(ReferenceMotion, KeyedBonesReplaceTheOffsets) {
  const BvhClip plain = make_synthetic_walk_clip();
  const MotionSkeleton sk_plain = make_motion_skeleton(plain, {});
  ReferenceMotion want(plain, sk_plain, {});
  for (double offset_scale : {1.0, 0.0, 0.5}) {
    SCOPED_TRACE(offset_scale);
    const BvhClip keyed = parse_bvh(
        format_bvh(test::with_bones_in_position_channels(plain, offset_scale)), "keyed.bvh");
    ASSERT_EQ(keyed.position_joint_count, keyed.joint_count());
    EXPECT_EQ(detect_bvh_up_axis(keyed), 'y');
    EXPECT_EQ(detect_bvh_scale_to_meters(keyed), detect_bvh_scale_to_meters(plain));
    const MotionSkeleton sk = make_motion_skeleton(keyed, {});
    ASSERT_EQ(sk.segment_count(), sk_plain.segment_count());
    for (int k = 0; k < sk.segment_count(); ++k)
      EXPECT_LT((sk.segments[k].offset - sk_plain.segments[k].offset).norm(), 1e-9) << k;
    ReferenceMotion got(keyed, sk, {});
    ReferencePose a = want.make_pose(), b = got.make_pose();
    std::vector<Eigen::Vector3d> pa, pb;
    std::vector<Eigen::Quaterniond> oa, ob;
    for (double t : {0.0, 0.37, 1.0}) {
      want.sample(t, a);
      got.sample(t, b);
      want.forward_kinematics(a, pa, oa);
      got.forward_kinematics(b, pb, ob);
      for (size_t k = 0; k < pa.size(); ++k) EXPECT_LT((pa[k] - pb[k]).norm(), 1e-8) << k;
    }
  }
}

TEST(ReferenceMotion, SlerpBetweenFramesAndVelocityIsItsDerivative) {
  ReferenceMotion ref = synthetic_reference();
  ReferencePose a = ref.make_pose(), b = ref.make_pose(), mid = ref.make_pose();
  const double ft = ref.frame_time_s();
  ref.frame_pose(10, a);
  ref.frame_pose(11, b);
  ref.sample(10.5 * ft, mid);
  for (size_t k = 0; k < a.rotations.size(); ++k) {
    double whole = geodesic_angle(a.rotations[k], b.rotations[k]);
    EXPECT_NEAR(geodesic_angle(a.rotations[k], mid.rotations[k]), 0.5 * whole, 1e-9);
  }
  EXPECT_NEAR((mid.root_position - 0.5 * (a.root_position + b.root_position)).norm(), 0, 1e-12);
  // the velocity is the derivative of the sampled curve (finite difference inside the interval)
  const double h = 1e-6, t = 10.3 * ft;
  ReferencePose p0 = ref.make_pose(), p1 = ref.make_pose();
  ref.sample(t, p0);
  ref.sample(t + h, p1);
  bool any_moving = false;
  for (size_t k = 0; k < p0.rotations.size(); ++k) {
    Eigen::Vector3d fd = angular_velocity_body(p0.rotations[k], p1.rotations[k], h);
    EXPECT_NEAR((fd - p0.angular_velocities[k]).norm(), 0, 1e-5) << k;
    any_moving |= p0.angular_velocities[k].norm() > 0.1;
  }
  EXPECT_TRUE(any_moving);
  EXPECT_NEAR((p0.root_velocity - (p1.root_position - p0.root_position) / h).norm(), 0, 1e-6);
}

TEST(ReferenceMotion, ResampleGivesTheSimulationRateTable) {
  ReferenceMotion ref = synthetic_reference();
  auto table = ref.resample(0.002, 1.0);
  ASSERT_EQ(table.size(), 501u);
  ReferencePose p = ref.make_pose();
  ref.sample(0.25, p);
  EXPECT_LT(geodesic_angle(table[125].rotations[3], p.rotations[3]), 1e-12);
  EXPECT_THROW(ref.resample(0, 1.0), InputError);
}

TEST(ReferenceMotion, GroundAlignmentAndStartAtOrigin) {
  ReferenceMotion ref = synthetic_reference();
  ReferencePose p = ref.make_pose();
  ref.sample(0, p);
  EXPECT_NEAR(p.root_position.x(), 0, 1e-12);
  EXPECT_NEAR(p.root_position.y(), 0, 1e-12);
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  ref.forward_kinematics(p, pos, rot);
  double lowest = 1e9;
  const MotionSkeleton& sk = ref.skeleton();
  for (int k = 0; k < sk.segment_count(); ++k)
    for (const auto& e : sk.segments[k].bone_ends)
      lowest = std::min(lowest, (pos[k] + rot[k] * e).z());
  EXPECT_NEAR(lowest, 0.0, 1e-12);
  // Z-up: the head is above the hips, which stand near a leg length up
  EXPECT_GT(pos[sk.find_segment("Head")].z(), pos[0].z() + 0.3);
  EXPECT_GT(pos[0].z(), 0.8);
  ReferenceOptions raised;
  raised.ground_height_m = 0.25;
  ReferencePose q = ref.make_pose();
  synthetic_reference(raised).sample(0, q);
  EXPECT_NEAR(q.root_position.z() - p.root_position.z(), 0.25, 1e-12);
}

TEST(ReferenceMotion, LoopingAccumulatesTheRootDisplacement) {
  ReferenceOptions ro;
  ro.loop = true;
  ReferenceMotion ref = synthetic_reference(ro);
  const double period = ref.duration_s();
  ReferencePose a = ref.make_pose(), b = ref.make_pose(), c = ref.make_pose();
  ref.sample(0.3, a);
  ref.sample(0.3 + period, b);
  ref.sample(0.3 + 2 * period, c);
  Eigen::Vector3d step1 = b.root_position - a.root_position;
  Eigen::Vector3d step2 = c.root_position - b.root_position;
  EXPECT_GT(step1.norm(), 0.5);                  // the synthetic walk covers over a metre per cycle
  EXPECT_NEAR((step1 - step2).norm(), 0, 1e-9);  // no yaw drift in this clip
  EXPECT_NEAR(step1.z(), 0, 1e-12);
  for (size_t k = 1; k < a.rotations.size(); ++k)
    EXPECT_LT(geodesic_angle(a.rotations[k], b.rotations[k]), 1e-12);
  // continuous across the loop seam
  ReferencePose before = ref.make_pose(), after = ref.make_pose();
  ref.sample(period - 1e-7, before);
  ref.sample(period + 1e-7, after);
  EXPECT_LT((before.root_position - after.root_position).norm(), 1e-3);
  // without looping the clip holds its last pose with zero velocity
  ReferenceMotion once = synthetic_reference();
  ReferencePose end = once.make_pose();
  once.sample(period + 1.0, end);
  EXPECT_EQ(end.root_velocity.norm(), 0.0);
}

TEST(ReferenceMotion, ClipRangeInFramesOrSeconds) {
  BvhClip clip = make_synthetic_walk_clip();
  MotionSkeleton sk = make_motion_skeleton(clip, {});
  ReferenceOptions frames;
  frames.first_frame = 12;
  frames.last_frame = 42;
  ReferenceOptions seconds;
  seconds.start_s = 12 * clip.frame_time_s;
  seconds.end_s = 42 * clip.frame_time_s;
  ReferenceMotion a(clip, sk, frames), b(clip, sk, seconds);
  EXPECT_EQ(a.frame_count(), 31);
  EXPECT_EQ(b.frame_count(), 31);
  ReferencePose pa = a.make_pose(), pb = b.make_pose();
  a.sample(0.1, pa);
  b.sample(0.1, pb);
  for (size_t k = 0; k < pa.rotations.size(); ++k)
    EXPECT_LT(geodesic_angle(pa.rotations[k], pb.rotations[k]), 1e-12);
  // frame 0 of the range is clip frame 12
  a.frame_pose(0, pa);
  Eigen::Quaterniond want =
      sk.to_z_up * clip.rotation(12, sk.segments[4].bvh_joint) * sk.to_z_up.conjugate();
  EXPECT_LT(geodesic_angle(pa.rotations[4], want), 1e-9);
  ReferenceOptions bad;
  bad.first_frame = 50;
  bad.last_frame = 10;
  EXPECT_THROW(ReferenceMotion(clip, sk, bad), InputError);
}

TEST(MotionSkeleton, MassWalkSkipsRigMeshHelpers) {
  const std::string path = test::shared_bvh("mass_walk.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  BvhClip clip = read_bvh(path);
  MotionSkeleton sk = make_motion_skeleton(clip, {});
  EXPECT_DOUBLE_EQ(sk.scale_to_meters, 0.01);
  for (const auto& seg : sk.segments) EXPECT_EQ(seg.name.find("_RIGMESH"), std::string::npos);
  // the toes have a zero-length end site: they are the feet's end points, not bodies
  EXPECT_LT(sk.find_segment("Character1_LeftToeBase"), 0);
  int foot = sk.find_segment("Character1_LeftFoot");
  ASSERT_GE(foot, 0);
  EXPECT_EQ(sk.segments[foot].bone_ends.size(), 1u);
  EXPECT_EQ(sk.segment_count(), 16);  // hands and head end at their parents: tiny end sites
}

TEST(MotionSkeleton, CmuMergesZeroLengthHelpers) {
  const std::string path = test::shared_bvh("cmu_131_01.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  BvhClip clip = read_bvh(path);
  MotionSkeleton sk = make_motion_skeleton(clip, {});
  EXPECT_LT(sk.find_segment("LHipJoint"), 0);
  EXPECT_LT(sk.find_segment("lowerback"), 0);
  int hip = sk.find_segment("LeftHip");
  ASSERT_GE(hip, 0);
  EXPECT_EQ(sk.segments[hip].parent, 0);
  ASSERT_EQ(sk.segments[hip].rotation_chain.size(), 2u);
  EXPECT_EQ(clip.joints[sk.segments[hip].rotation_chain[0]].name, "LHipJoint");
  // LeftHip sits at the LHipJoint bone's end: 1.24777 cm-ish CMU units from the hips
  EXPECT_NEAR(sk.segments[hip].offset.norm(),
              sk.scale_to_meters * Eigen::Vector3d(1.24777, -1.64261, 0.71711).norm(), 1e-9);
}

// the lowest point of each foot (its segment and bone ends) in a pose, in the world
void foot_low_points(const ReferenceMotion& ref, const ReferencePose& pose,
                     Eigen::Vector3d out[2]) {
  const MotionSkeleton& sk = ref.skeleton();
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  ref.forward_kinematics(pose, pos, rot);
  for (int side = 0; side < 2; ++side) {
    const int k = sk.find_segment(side == 0 ? "LeftFoot" : "RightFoot");
    out[side] = pos[k];
    for (const auto& e : sk.segments[k].bone_ends)
      if ((pos[k] + rot[k] * e).z() < out[side].z()) out[side] = pos[k] + rot[k] * e;
  }
}

// ... and its height, m above the floor
void foot_heights(const ReferenceMotion& ref, const ReferencePose& pose, double out[2]) {
  Eigen::Vector3d low[2];
  foot_low_points(ref, pose, low);
  for (int side = 0; side < 2; ++side) out[side] = low[side].z();
}

// the mean change of the joint rotations (rad) and the change of the root position (m) between
// two samples
void pose_jump(const ReferencePose& a, const ReferencePose& b, double& rot, double& pos) {
  rot = 0;
  for (size_t k = 0; k < a.rotations.size(); ++k)
    rot += geodesic_angle(a.rotations[k], b.rotations[k]) / a.rotations.size();
  pos = (a.root_position - b.root_position).norm();
}

TEST(SyntheticRun, HasAFlightPhaseAndLoopsSeamlessly) {
  BvhClip clip = make_synthetic_walk_clip(synthetic_run_options());
  EXPECT_EQ(clip.source, "synthetic_run.bvh");
  ReferenceOptions ro;
  ro.loop = true;
  ro.align_whole_clip = true;  // the floor under the lowest point of the cycle
  ReferenceMotion ref(clip, make_motion_skeleton(clip, {}), ro);
  ReferencePose pose = ref.make_pose();
  // both feet clear of the floor in some frames (flight), one on it in others (stance)
  int flight = 0, stance = 0;
  for (int f = 0; f < ref.frame_count(); ++f) {
    ref.frame_pose(f, pose);
    double h[2];
    foot_heights(ref, pose, h);
    if (std::min(h[0], h[1]) > 0.01) ++flight;
    if (std::min(h[0], h[1]) < 0.005) ++stance;
  }
  // the stance foot stays planted: its lowest point (the toe tip, while the heel rises) moves
  // along the floor by less than 2 cm while it is on the floor (the generator plans the legs
  // without the root's yaw sway)
  double slide = 0;
  Eigen::Vector3d planted[2];
  bool on[2] = {false, false};
  for (int f = 0; f < ref.frame_count(); ++f) {
    ref.frame_pose(f, pose);
    Eigen::Vector3d low[2];
    foot_low_points(ref, pose, low);
    for (int side = 0; side < 2; ++side) {
      const bool down = low[side].z() < 0.005;
      if (down && !on[side]) planted[side] = low[side];
      if (down) slide = std::max(slide, (low[side] - planted[side]).head<2>().norm());
      on[side] = down;
    }
  }
  std::cout << "synthetic run: " << ref.frame_count() << " frames, " << flight << " in flight, "
            << stance << " in stance; the planted toe slides " << slide << " m\n";
  EXPECT_LT(slide, 0.02);
  EXPECT_GE(flight, 10);
  EXPECT_GE(stance, 10);
  // a body can do it: the root flies ballistically (about -g while both feet are up), and its
  // horizontal speed stays within 2% of 2.5 m/s (the old run asked for 3 g forward in stance)
  const double dt_frame = ref.frame_time_s();
  ReferencePose p0 = ref.make_pose(), p1 = ref.make_pose(), p2 = ref.make_pose();
  int ballistic = 0;
  for (int f = 1; f + 1 < ref.frame_count(); ++f) {
    ref.frame_pose(f - 1, p0), ref.frame_pose(f, p1), ref.frame_pose(f + 1, p2);
    const Eigen::Vector3d v = (p2.root_position - p0.root_position) / (2 * dt_frame);
    EXPECT_NEAR(v.head<2>().norm(), 2.5, 0.05) << "frame " << f;
    double h0[2], h1[2], h2[2];
    foot_heights(ref, p0, h0), foot_heights(ref, p1, h1), foot_heights(ref, p2, h2);
    if (std::min({h0[0], h0[1], h1[0], h1[1], h2[0], h2[1]}) > 0.002) {
      const double a = (p2.root_position.z() - 2 * p1.root_position.z() + p0.root_position.z()) /
                       (dt_frame * dt_frame);
      EXPECT_NEAR(a, -9.81, 0.3) << "frame " << f;
      ++ballistic;
    }
  }
  EXPECT_GE(ballistic, 8) << "frames checked in flight";
  // the loop: across the seam the pose changes no more than between two frames inside the clip
  double inside_rot = 0, inside_pos = 0;
  ReferencePose a = ref.make_pose(), b = ref.make_pose();
  const double dt = ref.frame_time_s(), T = ref.duration_s();
  for (int f = 0; f + 1 < ref.frame_count(); ++f) {
    ref.frame_pose(f, a);
    ref.frame_pose(f + 1, b);
    double r, p;
    pose_jump(a, b, r, p);
    inside_rot = std::max(inside_rot, r);
    inside_pos = std::max(inside_pos, p);
  }
  ref.sample(T - dt, a);
  ref.sample(T + dt, b);  // two frame intervals across the seam
  double r, p;
  pose_jump(a, b, r, p);
  EXPECT_LT(r, 2 * inside_rot + 1e-9);
  EXPECT_LT(p, 2 * inside_pos + 1e-9);
  // a cycle: the last frame is the first one a stride on (the blend has nothing to do)
  ref.sample(T - 1e-9, a);
  ref.sample(T + 1e-9, b);
  pose_jump(a, b, r, p);
  EXPECT_LT(r, 1e-5);
  EXPECT_LT(p, 1e-5);
}

// a cut of a real clip that is no cycle: looped as it is, the pose jumps at the seam; with the
// a run needs some stance and some flight in every step
TEST(SyntheticRun, RejectsAStanceFractionWithoutFlight) {
  SyntheticWalkOptions o = synthetic_run_options();
  o.stance_fraction = 0.5;
  EXPECT_THROW(make_synthetic_walk_clip(o), InputError);
}

// blend the last 0.2 s fade onto the first frame and the seam is as smooth as the clip
TEST(ReferenceMotion, LoopBlendJoinsACutThatIsNoCycle) {
  const std::string path = test::shared_bvh("cmu_131_01.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  BvhClip clip = read_bvh(path);
  ReferenceOptions ro;
  ro.loop = true;
  ro.first_frame = 200;
  ro.last_frame = 380;  // 1.5 s of walking at 120 Hz: no whole number of steps
  double jump_rot[2], jump_pos[2], inside_rot = 0;
  for (int blend = 0; blend < 2; ++blend) {
    ro.loop_blend_s = blend ? 0.2 : 0;
    ReferenceMotion ref(clip, make_motion_skeleton(clip, {}), ro);
    const double dt = ref.frame_time_s(), T = ref.duration_s();
    ReferencePose a = ref.make_pose(), b = ref.make_pose();
    ref.sample(T - 0.5 * dt, a);
    ref.sample(T + 0.5 * dt, b);
    pose_jump(a, b, jump_rot[blend], jump_pos[blend]);
    if (blend) {
      for (int f = 0; f + 1 < ref.frame_count(); ++f) {
        ref.frame_pose(f, a);
        ref.frame_pose(f + 1, b);
        double r, p;
        pose_jump(a, b, r, p);
        inside_rot = std::max(inside_rot, r);
      }
      // the blend leaves the first 1.3 s alone
      ReferenceOptions plain = ro;
      plain.loop_blend_s = 0;
      ReferenceMotion unblended(clip, make_motion_skeleton(clip, {}), plain);
      ReferencePose c = unblended.make_pose();
      for (double t : {0.0, 0.5, 1.2}) {
        ref.sample(t, a);
        unblended.sample(t, c);
        double r, p;
        pose_jump(a, c, r, p);
        EXPECT_LT(r, 1e-12);
        EXPECT_LT(p, 1e-12);
      }
    }
  }
  std::cout << "cmu cut seam: " << jump_rot[0] << " rad, " << jump_pos[0] << " m unblended; "
            << jump_rot[1] << " rad, " << jump_pos[1] << " m blended; largest step inside "
            << inside_rot << " rad\n";
  EXPECT_GT(jump_rot[0], 5 * inside_rot);
  EXPECT_LT(jump_rot[1], 2 * inside_rot);
  EXPECT_LT(jump_pos[1], 0.01);
}

}  // namespace
}  // namespace stance
