#include "control/ankle_strategy.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace stance {

AnkleStrategy::AnkleStrategy(const AnkleStrategyParams& params, const ControllerContext&,
                             const Engine& engine) {
  model_.params = params;
  model_.heel_body = engine.require_body(params.heel_body);
  for (const auto& n : params.heel_dofs) model_.heel_dofs.push_back(engine.require_dof(n));
  for (const auto& n : params.toe_dofs) model_.toe_dofs.push_back(engine.require_dof(n));
  if (params.forward_axis.norm() < 1e-9)
    throw InputError("ankle_strategy.forward_axis: must be a non-zero vector");
  model_.axis = params.forward_axis.normalized();
  if (params.derivative != "velocity" && params.derivative != "per_step")
    throw InputError("ankle_strategy.derivative: expected velocity or per_step, found '" +
                     params.derivative + "'");
  model_.per_step = params.derivative == "per_step";
  double mass = params.supported_mass > 0 ? params.supported_mass : engine.total_mass();
  if (!model_.heel_dofs.empty())
    model_.foot_weight = mass * engine.gravity().norm() / model_.heel_dofs.size();
  for (const AnkleBand* b : {&params.forward, &params.backward})
    if (b->lower >= b->upper) throw InputError("ankle_strategy: a band needs lower < upper");
  if (params.capture.lower >= params.capture.upper)
    throw InputError("ankle_strategy.capture: needs lower < upper");
  const Eigen::Vector3d g = engine.gravity();
  if (params.capture.gain > 0 && g.norm() < 1e-9)
    throw InputError("ankle_strategy.capture: the capture point needs gravity");
  if (g.norm() >= 1e-9) {
    model_.gravity = g.norm();
    model_.up = -g.normalized();
  }
}

double AnkleStrategy::capture_torque(const AnkleCaptureTerm& c, double xi) {
  double tau = 0;
  if (xi < c.lower) tau = c.gain * (c.lower - xi);
  if (xi > c.upper) tau = -c.gain * (xi - c.upper);
  return std::clamp(tau, -c.max_torque, c.max_torque);
}

void AnkleStrategy::measure(const Model& model, const Engine& engine, double& offset, double& rate,
                            double& heel_point) {
  BodyPose heel = engine.body_pose(model.heel_body);
  Eigen::Vector3d point = heel.pos + heel.quat * model.params.heel_point;
  heel_point = model.axis.dot(point);
  offset = model.axis.dot(engine.com()) - heel_point;
  // velocity of the heel point: v_origin + w x (point - origin)
  Eigen::Matrix<double, 6, 1> tw = engine.body_velocity(model.heel_body);
  Eigen::Vector3d v_point = tw.tail<3>() + tw.head<3>().cross(point - heel.pos);
  rate = model.axis.dot(engine.com_velocity() - v_point);
}

void AnkleStrategy::compute(const Model& model, State& s, const Engine& engine,
                            ControlOutput& out) {
  double rate = 0;
  measure(model, engine, s.offset, rate, s.heel_point);
  const AnkleCaptureTerm& capture = model.params.capture;
  s.capture_torque = 0;
  if (capture.gain > 0) {
    // the linear inverted pendulum's capture point, from the COM's height over the heel point
    const BodyPose heel = engine.body_pose(model.heel_body);
    const Eigen::Vector3d point = heel.pos + heel.quat * model.params.heel_point;
    const double height = std::max(0.05, model.up.dot(engine.com() - point));
    s.capture_point = s.offset + rate / std::sqrt(model.gravity / height);
    if (model.params.enabled) s.capture_torque = capture_torque(capture, s.capture_point);
  }
  if (model.per_step) rate = s.first ? 0.0 : (s.offset - s.prev_offset);
  s.rate = rate;
  s.first = false;
  s.band = 0;
  const AnkleBand* band = nullptr;
  const AnkleStrategyParams& p = model.params;
  if (s.offset > p.forward.lower && s.offset < p.forward.upper) {
    band = &p.forward;
    s.band = 1;
  } else if (s.offset > p.backward.lower && s.offset < p.backward.upper) {
    band = &p.backward;
    s.band = -1;
  }
  if (band && p.enabled) {
    double heel = -band->k1 * s.offset - band->kd * rate;
    double toe = -band->k2 * s.offset - band->kd * rate;
    if (band->ramp > 0) {
      double depth = std::abs(band->lower) < std::abs(band->upper) ? s.offset - band->lower
                                                                   : band->upper - s.offset;
      double w = std::min(1.0, depth / band->ramp);
      heel *= w;
      toe *= w;
    }
    if (band->tip_lever > 0) {
      // past this moment the foot pivots about its edge instead of pushing the body
      double limit = model.foot_weight * band->tip_lever;
      heel = std::clamp(heel, -limit, limit);
      toe = std::clamp(toe, -limit, limit);
    }
    for (int i : model.heel_dofs) out.tau[i] += heel;
    for (int i : model.toe_dofs) out.tau[i] += toe;
  }
  for (int i : model.heel_dofs) out.tau[i] += s.capture_torque;
  s.prev_offset = s.offset;
}

void AnkleStrategy::reset_state(State& s, const Engine&) const {
  s = State{};
}

void AnkleStrategy::compute_step(State& s, const Engine& engine, ControlOutput& out) const {
  compute(model_, s, engine, out);
  s.max_abs_offset = std::max(s.max_abs_offset, std::abs(s.offset));
  s.abs_offset_sum += std::abs(s.offset);
  ++s.samples;
}

void AnkleStrategy::signal_names(std::vector<std::string>& names) const {
  names.push_back("ankle_offset_m");
  names.push_back("ankle_offset_rate");
  names.push_back("ankle_band");
  names.push_back("ankle_heel_point_m");
  names.push_back("ankle_capture_point_m");
  names.push_back("ankle_capture_torque_nm");
}
void AnkleStrategy::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.offset);
  values.push_back(s.rate);
  values.push_back(s.band);
  values.push_back(s.heel_point);
  values.push_back(s.capture_point);
  values.push_back(s.capture_torque);
}
void AnkleStrategy::add_metrics(const ControllerState& state, nlohmann::json& metrics) const {
  const State& s = cast(state);
  metrics["max_com_offset_m"] = s.max_abs_offset;
  metrics["mean_abs_ankle_offset_m"] = s.samples ? s.abs_offset_sum / s.samples : 0.0;
}

}  // namespace stance
