#include "sim/simulation.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <set>
#include <sstream>
#include <typeinfo>

#include "control/standing_pose.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/executor.h"
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/world_spec.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "sim/observers.h"

namespace stance {

nlohmann::json RunResult::to_json() const {
  nlohmann::json j;
  j["scenario"] = scenario;
  j["engine"] = engine;
  j["seed"] = seed;
  j["sim_time"] = sim_time;
  j["fell"] = fell;
  j["fall_time"] = fall_time ? nlohmann::json(*fall_time) : nlohmann::json(nullptr);
  if (fell) j["fall_reason"] = fall_reason;
  j["diverged"] = diverged;
  if (diverged) j["divergence"] = divergence;
  j["interrupted"] = interrupted;
  j["wall_time_s"] = wall_time_s;
  j["steps"] = steps;
  j["metrics"] = metrics;
  if (!expectation.is_null()) j["expectation"] = expectation;
  return j;
}

RunResult RunResult::from_json(const nlohmann::json& j) {
  RunResult r;
  r.scenario = j.at("scenario").get<std::string>();
  r.engine = j.at("engine").get<std::string>();
  r.seed = j.at("seed").get<int>();
  r.sim_time = j.at("sim_time").get<double>();
  r.fell = j.at("fell").get<bool>();
  if (!j.at("fall_time").is_null()) r.fall_time = j.at("fall_time").get<double>();
  r.fall_reason = j.value("fall_reason", "");
  r.diverged = j.at("diverged").get<bool>();
  r.divergence = j.value("divergence", "");
  r.interrupted = j.at("interrupted").get<bool>();
  r.wall_time_s = j.at("wall_time_s").get<double>();
  r.steps = j.at("steps").get<long>();
  r.metrics = j.at("metrics");
  r.expectation = j.value("expectation", nlohmann::json());
  return r;
}

bool is_wall_clock_metric(const std::string& key) {
  auto ends_with = [&](std::string_view suffix) {
    return key.size() >= suffix.size() &&
           key.compare(key.size() - suffix.size(), suffix.size(), suffix.data()) == 0;
  };
  return key == "realtime_factor" || key == "wall_time_s" || key == "compute_s_per_sim_s" ||
         key == "cpu_s_per_sim_s" || ends_with("_time_ms") || ends_with("_ns_per_step");
}

nlohmann::json without_wall_clock(const nlohmann::json& metrics) {
  if (!metrics.is_object()) return metrics;
  nlohmann::json out = nlohmann::json::object();
  for (auto it = metrics.begin(); it != metrics.end(); ++it)
    if (!is_wall_clock_metric(it.key())) out[it.key()] = without_wall_clock(it.value());
  return out;
}

// ---- the loop
Simulation::~Simulation() = default;

void Simulation::start_run() {
  Engine& e = *engine_;
  out_.resize(e.nv(), e.nu());
  correction_.setZero(model_->planner ? model_->planner->dimensions.size() : 0);
  progress_ = RunProgress{};
  progress_.velocity_sent = out_.dof_velocity;
  progress_.dof_steps_at_limit.setZero(e.nv());
  progress_.dof_peak_limit_ratio.setZero(e.nv());
  states_.clear();
  for (const auto& c : controllers_) states_.push_back(c->make_state(e));
  progress_.com0 = progress_.com_last = e.com();
  progress_.com_height0 = model_->up.dot(progress_.com0) - model_->scenario.fall.ground_height;
  progress_.min_com_height = progress_.com_height0;
}

void Simulation::reset() {
  Engine& e = *engine_;
  e.restore_state(model_->initial);
  e.forward();
  // release velocity servos from an earlier run
  send_velocity_commands(Eigen::VectorXd::Constant(e.nv(), std::nan("")));
  out_.resize(e.nv(), e.nu());
  progress_ = RunProgress{};
  progress_.velocity_sent = out_.dof_velocity;
  progress_.dof_steps_at_limit.setZero(e.nv());
  progress_.dof_peak_limit_ratio.setZero(e.nv());
  for (size_t i = 0; i < controllers_.size(); ++i) controllers_[i]->reset(*states_[i], e);
  progress_.com0 = progress_.com_last = e.com();
  progress_.com_height0 = model_->up.dot(progress_.com0) - model_->scenario.fall.ground_height;
  progress_.min_com_height = progress_.com_height0;
}

void Simulation::reset_controllers() {
  for (size_t i = 0; i < controllers_.size(); ++i) controllers_[i]->reset(*states_[i], *engine_);
}

void Simulation::send_velocity_commands(const Eigen::VectorXd& commands) {
  // pass on the commands that changed (NaN releases a dof)
  Eigen::VectorXd& sent = progress_.velocity_sent;
  for (int i = 0; i < commands.size(); ++i) {
    double now = commands[i], before = sent[i];
    if (now != before && !(std::isnan(now) && std::isnan(before))) {
      engine_->set_dof_velocity_command(i, now);
      sent[i] = now;
    }
  }
}

void Simulation::set_planner_params(const PlannerParams& params) {
  if (!model_->plans)
    throw InputError("planner: this run does not plan; enable it in the scenario");
  const CorrectionModel& old = *model_->planner;
  if (params.timestep != old.params.timestep)
    throw InputError("planner.timestep: the rollouts' step is fixed when the run is made");
  if (params.calm_timestep != old.params.calm_timestep)
    throw InputError(
        "planner.calm_timestep: the calm rollouts' step is fixed when the run is made");
  if (params.control_every != old.params.control_every)
    throw InputError("planner.control_every: fixed when the run is made");
  if (params.residual_dofs != old.params.residual_dofs)
    throw InputError("planner.residual_dofs: the dimensions are fixed when the run is made");
  if (params.objective != old.params.objective)
    throw InputError("planner.objective: the objective is fixed when the run is made");
  check_planner_params(params, "");
  auto planner = std::make_shared<CorrectionModel>(old);
  planner->params = params;
  for (PlanDimension& d : planner->dimensions)
    if (d.controller < 0) d.scale = params.residual_torque;
  auto model = std::make_shared<SimulationModel>(*model_);
  model->planner = planner;
  model_ = std::move(model);
  if (planner_) retired_planners_cpu_s_ += planner_->own_threads_cpu_seconds();
  planner_.reset();
  if (params.enabled) {
    planner_ = model_->planner_maker->make_source(model_->planner);
    progress_.plan.next_plan = time();  // plan at the next step, with the new parameters
  } else {
    progress_.plan.knots.resize(0, 0);  // no correction from now on
  }
}

// the one place torques meet the model's limits: the peak of |requested| / limit is measured,
// and the torques are clamped to the limits when the model says so. A controller that drives
// actuators (LQR) asks for moment^T ctrl besides: measured with the torques; MuJoCo clamps the
// controls to the actuators' ranges.
void Simulation::limit_torques() {
  const Eigen::VectorXd& limit = model_->force_limit;
  RunProgress& s = progress_;
  bool controls = out_.ctrl_used && engine_->nu() > 0 && ctrl_measurable_;
  if (controls) {
    ctrl_moment_.resize(engine_->nu(), engine_->nv());  // allocates on the first call only
    try {
      engine_->actuator_moment(ctrl_moment_);
    } catch (const InputError&) {  // an actuator without a fixed gain (a muscle): not measured
      ctrl_measurable_ = controls = false;
    }
  }
  if (controls) {
    ctrl_request_.resize(engine_->nv());
    ctrl_request_.noalias() = ctrl_moment_.transpose() * out_.ctrl;
  }
  bool clamped = false, at_limit = false;
  for (int i = 0; i < out_.tau.size(); ++i) {
    if (std::isinf(limit[i])) continue;
    const double tau = out_.tau[i];
    const double request = controls ? tau + ctrl_request_[i] : tau;
    const double ratio = std::abs(request) / std::max(limit[i], 1e-12);
    at_limit = at_limit || ratio >= 1;
    if (ratio >= 1) ++s.dof_steps_at_limit[i];
    s.dof_peak_limit_ratio[i] = std::max(s.dof_peak_limit_ratio[i], ratio);
    if (ratio > s.peak_limit_ratio) {
      s.peak_limit_ratio = ratio;
      s.peak_limit_dof = i;
    }
    const double tau_ratio = controls ? std::abs(tau) / std::max(limit[i], 1e-12) : ratio;
    if (model_->clamp_torques && tau_ratio > 1) {
      out_.tau[i] = std::clamp(tau, -limit[i], limit[i]);
      clamped = true;
    }
  }
  if (clamped) ++s.clamped_steps;
  if (at_limit) ++s.steps_at_limit;
}

// the planner (when it is time), then the controllers with their share of its correction, then
// the residual torques
bool Simulation::compute_controls() {
  Engine& e = *engine_;
  const CorrectionModel* pm = model_->planner.get();
  // a rollout of a multi-rate planner holds its last output (restore makes it compute)
  if (held_steps_left_ > 0) {
    --held_steps_left_;
    return true;
  }
  if (model_->rollout && pm) held_steps_left_ = pm->params.control_every - 1;
  out_.clear();
  if (pm) {
    if (planner_ && e.time() + 1e-12 >= progress_.plan.next_plan) planner_->plan(*this);
    progress_.plan.evaluate(e.time(), correction_);
    for (size_t d = 0; d < pm->dimensions.size(); ++d) correction_[d] *= pm->dimensions[d].scale;
  }
  for (size_t i = 0; i < controllers_.size(); ++i) {
    // a controller that offers correction dimensions gets its share of the correction
    const int first = pm ? pm->controller_first[i] : -1;
    const double* correction = first >= 0 ? correction_.data() + first : nullptr;
    const auto t0 = controller_seconds_ ? std::chrono::steady_clock::now()
                                        : std::chrono::steady_clock::time_point{};
    if (correction)
      controllers_[i]->as<Correctable>()->compute_corrected(*states_[i], e, correction, out_);
    else
      controllers_[i]->compute(*states_[i], e, out_);
    if (controller_seconds_)
      (*controller_seconds_)[i] +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!check_output(i, e.time())) return false;
  }
  out_.tau *= model_->scenario.torque_scale;
  if (pm)
    for (size_t d = 0; d < pm->dimensions.size(); ++d)
      if (pm->dimensions[d].dof >= 0) out_.tau[pm->dimensions[d].dof] += correction_[d];
  if (pm && !out_.tau.allFinite()) {
    progress_.diverged = true;
    progress_.diverged_at = e.time();
    progress_.divergence =
        fmt::format("the planner's correction is non-finite at t={:.6f} s", e.time());
    return false;
  }
  return true;
}

