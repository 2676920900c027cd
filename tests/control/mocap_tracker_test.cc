// The one tracker (mocap_retarget) on a bvh2mjcf character, with no joint map: the identity map
// reproduces the reference, kinematic follows it, assisted tracks with a measured helper, the
// export reads back; the metrics, the tracking error and the fall verdict on hand-made cases;
// the planner's correction; the mocap_tracker alias; and (with ../shared) mass_walk and the
// CMU crouch, which is no fall.
#include <gtest/gtest.h>

#include <filesystem>

#include "control/mocap_clip.h"
#include "control/mocap_retarget_tracker.h"
#include "control/stable_pd.h"
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

struct ClipFiles {
  std::string bvh, xml;
};

// the clip and its character as files
ClipFiles make_files(const BvhClip& clip, const std::string& tag, bool whole_clip_ground = false) {
  ClipFiles s;
  s.bvh = test::write_temp_file(tag + ".bvh", format_bvh(clip));
  BvhCharacterOptions o;
  o.reference.align_whole_clip = whole_clip_ground;
  s.xml = test::write_temp_file(tag + ".xml", make_bvh_character(clip, o).mjcf);
  return s;
}

std::unique_ptr<Engine> engine_of(const std::string& xml) {
  WorldSpec spec;
  spec.models.push_back({xml});
  return make_engine("mujoco", spec);
}

// a tracker on the character (no joint map), the engine at its first frame
struct Tracked {
  std::unique_ptr<Engine> engine;
  std::unique_ptr<MocapRetargetTracker> tracker;
  std::unique_ptr<ControllerState> state;
};

Tracked make_tracked(const MocapRetargetParams& p, const std::string& xml, double duration_s) {
  Tracked t;
  t.engine = engine_of(xml);
  ControllerContext ctx;
  ctx.duration_s = duration_s;
  ctx.scratch_engine = [xml] { return engine_of(xml); };
  t.tracker = std::make_unique<MocapRetargetTracker>(p, ctx, *t.engine);
  Eigen::VectorXd q, v;
  EXPECT_TRUE(t.tracker->initial_state(*t.engine, q, v));
  t.engine->set_positions(q);
  t.engine->set_velocities(v);
  t.engine->forward();
  t.state = t.tracker->make_state(*t.engine);
  return t;
}

struct Outcome {
  double mean_deg = 0, helper = 0, root_err = 0;
  bool root_fell = false, fell = false;
  nlohmann::json metrics;
};

Outcome track(Tracked& t, double seconds) {
  Engine& engine = *t.engine;
  ControlOutput out;
  out.resize(engine.nv(), engine.nu());
  const long steps = std::lround(seconds / engine.timestep());
  for (long k = 0; k < steps; ++k) {
    engine.forward();
    out.clear();
    t.tracker->compute(*t.state, engine, out);
    engine.set_generalized_forces(out.tau);
    engine.step();
    if (!engine.state_is_finite()) break;
  }
  Outcome o;
  t.tracker->add_metrics(*t.state, o.metrics);
  const auto& m = o.metrics["mocap"];
  o.mean_deg = m["mean_joint_error_deg"];
  o.helper = m["helper_impulse_Ns"];
  o.root_err = m["mean_root_error_m"];
  o.root_fell = !m["root_fall_time_s"].is_null();
  o.fell = !m["fall_time_s"].is_null();
  return o;
}

MocapRetargetParams params_for(const std::string& bvh, const std::string& mode) {
  MocapRetargetParams p;
  p.bvh = bvh;
  p.mode = mode;
  return p;
}

TEST(MocapTracker, IdentityMapReproducesTheReference) {
  BvhClip clip = make_synthetic_walk_clip();
  ClipFiles s = make_files(clip, "track_identity");
  Tracked t = make_tracked(params_for(s.bvh, "kinematic"), s.xml, 2.5);
  const RetargetedMotion& motion = t.tracker->motion();
  EXPECT_EQ(motion.yaw_rad(), 0.0);
  EXPECT_EQ(motion.scale(), 1.0);
  EXPECT_LT(motion.max_fit_error_deg(), 1e-6);
  // the reference as mocap_tracker read it: the clip, looped, its lowest point on the floor
  MotionSkeletonOptions so;
  ReferenceOptions ro;
  ro.loop = true;
  ro.loop_blend_s = 0.2;
  ReferenceMotion reference(clip, make_motion_skeleton(clip, so), ro);
  const MotionSkeleton& sk = reference.skeleton();
  ReferencePose pose = reference.make_pose();
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  auto probe = engine_of(s.xml);
  double worst_pos = 0, worst_rot = 0;
  for (int f = 0; f < motion.frame_count(); f += 3) {
    probe->set_positions(motion.frame(f));
    probe->forward();
    reference.sample(f * motion.frame_time_s(), pose);
    reference.forward_kinematics(pose, pos, rot);
    for (int k = 0; k < sk.segment_count(); ++k) {
      BodyPose b = probe->body_pose(probe->body_index(sk.segments[k].name));
      worst_rot = std::max(worst_rot, geodesic_angle(b.quat, rot[k]));
      worst_pos = std::max(worst_pos, (b.pos - pos[k]).norm());
    }
  }
  std::cout << "identity map: worst position " << worst_pos << " m, rotation " << worst_rot
            << " rad over " << motion.frame_count() << " frames\n";
  EXPECT_LT(worst_pos, 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
}

TEST(MocapTracker, KinematicFollowsTheReference) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_kin");
  Tracked t = make_tracked(params_for(s.bvh, "kinematic"), s.xml, 2.5);
  Outcome o = track(t, 2.5);  // more than two loops
  EXPECT_LT(o.mean_deg, 0.5);
  EXPECT_LT(o.root_err, 0.01);
  EXPECT_FALSE(o.root_fell);
  EXPECT_FALSE(o.fell);
  EXPECT_TRUE(o.metrics["mocap"]["success"].get<bool>());
  EXPECT_LT(o.metrics["mocap"]["mean_body_position_error_m"].get<double>(), 0.01);
}

