// Motion-capture tracking: stable PD on every ball joint towards a BVH reference (with target
// velocities), on a character built by `stance bvh2mjcf` (bodies and ball joints named after the
// BVH joints, free joint "root"). MuJoCo models only (quaternion ball joints).
//
// Root modes:
//  - kinematic: every dof, root included, is driven deadbeat by inverse dynamics:
//      tau = M (v_des - v) / dt + c - f_c,  v_des = (q_ref(t + dt) (-) q) / dt
//    so the character follows the reference up to the change of contact forces in one step;
//    the joint error is that of the resampling alone.
//  - assisted: SPD on the joints, plus root gains inside the same SPD solve; the root's share of
//    tau is the helper force and torque, integrated into helper impulses (N s, N m s).
//  - free: no root help. A SIMBICON-style balance layer (Yin et al. 2007) servoes the swing
//    thigh in the world frame and moves its target by theta = cd (d - d_ref) + cv (v - v_ref),
//    about the lateral axis (sagittal) and the heading axis (coronal), with d the root's
//    horizontal offset from the stance ankle; the stance hip's SPD target is the rotation that
//    puts the pelvis at the reference orientation over the current thigh (an implicit form of
//    SIMBICON's tau_stance_hip = -tau_torso - tau_swing_hip), optionally blended with the
//    reference hip. Optional pieces: stance from foot contacts, swing foot at its world
//    orientation, heading correction, and a Coros et al. 2010 virtual force at the COM carried
//    by the stance leg(s) (gravity compensation plus a spring on the root's offset from the
//    stance foot), applied as internal joint torques (add_com_support_torque).
//
// Metrics: joint angle error (geodesic, deg, mean and max over joints and time), root position
// error, end-effector error (leaf segments' bone ends), helper impulse (assisted), and the time
// the root fell below half its reference height. With export_bvh set, the simulated motion is
// written back on the clip's own skeleton at the clip's frame rate.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "control/controller.h"
#include "control/pose_tracking.h"
#include "engine/engine.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"

namespace stance {

// the clip and how it is read: shared by the trackers
struct MocapClipParams {
  std::string bvh;             // clip; relative paths start at the scenario's folder
  double scale_to_meters = 0;  // 0: detect from the leg length
  std::string up_axis = "y";   // the file's up axis
  int first_frame = 0;
  int last_frame = -1;  // -1: the last
  double start_s = -1;  // >= 0: overrides first_frame
  double end_s = -1;    // >= 0: overrides last_frame
  bool loop = true;
  bool align_ground = true;
  std::string ground = "start";  // align at the start, or the lowest point of the whole clip
  std::string export_bvh;        // write the simulated motion here (relative: to the output)

  template <class V>
  void visit(V& v) {
    v("bvh", bvh, {.help = "BVH clip to track"});
    v("scale_to_meters", scale_to_meters, {.unit = "m", .min = 0, .help = "0: detect"});
    v("up_axis", up_axis, {.help = "the file's up axis, y or z"});
    v("first_frame", first_frame, {.min = 0});
    v("last_frame", last_frame, {.min = -1, .help = "-1: the last frame"});
    v("start_s", start_s, {.unit = "s", .min = -1, .help = ">= 0: overrides first_frame"});
    v("end_s", end_s, {.unit = "s", .min = -1, .help = ">= 0: overrides last_frame"});
    v("loop", loop, {.help = "repeat the clip, accumulating the root displacement"});
    v("align_ground", align_ground, {.help = "lowest point on the floor at the start"});
    v("ground", ground,
      {.help = "start: lowest point at the start on the floor; clip: over the clip"});
    v("export_bvh", export_bvh, {.help = "write the simulated motion as BVH"});
  }
};

// the assisted mode's helper: PD gains on the root, inside the SPD solve
struct MocapHelperParams {
  double root_kp = 20000;     // assisted: N/m on the root position
  double root_kd = 2000;      // N s/m
  double root_kp_rot = 2000;  // N m/rad on the root orientation
  double root_kd_rot = 200;   // N m s/rad

