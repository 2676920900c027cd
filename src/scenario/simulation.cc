#include "scenario/simulation.h"

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
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/world_spec.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "scenario/observers.h"

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
         ends_with("_time_ms") || ends_with("_ns_per_step");
}

nlohmann::json without_wall_clock(const nlohmann::json& metrics) {
  if (!metrics.is_object()) return metrics;
  nlohmann::json out = nlohmann::json::object();
  for (auto it = metrics.begin(); it != metrics.end(); ++it)
    if (!is_wall_clock_metric(it.key())) out[it.key()] = without_wall_clock(it.value());
  return out;
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

Eigen::Vector3d push_point(const Engine& engine, const ResolvedPush& push) {
  if (push.at_origin && push.p.offset.isZero()) return engine.body_pose(push.body).pos;
  const BodyPose pose = engine.body_pose(push.body);
  const Eigen::Vector3d base = push.at_origin ? pose.pos : engine.body_com(push.body);
  return base + pose.quat * push.p.offset;
}

void parse_push_point(const std::string& text, std::string& point, Eigen::Vector3d& offset) {
  if (text == "com" || text == "origin") {
    point = text;
    offset.setZero();
    return;
  }
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, ',');) parts.push_back(p);
  Eigen::Vector3d x;
  bool ok = parts.size() == 3;
  for (int i = 0; ok && i < 3; ++i) {
    try {
      size_t used = 0;
      x[i] = std::stod(parts[i], &used);
      ok = used == parts[i].size() && std::isfinite(x[i]);
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok)
    throw InputError(fmt::format(
        "--point '{}': expected com, origin or x,y,z (a point in the body frame, m)", text));
  point = "origin";
  offset = x;
}

bool push_point_is_origin(const std::string& point, const std::string& where) {
  if (point == "com") return false;
  if (point == "origin") return true;
  throw InputError(
      fmt::format("{}: '{}' is not a push point (com or origin, plus an offset)", where, point));
}

namespace {
// "file:line: " of a key path in a scenario's document, or "" where it is not in the file (a
// value from --set or --push)
std::string place_in(const LoadedScenario* loaded, const std::vector<std::string>& path) {
  if (!loaded) return "";
  const YAML::Node doc = loaded->document;
  std::vector<YAML::Node> chain{doc};
  for (const std::string& key : path) {
    const YAML::Node at = chain.back();
    if (at.IsMap()) {
      chain.push_back(at[key]);
    } else if (at.IsSequence()) {
      char* end = nullptr;
      long i = std::strtol(key.c_str(), &end, 10);
      if (*end || i < 0 || i >= static_cast<long>(at.size())) return "";
      chain.push_back(at[i]);
    } else {
      return "";
    }
    if (!chain.back()) return "";
  }
  const int line = chain.back().Mark().line;
  return line >= 0 ? fmt::format("{}:{}: ", loaded->source, line + 1) : "";
}
}  // namespace

namespace {
// a world of URDF/SDF robots with a floating base and no floor: the base falls through at once
// (MJCF and SKEL files bring their own floors); checked and said once per process and model list
void warn_when_no_ground(const Scenario& s) {
  static std::mutex mutex;
  static std::set<std::string> checked;
  std::string key;
  for (const auto& m : s.model) key += m.file + (m.fixed_base ? " fixed\n" : "\n");
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (!checked.insert(key).second) return;
  }
  std::vector<RobotModel> robots;
  for (const auto& m : s.model) {
    const std::string path = resolve_model_path(m.file);
    const ModelFormat format = model_format(path);
    if (format != ModelFormat::kUrdf && format != ModelFormat::kSdf) return;
    robots.push_back(
        read_robot(m.file, path, {m.fixed_base, m.package_path, m.mesh_collision, m.lock_joints}));
  }
  if (robots_need_ground(robots))
    std::cerr << "warning: " << s.model.front().file
              << ": no model is a ground and the base floats: it falls through at once (add "
                 "models/ground.urdf under model:)\n";
}