TEST(MocapTracker, AssistedTracksWithAMeasuredHelper) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_assist");
  Tracked t = make_tracked(params_for(s.bvh, "assisted"), s.xml, 2.5);
  Outcome o = track(t, 2.5);
  EXPECT_LT(o.mean_deg, 5.0);
  EXPECT_GT(o.helper, 0.0);
  EXPECT_FALSE(o.root_fell);
  EXPECT_FALSE(o.fell);
  // without any root help (and without balance) the same gains do not keep the root on track
  MocapRetargetParams p = params_for(s.bvh, "free");
  p.balance = false;
  Tracked loose = make_tracked(p, s.xml, 2.5);
  Outcome f = track(loose, 2.5);
  EXPECT_EQ(f.helper, 0.0);
  EXPECT_GT(f.root_err, o.root_err);
  // ... and the fall rule says so: it judged a fall, and the run is no success
  EXPECT_TRUE(f.fell);
  EXPECT_FALSE(f.metrics["mocap"]["success"].get<bool>());
  std::string reason;
  EXPECT_EQ(loose.tracker->fall_verdict(*loose.state, *loose.engine, reason), FallVerdict::kFell);
  EXPECT_FALSE(reason.empty());
}

// also for a root carried by a ROOT above it (Bandai Namco's joint_Root): the carrier keeps
// the clip's channels, and the root's own take the rest
TEST(MocapTracker, ExportedMotionReadsBack) {
  const BvhClip plain = make_synthetic_walk_clip();
  const BvhClip carried =
      parse_bvh(format_bvh(test::with_carrier_root(plain, "joint_Root")), "carried.bvh");
  for (const BvhClip* clip : {&plain, &carried}) {
    const std::string name = clip == &plain ? "export" : "export_carried";
    SCOPED_TRACE(name);
    ClipFiles s = make_files(*clip, "track_" + name);
    MocapRetargetParams p = params_for(s.bvh, "kinematic");
    p.export_bvh = "tracked.bvh";
    Tracked t = make_tracked(p, s.xml, 1.0);
    track(t, 1.0);
    std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" / name).string();
    std::filesystem::create_directories(dir);
    t.tracker->write_outputs(*t.state, dir);
    BvhClip back = read_bvh(dir + "/tracked.bvh");
    EXPECT_EQ(back.joint_count(), clip->joint_count());
    EXPECT_NEAR(back.frame_time_s, clip->frame_time_s, 1e-9);
    EXPECT_NEAR(back.frame_count, 1.0 / clip->frame_time_s, 1.5);
    // kinematic tracking: the exported frames are the clip's own, up to the tracking error
    const MotionSkeleton sk = make_motion_skeleton(*clip, {});
    const int root = sk.segments[0].bvh_joint;
    for (int f : {1, 20, 45}) {
      for (int j = 0; j < clip->joint_count(); ++j)
        if (j != root)
          EXPECT_LT(geodesic_angle(back.rotation(f, j), clip->rotation(f, j)), 2.0 * M_PI / 180)
              << "frame " << f << " joint " << clip->joints[j].name;
      // the root moves like the clip's, up to the constant ground-alignment shift (cm)
      auto root_at = [&](const BvhClip& c, int frame) {
        return root_chain_translation(c, sk, frame);
      };
      Eigen::Vector3d shift = root_at(back, 1) - root_at(*clip, 1);
      EXPECT_LT((root_at(back, f) - root_at(*clip, f) - shift).norm(), 0.5);
    }
  }
}