  template <class V>
  void visit(V& v) {
    v("root_kp", root_kp, {.unit = "N/m", .min = 0, .max = 1e8, .help = "assisted mode"});
    v("root_kd", root_kd, {.unit = "N s/m", .min = 0, .max = 1e7});
    v("root_kp_rot", root_kp_rot, {.unit = "N m/rad", .min = 0, .max = 1e8});
    v("root_kd_rot", root_kd_rot, {.unit = "N m s/rad", .min = 0, .max = 1e7});
  }
};

// free mode's balance layer, shared by both trackers (docs/mocap.md, "Tracking")
struct MocapBalanceParams {
  bool balance = true;
  double cd_sagittal = 0.5;  // rad/m: swing-thigh feedback on the root's offset from the ankle
  double cv_sagittal = 0.2;  // rad s/m: ... and on its velocity
  double cd_coronal = 0.5;
  double cv_coronal = 0.2;
  double stance_hip_world_weight = 1;  // stance hip: 1 servoes the pelvis, 0 the reference angle
  bool swing_foot_world = false;       // swing foot at its reference world orientation
  double gravity_compensation = 0;     // weight fraction carried through the stance leg(s)
  double root_force_kp = 0;            // N/m: virtual force holding the root over the stance foot
  double root_force_kd = 0;            // N s/m
  double root_force_kd_z = 0;          // N s/m, along up
  std::string left_hip, right_hip;     // thigh joints (clip names); empty: found from the feet
  std::string left_foot, right_foot;   // feet; empty: the first foot/toe/ankle segment per leg

  template <class V>
  void visit(V& v) {
    v("balance", balance, {.help = "free mode: SIMBICON balance layer"});
    v("cd_sagittal", cd_sagittal, {.unit = "rad/m", .min = -100, .max = 100});
    v("cv_sagittal", cv_sagittal, {.unit = "rad s/m", .min = -100, .max = 100});
    v("cd_coronal", cd_coronal, {.unit = "rad/m", .min = -100, .max = 100});
    v("cv_coronal", cv_coronal, {.unit = "rad s/m", .min = -100, .max = 100});
    v("stance_hip_world_weight", stance_hip_world_weight,
      {.min = 0, .max = 1, .help = "free mode: 1 pelvis servo, 0 the reference hip angle"});
    v("swing_foot_world", swing_foot_world, {.help = "free mode: swing foot world orientation"});
    v("gravity_compensation", gravity_compensation,
      {.min = 0, .max = 2, .help = "free mode: weight fraction carried through the stance leg"});
    v("root_force_kp", root_force_kp,
      {.unit = "N/m", .min = 0, .max = 1e6, .help = "free mode: virtual root force, horizontal"});
    v("root_force_kd", root_force_kd, {.unit = "N s/m", .min = 0, .max = 1e6});
    v("root_force_kd_z", root_force_kd_z, {.unit = "N s/m", .min = 0, .max = 1e6});
    v("left_hip", left_hip);
    v("right_hip", right_hip);
    v("left_foot", left_foot);
    v("right_foot", right_foot);
  }
};

// a clip read and made ready to track
struct MocapClip {
  std::shared_ptr<const BvhClip> clip;
  std::shared_ptr<const ReferenceMotion> reference;
  int first_frame = 0;  // of the clip range, in the clip
};
// reads params.bvh (relative to base_dir) and builds its reference; throws InputError
MocapClip load_mocap_clip(const MocapClipParams& params, const std::string& base_dir);

// a clip on the source's skeleton from per-frame segment poses: local rotations (Z-up, as in
// ReferencePose::rotations; frame-major, segment_count per frame) and root positions (m, Z-up
// world). Joints that are no segment keep the clip's values at the matching frame of the range.
BvhClip clip_from_segment_poses(const MocapClip& mocap,
                                const std::vector<Eigen::Quaterniond>& locals,
                                const std::vector<Eigen::Vector3d>& roots);
// writes clip to export_path (relative: to out_dir)
void write_exported_bvh(const BvhClip& clip, const std::string& export_path,
                        const std::string& out_dir);
// whether two clip settings read the same clip the same way and export alike (a run's State
// made under one can go on under the other)
bool same_mocap_clip(const MocapClipParams& a, const MocapClipParams& b);
// the folder relative clip and map paths start at: the scenario file's
std::string mocap_base_dir(const ControllerContext& ctx);
// the recorded frames a run reserves, at the clip's frame rate: the run's length (at least
// two minutes, as a viewer runs on), plus a frame
size_t mocap_record_frames(double duration_s, double frame_time_s);

struct MocapTrackerParams : MocapClipParams, MocapHelperParams, MocapBalanceParams {
  std::string mode = "assisted";  // kinematic, assisted or free
  double kp = 1000;               // N m/rad on every ball joint
  double kd = 100;                // N m s/rad
  NamedValues kp_joints;          // per-joint kp (joint name)
  NamedValues kd_joints;
  // free mode balance layer: MocapBalanceParams, and
  bool stance_hip_world = true;  // stance hip target puts the pelvis at the reference
  double torso_kp = 0;           // N m/rad, extra explicit stance-hip torque on the pelvis
  double torso_kd = 0;
  bool contact_stance = false;    // stance from the feet's ground contacts, not the reference
  bool com_feedback = false;      // swing-thigh feedback on the COM instead of the root
  double root_force_kp_z = 0;     // N/m, vertical
  double heading_gain = 0;        // 0: targets on the simulated heading; 1: the reference's
  double swing_heading_gain = 0;  // the same for the swing leg alone (its landing yaw)
  double path_gain = 0;           // rad/m: the target heading turns towards the clip's path
  double ankle_cd_sagittal = 0;   // rad/m: stance-ankle tilt against the balance offset error
  double ankle_cv_sagittal = 0;   // rad s/m
  double ankle_cd_coronal = 0;
  double ankle_cv_coronal = 0;
  double max_torque = 0;  // N m clamp on joint torques; 0: none