void ExternalForces::apply(Engine& engine) const {
  const double t = engine.time();
  for (const Push& p : pushes)
    if (t < p.until_s && p.body >= 0)
      engine.apply_external_force(p.body, Eigen::Vector3d(p.force.data()), engine.body_com(p.body));
  if (spring.body < 0) return;
  const BodyPose pose = engine.body_pose(spring.body);
  const Eigen::Vector3d arm = pose.quat * Eigen::Vector3d(spring.point_in_body.data());
  const Eigen::Matrix<double, 6, 1> twist = engine.body_velocity(spring.body);
  const Eigen::Vector3d velocity = twist.tail<3>() + twist.head<3>().cross(arm);
  const Eigen::Vector3d force =
      spring.stiffness * (Eigen::Vector3d(spring.target.data()) - pose.pos - arm) -
      spring.damping * velocity;
  engine.apply_external_force(spring.body, force, pose.pos + arm);
}

bool Simulation::step() {
  Engine& e = *engine_;
  RunProgress& s = progress_;
  if (s.diverged) return false;
  e.forward();
  const double t = e.time();
  if (!compute_controls()) return false;
  limit_torques();
  e.set_generalized_forces(out_.tau);
  if (out_.ctrl_used) e.set_controls(out_.ctrl);
  if (out_.dof_velocity_used) send_velocity_commands(out_.dof_velocity);
  for (const auto& push : model_->pushes)
    if (push.p.active_at(t)) e.apply_external_force(push.body, push.p.force, push_point(e, push));
  s.external.apply(e);
  // torque statistics over the controlled (non-zero) entries
  for (int i = 0; i < out_.tau.size(); ++i) {
    double tau = out_.tau[i];
    if (tau == 0) continue;
    s.torque_sq_sum += tau * tau;
    ++s.torque_samples;
    s.max_abs_torque = std::max(s.max_abs_torque, std::abs(tau));
  }
  e.step();
  ++s.steps;
  if (!e.state_is_finite()) {
    // the engine may have reset itself: report the time the step started
    s.diverged = true;
    s.diverged_at = t;
    std::string w = e.last_warning();
    s.divergence = w.empty() ? fmt::format("non-finite state at t={:.6f} s", t) : w;
    return false;
  }
  e.forward();
  detect_fall();
  for (StepObserver* o : observers_) o->on_step(*this);
  return true;
}