// a clip that begins with a T-pose frame (cgspeed's CMU release) is tracked from its motion:
// the reference is the plain clip's, unless skip_leading_pose is off
TEST(MocapTracker, ALeadingTPoseIsNoPartOfTheReference) {
  const BvhClip plain = make_synthetic_walk_clip();
  const std::string plain_bvh = test::write_temp_file("plain_walk.bvh", format_bvh(plain));
  const std::string posed_bvh = test::write_temp_file(
      "t_posed_walk.bvh", format_bvh(test::with_leading_t_pose(plain, 1, Eigen::Vector3d::Zero())));
  auto bodies = [](const std::string& bvh, bool skip, double t) {
    MocapClipParams p;
    p.bvh = bvh;
    p.skip_leading_pose = skip;
    MocapClip clip = load_mocap_clip(p, "");
    ReferencePose pose = clip.reference->make_pose();
    clip.reference->sample(t, pose);
    std::vector<Eigen::Vector3d> pos;
    std::vector<Eigen::Quaterniond> rot;
    clip.reference->forward_kinematics(pose, pos, rot);
    return pos;
  };
  for (double t : {0.0, 0.3, 1.0}) {
    SCOPED_TRACE(t);
    const std::vector<Eigen::Vector3d> want = bodies(plain_bvh, true, t);
    const std::vector<Eigen::Vector3d> got = bodies(posed_bvh, true, t);
    for (size_t k = 0; k < want.size(); ++k) EXPECT_LT((got[k] - want[k]).norm(), 1e-9) << k;
  }
  const std::vector<Eigen::Vector3d> t_pose = bodies(posed_bvh, false, 0.0);
  const std::vector<Eigen::Vector3d> walk = bodies(plain_bvh, true, 0.0);
  double furthest = 0;
  for (size_t k = 0; k < walk.size(); ++k)
    furthest = std::max(furthest, (t_pose[k] - walk[k]).norm());
  EXPECT_GT(furthest, 0.1);
}

TEST(MocapTracker, RejectsBadInput) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_bad");
  auto expect_error = [&](const MocapRetargetParams& p, const std::string& xml,
                          const std::string& want) {
    try {
      make_tracked(p, xml, 0);
      ADD_FAILURE() << "no error, wanted " << want;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  expect_error(params_for("", "assisted"), s.xml, "bvh: a BVH file is required");
  expect_error(params_for(s.bvh, "hover"), s.xml, "mode: expected kinematic, assisted or free");
  MocapRetargetParams sideways = params_for(s.bvh, "assisted");
  sideways.up_axis = "x";
  expect_error(sideways, s.xml, "up_axis: expected y, z or auto, found 'x'");
  MocapRetargetParams p = params_for(s.bvh, "assisted");
  p.kp_joints["NoSuchJoint"] = 10;
  expect_error(p, s.xml, "kp_joints: the model has no dof or joint 'NoSuchJoint'");
  // a model that is not the clip's character, and no map
  const std::string chain = test::write_temp_file("chain.xml", test::kFloatingChainMjcf);
  expect_error(params_for(s.bvh, "assisted"), chain, "build the model with `stance bvh2mjcf`");
}

// per-joint gains by joint name set the joint's three dofs
// the recording a run reserves is bounded whatever the frame time: 1e-300 s cast 1.2e302
// frames to a size (a crash)
TEST(MocapTracker, RecordedFramesAreBounded) {
  EXPECT_EQ(mocap_record_frames(10, 0.01), 12001u);
  EXPECT_EQ(mocap_record_frames(200, 0.1), 2001u);
  const size_t cap = (size_t{1} << 20) + 1;
  EXPECT_EQ(mocap_record_frames(120, 1e-300), cap);
  EXPECT_EQ(mocap_record_frames(120, 0.0), cap);
  EXPECT_EQ(mocap_record_frames(std::nan(""), 0.01), 12001u);
  EXPECT_EQ(mocap_record_frames(120, std::nan("")), cap);
}

TEST(MocapTracker, JointGainsByJointName) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_gains");
  MocapRetargetParams p = params_for(s.bvh, "assisted");
  p.kp_joints["LeftLeg"] = 1234;
  Tracked t = make_tracked(p, s.xml, 0);
  // the gains show in the SPD torque: the same state, another kp on LeftLeg only
  p.kp_joints.clear();
  Tracked u = make_tracked(p, s.xml, 0);
  // moving away from the clip, so that the position error is not zero
  for (Engine* e : {t.engine.get(), u.engine.get()}) {
    e->set_velocities(Eigen::VectorXd::LinSpaced(e->nv(), -1, 1));
    e->forward();
  }
  ControlOutput a, b;
  a.resize(t.engine->nv(), 0);
  b.resize(u.engine->nv(), 0);
  t.tracker->compute(*t.state, *t.engine, a);
  u.tracker->compute(*u.state, *u.engine, b);
  const JointInfo& knee = t.engine->joint(t.engine->joint_index("LeftLeg"));
  for (int i = 0; i < 3; ++i) EXPECT_NE(a.tau[knee.dof_adr + i], b.tau[knee.dof_adr + i]);
}

