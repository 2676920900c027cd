// Motion-capture tracking on an existing model: a BVH clip mapped onto the model's bodies by a
// YAML joint-name map (control/retarget.h), then tracked by stable PD with target velocities on
// every dof, on MuJoCo or DART. The run starts on the clip's first mapped frame.
//
// Root modes as in mocap_tracker: kinematic (deadbeat inverse dynamics on every dof: the error
// of the table's interpolation alone), assisted (root gains inside the SPD solve; the root's
// share is the helper force, integrated into an impulse) and free (no root help). Free mode has
// mocap_tracker's balance layer in model terms: the stance side from the feet's contacts, the
// swing thigh servoed in the world with SIMBICON feedback, the pelvis servoed through the stance
// hip, the swing foot at its world orientation, and a virtual COM force carried by the stance
// leg; world targets become joint coordinates by the map's own hinge fit.
//
// Metrics: joint error (geodesic angle between each mapped body's rotation relative to its
// parent body and the table's, deg), root position error, end error (mapped bodies with no
// mapped body below them: feet, hands, head), the map's fit error (what the model's joints
// cannot express), helper impulse and the time of fall (the root more than half its reference
// height above the lowest mapped body below where it should be). With export_bvh set, the
// simulated motion is mapped back onto the clip's skeleton (the inverse of the map; joints not
// mapped keep the clip's rotations) and written at the clip's frame rate.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "control/controller.h"
#include "control/legacy_controller.h"
#include "control/mocap_tracker.h"
#include "control/pose_tracking.h"
#include "control/retarget.h"

namespace stance {

struct MocapRetargetParams : MocapClipParams, MocapHelperParams, MocapBalanceParams {
  MocapRetargetParams() { swing_foot_world = true; }
  std::string joint_map;          // YAML map file; relative paths start at the scenario's folder
  std::string mode = "assisted";  // kinematic, assisted or free
  double kp = 300;                // N m/rad on every joint dof
  double kd = 30;                 // N m s/rad
  NamedValues kp_joints;          // per-dof kp (dof name)
  NamedValues kd_joints;
  double max_torque = 0;  // N m clamp on joint torques; 0: none

  template <class V>
  void visit(V& v) {
    MocapClipParams::visit(v);
    v("joint_map", joint_map, {.help = "YAML map: clip joint -> model body"});
    v("mode", mode, {.help = "kinematic, assisted or free"});
    v("kp", kp, {.unit = "N m/rad", .min = 0, .max = 1e7});
    v("kd", kd, {.unit = "N m s/rad", .min = 0, .max = 1e6});
    v("kp_joints", kp_joints, {.unit = "N m/rad", .help = "per-dof kp"});
    v("kd_joints", kd_joints, {.unit = "N m s/rad", .help = "per-dof kd"});
    MocapHelperParams::visit(v);
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "0: none"});
    MocapBalanceParams::visit(v);
  }
};

class MocapRetargetTracker final : public LegacyController {
 public:
  // `probe`: a scratch engine of the same model, overwritten while the table is built;
  // duration_s: how long the table must run (looping clips)
  MocapRetargetTracker(const MocapRetargetParams& params, const Engine& engine, Engine& probe,
                       double duration_s, const std::string& base_dir = "");
  std::string_view type() const override { return "mocap_retarget"; }
  void reset(const Engine& engine) override;
  void compute(const Engine& engine, ControlOutput& out) override;
  void signal_names(std::vector<std::string>& names) const override;
  void signals(std::vector<double>& values) const override;
  void add_metrics(nlohmann::json& metrics) const override;
  void write_outputs(const std::string& out_dir) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }
  bool reference_qpos(const Engine& engine, Eigen::VectorXd& qpos) const override;
  bool initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                     Eigen::VectorXd& qvel) const override;

  const RetargetedMotion& motion() const { return *motion_; }
  // the simulated motion so far, mapped back onto the clip's skeleton (file units, as read)
  BvhClip recorded_clip() const;
  double mean_joint_error_deg() const;
  double helper_impulse_ns() const { return helper_impulse_; }
  std::optional<double> fall_time() const {
    return fall_time_ >= 0 ? std::optional<double>(fall_time_) : std::nullopt;
  }

 private:
  void accumulate_metrics(const Engine& engine);
  void balance(const Engine& engine, double t);

  // the immutable part
  MocapRetargetParams params_;
  MocapRootMode mode_ = MocapRootMode::kAssisted;
  MocapClip clip_;
  std::shared_ptr<const RetargetedMotion> motion_;
  int root_body_ = -1, root_dof_ = -1;
  // per root dof: a translation (MuJoCo's free joint lists them first, DART's last)
  bool root_translation_[6] = {false, false, false, false, false, false};
  Eigen::VectorXd kp_, kd_;
  // per-run state
  Eigen::VectorXd q_, v_, q_ref_, v_ref_, tau_, scratch_;
  PoseTrackingWork work_;
  std::vector<Eigen::Quaterniond> ref_local_;
  std::vector<Eigen::Vector3d> ref_position_;
  double error_sum_deg_ = 0, max_error_deg_ = 0, last_error_deg_ = 0;
  long error_samples_ = 0;
  double root_error_sum_ = 0, root_error_max_ = 0, last_root_error_ = 0;
  double end_error_sum_ = 0, end_error_max_ = 0;
  long steps_ = 0;
  double helper_impulse_ = 0, helper_angular_impulse_ = 0;
  double fall_time_ = -1;
  // export: per recorded frame (the clip's rate), the mapped bodies' world rotations and the
  // root-mapped body's position
  std::vector<Eigen::Quaterniond> recorded_rotations_;
  std::vector<Eigen::Vector3d> recorded_roots_;
  double next_record_t_ = 0;
  int root_mapped_ = -1;  // index into motion().bodies() of the clip root's body
  // free mode balance: mapped indices of the thighs and feet, engine bodies of each foot's
  // subtree, and the walking direction in the root body's frame
  int hip_[2] = {-1, -1}, foot_[2] = {-1, -1};
  std::vector<int> foot_bodies_[2];
  Eigen::Vector3d forward_in_root_ = Eigen::Vector3d::UnitX();
  std::vector<Eigen::Quaterniond> bal_world_, bal_local_;
  std::vector<Eigen::Vector3d> bal_pos_, bal_pos_ahead_;
  Eigen::MatrixXd jac_a_, jac_b_;
  int stance_ = 0;
  double stance_share_[2] = {1, 0};
  Eigen::Vector3d up_ = Eigen::Vector3d::UnitZ();
};

std::shared_ptr<const Controller> make_mocap_retarget_tracker(const YAML::Node& node,
                                                              const ControllerContext& ctx,
                                                              const Engine& engine);

}  // namespace stance