// stand_pose: auto leans the legs until the COM is over the feet (control/standing_pose.h); the
// feet are the fall check's two allowed contacts when it names two. Said once per process.
void apply_stand_pose(Engine& engine, const Scenario& s, const LoadedScenario* loaded) {
  if (s.stand_pose.empty() || s.stand_pose == "off") return;
  if (s.stand_pose != "auto")
    throw InputError(fmt::format("{}stand_pose: expected auto or off, found '{}'",
                                 place_in(loaded, {"stand_pose"}), s.stand_pose));
  StandingPoseOptions options;
  if (s.fall.allowed_contacts.size() == 2) options.feet = s.fall.allowed_contacts;
  StandingPose pose;
  try {
    pose = find_standing_pose(engine, options);
  } catch (const InputError& e) {
    throw InputError(place_in(loaded, {"stand_pose"}) + e.what());
  }
  static std::mutex mutex;
  static std::set<std::string> said;
  const std::string line = describe_standing_pose(pose, engine);
  std::lock_guard<std::mutex> lock(mutex);
  if (said.insert(line).second) std::cerr << "note: " << line << "\n";
}
}  // namespace

std::unique_ptr<Engine> make_scenario_engine(const Scenario& s, const std::string& engine_name,
                                             const LoadedScenario* loaded) {
  WorldSpec spec;
  for (const auto& m : s.model)
    spec.models.push_back(
        {m.file, m.offset, {m.fixed_base, m.package_path, m.mesh_collision, m.lock_joints}});
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
  warn_when_no_ground(s);
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
      throw InputError(fmt::format("{}initial_pose: unknown dof '{}'{}",
                                   place_in(loaded, {"initial_pose", name}), name,
                                   did_you_mean(name, engine->dof_names())));
    engine->set_dof_position(dof, value);
  }
  engine->forward();
  apply_stand_pose(*engine, s, loaded);
  return engine;
}

std::mutex& model_load_mutex() {
  static std::mutex m;
  return m;
}

// ---- controller models shared across runs

std::shared_ptr<const Controller> ControllerCache::get_or_build(
    const std::string& key, const std::function<std::shared_ptr<const Controller>()>& build) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = models_.find(key);
    if (it != models_.end()) return it->second;
  }
  std::shared_ptr<const Controller> built = build();
  std::lock_guard<std::mutex> lock(mutex_);
  ++builds_;
  auto [it, inserted] = models_.emplace(key, std::move(built));
  if (inserted) {
    order_.push_back(key);
    while (models_.size() > capacity_) {
      models_.erase(order_.front());
      order_.pop_front();
    }
    it = models_.find(key);
  }
  return it->second;
}

long ControllerCache::builds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return builds_;
}

