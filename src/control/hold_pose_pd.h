// Hold a pose with joint-space PD: tau = -kp (q (-) q_target) - kd v on the chosen dofs.
// The first user of the engine interface; positions are differenced by the engine, so ball
// and free joints work.
#pragma once

#include "control/controller.h"
#include "engine/engine.h"

namespace stance {

struct HoldPosePdParams {
  double kp = 100;                // N m/rad
  double kd = 10;                 // N m s/rad
  std::vector<std::string> dofs;  // empty: every non-root dof
  NamedValues target;             // dof -> value; unnamed dofs hold their initial value
  double max_torque = 1e9;        // N m, symmetric clamp
  bool compensate_bias = false;   // add the bias forces (gravity + Coriolis) on the held dofs

  template <class V>
  void visit(V& v) {
    v("kp", kp, {.unit = "N m/rad", .min = 0, .help = "position gain"});
    v("kd", kd, {.unit = "N m s/rad", .min = 0, .help = "velocity gain"});
    v("dofs", dofs, {.help = "dofs to hold; empty = all non-root dofs"});
    v("target", target, {.unit = "rad or m", .help = "target per dof; default: initial pose"});
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "torque clamp"});
    v("compensate_bias", compensate_bias, {.help = "feed forward gravity and Coriolis forces"});
  }
};

// the per-run data: the target pose captured at reset, work vectors, the last error
struct HoldPosePdState {
  Eigen::VectorXd q_target, q, v, dq, bias;  // nq or nv
  double last_error_norm = 0;                // rad

  template <class A>
  void serialize(A& a) {
    a(q_target), a(q), a(v), a(dq), a(bias), a(last_error_norm);
  }
};

class HoldPosePd final : public TypedController<HoldPosePdState, Reporting, Retunable> {
 public:
  // model: gains and dof indices, fixed after construction
  struct Model {
    HoldPosePdParams params;
    std::vector<int> dofs;
    std::vector<std::pair<int, double>> targets;  // (qpos index, value) for named targets
  };

  HoldPosePd(const HoldPosePdParams& params, const ControllerContext& ctx, const Engine& engine);
  std::string_view type() const override { return "hold_pose_pd"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(model_.params, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(model_.params); }
  // the named targets are captured into the State at reset: a State made for other targets
  // would hold the old ones
  bool keeps_state_of(const Controller& previous) const override;

  const Model& model() const { return model_; }

  void signals(const ControllerState& state, std::vector<double>& values) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  void compute_step(State& state, const Engine& engine, ControlOutput& out) const override;

 private:
  Model model_;
};

}  // namespace stance