// the Coros virtual force: a force at the COM reacted at a foot is internal (no root share) and
// does the same virtual work as the two forces it stands for
TEST(MocapTracker, ComSupportTorqueIsInternal) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_support");
  auto engine = engine_of(s.xml);
  engine->apply_keyframe("start");
  engine->forward();
  const int nv = engine->nv();
  const int foot = engine->body_index("LeftFoot");
  ASSERT_GE(foot, 0);
  Eigen::MatrixXd jac_com(3, nv), scratch(3, nv), jac_foot(3, nv), none(3, 0);
  engine->com_jacobian(jac_com);
  const Eigen::Vector3d force(30, -20, 650);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(nv);
  add_com_support_torque(*engine, foot, force, jac_com, scratch, tau);
  const int root = engine->joint(engine->joint_index("root")).dof_adr;
  EXPECT_LT(tau.segment<6>(root).norm(), 1e-9 * force.norm());
  EXPECT_GT(tau.norm(), 10.0);
  // virtual work: tau . v == F . (v_com - v_foot point at the COM) for any v
  engine->point_jacobian(foot, engine->com(), jac_foot, none);
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(nv, -1, 1);
  EXPECT_NEAR(tau.dot(v), force.dot((jac_com - jac_foot) * v), 1e-9 * force.norm());
}

// whether `foot` or a body below it touches the ground
bool foot_touches_ground(const Engine& e, int foot) {
  for (int b = 0; b < e.nbody(); ++b)
    for (int a = b; a >= 0; a = e.body_parent(a))
      if (a == foot && e.body_touches_ground(b)) return true;
  return false;
}

// the engine set to the clip's state at its time, 1 cm down, so that a foot on the floor is in
// contact
void set_clip_state(const RetargetedMotion& motion, Engine& e, Eigen::VectorXd& q,
                    Eigen::VectorXd& v, Eigen::VectorXd& scratch) {
  motion.sample(e, e.time(), q, v, scratch);
  q[e.joint(e.joint_index("root")).qpos_adr + 2] -= 0.01;
  e.set_positions(q);
  e.set_velocities(v);
  e.forward();
}

// reference_support on the run: held on the clip's own motion, the torques it adds are exactly
// the Coros torques of share * m * max(0, g + a_ref,z) at the foot that alone touches the ground,
// where a_ref is the clip root's acceleration; nothing in flight, over twice the weight at its peak
TEST(MocapTracker, ReferenceSupportCarriesTheClipsGroundForce) {
  ClipFiles s = make_files(make_synthetic_walk_clip(synthetic_run_options()), "track_ref_support");
  MocapRetargetParams p = params_for(s.bvh, "free");
  p.loop = true;
  p.kp = p.kd = 0;  // the SPD, which would answer any torque, off: the balance layer's alone
  p.reference_support = 0;
  Tracked off = make_tracked(p, s.xml, 2.0);
  const double share = 0.5;  // at the peak, about 1.2 m g: under the 2 m g clamp
  p.reference_support = share;
  Tracked on = make_tracked(p, s.xml, 2.0);
  Engine& e = *on.engine;
  const RetargetedMotion& motion = on.tracker->motion();
  int hips = -1;
  for (size_t i = 0; i < motion.bodies().size(); ++i)
    if (motion.bodies()[i].name.rfind("Hips", 0) == 0) hips = static_cast<int>(i);
  ASSERT_GE(hips, 0);
  const int feet[2] = {e.body_index("LeftFoot"), e.body_index("RightFoot")};
  ASSERT_GE(feet[0], 0);
  ASSERT_GE(feet[1], 0);
  const int nv = e.nv();
  Eigen::VectorXd q(e.nq()), v(nv), scratch(nv), expected(nv);
  Eigen::MatrixXd jac_com(3, nv), jac_scratch(3, nv);
  ControlOutput a, b;
  a.resize(nv, 0);
  b.resize(nv, 0);
  const double m = e.total_mass(), g = e.gravity().norm();
  int single = 0, flight = 0;
  double peak = 0;
  const long steps = std::lround(0.7 / e.timestep());  // a whole cycle: two steps
  for (long k = 0; k < steps; ++k) {
    set_clip_state(motion, e, q, v, scratch);
    a.clear();
    b.clear();
    off.tracker->compute(*off.state, e, a);
    on.tracker->compute(*on.state, e, b);
    const bool left = foot_touches_ground(e, feet[0]), right = foot_touches_ground(e, feet[1]);
    // the tracker's targets are for the end of the step
    const double t_target = e.time() + e.timestep();
    const double need = std::max(0.0, motion.sample_body_acceleration(t_target, hips).z() + g);
    if (!left && !right) {
      ++flight;
      EXPECT_LT((b.tau - a.tau).norm(), 1e-9) << "t " << e.time();
    } else if (left != right) {
      ++single;
      peak = std::max(peak, need / g);
      expected.setZero();
      e.com_jacobian(jac_com);
      add_com_support_torque(e, feet[left ? 0 : 1], Eigen::Vector3d(0, 0, share * m * need),
                             jac_com, jac_scratch, expected);
      EXPECT_LT((b.tau - a.tau - expected).norm(), 1e-9 * (1 + expected.norm()))
          << "t " << e.time();
    }
    e.step();  // only the clock: the next pass sets the state again
  }
  std::cout << "reference_support: " << single << " single-stance and " << flight
            << " flight samples, peak m (g + a) / m g " << peak << "\n";
  EXPECT_GT(single, 0.3 * steps);
  EXPECT_GT(flight, 0.15 * steps);
  EXPECT_GT(peak, 2.0);
}

