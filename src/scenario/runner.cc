#include "scenario/runner.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "engine/world_spec.h"

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
  j["wall_time_s"] = wall_time_s;
  j["steps"] = steps;
  j["metrics"] = metrics;
  return j;
}

Perturbation parse_push(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, ',');) parts.push_back(p);
  if (parts.size() != 6)
    throw InputError(fmt::format("--push '{}': expected body,fx,fy,fz,start,duration", text));
  Perturbation p;
  p.body = parts[0];
  double vals[5];
  for (int i = 0; i < 5; ++i) {
    try {
      size_t used = 0;
      vals[i] = std::stod(parts[i + 1], &used);
      if (used != parts[i + 1].size() || !std::isfinite(vals[i])) throw std::invalid_argument("");
    } catch (const std::exception&) {
      throw InputError(fmt::format("--push '{}': '{}' is not a finite number", text, parts[i + 1]));
    }
  }
  p.force = Eigen::Vector3d(vals[0], vals[1], vals[2]);
  p.start = vals[3];
  p.duration = vals[4];
  if (p.start < 0 || p.duration < 0)
    throw InputError(fmt::format("--push '{}': start and duration must be >= 0", text));
  return p;
}

std::unique_ptr<Engine> make_scenario_engine(const Scenario& s, const std::string& engine_name) {
  WorldSpec spec;
  for (const auto& m : s.model) spec.models.push_back({m.file, m.offset});
  if (s.timestep > 0) spec.timestep = s.timestep;
  if (s.gravity.size() == 3)
    spec.gravity = Eigen::Vector3d(s.gravity[0], s.gravity[1], s.gravity[2]);
  if (s.slope_rad != 0) {
    // a slope tilts gravity about the y axis instead of the floor: the walker goes down +x
    Eigen::Vector3d g0 = spec.gravity ? *spec.gravity : Eigen::Vector3d(0, 0, -9.81);
    double g = g0.norm();
    spec.gravity = Eigen::Vector3d(g * std::sin(s.slope_rad), 0, -g * std::cos(s.slope_rad));
  }
  std::unique_ptr<Engine> engine = make_engine(engine_name, spec);
  if (!s.keyframe.empty()) {
    try {
      engine->apply_keyframe(s.keyframe);
    } catch (const InputError& e) {
      throw InputError(fmt::format("keyframe: {}", e.what()));
    }
  }
  for (const auto& [name, value] : s.initial_pose) {
    int dof = engine->dof_index(name);
    if (dof < 0)
      throw InputError(fmt::format("initial_pose: unknown dof '{}'{}", name,
                                   did_you_mean(name, engine->dof_names())));
    engine->set_dof_position(dof, value);
  }
  engine->forward();
  return engine;
}

struct ScenarioRun::Impl {
  // resolved pushes
  struct Push {
    Perturbation p;
    int body;
  };
  std::vector<Push> pushes;
  std::vector<bool> allowed_contact;  // per body
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double com_height0 = 0;
  ControlOutput out;
  Eigen::VectorXd velocity_sent;  // the velocity commands the engine holds, dim nv; NaN: none
  EngineState initial;
  // log
  std::ofstream log;
  long log_every = 1;
  std::vector<std::string> signal_names;
  std::vector<double> signal_values;
  // metrics accumulators
  double torque_sq_sum = 0;
  long torque_samples = 0;
  double max_abs_torque = 0;
  double min_com_height = 1e300;
  Eigen::Vector3d com0 = Eigen::Vector3d::Zero();
};