bool Simulation::check_output(size_t i, double t) {
  // checked before the engine sees it: MuJoCo would reset itself on a NaN force and go on
  const bool tau_ok = out_.tau.allFinite(), ctrl_ok = !out_.ctrl_used || out_.ctrl.allFinite();
  if (tau_ok && ctrl_ok) return true;
  RunProgress& s = progress_;
  s.diverged = true;
  s.diverged_at = t;
  std::string where;
  if (!tau_ok) {
    int k = 0;
    while (k < out_.tau.size() && std::isfinite(out_.tau[k])) ++k;
    where = fmt::format("torque {} on dof '{}'", out_.tau[k], engine_->dof_name(k));
  } else {
    int k = 0;
    while (k < out_.ctrl.size() && std::isfinite(out_.ctrl[k])) ++k;
    where = fmt::format("control {} on actuator '{}'", out_.ctrl[k], engine_->actuator_name(k));
  }
  s.divergence = fmt::format("controller {} ('{}') output a non-finite {} at t={:.6f} s", i,
                             controllers_[i]->type(), where, t);
  return false;
}

void Simulation::detect_fall() {
  Engine& e = *engine_;
  RunProgress& s = progress_;
  const FallCriterion& fall = model_->scenario.fall;
  const Eigen::Vector3d com = e.com();
  if (com.allFinite()) s.com_last = com;
  double h = model_->up.dot(com) - fall.ground_height;
  s.min_com_height = std::min(s.min_com_height, h);
  if (!fall.enabled || s.fell) return;
  // a controller that tracks a reference judges the fall against it (a crouch in a clip is no
  // fall); the scenario's criterion applies when no controller has an opinion
  bool judged = false;
  for (size_t i = 0; i < controllers_.size() && !s.fell; ++i) {
    const FallJudge* judge = controllers_[i]->as<FallJudge>();
    const FallVerdict v =
        judge ? judge->fall_verdict(*states_[i], e, s.fall_reason) : FallVerdict::kNoOpinion;
    if (v == FallVerdict::kNoOpinion) continue;
    judged = true;
    if (v == FallVerdict::kFell) {
      s.fell = true;
      s.fall_time = e.time();
    }
  }
  if (judged) {
    if (s.fell) snapshot_controller_metrics();
    return;
  }
  if (h < fall.com_height_fraction * s.com_height0) {
    s.fell = true;
    s.fall_time = e.time();
    s.fall_reason = fmt::format("COM height {:.3f} m below {:.0f}% of its start {:.3f} m", h,
                                100 * fall.com_height_fraction, s.com_height0);
  } else if (!fall.allowed_contacts.empty()) {
    for (int i = 0, n = e.num_contacts(); i < n && !s.fell; ++i) {
      Contact c = e.contact(i);
      int other = c.body1 < 0 ? c.body2 : (c.body2 < 0 ? c.body1 : -1);
      if (other >= 0 && !model_->allowed_contact[other]) {
        s.fell = true;
        s.fall_time = e.time();
        s.fall_reason = "'" + e.body_name(other) + "' touched the ground";
      }
    }
  }
  if (s.fell) snapshot_controller_metrics();
}