// root_force_kd: a root that moves faster than the clip's by dv gets, at the COM, the horizontal
// force -kd dv, reacted by the feet that touch in their stance shares; its vertical part is
// root_force_kd_z's, off here
TEST(MocapTracker, RootForceKdHoldsTheClipsSpeedThroughTheStanceFeet) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_root_kd");
  MocapRetargetParams p = params_for(s.bvh, "free");
  p.loop = true;
  p.kp = p.kd = 0;  // the SPD off: the balance layer's torques alone
  p.root_force_kd = 0;
  // each pair (kd off, kd on) sees the clip's state; the second pair sees it with the root faster
  Tracked off = make_tracked(p, s.xml, 2.0), off_fast = make_tracked(p, s.xml, 2.0);
  p.root_force_kd = 150;
  ASSERT_EQ(p.root_force_kd_z, 0);
  Tracked on = make_tracked(p, s.xml, 2.0), on_fast = make_tracked(p, s.xml, 2.0);
  Engine& e = *on.engine;
  const RetargetedMotion& motion = on.tracker->motion();
  const int feet[2] = {e.body_index("LeftFoot"), e.body_index("RightFoot")};
  ASSERT_GE(feet[0], 0);
  ASSERT_GE(feet[1], 0);
  const int nv = e.nv();
  const int root_v = e.joint(e.joint_index("root")).dof_adr;  // world linear velocity first
  const Eigen::Vector3d dv(0.3, -0.2, 0.25);  // m/s; the 0.25 up must change nothing
  Eigen::VectorXd q(e.nq()), v(nv), scratch(nv), expected(nv);
  Eigen::MatrixXd jac_com(3, nv), jac_scratch(3, nv);
  ControlOutput a, b, a_fast, b_fast;
  for (ControlOutput* o : {&a, &b, &a_fast, &b_fast}) o->resize(nv, 0);
  int single = 0, both = 0;
  double largest = 0;
  const long steps = std::lround(1.2 / e.timestep());  // a whole cycle
  for (long k = 0; k < steps; ++k) {
    set_clip_state(motion, e, q, v, scratch);
    for (ControlOutput* o : {&a, &b, &a_fast, &b_fast}) o->clear();
    off.tracker->compute(*off.state, e, a);
    on.tracker->compute(*on.state, e, b);
    const bool left = foot_touches_ground(e, feet[0]), right = foot_touches_ground(e, feet[1]);
    v.segment<3>(root_v) += dv;
    e.set_velocities(v);
    e.forward();
    off_fast.tracker->compute(*off_fast.state, e, a_fast);
    on_fast.tracker->compute(*on_fast.state, e, b_fast);
    const Eigen::VectorXd change = (b_fast.tau - a_fast.tau) - (b.tau - a.tau);
    expected.setZero();
    if (left || right) {
      const Eigen::Vector3d force(-150 * dv.x(), -150 * dv.y(), 0);
      const double share = left && right ? 0.5 : 1.0;
      e.com_jacobian(jac_com);
      for (int side = 0; side < 2; ++side)
        if (side == 0 ? left : right)
          add_com_support_torque(e, feet[side], share * force, jac_com, jac_scratch, expected);
      (left && right ? both : single)++;
    }
    EXPECT_LT((change - expected).norm(), 1e-9 * (1 + expected.norm())) << "t " << e.time();
    largest = std::max(largest, expected.norm());
    e.step();  // only the clock: the next pass sets the state again
  }
  std::cout << "root_force_kd: " << single << " single and " << both
            << " double-support samples, largest torque change " << largest << " N m\n";
  EXPECT_GT(single, 0.3 * steps);
  EXPECT_GT(both, 0.05 * steps);
  EXPECT_GT(largest, 10.0);
}

// one SPD: the tracker's law with a zero target velocity and no other torques is stable_pd's
TEST(MocapTracker, TrackerSpdIsStablePd) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_spd");
  auto engine = engine_of(s.xml);
  engine->apply_keyframe("start");
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(engine->nv(), -0.5, 0.5);
  engine->set_velocities(v);
  engine->forward();
  JointPdParams jp;
  jp.kp = 700;
  jp.kd = 60;
  JointPdModel model = make_joint_pd_model(jp, *engine);
  StablePdState st;
  st.resize(engine->nq(), engine->nv());
  st.q_target.setZero();
  engine->get_positions(st.q_target);
  Eigen::VectorXd q(engine->nq());
  engine->get_positions(q);
  // the target: the start pose with every ball joint turned a little
  engine->integrate_positions(q, Eigen::VectorXd::Constant(engine->nv(), 0.1), 1.0, st.q_target);
  ControlOutput out;
  out.resize(engine->nv(), 0);
  compute_stable_pd(model, st, *engine, out);
  PoseTrackingWork w;
  w.resize(engine->nq(), engine->nv());
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(engine->nv());
  add_stable_pd_torques(*engine, q, v, st.q_target, Eigen::VectorXd::Zero(engine->nv()), model.kp,
                        model.kd, 0, 0, 0, w, tau);
  EXPECT_GT(tau.norm(), 1.0);
  EXPECT_LT((tau - out.tau).norm(), 1e-12 * tau.norm());
}