namespace {

// what a controller model depends on besides its own parameters: the world and the start
std::string world_key(const Scenario& s, const std::string& engine_name,
                      const std::string& source) {
  std::string k = fmt::format("{}|{}|", engine_name, source);
  for (const auto& m : s.model)
    k += fmt::format("{}@{:.17g},{:.17g},{:.17g}|{}|{}|{};", m.file, m.offset.x(), m.offset.y(),
                     m.offset.z(), m.fixed_base, fmt::join(m.package_path, ":"), m.mesh_collision) +
         fmt::format("lock={};", fmt::join(m.lock_joints, ","));
  k += fmt::format("|dt={:.17g}|g=", s.timestep);
  for (double g : s.gravity) k += fmt::format("{:.17g},", g);
  k += fmt::format("|slope={:.17g}|key={}|pose=", s.slope_rad, s.keyframe);
  for (const auto& [name, value] : s.initial_pose) k += fmt::format("{}={:.17g},", name, value);
  k += fmt::format("|stand={}", s.stand_pose);
  k += fmt::format("|seed={}|T={:.17g}", s.seed, s.duration);
  return k;
}

void build_controllers(const LoadedScenario& loaded, const RunOptions& options,
                       const std::string& engine_name, SimulationModel& m, const Engine& e) {
  const std::string world = world_key(m.scenario, engine_name, loaded.source);
  for (size_t i = 0; i < loaded.controllers.size(); ++i) {
    const YAML::Node& node = loaded.controllers[i];
    const bool external = node["type"].Scalar() == kExternalControllerType;
    if (external && !options.external_controllers)
      throw InputError(located(loaded.source, node["type"].Mark().line + 1,
                               fmt::format("controllers[{}]: type 'python' is resolved only when "
                                           "the scenario is loaded from Python (stance.load)",
                                           i)));
    const ControllerFactory& make =
        external ? options.external_controllers : find_controller_type(node["type"].Scalar()).make;
    ControllerContext ctx = controller_context(m, i);
    auto build = [&]() -> std::shared_ptr<const Controller> {
      try {
        return make(node, ctx, e);
      } catch (const InputError& err) {
        std::string msg = err.what();
        // name errors from the engine get the controller's place in the file
        if (msg.rfind(loaded.source, 0) != 0)
          msg = located(loaded.source, node.Mark().line + 1, ctx.path + ": " + msg);
        throw InputError(msg);
      }
    };
    if (options.cache && !external) {
      YAML::Emitter out;
      out << node;
      m.controllers.push_back(options.cache->get_or_build(
          fmt::format("{}|{}|{}|{}", world, i, m.rollout ? "rollout" : "run", out.c_str()), build));
    } else {
      m.controllers.push_back(build());
    }
  }
}

void add_planner(const LoadedScenario& loaded, const RunOptions& options, SimulationModel& m,
                 double timestep);

std::shared_ptr<SimulationModel> build_model(const LoadedScenario& loaded,
                                             const RunOptions& options,
                                             std::unique_ptr<Engine>& engine,
                                             bool rollout = false) {
  auto m = std::make_shared<SimulationModel>();
  m->rollout = rollout;
  m->scenario = loaded.scenario;
  m->source = loaded.source;
  Scenario& sc = m->scenario;
  if (options.duration) sc.duration = *options.duration;
  for (const auto& p : options.extra_pushes) sc.perturbations.push_back(p);
  m->engine_name = options.engine.empty() ? sc.engine : options.engine;
  if (m->engine_name != "mujoco" && m->engine_name != "dart")
    throw InputError(fmt::format("--engine: expected mujoco or dart, found '{}'", m->engine_name));
  m->stop_after_fall_s = options.stop_after_fall_s;
  {
    std::lock_guard<std::mutex> lock(model_load_mutex());
    engine = make_scenario_engine(sc, m->engine_name, &loaded);
  }
  Engine& e = *engine;
  build_controllers(loaded, options, m->engine_name, *m, e);
  // a controller that tracks a clip may start the run on the clip's first frame
  for (const auto& c : m->controllers) {
    Eigen::VectorXd q0, v0;
    if (c->initial_state(e, q0, v0)) {
      e.set_positions(q0);
      e.set_velocities(v0);
      e.forward();
    }
  }
  for (size_t i = 0; i < sc.perturbations.size(); ++i) {
    const Perturbation& p = sc.perturbations[i];
    int b = e.body_index(p.body);
    if (b < 0)
      throw InputError(fmt::format("{}perturbation: unknown body '{}'{}",
                                   place_in(&loaded, {"perturbations", std::to_string(i), "body"}),
                                   p.body, did_you_mean(p.body, e.body_names())));
    const bool at_origin = push_point_is_origin(
        p.point, place_in(&loaded, {"perturbations", std::to_string(i), "point"}) +
                     fmt::format("perturbations.{}.point", i));
    m->pushes.push_back({p, b, at_origin});
  }
  m->allowed_contact.assign(e.nbody(), 0);
  for (const auto& name : sc.fall.allowed_contacts) {
    int b = e.body_index(name);
    if (b < 0)
      throw InputError(fmt::format("fall.allowed_contacts: unknown body '{}'{}", name,
                                   did_you_mean(name, e.body_names())));
    m->allowed_contact[b] = 1;
  }
  // heights are measured along the floor's normal: -gravity, or z when a slope tilts gravity
  Eigen::Vector3d g = e.gravity();
  if (sc.slope_rad != 0)
    m->up = Eigen::Vector3d::UnitZ();
  else if (g.norm() > 0)
    m->up = -g.normalized();
  // torque limits: per dof from its joint; clamped on URDF/SDF models unless asked otherwise
  m->force_limit.resize(e.nv());
  for (int d = 0; d < e.nv(); ++d) m->force_limit[d] = e.joint(e.dof_joint(d)).force_limit;
  bool robot_model = false;
  for (const auto& mf : sc.model) {
    const ModelFormat f = model_format(mf.file);
    robot_model = robot_model || f == ModelFormat::kUrdf || f == ModelFormat::kSdf;
  }
  m->clamp_torques = sc.torque_limits == "on" || (sc.torque_limits == "auto" && robot_model);
  e.save_state(m->initial);
  for (const auto& c : m->controllers) c->signal_names(m->signal_names);
  const double dt = e.timestep();
  // a run too long to finish in any reasonable time (duration, timestep or both absurd)
  if (const std::string problem = step_count_problem(sc.duration, dt); !problem.empty())
    throw InputError(loaded.source + ": " + problem);
  m->total_steps = std::lround(sc.duration / dt);
  m->log_every = std::max<long>(1, std::lround(1.0 / (sc.log.rate_hz * dt)));
  if (sc.planner.enabled) add_planner(loaded, options, *m, dt);
  return m;
}

// the planner's rollouts run the same scenario without planning, at the planner's timestep,
// without the scheduled pushes (the planner reacts to a push; it does not foresee it) and
// without the controllers' output files. The planner's step is only ever coarser than the
// run's (`timestep`): a finer one would cost more for nothing the run could follow.
void add_planner(const LoadedScenario& loaded, const RunOptions& options, SimulationModel& m,
                 double timestep) {
  const PlannerParams& p = m.scenario.planner;
  LoadedScenario r = loaded;
  r.scenario.planner.enabled = false;
  r.scenario.perturbations.clear();
  if (p.timestep > timestep) r.scenario.timestep = p.timestep;
  for (YAML::Node& node : r.controllers) {
    node = YAML::Clone(node);
    if (node["export_bvh"]) node.remove("export_bvh");
  }
  RunOptions ro = options;
  ro.extra_pushes.clear();
  ro.duration = m.scenario.duration + p.horizon_s + 1;
  std::unique_ptr<Engine> scratch;
  std::shared_ptr<SimulationModel> rollout = build_model(r, ro, scratch, true);
  m.planner = make_planner_model(p, m, rollout);
  m.plans = true;
  auto dimensions = std::make_shared<PlannerModel>(*m.planner);
  dimensions->rollout = nullptr;  // a rollout plans nothing
  rollout->planner = std::move(dimensions);
  rollout->plans = false;
}

}  // namespace

