// Building a simulation from a scenario: its engine, its controller models (shared across runs
// by ControllerCache) and the planner; the pushes of --push.
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
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/world_spec.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "sim/observers.h"

namespace stance {

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
// a world of URDF/SDF/MJCF robots with a floating base (an MJCF free joint) and no floor: the
// base falls through at once (SKEL files bring their own floors); checked and said once per
// process and model list
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
  MjcfGroundFacts mjcf;  // of the MJCF models, which may bring a floor or a free joint
  for (const auto& m : s.model) {
    const std::string path = resolve_model_path(m.file);
    const ModelFormat format = model_format(path);
    if (format == ModelFormat::kMjcf) {
      const MjcfGroundFacts f = mjcf_ground_facts(path);
      mjcf.floats |= f.floats && !m.fixed_base;
      mjcf.has_floor |= f.has_floor;
      continue;
    }
    if (format != ModelFormat::kUrdf && format != ModelFormat::kSdf) return;
    robots.push_back(
        read_robot(m.file, path, {m.fixed_base, m.package_path, m.mesh_collision, m.lock_joints}));
  }
  const bool urdf_ground = std::any_of(robots.begin(), robots.end(), robot_is_ground);
  if (mjcf.has_floor || urdf_ground) return;
  if (mjcf.floats || robots_need_ground(robots))
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
    const InitialState* start = c->as<InitialState>();
    if (start && start->initial_state(e, q0, v0)) {
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
  // torque limits: per dof from its joint (URDF/SDF effort, MJCF actuators, actuatorfrcrange);
  // clamped wherever the model gives one unless asked otherwise
  m->force_limit.resize(e.nv());
  for (int d = 0; d < e.nv(); ++d) m->force_limit[d] = e.joint(e.dof_joint(d)).force_limit;
  m->clamp_torques = sc.torque_limits == "on" ||
                     (sc.torque_limits == "auto" && m->force_limit.array().isFinite().any());
  e.save_state(m->initial);
  for (const auto& c : m->controllers)
    if (const Reporting* r = c->as<Reporting>()) r->signal_names(m->signal_names);
  const double dt = e.timestep();
  // a run too long to finish in any reasonable time (duration, timestep or both absurd)
  if (const std::string problem = step_count_problem(sc.duration, dt); !problem.empty())
    throw InputError(loaded.source + ": " + problem);
  m->total_steps = std::lround(sc.duration / dt);
  m->log_every = std::max<long>(1, std::lround(1.0 / (sc.log.rate_hz * dt)));
  if (sc.planner.enabled) add_planner(loaded, options, *m, dt);
  return m;
}

// the rollouts' solver settings, checked on an engine of the world (names: InputError)
SolverSettings planner_solver_settings(const PlannerSolverParams& p, Engine& engine,
                                       const std::string& source) {
  const SolverSettings s{p.iterations, p.tolerance, p.noslip_iterations, p.type, p.cone};
  try {
    engine.set_solver_settings(s);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: planner.solver.{}", source, e.what()));
  }
  return s;
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
  const double rollout_step = std::max(p.timestep, timestep);
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
  rollout->solver = planner_solver_settings(p.solver, *scratch, loaded.source);
  auto correction = std::make_shared<CorrectionModel>();
  correction->params = p;
  correction->rollout = rollout;
  // calm steps' model: the same at a coarser step (only ever coarser than the rollouts')
  std::shared_ptr<SimulationModel> calm_rollout;
  if (p.calm_timestep > rollout_step) {
    r.scenario.timestep = p.calm_timestep;
    calm_rollout = build_model(r, ro, scratch, true);
    calm_rollout->solver = planner_solver_settings(p.solver, *scratch, loaded.source);
    correction->calm_rollout = calm_rollout;
  }
  check_planner_params(p, m.source);
  std::unique_ptr<Engine> start = m.make_engine();
  start->restore_state(m.initial);
  start->forward();
  resolve_correction_dims(m, *start, *correction);
  const CorrectionSourceMakerFactory make_maker = correction_source_factory();
  if (!make_maker)
    throw InputError(m.source + ": planner: this program is built without the planner (src/plan)");
  m.planner = correction;
  m.planner_maker = make_maker(m, *start);
  m.plans = true;
  auto dimensions = std::make_shared<CorrectionModel>(*correction);
  dimensions->rollout = nullptr;  // a rollout plans nothing
  dimensions->calm_rollout = nullptr;
  if (calm_rollout) {
    calm_rollout->planner = dimensions;
    calm_rollout->plans = false;
  }
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
  if (solver.any()) e->set_solver_settings(solver);
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
    if (controllers[i] && same_state_type(*controllers[i], src))
      controllers[i]->assign(src);
    else
      controllers[i] = src.clone();
  }
  return *this;
}

Simulation::Simulation(std::shared_ptr<const SimulationModel> model)
    : model_(std::move(model)), engine_(model_->make_engine()) {
  controllers_ = model_->controllers;
  if (model_->plans) planner_ = model_->planner_maker->make_source(model_->planner);
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
  if (model_->plans) planner_ = model_->planner_maker->make_source(model_->planner);
  start_run();
  // the expectation's metrics by the names this run will report, before it writes anything
  if (model_->scenario.expect.given && options.check_expect_names)
    check_expectation_metrics(model_->scenario.expect, result().metrics, loaded.source,
                              loaded.document["expect"]);
}

}  // namespace stance