// the metrics and the tracking error on a hand-made case: the character held at the reference
// pose shifted 10 cm sideways and moving at 0.3 m/s, so every body is exactly 0.1 m off, the
// joints are exact and a touching foot skates at 0.3 m/s
TEST(MocapTracker, MetricsOnAShiftedReference) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_metrics");
  for (double shift : {0.1, 0.6}) {
    SCOPED_TRACE(shift);
    Tracked t = make_tracked(params_for(s.bvh, "kinematic"), s.xml, 1.0);
    Engine& e = *t.engine;
    const int root = e.joint(e.joint_index("root")).qpos_adr;
    const int root_dof = e.joint(e.joint_index("root")).dof_adr;
    Eigen::VectorXd q(e.nq()), v(e.nv()), scratch(e.nv());
    ControlOutput out;
    out.resize(e.nv(), 0);
    TrackingError err;
    for (int k = 0; k < 250; ++k) {
      t.tracker->motion().sample(e, e.time(), q, v, scratch);
      q[root] += shift;
      v.setZero();
      v[root_dof] = 0.3;  // MuJoCo's free joint: linear velocity first, in the world
      e.set_positions(q);
      e.set_velocities(v);
      e.forward();
      out.clear();
      t.tracker->compute(*t.state, e, out);
      ASSERT_TRUE(t.tracker->tracking_error(*t.state, e, err));
      EXPECT_NEAR(err.root_m, shift, 1e-9);
      // the table's body positions interpolate linearly between frames, the pose on the
      // configuration manifold: they agree to a few micrometres between frames
      EXPECT_NEAR(err.body_m, shift, 1e-5);
      EXPECT_LT(err.joint_rad, 1e-7);
      EXPECT_LT(err.root_tilt_rad, 1e-7);
      e.step();
    }
    nlohmann::json m;
    t.tracker->add_metrics(*t.state, m);
    const auto& j = m["mocap"];
    std::cout << "shift " << shift << ": " << j["mean_body_position_error_m"] << " m, skate "
              << j["foot_skate_m_per_s"] << " m/s, success " << j["success"] << "\n";
    EXPECT_NEAR(j["mean_body_position_error_m"].get<double>(), shift, 1e-5);
    EXPECT_NEAR(j["mean_root_error_m"].get<double>(), shift, 1e-9);
    EXPECT_LT(j["mean_joint_error_deg"].get<double>(), 1e-5);
    EXPECT_NEAR(j["foot_skate_m_per_s"].get<double>(), 0.3, 1e-9);
    EXPECT_TRUE(j["fall_time_s"].is_null());
    // PHC: success while the per-frame mean stays within 0.5 m
    EXPECT_EQ(j["success"].get<bool>(), shift < 0.5);
  }
}

// the root tilted 0.2 rad about a horizontal axis is a 0.2 rad tilt error; the COM at a third of
// the reference's height is a fall, and a crouch the reference makes is not
TEST(MocapTracker, TiltErrorAndFallVerdictOnHandMadeStates) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_verdict");
  Tracked t = make_tracked(params_for(s.bvh, "kinematic"), s.xml, 1.0);
  Engine& e = *t.engine;
  const int root = e.joint(e.joint_index("root")).qpos_adr;
  Eigen::VectorXd q(e.nq()), v(e.nv()), scratch(e.nv());
  t.tracker->motion().sample(e, 0, q, v, scratch);
  std::string reason;
  e.set_positions(q);
  e.forward();
  EXPECT_EQ(t.tracker->fall_verdict(*t.state, e, reason), FallVerdict::kUp);
  Eigen::Quaterniond r(q[root + 3], q[root + 4], q[root + 5], q[root + 6]);
  r = Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX())) * r;
  Eigen::VectorXd tilted = q;
  tilted.segment<4>(root + 3) << r.w(), r.x(), r.y(), r.z();
  e.set_positions(tilted);
  e.forward();
  TrackingError err;
  t.tracker->tracking_error(*t.state, e, err);
  EXPECT_NEAR(err.root_tilt_rad, 0.2, 1e-9);
  // the whole character lowered until its COM is at a third of its height: a fall
  Eigen::VectorXd low = q;
  low[root + 2] -= 0.6;
  e.set_positions(low);
  e.forward();
  EXPECT_EQ(t.tracker->fall_verdict(*t.state, e, reason), FallVerdict::kFell);
  EXPECT_NE(reason.find("the COM is"), std::string::npos) << reason;
  // lying on its back at the reference's height is a fall by contact
  Eigen::VectorXd lying = q;
  Eigen::Quaterniond flat =
      Eigen::Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX())) *
      Eigen::Quaterniond(q[root + 3], q[root + 4], q[root + 5], q[root + 6]);
  lying.segment<4>(root + 3) << flat.w(), flat.x(), flat.y(), flat.z();
  lying[root + 2] = 0.1;
  e.set_positions(lying);
  e.forward();
  EXPECT_EQ(t.tracker->fall_verdict(*t.state, e, reason), FallVerdict::kFell);
}