ControllerContext controller_context(const SimulationModel& m, size_t index) {
  Scenario scenario = m.scenario;
  std::string engine_name = m.engine_name;
  return {{m.source.empty() ? "viewer" : m.source},
          fmt::format("controllers[{}]", index),
          static_cast<uint64_t>(scenario.seed) * 1000003ull + index,
          scenario.duration,
          [scenario, engine_name] {
            std::lock_guard<std::mutex> lock(model_load_mutex());
            return make_scenario_engine(scenario, engine_name);
          },
          m.rollout};
}

std::unique_ptr<Engine> SimulationModel::make_engine() const {
  std::unique_ptr<Engine> e;
  {
    std::lock_guard<std::mutex> lock(model_load_mutex());
    e = make_scenario_engine(scenario, engine_name);
  }
  e->restore_state(initial);
  e->forward();
  return e;
}

std::shared_ptr<const SimulationModel> make_simulation_model(const LoadedScenario& loaded,
                                                             const RunOptions& options) {
  std::unique_ptr<Engine> engine;
  return build_model(loaded, options, engine);
}

SimulationState& SimulationState::operator=(const SimulationState& other) {
  if (this == &other) return *this;
  engine = other.engine;
  progress = other.progress;
  controllers.resize(other.controllers.size());
  for (size_t i = 0; i < other.controllers.size(); ++i) {
    const ControllerState& src = *other.controllers[i];
    if (controllers[i] && typeid(*controllers[i]) == typeid(src))
      controllers[i]->assign(src);
    else
      controllers[i] = src.clone();
  }
  return *this;
}

