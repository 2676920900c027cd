// Motion-capture tracking, the one tracker of stance: a BVH clip mapped onto the model's bodies
// (control/retarget.h), then tracked by stable PD with target velocities on every dof, on MuJoCo
// or DART. The run starts on the clip's first mapped frame.
//
// The map: a YAML joint-name map (joint_map) for any model with a free root; without one, the
// model must be the clip's own `stance bvh2mjcf` character (bodies named after the clip's
// segments, free joint "root") and the map is the identity (bvh_character_joint_map): the table
// is then the reference itself, to 1e-9. The registry's `mocap_tracker` is an alias of this
// tracker for old scenarios (control/registry.cc).
//
// Root modes: kinematic (deadbeat inverse dynamics on every dof: the error of the table's
// interpolation alone), assisted (root gains inside the SPD solve; the root's share is the helper
// force, integrated into an impulse) and free (no root help). Free mode has a SIMBICON-style
// balance layer in model terms: the stance side from the feet's contacts, the swing thigh
// servoed in the world with SIMBICON feedback, the pelvis servoed through the stance hip, the
// swing foot at its world orientation, and a Coros virtual COM force carried by the stance
// leg; world targets become joint coordinates by the map's own hinge fit. The balance layer is
// the planner's hook: correction_dims() lists offsets of its targets (docs/mocap.md).
//
// Metrics (metrics.mocap): joint error (geodesic angle between each mapped body's rotation
// relative to its parent body and the table's, deg), root position error, the mean world
// position error of the mapped bodies (PHC's G-MPJPE), end error (mapped bodies with no mapped
// body below them), foot skate, success (no fall by fall_verdict() and the body error never
// above 0.5 m), the map's fit error, helper impulse and the fall times. With export_bvh set,
// the simulated motion is mapped back onto the clip's skeleton (the inverse of the map; joints
// not mapped keep the clip's rotations) and written at the clip's frame rate.
#pragma once

#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "control/controller.h"
#include "control/mocap_clip.h"
#include "control/mocap_weak_ankles.h"
#include "control/pose_tracking.h"
#include "control/retarget.h"

namespace stance {

struct MocapRetargetParams : MocapClipParams, MocapHelperParams, MocapBalanceParams {
  MocapRetargetParams() { swing_foot_world = true; }
  std::string joint_map;          // YAML map file (relative: to the scenario); empty: the identity
  std::string mode = "assisted";  // kinematic, assisted or free
  double kp = 2000;               // N m/rad on every joint dof (shared by every clip and model)
  double kd = 175;                // N m s/rad
  NamedValues kp_joints;          // per-dof kp (a dof name, or a joint name for all its dofs)
  NamedValues kd_joints;
  double max_torque = 0;  // N m clamp on joint torques; 0: none
  // free mode: a dof's kp is at most its torque limit / this (kd by the same factor), so that its
  // PD reaches the limit no sooner than at this error whatever kp is (0: off)
  double limit_gain_error = 0.1;  // rad
  // free mode: a leg dof's kp is at least this x the body's gravity stiffness m g h (h: the COM
  // over the ankles), kd by the same factor (0: off, the default: at 1.25 Atlas's kp 1600 held
  // on DART at seeds 0 and 2 but lost success on MuJoCo at seed 1; docs/robots.md)
  double load_gain_margin = 0;

  template <class V>
  void visit(V& v) {
    MocapClipParams::visit(v);
    v("joint_map", joint_map,
      {.help = "YAML map: clip joint -> model body; empty: the clip's bvh2mjcf character"});
    v("mode", mode, {.help = "kinematic, assisted or free"});
    v("kp", kp, {.unit = "N m/rad", .min = 0, .max = 1e7});
    v("kd", kd, {.unit = "N m s/rad", .min = 0, .max = 1e6});
    v("kp_joints", kp_joints, {.unit = "N m/rad", .help = "per-dof or per-joint kp"});
    v("kd_joints", kd_joints, {.unit = "N m s/rad", .help = "per-dof or per-joint kd"});
    MocapHelperParams::visit(v);
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "0: none"});
    v("limit_gain_error", limit_gain_error,
      {.unit = "rad", .min = 0, .max = 10, .help = "free mode: kp at most limit / this; 0: off"});
    v("load_gain_margin", load_gain_margin,
      {.min = 0, .max = 10, .help = "free mode: a leg's kp at least this x m g h; 0: off"});
    MocapBalanceParams::visit(v);
  }
};