// once per run, on the step that detects the fall (the only allocation of a step)
void Simulation::snapshot_controller_metrics() {
  nlohmann::json m = nlohmann::json::object();
  add_controller_metrics(m);
  progress_.controller_metrics_at_fall = m.dump();
}

bool Simulation::done() const {
  const RunProgress& s = progress_;
  if (s.diverged || s.steps >= model_->total_steps) return true;
  // a while past a fall is enough to see it; the rest is lying on the floor
  return s.fell && model_->stop_after_fall_s >= 0 &&
         engine_->time() > s.fall_time + model_->stop_after_fall_s;
}

void Simulation::signals(std::vector<double>& values) const {
  for (size_t i = 0; i < controllers_.size(); ++i)
    if (const Reporting* r = controllers_[i]->as<Reporting>()) r->signals(*states_[i], values);
}

void Simulation::add_controller_metrics(nlohmann::json& metrics) const {
  for (size_t i = 0; i < controllers_.size(); ++i)
    if (const Reporting* r = controllers_[i]->as<Reporting>()) r->add_metrics(*states_[i], metrics);
}

// per dof that reached its limit: its share of the steps at it and its largest request over it;
// and the three most often at it ("which joint is too weak"), ties in dof order
void Simulation::add_limits_per_dof(nlohmann::json& torque_limit) const {
  const RunProgress& s = progress_;
  nlohmann::json& per_dof = torque_limit["per_dof"] = nlohmann::json::object();
  std::vector<int> reached;
  for (int i = 0; i < s.dof_steps_at_limit.size(); ++i) {
    if (s.dof_steps_at_limit[i] == 0) continue;
    reached.push_back(i);
    per_dof[engine_->dof_name(i)] = {
        {"share_at_limit", s.steps > 0 ? double(s.dof_steps_at_limit[i]) / s.steps : 0.0},
        {"peak_request_ratio", s.dof_peak_limit_ratio[i]}};
  }
  if (reached.empty()) return;
  std::stable_sort(reached.begin(), reached.end(),
                   [&](int a, int b) { return s.dof_steps_at_limit[a] > s.dof_steps_at_limit[b]; });
  nlohmann::json& most = torque_limit["most_at_limit"] = nlohmann::json::array();
  for (size_t k = 0; k < std::min<size_t>(3, reached.size()); ++k)
    most.push_back(engine_->dof_name(reached[k]));
}