// ---- the loop

Simulation::Simulation(std::shared_ptr<const SimulationModel> model)
    : model_(std::move(model)), engine_(model_->make_engine()) {
  controllers_ = model_->controllers;
  if (model_->plans) planner_ = std::make_unique<Planner>(model_->planner);
  start_run();
}

Simulation::Simulation(const LoadedScenario& loaded, const RunOptions& options) {
  std::unique_ptr<Engine> engine;
  model_ = build_model(loaded, options, engine);
  engine_ = std::move(engine);
  controllers_ = model_->controllers;
  run_files_ = options;
  engine_->restore_state(model_->initial);
  engine_->forward();
  if (model_->plans) planner_ = std::make_unique<Planner>(model_->planner);
  start_run();
  // the expectation's metrics by the names this run will report, before it writes anything
  if (model_->scenario.expect.given && options.check_expect_names)
    check_expectation_metrics(model_->scenario.expect, result().metrics, loaded.source,
                              loaded.document["expect"]);
}

Simulation::~Simulation() = default;

void Simulation::start_run() {
  Engine& e = *engine_;
  out_.resize(e.nv(), e.nu());
  correction_.setZero(model_->planner ? model_->planner->dimensions.size() : 0);
  progress_ = RunProgress{};
  progress_.velocity_sent = out_.dof_velocity;
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
  const PlannerModel& old = *model_->planner;
  if (params.timestep != old.params.timestep)
    throw InputError("planner.timestep: the rollouts' step is fixed when the run is made");
  if (params.residual_dofs != old.params.residual_dofs)
    throw InputError("planner.residual_dofs: the dimensions are fixed when the run is made");
  check_planner_params(params, "");
  auto planner = std::make_shared<PlannerModel>(old);
  planner->params = params;
  for (PlanDimension& d : planner->dimensions)
    if (d.controller < 0) d.scale = params.residual_torque;
  auto model = std::make_shared<SimulationModel>(*model_);
  model->planner = planner;
  model_ = std::move(model);
  planner_.reset();
  if (params.enabled) {
    planner_ = std::make_unique<Planner>(model_->planner);
    progress_.plan.next_plan = time();  // plan at the next step, with the new parameters
  } else {
    progress_.plan.knots.resize(0, 0);  // no correction from now on
  }
}