  template <class V>
  void visit(V& v) {
    MocapClipParams::visit(v);
    v("mode", mode, {.help = "kinematic, assisted or free"});
    v("kp", kp, {.unit = "N m/rad", .min = 0, .max = 1e7});
    v("kd", kd, {.unit = "N m s/rad", .min = 0, .max = 1e6});
    v("kp_joints", kp_joints, {.unit = "N m/rad", .help = "per-joint kp"});
    v("kd_joints", kd_joints, {.unit = "N m s/rad", .help = "per-joint kd"});
    MocapHelperParams::visit(v);
    MocapBalanceParams::visit(v);
    v("stance_hip_world", stance_hip_world, {.help = "free mode: pelvis servo via stance hip"});
    v("torso_kp", torso_kp, {.unit = "N m/rad", .min = 0, .max = 1e7});
    v("torso_kd", torso_kd, {.unit = "N m s/rad", .min = 0, .max = 1e6});
    v("contact_stance", contact_stance, {.help = "free mode: stance from foot contacts"});
    v("com_feedback", com_feedback, {.help = "free mode: balance feedback on the COM"});
    v("root_force_kp_z", root_force_kp_z, {.unit = "N/m", .min = 0, .max = 1e6});
    v("heading_gain", heading_gain,
      {.min = 0, .max = 1, .help = "free mode: share of the heading error the targets correct"});
    v("swing_heading_gain", swing_heading_gain,
      {.min = 0, .max = 1, .help = "free mode: share of the heading error the swing leg corrects"});
    v("path_gain", path_gain,
      {.unit = "rad/m", .min = 0, .max = 10, .help = "free mode: turn towards the clip's path"});
    v("ankle_cd_sagittal", ankle_cd_sagittal,
      {.unit = "rad/m", .min = -100, .max = 100, .help = "free mode: stance-ankle feedback"});
    v("ankle_cv_sagittal", ankle_cv_sagittal, {.unit = "rad s/m", .min = -100, .max = 100});
    v("ankle_cd_coronal", ankle_cd_coronal, {.unit = "rad/m", .min = -100, .max = 100});
    v("ankle_cv_coronal", ankle_cv_coronal, {.unit = "rad s/m", .min = -100, .max = 100});
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "0: none"});
  }
};

enum class MocapRootMode { kKinematic, kAssisted, kFree };

// the immutable part: the clip, its reference motion and the engine indices
struct MocapTrackerModel {
  MocapTrackerParams params;
  MocapRootMode mode = MocapRootMode::kAssisted;
  std::shared_ptr<const BvhClip> clip;
  std::shared_ptr<const ReferenceMotion> reference;
  int first_frame = 0;                      // of the clip range, in the clip
  std::vector<int> body;                    // per segment: engine body
  std::vector<int> qpos_adr, dof_adr;       // per segment: its joint's (free for the root)
  Eigen::VectorXd kp, kd;                   // dim nv
  std::vector<int> end_effectors;           // segments
  std::vector<Eigen::Vector3d> end_points;  // per end effector: point in its frame, m
  int hip[2] = {-1, -1};                    // segments: left, right thigh
  int foot[2] = {-1, -1};                   // segments: left, right foot
  std::vector<int> foot_bodies[2];          // engine bodies of each foot and its subtree
  Eigen::Vector3d forward_in_root = Eigen::Vector3d::UnitX();  // walking direction, root frame
};