// the planner's hook: named offsets in free mode with the balance layer, none otherwise; a zero
// correction is no correction, a swing-hip offset changes the torques
TEST(MocapTracker, CorrectionMovesTheBalanceTargets) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_correction");
  std::vector<CorrectionDim> dims;
  make_tracked(params_for(s.bvh, "assisted"), s.xml, 0).tracker->correction_dims(dims);
  EXPECT_TRUE(dims.empty());
  Tracked t = make_tracked(params_for(s.bvh, "free"), s.xml, 0);
  t.tracker->correction_dims(dims);
  std::vector<std::string> names;
  for (const auto& d : dims) {
    names.push_back(d.name);
    EXPECT_EQ(d.unit, "rad");
    EXPECT_GE(d.scale, 0.1);
    EXPECT_LE(d.scale, 0.2);
  }
  EXPECT_EQ(names,
            (std::vector<std::string>{"swing_hip_pitch", "swing_hip_roll", "pelvis_pitch",
                                      "pelvis_roll", "stance_ankle_pitch", "stance_ankle_roll"}));
  auto torques = [&](const double* correction) {
    Tracked u = make_tracked(params_for(s.bvh, "free"), s.xml, 0);
    ControlOutput out;
    out.resize(u.engine->nv(), 0);
    if (correction)
      u.tracker->as<Correctable>()->compute_corrected(*u.state, *u.engine, correction, out);
    else
      u.tracker->compute(*u.state, *u.engine, out);
    return Eigen::VectorXd(out.tau);
  };
  const double zero[6] = {}, hip[6] = {0.1, 0, 0, 0, 0, 0}, ankle[6] = {0, 0, 0, 0, 0.1, 0};
  const Eigen::VectorXd none = torques(nullptr);
  EXPECT_EQ(torques(zero), none);
  EXPECT_GT((torques(hip) - none).norm(), 1.0);
  EXPECT_GT((torques(ankle) - none).norm(), 1.0);
}

// the planner's rollouts: a tracker built for them keeps no metrics, and one that reads its
// reference from a horizon sampled once (then, past its end, samples as a run does) computes the
// run's torques, tracking errors and fall verdicts to the bit
TEST(MocapTracker, RolloutsReadTheirReferenceFromTheHorizonToTheBit) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_horizon");
  const MocapRetargetParams p = params_for(s.bvh, "free");
  Tracked run = make_tracked(p, s.xml, 1);
  Tracked rollout;
  rollout.engine = engine_of(s.xml);
  ControllerContext ctx;
  ctx.duration_s = 1;
  ctx.rollout = true;
  ctx.scratch_engine = [xml = s.xml] { return engine_of(xml); };
  rollout.tracker = std::make_unique<MocapRetargetTracker>(p, ctx, *rollout.engine);
  EngineState start;
  run.engine->save_state(start);
  rollout.engine->restore_state(start);
  rollout.engine->forward();
  rollout.state = rollout.tracker->make_state(*rollout.engine);
  const int steps = 150, sampled = 100;
  std::unique_ptr<ReferenceHorizon> horizon = rollout.tracker->make_reference_horizon();
  ASSERT_NE(horizon, nullptr);
  rollout.tracker->sample_reference_horizon(*horizon, *rollout.engine, start.time, sampled);
  rollout.tracker->use_reference_horizon(*rollout.state, horizon.get());
  const auto& h = static_cast<const MocapReferenceHorizon&>(*horizon);
  ControlOutput out_run, out_rollout;
  out_run.resize(run.engine->nv(), 0);
  out_rollout.resize(run.engine->nv(), 0);
  int read = 0;
  for (int k = 0; k < steps; ++k) {
    const double correction[6] = {0.3 * std::sin(0.1 * k), 0.1, -0.05, 0.02, 0.1, -0.1};
    for (Tracked* t : {&run, &rollout}) {
      ControlOutput& out = t == &run ? out_run : out_rollout;
      t->engine->forward();
      out.clear();
      t->tracker->as<Correctable>()->compute_corrected(*t->state, *t->engine, correction, out);
      t->engine->set_generalized_forces(out.tau);
      t->engine->step();
      t->engine->forward();
    }
    ASSERT_EQ(run.engine->time(), rollout.engine->time());
    if (h.find(rollout.engine->time()) >= 0) ++read;
    ASSERT_EQ(out_run.tau, out_rollout.tau) << "step " << k;
    TrackingError a, b;
    ASSERT_TRUE(run.tracker->tracking_error(*run.state, *run.engine, a));
    ASSERT_TRUE(rollout.tracker->tracking_error(*rollout.state, *rollout.engine, b));
    EXPECT_EQ(a.body_m, b.body_m);
    EXPECT_EQ(a.joint_rad, b.joint_rad);
    EXPECT_EQ(a.root_tilt_rad, b.root_tilt_rad);
    std::string why_a, why_b;
    EXPECT_EQ(run.tracker->fall_verdict(*run.state, *run.engine, why_a),
              rollout.tracker->fall_verdict(*rollout.state, *rollout.engine, why_b));
  }
  EXPECT_EQ(read, sampled);  // the horizon served every step it holds
  nlohmann::json m_run, m_rollout;
  run.tracker->add_metrics(*run.state, m_run);
  rollout.tracker->add_metrics(*rollout.state, m_rollout);
  EXPECT_GT(m_run["mocap"]["mean_body_position_error_m"].get<double>(), 0.0);
  EXPECT_EQ(m_rollout["mocap"]["mean_body_position_error_m"].get<double>(), 0.0);
  // the rollout read its targets from the horizon: another pose there gives other torques
  auto first_torques = [&](const ReferenceHorizon& from) {
    rollout.engine->restore_state(start);
    rollout.engine->forward();
    rollout.tracker->reset(*rollout.state, *rollout.engine);
    rollout.tracker->use_reference_horizon(*rollout.state, &from);
    out_rollout.clear();
    rollout.tracker->compute(*rollout.state, *rollout.engine, out_rollout);
    return Eigen::VectorXd(out_rollout.tau);
  };
  MocapReferenceHorizon bent = h;
  bent.v.col(0).array() += 1.0;
  EXPECT_GT((first_torques(bent) - first_torques(h)).norm(), 1.0);
}

