#include "control/hold_pose_pd.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace stance {

HoldPosePd::HoldPosePd(const HoldPosePdParams& params, const ControllerContext&,
                       const Engine& engine) {
  model_.params = params;
  if (params.dofs.empty()) {
    for (int i = 0; i < engine.nv(); ++i)
      if (!engine.dof_is_root(i)) model_.dofs.push_back(i);
  } else {
    for (const auto& name : params.dofs) model_.dofs.push_back(engine.require_dof(name));
  }
  // named targets: hinge/slide dofs map straight onto q
  for (const auto& [name, value] : params.target) {
    int dof = engine.require_dof(name);
    const JointInfo& j = engine.joint(engine.dof_joint(dof));
    if (j.type != JointType::kHinge && j.type != JointType::kSlide)
      throw InputError("hold_pose_pd.target: '" + name + "' is not a hinge or slide dof");
    model_.targets.emplace_back(j.qpos_adr, value);
  }
}

bool HoldPosePd::keeps_state_of(const Controller& previous) const {
  const auto* p = dynamic_cast<const HoldPosePd*>(&previous);
  return p && p->model_.targets == model_.targets;
}

void HoldPosePd::reset_state(State& s, const Engine& engine) const {
  s.q_target.resize(engine.nq());
  s.q.resize(engine.nq());
  s.v.resize(engine.nv());
  s.dq.resize(engine.nv());
  s.bias.setZero(engine.nv());
  engine.get_positions(s.q_target);
  for (const auto& [adr, value] : model_.targets) s.q_target[adr] = value;
  s.last_error_norm = 0;
}

void HoldPosePd::compute_step(State& s, const Engine& engine, ControlOutput& out) const {
  const HoldPosePdParams& p = model_.params;
  engine.get_positions(s.q);
  engine.get_velocities(s.v);
  engine.difference_positions(s.q_target, s.q, s.dq);
  if (p.compensate_bias) engine.bias_forces(s.bias);
  const double lim = p.max_torque;
  for (int i : model_.dofs) {
    // a kept State may hold the bias of a model that compensated it
    const double bias = p.compensate_bias ? s.bias[i] : 0.0;
    double t = -p.kp * s.dq[i] - p.kd * s.v[i] + bias;
    out.tau[i] += std::clamp(t, -lim, lim);
  }
  double e = 0;
  for (int i : model_.dofs) e += s.dq[i] * s.dq[i];
  s.last_error_norm = std::sqrt(e);
}

void HoldPosePd::signal_names(std::vector<std::string>& names) const {
  names.push_back("hold_error_rad");
}
void HoldPosePd::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.last_error_norm);
}

}  // namespace stance