// the reference over a planning horizon (Controller::make_reference_horizon): per step k, the
// samples a rollout's step takes at time[k], the engine's time at step k plus its timestep
struct MocapReferenceHorizon final : ReferenceHorizon {
  double dt = 0;
  int bodies = 0;                                // mapped bodies per step
  std::vector<double> time;                      // s, per step
  Eigen::MatrixXd q, v;                          // sample(): nq x steps, nv x steps
  std::vector<Eigen::Quaterniond> world, local;  // sample_world(), sample_bodies(): steps x bodies
  std::vector<Eigen::Vector3d> position;         // sample_bodies()
  std::vector<Eigen::Vector3d> root_ahead;       // the root's position 10 ms later, per step
  std::vector<Eigen::Vector3d> root_acceleration;  // sample_body_acceleration() of the root
  std::vector<BodyPose> pose;                      // sample_body_pose(): steps x bodies
  std::vector<Eigen::Quaterniond> body_local;      // sample_body_local(): steps x bodies
  std::vector<double> com_height;                  // the fall rule's reference COM height, per step
  // work vectors of the sampling
  Eigen::VectorXd scratch;
  std::vector<Eigen::Quaterniond> work_world, work_local;
  std::vector<Eigen::Vector3d> work_position, work_ahead;

  // the step whose time is exactly t; -1: none
  int find(double t) const {
    if (time.empty() || dt <= 0) return -1;
    const long k = std::lround((t - time[0]) / dt);
    return k >= 0 && k < static_cast<long>(time.size()) && time[k] == t ? static_cast<int>(k) : -1;
  }
};

// one run's tracking state: work vectors, the reference sample, the accumulated errors and
// helper impulses, the recorded frames (with export_bvh) and the balance layer's stance
struct MocapRetargetState {
  Eigen::VectorXd q, v, q_ref, v_ref, tau, scratch;
  PoseTrackingWork work;
  std::vector<Eigen::Quaterniond> ref_local;
  std::vector<Eigen::Vector3d> ref_position;
  double error_sum_deg = 0, max_error_deg = 0, last_error_deg = 0;
  long error_samples = 0;
  double root_error_sum = 0, root_error_max = 0, last_root_error = 0;
  double end_error_sum = 0, end_error_max = 0;
  double body_error_sum = 0, body_error_max = 0, last_body_error = 0;  // per step: mean over bodies
  double skate_sum = 0;  // m/s, summed over steps and touching feet
  long skate_samples = 0;
  long steps = 0;
  double helper_impulse = 0, helper_angular_impulse = 0;
  double fall_time = -1;      // the root below half its reference height (the old rule)
  double ref_fall_time = -1;  // fall_verdict()'s first fall
  int fall_cause = 0;         // of that fall: MocapFallCause
  int fall_body = -1;         // the body that touched the ground
  // export: per recorded frame (the clip's rate), the mapped bodies' world rotations and the
  // root-mapped body's position
  std::vector<Eigen::Quaterniond> recorded_rotations;
  std::vector<Eigen::Vector3d> recorded_roots;
  double next_record_t = 0;
  // free mode balance
  std::vector<Eigen::Quaterniond> bal_world, bal_local;
  std::vector<Eigen::Vector3d> bal_pos, bal_pos_ahead;
  Eigen::MatrixXd jac_a, jac_b;
  int stance = 0;
  std::array<double, 2> stance_share = {1, 0};
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  // a planner rollout's reference over its horizon (null: the run's own state); not saved
  const MocapReferenceHorizon* horizon = nullptr;

  double mean_joint_error_deg() const {
    return error_samples ? error_sum_deg / error_samples : 0.0;
  }
  double helper_impulse_ns() const { return helper_impulse; }
  std::optional<double> fall_time_s() const {
    return fall_time >= 0 ? std::optional<double>(fall_time) : std::nullopt;
  }