// old scenarios: mocap_tracker loads as the one tracker, and its removed free-mode keys are
// ignored with one warning
TEST(MocapTracker, AliasLoadsOldScenarios) {
  const std::string file = test::scenario_path("mocap_track.yaml");
  testing::internal::CaptureStderr();
  Simulation run(load_scenario(file, {"controllers.0.mode=free", "controllers.0.path_gain=0.1",
                                      "controllers.0.contact_stance=true"}),
                 RunOptions{});
  const std::string err = testing::internal::GetCapturedStderr();
  const auto* tracker = dynamic_cast<const MocapRetargetTracker*>(run.controllers().at(0).get());
  ASSERT_NE(tracker, nullptr);
  EXPECT_EQ(tracker->type(), "mocap_tracker");
  EXPECT_TRUE(tracker->params().joint_map.empty());
  EXPECT_NE(err.find("ignored its removed free-mode keys: contact_stance, path_gain"),
            std::string::npos)
      << err;
  // a key that never was mocap_tracker's is still an error
  EXPECT_THROW(Simulation(load_scenario(file, {"controllers.0.no_such_key=1"}), RunOptions{}),
               InputError);
}

// the acceptance numbers on the MASS walk, looped for 10 s
TEST(MocapTracker, MassWalkTenSeconds) {
  const std::string path = test::shared_bvh("mass_walk.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  for (const char* mode : {"kinematic", "assisted"}) {
    SCOPED_TRACE(mode);
    // kinematic: the clip's feet dip below their start height, and the floor would push them
    // back; align the lowest point of the whole clip instead
    const bool kinematic = std::string(mode) == "kinematic";
    ClipFiles s = make_files(read_bvh(path), std::string("mass_walk_") + mode, kinematic);
    MocapRetargetParams p = params_for(path, mode);
    if (kinematic) p.ground = "clip";
    Tracked t = make_tracked(p, s.xml, 10.0);
    Outcome o = track(t, 10.0);
    std::cout << mode << ": " << o.metrics["mocap"]["mean_joint_error_deg"] << " deg, success "
              << o.metrics["mocap"]["success"] << "\n";
    EXPECT_LT(o.mean_deg, kinematic ? 0.5 : 5.0);
    EXPECT_FALSE(o.root_fell);
    EXPECT_FALSE(o.fell);
    if (!kinematic) EXPECT_GT(o.helper, 0);
  }
}

// CMU 131_01 crouches (its root drops to about 0.52 m): followed kinematically, that is no fall
TEST(MocapTracker, CrouchInTheClipIsNoFall) {
  const std::string path = test::shared_bvh("cmu_131_01.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  ClipFiles s = make_files(read_bvh(path), "cmu_crouch", true);
  MocapRetargetParams p = params_for(path, "kinematic");
  p.ground = "clip";
  p.loop = false;
  Tracked t = make_tracked(p, s.xml, 0);
  const double length = t.tracker->motion().duration_s();
  double lowest_root = 1e9;
  Engine& e = *t.engine;
  ControlOutput out;
  out.resize(e.nv(), e.nu());
  std::string reason;
  while (e.time() < length) {
    e.forward();
    lowest_root = std::min(lowest_root, e.body_pose(e.body_index("Hips")).pos.z());
    ASSERT_NE(t.tracker->fall_verdict(*t.state, e, reason), FallVerdict::kFell)
        << "at " << e.time() << " s: " << reason;
    out.clear();
    t.tracker->compute(*t.state, e, out);
    e.set_generalized_forces(out.tau);
    e.step();
  }
  std::cout << "cmu_131_01: " << length << " s, lowest root " << lowest_root << " m\n";
  EXPECT_LT(lowest_root, 0.6);
  nlohmann::json m;
  t.tracker->add_metrics(*t.state, m);
  EXPECT_TRUE(m["mocap"]["success"].get<bool>());
}

}  // namespace
}  // namespace stance