ScenarioRun::ScenarioRun(const LoadedScenario& loaded, const RunOptions& options)
    : impl_(std::make_unique<Impl>()), scenario_(loaded.scenario), options_(options) {
  if (options_.duration) scenario_.duration = *options_.duration;
  for (const auto& p : options_.extra_pushes) scenario_.perturbations.push_back(p);
  std::string engine_name = options_.engine.empty() ? scenario_.engine : options_.engine;
  if (engine_name != "mujoco" && engine_name != "dart")
    throw InputError(fmt::format("--engine: expected mujoco or dart, found '{}'", engine_name));
  engine_ = make_scenario_engine(scenario_, engine_name);
  Engine& e = *engine_;

  for (size_t i = 0; i < loaded.controllers.size(); ++i) {
    const YAML::Node& node = loaded.controllers[i];
    const ControllerType& type = find_controller_type(node["type"].Scalar());
    ControllerContext ctx{
        {loaded.source},
        fmt::format("controllers[{}]", i),
        static_cast<uint64_t>(scenario_.seed) * 1000003ull + i,
        scenario_.duration,
        [this, engine_name] { return make_scenario_engine(scenario_, engine_name); }};
    try {
      controllers_.push_back(type.make(node, ctx, e));
    } catch (const InputError& err) {
      std::string msg = err.what();
      // name errors from the engine get the controller's place in the file
      if (msg.rfind(loaded.source, 0) != 0)
        msg = located(loaded.source, node.Mark().line + 1, ctx.path + ": " + msg);
      throw InputError(msg);
    }
  }
  // a controller that tracks a clip may start the run on the clip's first frame
  for (const auto& c : controllers_) {
    Eigen::VectorXd q0, v0;
    if (c->initial_state(e, q0, v0)) {
      e.set_positions(q0);
      e.set_velocities(v0);
      e.forward();
    }
  }
  for (const auto& p : scenario_.perturbations) {
    int b = e.body_index(p.body);
    if (b < 0)
      throw InputError(fmt::format("perturbation: unknown body '{}'{}", p.body,
                                   did_you_mean(p.body, e.body_names())));
    impl_->pushes.push_back({p, b});
  }
  impl_->allowed_contact.assign(e.nbody(), false);
  for (const auto& name : scenario_.fall.allowed_contacts) {
    int b = e.body_index(name);
    if (b < 0)
      throw InputError(fmt::format("fall.allowed_contacts: unknown body '{}'{}", name,
                                   did_you_mean(name, e.body_names())));
    impl_->allowed_contact[b] = true;
  }
  // heights are measured along the floor's normal: -gravity, or z when a slope tilts gravity
  Eigen::Vector3d g = e.gravity();
  if (scenario_.slope_rad != 0)
    impl_->up = Eigen::Vector3d::UnitZ();
  else if (g.norm() > 0)
    impl_->up = -g.normalized();
  impl_->out.resize(e.nv(), e.nu());
  impl_->velocity_sent = impl_->out.dof_velocity;
  e.save_state(impl_->initial);
  for (auto& c : controllers_) c->signal_names(impl_->signal_names);
  impl_->signal_values.reserve(impl_->signal_names.size());
  reset();
}

ScenarioRun::~ScenarioRun() = default;

void ScenarioRun::reset() {
  Engine& e = *engine_;
  e.restore_state(impl_->initial);
  e.forward();
  // release velocity servos from an earlier run
  for (int i = 0; i < impl_->velocity_sent.size(); ++i)
    if (!std::isnan(impl_->velocity_sent[i])) e.set_dof_velocity_command(i, std::nan(""));
  impl_->out.resize(e.nv(), e.nu());
  impl_->velocity_sent = impl_->out.dof_velocity;
  for (auto& c : controllers_) c->reset(e);
  impl_->com0 = e.com();
  impl_->com_height0 = impl_->up.dot(impl_->com0) - scenario_.fall.ground_height;
  impl_->min_com_height = impl_->com_height0;
  impl_->torque_sq_sum = 0;
  impl_->torque_samples = 0;
  impl_->max_abs_torque = 0;
  result_ = RunResult{};
  result_.scenario = scenario_.name;
  result_.engine = std::string(e.engine_name());
  result_.seed = scenario_.seed;
}

const ControlOutput& ScenarioRun::last_output() const {
  return impl_->out;
}

bool ScenarioRun::step() {
  Engine& e = *engine_;
  Impl& s = *impl_;
  if (result_.diverged) return false;
  e.forward();
  s.out.clear();
  for (auto& c : controllers_) c->compute(e, s.out);
  s.out.tau *= scenario_.torque_scale;
  e.set_generalized_forces(s.out.tau);
  if (s.out.ctrl_used) e.set_controls(s.out.ctrl);
  if (s.out.dof_velocity_used) {
    // velocity servos: pass on the commands that changed (NaN releases a dof)
    for (int i = 0; i < s.out.dof_velocity.size(); ++i) {
      double now = s.out.dof_velocity[i], before = s.velocity_sent[i];
      if (now != before && !(std::isnan(now) && std::isnan(before))) {
        e.set_dof_velocity_command(i, now);
        s.velocity_sent[i] = now;
      }
    }
  }
  double t = e.time();
  for (const auto& push : s.pushes)
    if (push.p.active_at(t)) e.apply_external_force(push.body, push.p.force, e.body_com(push.body));
  // torque statistics over the controlled (non-zero) entries
  for (int i = 0; i < s.out.tau.size(); ++i) {
    double tau = s.out.tau[i];
    if (tau == 0) continue;
    s.torque_sq_sum += tau * tau;
    ++s.torque_samples;
    s.max_abs_torque = std::max(s.max_abs_torque, std::abs(tau));
  }
  e.step();
  ++result_.steps;
  result_.sim_time = e.time();
  if (!e.state_is_finite()) {
    // the engine may have reset itself: report the time the step started
    result_.sim_time = t;
    result_.diverged = true;
    std::string w = e.last_warning();
    result_.divergence = w.empty() ? fmt::format("non-finite state at t={:.6f} s", t) : w;
    return false;
  }
  return true;
}