// the one place torques meet the model's limits: the peak of |requested| / limit is measured,
// and the torques are clamped to the limits when the model says so
void Simulation::limit_torques() {
  const Eigen::VectorXd& limit = model_->force_limit;
  RunProgress& s = progress_;
  bool clamped = false, at_limit = false;
  for (int i = 0; i < out_.tau.size(); ++i) {
    if (std::isinf(limit[i])) continue;
    const double tau = out_.tau[i];
    const double ratio = std::abs(tau) / std::max(limit[i], 1e-12);
    at_limit = at_limit || ratio >= 1;
    if (ratio > s.peak_limit_ratio) {
      s.peak_limit_ratio = ratio;
      s.peak_limit_dof = i;
    }
    if (model_->clamp_torques && ratio > 1) {
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
  out_.clear();
  const PlannerModel* pm = model_->planner.get();
  if (pm) {
    if (planner_ && e.time() + 1e-12 >= progress_.plan.next_plan) planner_->plan(*this);
    progress_.plan.evaluate(e.time(), correction_);
    for (size_t d = 0; d < pm->dimensions.size(); ++d) correction_[d] *= pm->dimensions[d].scale;
  }
  for (size_t i = 0; i < controllers_.size(); ++i) {
    const int first = pm ? pm->controller_first[i] : -1;
    out_.correction = first >= 0 ? correction_.data() + first : nullptr;
    if (controller_seconds_) {
      auto t0 = std::chrono::steady_clock::now();
      controllers_[i]->compute(*states_[i], e, out_);
      (*controller_seconds_)[i] +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } else {
      controllers_[i]->compute(*states_[i], e, out_);
    }
    if (!check_output(i, e.time())) {
      out_.correction = nullptr;
      return false;
    }
  }
  out_.correction = nullptr;
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
      engine.apply_external_force(p.body, Eigen::Vector3d(p.force.data()),
                                  engine.body_com(p.body));
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
    const FallVerdict v = controllers_[i]->fall_verdict(*states_[i], e, s.fall_reason);
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
  for (size_t i = 0; i < controllers_.size(); ++i) controllers_[i]->add_metrics(*states_[i], m);
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
  for (size_t i = 0; i < controllers_.size(); ++i) controllers_[i]->signals(*states_[i], values);
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
  }
  m["pushes_applied"] = static_cast<int>(model_->pushes.size());
  m["pushes_survived"] = survived;
  // a state that blew up after the fall says nothing of the walk: its metrics are the fall's
  if (diverged_after_fall && !s.controller_metrics_at_fall.empty())
    m.update(nlohmann::json::parse(s.controller_metrics_at_fall));
  else
    for (size_t i = 0; i < controllers_.size(); ++i) controllers_[i]->add_metrics(*states_[i], m);
  if (model_->plans) {
    const CorrectionPlan& plan = s.plan;
    nlohmann::json& pm = m["planner"];
    pm["plans"] = plan.plans;
    pm["dimensions"] = model_->planner->dimensions.size();
    pm["mean_cost"] = plan.plans ? plan.cost_sum / plan.plans : 0.0;
    pm["kept_nominal_share"] = plan.plans ? double(plan.kept_nominal) / plan.plans : 0.0;
    pm["rescues"] = plan.rescues;
    pm["steady"] = plan.steady;
    pm["model_steps_per_sim_s"] = s.steps ? plan.rollout_steps / time() : 0.0;
  }
  return r;
}

RunResult Simulation::run(long max_steps) {
  auto wall0 = std::chrono::steady_clock::now();
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
  if (r.metrics.contains("mocap") && r.metrics["mocap"].is_object())
    r.metrics["mocap"]["compute_s_per_sim_s"] = r.metrics["compute_s_per_sim_s"];
  if (model_->scenario.expect.given)
    r.expectation = evaluate_expectation(model_->scenario.expect, r.to_json());
  for (StepObserver* o : observers_) o->on_finish(*this, r);
  if (log) {
    remove_observer(log.get());
    for (size_t i = 0; i < controllers_.size(); ++i)
      controllers_[i]->write_outputs(*states_[i], run_files_.out_dir);
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
  const bool keep = controller->keeps_state_of(*controllers_.at(i));
  if (!keep) states_[i] = controller->make_state(*engine_);
  controllers_[i] = std::move(controller);
}

// ---- branching and the state file

void Simulation::save(SimulationState& state) const {
  engine_->save_state(state.engine);
  state.progress = progress_;
  state.controllers.resize(states_.size());
  for (size_t i = 0; i < states_.size(); ++i) {
    if (state.controllers[i] && typeid(*state.controllers[i]) == typeid(*states_[i]))
      state.controllers[i]->assign(*states_[i]);
    else
      state.controllers[i] = states_[i]->clone();
  }
}

void Simulation::restore(const SimulationState& state) {
  if (state.controllers.size() != states_.size())
    throw std::logic_error("restore: a state of another simulation");
  engine_->restore_state(state.engine);
  engine_->forward();
  for (size_t i = 0; i < states_.size(); ++i) {
    if (typeid(*states_[i]) == typeid(*state.controllers[i]))
      states_[i]->assign(*state.controllers[i]);
    else
      states_[i] = state.controllers[i]->clone();
  }
  // the engine goes on with the servo commands of the saved moment: only those that differ
  // from what it holds now are sent (a release on a dof that never had one is not)
  Eigen::VectorXd held = progress_.velocity_sent;
  progress_ = state.progress;
  progress_.velocity_sent = held;
  send_velocity_commands(state.progress.velocity_sent);
}

std::unique_ptr<Simulation> Simulation::clone() const {
  auto sim = std::make_unique<Simulation>(model_);
  for (size_t i = 0; i < controllers_.size(); ++i)
    if (i >= sim->controllers_.size()) {
      sim->add_controller(controllers_[i]);
    } else if (sim->controllers_[i] != controllers_[i]) {
      sim->controllers_[i] = controllers_[i];
      sim->states_[i] = controllers_[i]->make_state(*sim->engine_);
    }
  SimulationState state;
  save(state);
  sim->restore(state);
  return sim;
}

namespace {
// 3: the plan counts its rescue rounds; 4: and its steps on track and rollout steps
constexpr char kStateMagic[] = "stance-state 4\n";
}  // namespace

void Simulation::write_state(const std::string& path) const {
  std::string out = kStateMagic;
  StateWriter w(out);
  const Engine& e = *engine_;
  w(std::string(e.engine_name())), w(e.nq()), w(e.nv()), w(e.nu());
  EngineState es;
  e.save_state(es);
  w(es.time), w(es.q), w(es.v), w(es.act), w(es.ctrl), w(es.extra);
  w(const_cast<RunProgress&>(progress_).steps);
  const_cast<RunProgress&>(progress_).serialize(w);
  w(controllers_.size());
  for (size_t i = 0; i < controllers_.size(); ++i) {
    w(std::string(controllers_[i]->type()));
    states_[i]->write(out);
  }
  write_file_atomically(path, out);
}

void Simulation::read_state(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot read the state file", path));
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string magic = kStateMagic;
  if (data.compare(0, magic.size(), magic) != 0)
    throw InputError(fmt::format(
        "{}: not a stance state file, or one written by another stance version (this one reads "
        "'{}')",
        path, magic.substr(0, magic.size() - 1)));
  const Engine& e = *engine_;
  try {
    StateReader r(data, magic.size());
    std::string engine_name;
    int nq = 0, nv = 0, nu = 0;
    r(engine_name), r(nq), r(nv), r(nu);
    if (engine_name != e.engine_name() || nq != e.nq() || nv != e.nv() || nu != e.nu())
      throw InputError(fmt::format(
          "{}: a state of another model ({} nq {} nv {} nu {}; this run: {} nq {} nv {} nu {})",
          path, engine_name, nq, nv, nu, e.engine_name(), e.nq(), e.nv(), e.nu()));
    SimulationState state;
    r(state.engine.time), r(state.engine.q), r(state.engine.v), r(state.engine.act);
    r(state.engine.ctrl), r(state.engine.extra);
    long steps = 0;
    r(steps);
    state.progress.serialize(r);
    size_t n = 0;
    r(n);
    if (n != controllers_.size())
      throw InputError(
          fmt::format("{}: {} controllers, this scenario has {}", path, n, controllers_.size()));
    size_t offset = r.position();
    for (size_t i = 0; i < n; ++i) {
      StateReader tr(data, offset);
      std::string type;
      tr(type);
      if (type != controllers_[i]->type())
        throw InputError(fmt::format("{}: controller {} is '{}', this scenario's is '{}'", path, i,
                                     type, controllers_[i]->type()));
      offset = tr.position();
      auto cs = states_[i]->clone();
      cs->read(data, offset);
      state.controllers.push_back(std::move(cs));
    }
    if (offset != data.size())
      throw InputError(fmt::format("{}: {} bytes after the state", path, data.size() - offset));
    restore(state);
  } catch (const StateFormatError& err) {
    throw InputError(fmt::format("{}: corrupt state file ({})", path, err.what()));
  }
}

}  // namespace stance