RunResult Simulation::result() const {
  const Engine& e = *engine_;
  const RunProgress& s = progress_;
  RunResult r;
  r.scenario = model_->scenario.name;
  r.engine = std::string(e.engine_name());
  r.seed = model_->scenario.seed;
  r.steps = s.steps;
  r.sim_time = s.diverged ? s.diverged_at : e.time();
  r.fell = s.fell;
  if (s.fell) {
    r.fall_time = s.fall_time;
    r.fall_reason = s.fall_reason;
  }
  // a body lying on the floor may tangle its joints until the state blows up: that run fell, and
  // its divergence is a footnote to the fall, not an error of the run. A fall found less than
  // kBlowUpAfterFallS before the blow-up is the blow-up's own start (the COM flung off in a few
  // steps; a falling body takes longer to come down and tangle): that run diverged.
  constexpr double kBlowUpAfterFallS = 0.1;
  const bool diverged_after_fall =
      s.diverged && s.fell && s.diverged_at >= s.fall_time + kBlowUpAfterFallS;
  r.diverged = s.diverged && !diverged_after_fall;
  r.divergence = s.divergence;
  if (diverged_after_fall)
    r.fall_reason += fmt::format(" (then diverged {:.3f} s later: {})", s.diverged_at - s.fall_time,
                                 s.divergence);
  nlohmann::json& m = r.metrics;
  m["torque_rms"] = s.torque_samples ? std::sqrt(s.torque_sq_sum / s.torque_samples) : 0.0;
  m["max_abs_torque"] = s.max_abs_torque;
  m["min_com_height_m"] = s.min_com_height;
  m["com_height_start_m"] = s.com_height0;
  // a diverged engine's state is not finite: the metrics stop at its last finite step
  m["com_displacement_m"] = ((s.diverged ? s.com_last : e.com()) - s.com0).norm();
  m["realtime_factor"] = 0.0;
  int survived = 0;
  for (const auto& push : model_->pushes) {
    double end = push.p.start + push.p.duration;
    if (end <= r.sim_time && (!s.fell || s.fall_time > end + 2.0)) ++survived;
  }
  if (model_->force_limit.size() > 0 && model_->force_limit.array().isFinite().any()) {
    nlohmann::json& tl = m["torque_limit"];
    tl["peak_ratio"] = s.peak_limit_ratio;
    tl["dof"] = s.peak_limit_dof >= 0 ? e.dof_name(s.peak_limit_dof) : "";
    tl["limit"] = s.peak_limit_dof >= 0 ? model_->force_limit[s.peak_limit_dof] : 0.0;
    tl["clamping"] = model_->clamp_torques;
    tl["clamped_steps"] = s.clamped_steps;
    tl["steps_at_limit"] = s.steps_at_limit;
    tl["share_at_limit"] = s.steps > 0 ? static_cast<double>(s.steps_at_limit) / s.steps : 0.0;
    add_limits_per_dof(tl);
  }
  m["pushes_applied"] = static_cast<int>(model_->pushes.size());
  m["pushes_survived"] = survived;
  // a state that blew up after the fall says nothing of the walk: its metrics are the fall's
  if (diverged_after_fall && !s.controller_metrics_at_fall.empty())
    m.update(nlohmann::json::parse(s.controller_metrics_at_fall));
  else
    add_controller_metrics(m);
  // a success on a model with limits is one within them: an unclamped request over one voids it
  if (!model_->clamp_torques && s.peak_limit_ratio > 1)
    for (auto& [name, metrics] : m.items())
      if (metrics.is_object() && metrics.value("success", false)) {
        metrics["success"] = false;
        metrics["success_voided"] = "torques over the model's limits (torque_limits: off)";
      }
  if (model_->plans) {
    const CorrectionPlan& plan = s.plan;
    nlohmann::json& pm = m["planner"];
    pm["plans"] = plan.plans;
    pm["dimensions"] = model_->planner->dimensions.size();
    pm["mean_cost"] = plan.plans ? plan.cost_sum / plan.plans : 0.0;
    pm["kept_nominal_share"] = plan.plans ? double(plan.kept_nominal) / plan.plans : 0.0;
    pm["rescues"] = plan.rescues;
    pm["steady"] = plan.steady;
    pm["calm"] = plan.calm;
    pm["model_steps_per_sim_s"] = s.steps ? plan.rollout_steps / time() : 0.0;
  }
  return r;
}