RunResult ScenarioRun::run() {
  Engine& e = *engine_;
  Impl& s = *impl_;
  auto wall0 = std::chrono::steady_clock::now();
  std::filesystem::path dir(options_.out_dir);
  if (!options_.out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw InputError(fmt::format("--out {}: {}", options_.out_dir, ec.message()));
    s.log.open(dir / "log.csv");
    if (!s.log) throw InputError(fmt::format("--out {}: cannot write log.csv", options_.out_dir));
    s.log << "time,com_x,com_y,com_z,root_x,root_y,root_z";
    for (const auto& n : s.signal_names) s.log << ',' << n;
    s.log << ",push_fx,push_fy,push_fz,push_tail_x,push_tail_y,push_tail_z,push_head_x,"
             "push_head_y,push_head_z\n";
  }
  double dt = e.timestep();
  s.log_every = std::max<long>(1, std::lround(1.0 / (scenario_.log.rate_hz * dt)));
  long total_steps = std::lround(scenario_.duration / dt);
  auto write_row = [&]() {
    if (!s.log.is_open()) return;
    Eigen::Vector3d c = e.com();
    Eigen::Vector3d root = e.nbody() > 0 ? e.body_pose(0).pos : Eigen::Vector3d::Zero();
    s.log << fmt::format("{:.6f},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}", e.time(), c.x(), c.y(),
                         c.z(), root.x(), root.y(), root.z());
    s.signal_values.clear();
    for (auto& ctl : controllers_) ctl->signals(s.signal_values);
    for (double v : s.signal_values) s.log << fmt::format(",{:.9g}", v);
    // pushes: the force and the seed's arrow (force/30, ending at the body)
    Eigen::Vector3d f = Eigen::Vector3d::Zero(), head = Eigen::Vector3d::Zero();
    bool any = false;
    for (const auto& push : s.pushes)
      if (push.p.active_at(e.time())) {
        f += push.p.force;
        if (!any) head = e.body_pose(push.body).pos;
        any = true;
      }
    Eigen::Vector3d tail = head - f / 30.0;
    if (!any) tail = head;
    s.log << fmt::format(",{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", f.x(),
                         f.y(), f.z(), tail.x(), tail.y(), tail.z(), head.x(), head.y(), head.z());
  };

  e.forward();
  write_row();
  for (long k = 0; k < total_steps; ++k) {
    if (!step()) break;
    e.forward();
    // fall criterion
    double h = s.up.dot(e.com()) - scenario_.fall.ground_height;
    s.min_com_height = std::min(s.min_com_height, h);
    if (scenario_.fall.enabled && !result_.fell) {
      if (h < scenario_.fall.com_height_fraction * s.com_height0) {
        result_.fell = true;
        result_.fall_time = e.time();
        result_.fall_reason =
            fmt::format("COM height {:.3f} m below {:.0f}% of its start {:.3f} m", h,
                        100 * scenario_.fall.com_height_fraction, s.com_height0);
      } else if (!scenario_.fall.allowed_contacts.empty()) {
        for (int i = 0, n = e.num_contacts(); i < n && !result_.fell; ++i) {
          Contact c = e.contact(i);
          int other = c.body1 < 0 ? c.body2 : (c.body2 < 0 ? c.body1 : -1);
          if (other >= 0 && !s.allowed_contact[other]) {
            result_.fell = true;
            result_.fall_time = e.time();
            result_.fall_reason = "'" + e.body_name(other) + "' touched the ground";
          }
        }
      }
    }
    if ((k + 1) % s.log_every == 0) write_row();
    // one second past a fall is enough to see it; the rest is lying on the floor
    if (result_.fell && e.time() > *result_.fall_time + 1.0) break;
  }
  auto wall1 = std::chrono::steady_clock::now();
  result_.wall_time_s = std::chrono::duration<double>(wall1 - wall0).count();

  // metrics
  nlohmann::json& m = result_.metrics;
  m["torque_rms"] = s.torque_samples ? std::sqrt(s.torque_sq_sum / s.torque_samples) : 0.0;
  m["max_abs_torque"] = s.max_abs_torque;
  m["min_com_height_m"] = s.min_com_height;
  m["com_height_start_m"] = s.com_height0;
  Eigen::Vector3d com_end = e.com();
  m["com_displacement_m"] = (com_end - s.com0).norm();
  m["realtime_factor"] = result_.wall_time_s > 0 ? result_.sim_time / result_.wall_time_s : 0.0;
  int survived = 0;
  for (const auto& push : s.pushes) {
    double end = push.p.start + push.p.duration;
    if (end <= result_.sim_time && (!result_.fell || *result_.fall_time > end + 2.0)) ++survived;
  }
  m["pushes_applied"] = static_cast<int>(s.pushes.size());
  m["pushes_survived"] = survived;
  for (auto& c : controllers_) c->add_metrics(m);

  if (!options_.out_dir.empty()) {
    s.log.flush();
    s.log.close();
    for (auto& c : controllers_) c->write_outputs(options_.out_dir);
    std::ofstream js(dir / "summary.json");
    js << result_.to_json().dump(2) << "\n";
  }
  return result_;
}

}  // namespace stance
