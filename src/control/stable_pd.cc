#include "control/stable_pd.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace stance {

JointPdModel make_joint_pd_model(const JointPdParams& params, const Engine& engine) {
  JointPdModel m;
  m.params = params;
  const int nv = engine.nv();
  m.kp = Eigen::VectorXd::Constant(nv, params.kp);
  m.kd = Eigen::VectorXd::Constant(nv, params.kd);
  for (const auto& [name, value] : params.kp_dofs) {
    if (value < 0) throw InputError("kp_dofs." + name + ": must be >= 0");
    m.kp[engine.require_dof(name)] = value;
  }
  for (const auto& [name, value] : params.kd_dofs) {
    if (value < 0) throw InputError("kd_dofs." + name + ": must be >= 0");
    m.kd[engine.require_dof(name)] = value;
  }
  for (const auto& name : params.free_dofs) {
    int i = engine.require_dof(name);
    m.kp[i] = m.kd[i] = 0;
  }
  for (int i = 0; i < nv; ++i)
    if (engine.dof_is_root(i)) m.kp[i] = m.kd[i] = 0;
  for (const auto& [name, value] : params.target) {
    int dof = engine.require_dof(name);
    const JointInfo& j = engine.joint(engine.dof_joint(dof));
    if (j.type != JointType::kHinge && j.type != JointType::kSlide)
      throw InputError("target: '" + name + "' is not a hinge or slide dof");
    m.targets.emplace_back(j.qpos_adr, value);
  }
  for (const auto& name : params.planner_dofs) {
    const JointInfo& j = engine.joint(engine.dof_joint(engine.require_dof(name)));
    if (j.type != JointType::kHinge && j.type != JointType::kSlide)
      throw InputError("planner_dofs: '" + name + "' is not a hinge or slide dof");
    m.planner_qpos.push_back(j.qpos_adr);
  }
  m.scalar_gains_only = true;
  for (int i = 0; i < nv; ++i) {
    if (m.kp[i] == 0 && m.kd[i] == 0) continue;
    const JointInfo& j = engine.joint(engine.dof_joint(i));
    if (j.type != JointType::kHinge && j.type != JointType::kSlide) {
      m.scalar_gains_only = false;
      m.scalar_dofs.clear();
      break;
    }
    m.scalar_dofs.emplace_back(i, j.qpos_adr);
  }
  return m;
}

void StablePdState::resize(int nq, int nv) {
  q_target.resize(nq);
  q_planned.resize(nq);
  q.resize(nq);
  q_pred.resize(nq);
  for (Eigen::VectorXd* x : {&v, &err, &tau}) x->setZero(nv);
  solve.resize(nv);
}

namespace {
// err = (q + v h) (-) q_target: per dof when only hinges and slides have gains (the other
// dofs' errors are multiplied by zero gains), else on the configuration manifold
void predicted_error(const JointPdModel& model, StablePdState& s, const Engine& engine, double h) {
  if (model.scalar_gains_only) {
    s.err.setZero();
    for (const auto& [dof, adr] : model.scalar_dofs)
      s.err[dof] = s.q[adr] + s.v[dof] * h - s.q_target[adr];
    return;
  }
  if (h != 0) {
    engine.integrate_positions(s.q, s.v, h, s.q_pred);
    engine.difference_positions(s.q_target, s.q_pred, s.err);
  } else {
    engine.difference_positions(s.q_target, s.q, s.err);
  }
}

void add_clamped(const JointPdModel& model, const Eigen::VectorXd& tau, ControlOutput& out) {
  const double lim = model.params.max_torque;
  if (lim > 0)
    out.tau += tau.cwiseMax(-lim).cwiseMin(lim);
  else
    out.tau += tau;
}
}  // namespace

void compute_stable_pd(const JointPdModel& model, StablePdState& s, const Engine& engine,
                       ControlOutput& out) {
  engine.get_positions(s.q);
  engine.get_velocities(s.v);
  // err = q + v dt - q_target, on the configuration manifold; the target velocity is zero
  predicted_error(model, s, engine, engine.timestep());
  stable_pd_torque(engine, model.kp, model.kd, s.err, s.v, nullptr, model.params.constraint_forces,
                   s.solve, s.tau);
  add_clamped(model, s.tau, out);
}

void compute_plain_pd(const JointPdModel& model, StablePdState& s, const Engine& engine,
                      ControlOutput& out) {
  engine.get_positions(s.q);
  engine.get_velocities(s.v);
  predicted_error(model, s, engine, 0);
  s.tau.noalias() = -model.kp.cwiseProduct(s.err);
  s.tau.noalias() -= model.kd.cwiseProduct(s.v);
  add_clamped(model, s.tau, out);
}

template <bool kStable>
JointPd<kStable>::JointPd(const JointPdParams& params, const ControllerContext&,
                          const Engine& engine)
    : model_(make_joint_pd_model(params, engine)) {}

template <bool kStable>
bool JointPd<kStable>::keeps_state_of(const Controller& previous) const {
  const auto* p = dynamic_cast<const JointPd*>(&previous);
  return p && p->model_.targets == model_.targets;
}

template <bool kStable>
void JointPd<kStable>::reset_state(State& s, const Engine& engine) const {
  s.resize(engine.nq(), engine.nv());
  engine.get_positions(s.q_target);
  for (const auto& [adr, value] : model_.targets) s.q_target[adr] = value;
  s.last_error_norm = 0;
  s.error_sq_sum = 0;
  s.error_samples = 0;
}

template <bool kStable>
void JointPd<kStable>::compute_with(State& s, const Engine& engine, const double* correction,
                                    ControlOutput& out) const {
  // the planner's offsets go on a copy of the target, swapped in while computing
  const bool planned = correction && !model_.planner_qpos.empty();
  if (planned) {
    s.q_planned = s.q_target;
    for (size_t i = 0; i < model_.planner_qpos.size(); ++i)
      s.q_planned[model_.planner_qpos[i]] += correction[i];
    s.q_target.swap(s.q_planned);
  }
  if constexpr (kStable)
    compute_stable_pd(model_, s, engine, out);
  else
    compute_plain_pd(model_, s, engine, out);
  if (planned) s.q_target.swap(s.q_planned);
  // tracking error of the controlled dofs, now (not predicted)
  double e = 0;
  int n = 0;
  predicted_error(model_, s, engine, 0);
  for (int i = 0; i < s.err.size(); ++i)
    if (model_.kp[i] > 0) {
      e += s.err[i] * s.err[i];
      ++n;
    }
  s.last_error_norm = n ? std::sqrt(e / n) : 0;
  s.error_sq_sum += e / std::max(n, 1);
  ++s.error_samples;
}

template <bool kStable>
void JointPd<kStable>::correction_dims(std::vector<CorrectionDim>& dims) const {
  for (const auto& name : model_.params.planner_dofs)
    dims.push_back({name, model_.params.planner_scale, "rad or m"});
}

template <bool kStable>
void JointPd<kStable>::signal_names(std::vector<std::string>& names) const {
  names.push_back(std::string(type()) + "_rms_error_rad");
}
template <bool kStable>
void JointPd<kStable>::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.last_error_norm);
}
template <bool kStable>
void JointPd<kStable>::add_metrics(const ControllerState& state, nlohmann::json& metrics) const {
  const State& s = cast(state);
  metrics[std::string(type()) + "_rms_error_rad"] =
      s.error_samples ? std::sqrt(s.error_sq_sum / s.error_samples) : 0.0;
}

template class JointPd<true>;
template class JointPd<false>;

}  // namespace stance