double Simulation::run_cpu_seconds() const {
  const double planners =
      retired_planners_cpu_s_ + (planner_ ? planner_->own_threads_cpu_seconds() : 0.0);
  return thread_cpu_seconds() + planners;
}

RunResult Simulation::run(long max_steps) {
  auto wall0 = std::chrono::steady_clock::now();
  const double cpu0 = run_cpu_seconds();
  std::unique_ptr<CsvLog> log;
  std::unique_ptr<ProgressBar> bar;
  if (!run_files_.out_dir.empty()) {
    log = std::make_unique<CsvLog>(run_files_.out_dir);
    add_observer(log.get());
  }
  if (run_files_.progress) {
    bar = std::make_unique<ProgressBar>();
    add_observer(bar.get());
  }
  for (StepObserver* o : observers_) o->on_start(*this);
  bool interrupted = false;
  for (long n = 0; !done() && (max_steps < 0 || n < max_steps); ++n) {
    if (run_files_.interrupt && run_files_.interrupt->load(std::memory_order_relaxed)) {
      interrupted = true;
      break;
    }
    if (!step()) break;
  }
  RunResult r = result();
  r.interrupted = interrupted;
  r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  r.metrics["realtime_factor"] = r.wall_time_s > 0 ? r.sim_time / r.wall_time_s : 0.0;
  r.metrics["compute_s_per_sim_s"] = r.sim_time > 0 ? r.wall_time_s / r.sim_time : 0.0;
  r.metrics["cpu_s_per_sim_s"] = r.sim_time > 0 ? (run_cpu_seconds() - cpu0) / r.sim_time : 0.0;
  if (r.metrics.contains("mocap") && r.metrics["mocap"].is_object())
    for (const char* key : {"compute_s_per_sim_s", "cpu_s_per_sim_s"})
      r.metrics["mocap"][key] = r.metrics[key];
  if (model_->scenario.expect.given)
    r.expectation = evaluate_expectation(model_->scenario.expect, r.to_json());
  for (StepObserver* o : observers_) o->on_finish(*this, r);
  if (log) {
    remove_observer(log.get());
    for (size_t i = 0; i < controllers_.size(); ++i)
      if (const Reporting* r = controllers_[i]->as<Reporting>())
        r->write_outputs(*states_[i], run_files_.out_dir);
    // bytes that are not UTF-8 (a file name's) are written as U+FFFD rather than lost with the file
    write_file_atomically(
        std::filesystem::path(run_files_.out_dir) / "summary.json",
        r.to_json().dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  }
  if (bar) remove_observer(bar.get());
  return r;
}

void Simulation::remove_observer(StepObserver* observer) {
  observers_.erase(std::remove(observers_.begin(), observers_.end(), observer), observers_.end());
}

void Simulation::add_controller(std::shared_ptr<const Controller> controller) {
  states_.push_back(controller->make_state(*engine_));
  controllers_.push_back(std::move(controller));
}

void Simulation::replace_controller(size_t i, std::shared_ptr<const Controller> controller) {
  const bool keep = keeps_state_of(*controller, *controllers_.at(i));
  if (!keep) states_[i] = controller->make_state(*engine_);
  controllers_[i] = std::move(controller);
}

}  // namespace stance