  template <class A>
  void serialize(A& a) {
    a(q), a(v), a(q_ref), a(v_ref), a(tau), a(scratch), a(ref_local), a(ref_position);
    a(error_sum_deg), a(max_error_deg), a(last_error_deg), a(error_samples);
    a(root_error_sum), a(root_error_max), a(last_root_error), a(end_error_sum), a(end_error_max),
        a(steps), a(helper_impulse), a(helper_angular_impulse), a(fall_time);
    a(body_error_sum), a(body_error_max), a(last_body_error), a(skate_sum), a(skate_samples);
    a(ref_fall_time), a(fall_cause), a(fall_body);
    a(recorded_rotations), a(recorded_roots), a(next_record_t);
    a(bal_world), a(bal_local), a(bal_pos), a(bal_pos_ahead), a(jac_a), a(jac_b), a(stance),
        a(stance_share), a(up);
  }
};

// why fall_verdict() judged a fall
enum class MocapFallCause { kNone, kComLow, kBodyTouches };

class MocapRetargetTracker final
    : public CorrectedController<MocapRetargetState, Reporting, Retunable, Tracking, FallJudge,
                                 HorizonSampling, InitialState> {
 public:
  // the table is built once here on ctx.scratch_engine (overwritten while it is probed), long
  // enough for ctx.duration_s (looping clips); relative bvh and joint_map paths start at the
  // folder of ctx.source.file
  // type_name: the registry name it is built under (the alias mocap_tracker keeps its own, so a
  // saved scenario loads as it was written)
  MocapRetargetTracker(const MocapRetargetParams& params, const ControllerContext& ctx,
                       const Engine& engine, std::string_view type_name = "mocap_retarget");
  std::string_view type() const override { return type_name_; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }
  std::vector<ParamEntry> tunable_params() const override;
  bool initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                     Eigen::VectorXd& qvel) const override;
  // a State goes on under other gains, not under another clip, map (its sizes) or mode
  bool keeps_state_of(const Controller& previous) const override;
  // free mode with the balance layer: offsets of its targets (docs/mocap.md, "The planner's
  // hook"); none in the other modes
  void correction_dims(std::vector<CorrectionDim>& dims) const override;
  // the planner's rollouts read the reference's samples over the horizon from one
  // MocapReferenceHorizon per planning step
  std::unique_ptr<ReferenceHorizon> make_reference_horizon() const override;
  void sample_reference_horizon(ReferenceHorizon& horizon, const Engine& engine, double t0,
                                int steps) const override;
  void use_reference_horizon(ControllerState& state,
                             const ReferenceHorizon* horizon) const override;

  // the fall rule of fall_verdict(): the COM below this fraction of the reference's COM height,
  // or a body outside the feet on the ground where the reference's origin is higher than
  // kTouchHeight above the reference's sole level (heights from that level: the lowest mapped
  // body origin of the reference over the table)
  static constexpr double kComFraction = 0.6;
  static constexpr double kTouchHeight = 0.15;      // m
  static constexpr double kSuccessBodyError = 0.5;  // m: PHC's bound on the per-frame mean
  // s: the balance layer's reference root velocity is a forward difference over this step
  static constexpr double kRootVelocityStep = 0.01;
  // m: on weak ankles, a clip's foot this far above its stance foot is swinging
  static constexpr double kWeakSwingClearance = 0.02;
  // m: ... and its swing foot is lifted by at most this
  static constexpr double kWeakSwingMaxLift = 0.2;

  const MocapRetargetParams& params() const { return params_; }
  const RetargetedMotion& motion() const { return *motion_; }
  // the gains per dof, as the stable PD uses them (after kp_joints and limit_gain_error)
  const Eigen::VectorXd& kp() const { return kp_; }
  const Eigen::VectorXd& kd() const { return kd_; }
  // free mode's weak-ankle legs (mocap_weak_ankles.h)
  const WeakAnkleLegs& weak_ankle_legs() const { return weak_legs_; }
  // the simulated motion of a run so far, mapped back onto the clip's skeleton (file units, as
  // read)
  BvhClip recorded_clip(const State& state) const;

  void signals(const ControllerState& s, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& s, nlohmann::json& metrics) const override;
  // export_bvh: the recorded motion
  void write_outputs(const ControllerState& s, const std::string& out_dir) const override;
  bool reference_qpos(const ControllerState& s, const Engine& engine,
                      Eigen::VectorXd& qpos) const override;
  bool tracking_error(const ControllerState& s, const Engine& engine,
                      TrackingError& error) const override;
  FallVerdict fall_verdict(const ControllerState& s, const Engine& engine,
                           std::string& reason) const override;

 protected:
  void reset_state(State& s, const Engine& engine) const override;
  void compute_with(State& state, const Engine& engine, const double* correction,
                    ControlOutput& out) const override;

 private:
  // the constructor's parts: the fall rule's tables; the gains
  void init_fall_rule(const Engine& engine, const Engine& probe);
  void init_gains(const MocapRetargetParams& params, const Engine& engine);
  void accumulate_metrics(State& s, const Engine& engine) const;
  void balance(State& s, const Engine& engine, double t, const double* correction) const;
  // weak ankles (mocap_weak_ankles.cc): the swing foot lifted by as much as the root rides below
  // the clip's
  void lift_swing_foot(State& s, const Engine& engine, int swing, const BodyPose& root) const;
  // the fall rule at the engine's time: the cause and the body that touched (allocates nothing);
  // `horizon` (null: none) holds the reference's samples at some times
  MocapFallCause judge_fall(const Engine& engine, const MocapReferenceHorizon* horizon, int& body,
                            double& com_height, double& ref_height) const;
  // the reference COM's height over the sole level at time t, from the model's masses
  double reference_com_height(const Engine& engine, double t) const;

  // the model: fixed after construction
  std::string type_name_;
  MocapRetargetParams params_;
  MocapRootMode mode_ = MocapRootMode::kAssisted;
  double duration_s_ = 0;  // the run's length (the recording's reserve); 0: unknown
  // false in the planner's rollouts: no errors, foot skate or second fall check accumulated
  bool metrics_ = true;
  MocapClip clip_;
  std::shared_ptr<const RetargetedMotion> motion_;
  int root_body_ = -1, root_dof_ = -1;
  // per root dof: a translation (MuJoCo's free joint lists them first, DART's last)
  bool root_translation_[6] = {false, false, false, false, false, false};
  Eigen::VectorXd kp_, kd_;
  int root_mapped_ = -1;  // index into motion().bodies() of the clip root's body
  // free mode balance: mapped indices of the thighs and feet, engine bodies of each foot's
  // subtree, and the walking direction in the root body's frame
  int hip_[2] = {-1, -1}, foot_[2] = {-1, -1};
  std::vector<int> foot_bodies_[2];
  Eigen::Vector3d forward_in_root_ = Eigen::Vector3d::UnitX();
  bool has_legs_ = false;
  // the stance ankle's corrections (correction_dims): 2 (pitch, roll) or 1 (a one-axis ankle:
  // pitch); the hips' (swing pitch and roll, pelvis pitch and roll) are always there
  int ankle_corrections_ = 2;
  // weak ankles: the swing leg servoed while the clip swings it, its foot lifted (free mode)
  WeakAnkleLegs weak_legs_;
  // the fall rule: per engine body, the mapped body it moves with (-1: none), its COM and origin
  // in that body's frame, whether it belongs to a foot; the mass of the anchored bodies and the
  // reference's sole level along up
  std::vector<int> anchor_;
  std::vector<Eigen::Vector3d> anchor_com_, anchor_origin_;
  std::vector<char> is_foot_;
  // per engine body, its child bodies (children_[child_first_[b] .. child_first_[b + 1])): a
  // body's bone reaches down to them, so its reference height is the lowest of those origins
  std::vector<int> child_first_, children_;
  double anchored_mass_ = 0;
  double sole_level_ = 0;
  double com_height_ = 0;  // m: the COM over the lowest foot origin at the first frame
  std::vector<std::string> body_names_;  // the engine's, for the metrics
  Eigen::Vector3d up_ = Eigen::Vector3d::UnitZ();
};

}  // namespace stance
