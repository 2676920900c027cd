#include "control/hold_pose_pd.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace stance {

HoldPosePd::HoldPosePd(const HoldPosePdParams& params, const Engine& engine) {
  model_.params = params;
  if (params.dofs.empty()) {
    for (int i = 0; i < engine.nv(); ++i)
      if (!engine.dof_is_root(i)) model_.dofs.push_back(i);
  } else {
    for (const auto& name : params.dofs) model_.dofs.push_back(engine.require_dof(name));
  }
  for (const auto& [name, value] : params.target) engine.require_dof(name);
  state_.q_target.resize(engine.nq());
  state_.q.resize(engine.nq());
  state_.v.resize(engine.nv());
  state_.dq.resize(engine.nv());
  state_.bias.setZero(engine.nv());
}

void HoldPosePd::reset(const Engine& engine) {
  engine.get_positions(state_.q_target);
  // named targets: hinge/slide dofs map straight onto q
  for (const auto& [name, value] : model_.params.target) {
    int dof = engine.require_dof(name);
    const JointInfo& j = engine.joint(engine.dof_joint(dof));
    if (j.type != JointType::kHinge && j.type != JointType::kSlide)
      throw InputError("hold_pose_pd.target: '" + name + "' is not a hinge or slide dof");
    state_.q_target[j.qpos_adr] = value;
  }
  last_error_norm_ = 0;
}

void HoldPosePd::compute(const Model& model, State& state, const Engine& engine,
                         ControlOutput& out) {
  engine.get_positions(state.q);
  engine.get_velocities(state.v);
  engine.difference_positions(state.q_target, state.q, state.dq);
  if (model.params.compensate_bias) engine.bias_forces(state.bias);
  const double lim = model.params.max_torque;
  for (int i : model.dofs) {
    double t = -model.params.kp * state.dq[i] - model.params.kd * state.v[i] + state.bias[i];
    out.tau[i] += std::clamp(t, -lim, lim);
  }
}

void HoldPosePd::compute(const Engine& engine, ControlOutput& out) {
  compute(model_, state_, engine, out);
  double e = 0;
  for (int i : model_.dofs) e += state_.dq[i] * state_.dq[i];
  last_error_norm_ = std::sqrt(e);
}

void HoldPosePd::signal_names(std::vector<std::string>& names) const {
  names.push_back("hold_error_rad");
}
void HoldPosePd::signals(std::vector<double>& values) const {
  values.push_back(last_error_norm_);
}

}  // namespace stance