// one run's tracking state: the reference samples, work vectors, the recorded frames (with
// export_bvh), the stance side and the accumulated errors and helper impulses
struct MocapTrackerState {
  ReferencePose pose, pose_now;  // the targets' sample (t + dt) and the metrics' (t)
  std::vector<Eigen::Vector3d> fk_pos;
  std::vector<Eigen::Quaterniond> fk_rot;
  Eigen::VectorXd q, v, q_ref, v_ref, tau;
  Eigen::MatrixXd jac_a, jac_b;  // jacobians: 3 x nv
  PoseTrackingWork work;
  std::vector<double> recorded;  // recorded frames of q, nq each
  int recorded_frames = 0;
  double next_record_t = 0;
  int stance = 0;                               // 0 left, 1 right
  std::array<double, 2> stance_share = {1, 0};  // weight share per foot (contacts)
  std::vector<double> joint_error_sum_deg;      // per segment
  double error_sum_deg = 0, max_error_deg = 0;
  long error_samples = 0;
  double root_error_sum = 0, root_error_max = 0, ee_error_sum = 0, ee_error_max = 0;
  long steps = 0;
  double helper_impulse = 0, helper_angular_impulse = 0;
  double fall_time = -1;
  double last_error_deg = 0, last_root_error = 0;
  Eigen::Vector3d last_helper_force = Eigen::Vector3d::Zero();

  double mean_joint_error_deg() const {
    return error_samples ? error_sum_deg / error_samples : 0.0;
  }
  double max_joint_error_deg() const { return max_error_deg; }
  double helper_impulse_ns() const { return helper_impulse; }

  template <class A>
  void serialize(A& a) {
    for (ReferencePose* p : {&pose, &pose_now})
      a(p->root_position), a(p->root_velocity), a(p->rotations), a(p->angular_velocities);
    a(fk_pos), a(fk_rot), a(q), a(v), a(q_ref), a(v_ref), a(tau), a(jac_a), a(jac_b);
    a(recorded), a(recorded_frames), a(next_record_t), a(stance), a(stance_share);
    a(joint_error_sum_deg), a(error_sum_deg), a(max_error_deg), a(error_samples);
    a(root_error_sum), a(root_error_max), a(ee_error_sum), a(ee_error_max), a(steps);
    a(helper_impulse), a(helper_angular_impulse), a(fall_time), a(last_error_deg),
        a(last_root_error), a(last_helper_force);
  }
};

class MocapTracker final : public TypedController<MocapTrackerState> {
 public:
  // a relative params.bvh starts at the folder of ctx.source.file; ctx.duration_s sizes the
  // recording
  MocapTracker(const MocapTrackerParams& params, const ControllerContext& ctx,
               const Engine& engine);
  std::string_view type() const override { return "mocap_tracker"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(model_.params, type()); }
  // a State goes on under other gains, not under another clip (its sizes) or mode
  bool keeps_state_of(const Controller& previous) const override;

  const MocapTrackerModel& model() const { return model_; }
  // the simulated motion of a run so far as a clip on the reference's skeleton (file units,
  // Y-up as read)
  BvhClip recorded_clip(const State& state) const;

 protected:
  void reset_state(State& s, const Engine& engine) const override;
  void compute_step(State& s, const Engine& engine, ControlOutput& out) const override;
  void state_signals(const State& s, std::vector<double>& values) const override;
  void state_metrics(const State& s, nlohmann::json& metrics) const override;
  // export_bvh: the recorded motion
  void state_outputs(const State& s, const std::string& out_dir) const override;
  // the reference sample at the engine's time: root and segment rotations (the viewer's ghost)
  bool state_reference_qpos(const State& s, const Engine& engine,
                            Eigen::VectorXd& qpos) const override;

 private:
  void track_state(State& s, double t) const;
  void balance(State& s, const Engine& engine, double t_target) const;
  void accumulate_metrics(State& s, const Engine& engine) const;

  const MocapTrackerModel model_;
  const double duration_s_;  // the run's length, 0: unknown
};

// the joint torques that push the whole-body COM with a virtual force F (N, world) while the
// support body pushes back with -F at the same point (Coros et al. 2010):
// tau += (J_com - J_support(com))^T F, dim nv. The two forces cancel, so the free root's share is
// zero: these are internal torques on the joints between the support body and every other body.
// jac_com is the engine's COM Jacobian (3 x nv); jac_scratch is 3 x nv scratch.
void add_com_support_torque(const Engine& engine, int support_body, const Eigen::Vector3d& force,
                            const Eigen::MatrixXd& jac_com, Eigen::MatrixXd& jac_scratch,
                            Eigen::VectorXd& tau);

// the legs of a skeleton: per side (left, right) the thigh segment and the topmost foot segment
// (named like a foot, toe or ankle; the side from "right"/"R"), or -1. Non-empty names
// (left_hip, right_hip, left_foot, right_foot) override; unknown ones throw InputError.
void find_mocap_legs(const MotionSkeleton& skeleton, const std::array<std::string, 4>& names,
                     int hip[2], int foot[2]);

// "kinematic", "assisted", "free"; throws InputError otherwise
MocapRootMode parse_mocap_root_mode(const std::string& mode);

}  // namespace stance
