// The one step loop. A Simulation owns an engine, every controller's State, the pushes and the
// clock, and steps them in one fixed order:
//   forward -> controllers (summed, torque_scale) -> servos -> pushes -> engine step ->
//   divergence check -> forward -> fall detection and metrics -> observers
// A controller's non-finite output, or a non-finite state after the step, ends the run as
// diverged with the time and the cause.
// Every entry point (run, view, record, sweep, tune, push-threshold, the benchmarks) steps it.
// What a scenario resolves to once (the world, the controllers' immutable models, the pushes'
// bodies) is a SimulationModel, shared by every run, clone and thread.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <atomic>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"
#include "sim/correction.h"
#include "sim/scenario.h"

namespace stance {

class ControllerCache;

struct RunOptions {
  std::string engine;                      // overrides the scenario's engine when set
  std::optional<double> duration;          // s, overrides the scenario's
  std::string out_dir;                     // where summary.json and log.csv go; empty: no files
  std::vector<Perturbation> extra_pushes;  // from the CLI
  bool quiet = false;
  bool progress = false;           // a progress bar on stderr (shown only when it is a terminal)
  double stop_after_fall_s = 1.0;  // s a run goes on after a fall; < 0: to the end
  // controller models reused across runs whose world and parameters are the same; null: none
  ControllerCache* cache = nullptr;
  // set (by a signal handler): run() stops before its next step and writes its outputs with
  // "interrupted": true; null: never
  const std::atomic<bool>* interrupt = nullptr;
  // builds the entries of type kExternalControllerType ("python": outside the registry, given
  // by the Python module); empty: such an entry is bad input (the CLI). Never cached.
  ControllerFactory external_controllers;
  // the scenario's `expect` may name only metrics this run reports (InputError at construction,
  // before anything is written): on in `stance run`; off where a program swaps the file's
  // controllers after loading (tests, Python), whose verdict then simply misses the metric
  bool check_expect_names = false;
};

struct RunResult {
  std::string scenario;
  std::string engine;
  int seed = 0;
  double sim_time = 0;
  bool fell = false;
  std::optional<double> fall_time;
  std::string fall_reason;
  bool diverged = false;
  std::string divergence;    // message with time and cause
  bool interrupted = false;  // stopped early by RunOptions::interrupt (SIGINT)
  double wall_time_s = 0;
  long steps = 0;
  nlohmann::json metrics = nlohmann::json::object();
  // the scenario's `expect` checked on this run (scenario/expectation.h); null: it has none
  nlohmann::json expectation;

  nlohmann::json to_json() const;
  // back from to_json() (results gathered from another MPI rank)
  static RunResult from_json(const nlohmann::json& j);
};

// metrics measured on the wall clock (realtime_factor, design_time_ms, controller_ns_per_step,
// ...) or a CPU clock (cpu_s_per_sim_s): they vary from run to run, so comparisons of results
// leave them out
bool is_wall_clock_metric(const std::string& key);
// `metrics` without its wall-clock entries (nested objects included)
nlohmann::json without_wall_clock(const nlohmann::json& metrics);

// a push resolved to its body
struct ResolvedPush {
  Perturbation p;
  int body = -1;
  bool at_origin = false;  // p.point == "origin"
};

// the world point where a push acts now (its point and offset on the body)
Eigen::Vector3d push_point(const Engine& engine, const ResolvedPush& push);
// "com" or "origin", else InputError naming `where` ("perturbations.0.point", "--point")
bool push_point_is_origin(const std::string& point, const std::string& where);
// "com", "origin" or "x,y,z" (the origin plus that offset in the body frame, m), as the CLI's
// --point; InputError naming --point otherwise
void parse_push_point(const std::string& text, std::string& point, Eigen::Vector3d& offset);

// what a loaded scenario resolves to once; immutable and shared by every run of it
struct SimulationModel {
  Scenario scenario;  // the options' duration and extra pushes applied
  std::string engine_name;
  std::string source;  // scenario file, for messages
  std::vector<std::shared_ptr<const Controller>> controllers;
  std::vector<ResolvedPush> pushes;
  std::vector<char> allowed_contact;              // per body
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // heights are measured along it
  EngineState initial;                            // the start: pose, keyframe, clip's first frame
  std::vector<std::string> signal_names;          // the controllers' log columns
  double stop_after_fall_s = 1.0;
  long total_steps = 0;
  long log_every = 1;
  // the planner's parameters, dimensions and rollout model; null: no planner
  std::shared_ptr<const CorrectionModel> planner;
  // makes each run's planner (src/plan/); null when the model does not plan
  std::shared_ptr<const CorrectionSourceMaker> planner_maker;
  bool plans = false;    // runs of this model plan (false for the planner's own rollouts)
  bool rollout = false;  // the planner's rollouts run this model (its controllers keep no metrics)
  // the planner's rollouts: a cheaper constraint solver than the run's (defaults: the model's)
  SolverSettings solver;
  // each dof's torque limit (N m or N; inf: none), from the engine's joints, dim nv; the summed
  // controller torques are clamped to it when clamp_torques
  Eigen::VectorXd force_limit;
  bool clamp_torques = false;

  // a new engine of this world at the initial state (under the one load lock)
  std::unique_ptr<Engine> make_engine() const;
};

// build the model of a scenario: the engine is loaded once to resolve names, the controllers are
// built (or taken from options.cache)
std::shared_ptr<const SimulationModel> make_simulation_model(const LoadedScenario& loaded,
                                                             const RunOptions& options);

// the context the simulation gives controller `index` of `model` when it builds it (the same
// seed keeps noise streams reproducible; the scratch engine is a fresh engine of the world)
ControllerContext controller_context(const SimulationModel& model, size_t index);

// Controller models shared across runs of a sweep, tune or push search. A model is reused when
// its parameters, the world (model files, timestep, gravity, slope), the initial state, the seed
// and the run length are the same. Thread-safe; holds at most `capacity` models (the oldest go).
class ControllerCache {
 public:
  explicit ControllerCache(size_t capacity = 64) : capacity_(capacity > 0 ? capacity : 1) {}
  std::shared_ptr<const Controller> get_or_build(
      const std::string& key, const std::function<std::shared_ptr<const Controller>()>& build);
  long builds() const;  // how many models were built (not reused)

 private:
  mutable std::mutex mutex_;
  size_t capacity_;
  std::map<std::string, std::shared_ptr<const Controller>> models_;
  std::deque<std::string> order_;  // oldest first
  long builds_ = 0;
};

// forces from outside the scenario, set while it runs (the viewer's keys and mouse spring). They
// are part of the run's state (RunProgress): saved, restored and branched with it, so that the
// planner's rollouts feel them too; step() applies them after the scenario's pushes.
struct ExternalForces {
  // a force at a body's COM (world, N) until a simulated time (s)
  struct Push {
    int body = -1;
    std::array<double, 3> force = {0, 0, 0};
    double until_s = 0;
  };
  // a damped spring pulling a point on a body (body frame, m) towards a world target (m):
  // stiffness (N/m) * (target - point) - damping (N s/m) * the point's velocity; body < 0: none
  struct Spring {
    int body = -1;
    std::array<double, 3> point_in_body = {0, 0, 0};
    std::array<double, 3> target = {0, 0, 0};
    double stiffness = 0, damping = 0;
  };
  std::vector<Push> pushes;
  Spring spring;

  template <class A>
  void serialize(A& a) {
    a(pushes), a(spring);
  }
  // the forces acting at the engine's time, applied to it (its positions forwarded)
  void apply(Engine& engine) const;
};

// the run's bookkeeping: fall and divergence detection, metric accumulators, servo commands
struct RunProgress {
  long steps = 0;
  bool fell = false;
  double fall_time = 0;
  std::string fall_reason;
  bool diverged = false;
  std::string divergence;
  double diverged_at = 0;
  double com_height0 = 0, min_com_height = 0;
  Eigen::Vector3d com0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d com_last = Eigen::Vector3d::Zero();  // the last finite COM (after divergence)
  double torque_sq_sum = 0, max_abs_torque = 0;
  long torque_samples = 0;
  // the largest |requested torque| / limit over the run and its dof; steps with a clamped dof;
  // steps on which some dof asked for at least its limit (clamped or not)
  double peak_limit_ratio = 0;
  int peak_limit_dof = -1;
  long clamped_steps = 0;
  long steps_at_limit = 0;
  // per dof (dim nv, sized at run start: the step allocates nothing): the steps on which it asked
  // for at least its limit, and its largest |requested torque| / limit
  Eigen::Matrix<long, Eigen::Dynamic, 1> dof_steps_at_limit;
  Eigen::VectorXd dof_peak_limit_ratio;
  Eigen::VectorXd velocity_sent;  // the velocity commands the engine holds, dim nv; NaN: none
  CorrectionPlan plan;            // the planner's correction being applied
  // the controllers' metrics (JSON) as they were when the run fell: if the state blows up on the
  // floor afterwards, a walk's distance and speed are those it had, not the blown-up state's
  std::string controller_metrics_at_fall;
  ExternalForces external;  // the viewer's pushes and spring

  template <class A>
  void serialize(A& a) {
    a(steps), a(fell), a(fall_time), a(fall_reason), a(diverged), a(divergence), a(diverged_at);
    a(com_height0), a(min_com_height), a(com0), a(torque_sq_sum), a(max_abs_torque);
    a(torque_samples), a(velocity_sent), a(com_last), a(peak_limit_ratio), a(peak_limit_dof);
    a(clamped_steps), a(steps_at_limit), a(dof_steps_at_limit), a(dof_peak_limit_ratio);
    plan.serialize(a);
    a(controller_metrics_at_fall);
    external.serialize(a);
  }
};

// the whole state of a simulation: restoring it on any engine of the same world continues the
// run exactly
struct SimulationState {
  EngineState engine;
  std::vector<std::unique_ptr<ControllerState>> controllers;
  RunProgress progress;

  SimulationState() = default;
  SimulationState(const SimulationState& other) { *this = other; }
  SimulationState& operator=(const SimulationState& other);
  SimulationState(SimulationState&&) = default;
  SimulationState& operator=(SimulationState&&) = default;
};

class Simulation;

// hooks on the loop: log rows, frames, a progress bar. Called on the stepping thread.
class StepObserver {
 public:
  virtual ~StepObserver() = default;
  virtual void on_start(const Simulation& sim) {}  // at the current state, before stepping
  virtual void on_step(const Simulation& sim) {}   // after each step, the engine forwarded
  virtual void on_finish(const Simulation& sim, const RunResult& result) {}
};

class Simulation {
 public:
  explicit Simulation(std::shared_ptr<const SimulationModel> model);
  Simulation(const LoadedScenario& loaded, const RunOptions& options);
  ~Simulation();

  // one control + physics step, then fall detection and the observers; false once diverged
  bool step();
  // the run is over: its length reached, diverged, or stop_after_fall_s past a fall
  bool done() const;
  // step until done (or max_steps steps, when >= 0), with log.csv, summary.json and the
  // controllers' files when out_dir is set
  RunResult run(long max_steps = -1);
  // the result and metrics as of now
  RunResult result() const;
  // restart from the initial state (replay)
  void reset();
  // restart every controller's state at the engine's current state (after a history scrub)
  void reset_controllers();

  // branching: the whole state (engine, controller states, progress, time)
  void save(SimulationState& state) const;
  void restore(const SimulationState& state);
  // a simulation of the same model on a new engine, at this one's state
  std::unique_ptr<Simulation> clone() const;
  // the state as a file (binary; checked against this model's sizes and types when read)
  void write_state(const std::string& path) const;
  void read_state(const std::string& path);

  void add_observer(StepObserver* observer) { observers_.push_back(observer); }
  void remove_observer(StepObserver* observer);

  Engine& engine() { return *engine_; }
  const Engine& engine() const { return *engine_; }
  const SimulationModel& model() const { return *model_; }
  std::shared_ptr<const SimulationModel> shared_model() const { return model_; }
  const Scenario& scenario() const { return model_->scenario; }
  const std::string& source() const { return model_->source; }
  const std::vector<std::shared_ptr<const Controller>>& controllers() const { return controllers_; }
  ControllerState& controller_state(size_t i) { return *states_.at(i); }
  const ControllerState& controller_state(size_t i) const { return *states_.at(i); }
  // a controller's state as its type (throws std::logic_error on a wrong type)
  template <class S>
  S& state_as(size_t i) {
    auto* s = dynamic_cast<StateOf<S>*>(&controller_state(i));
    if (!s) throw std::logic_error("controller state of another type");
    return s->value;
  }
  // compose one more controller with the scenario's (the Python module's sim.add_controller);
  // its state starts at the engine's current state. It is not part of the shared model: clones
  // take it along, but its log signals are not in log.csv.
  void add_controller(std::shared_ptr<const Controller> controller);
  // replace controller i (a live parameter edit); its state is kept when the new model
  // keeps_state_of the old one, else made fresh at the engine's current state
  void replace_controller(size_t i, std::shared_ptr<const Controller> controller);
  // new planner parameters for the rest of the run (the viewer's sliders): the next plan uses
  // them, warm-started from the current plan; enabled: false stops planning and drops the
  // correction. Throws InputError when the run does not plan, or for a change that needs a new
  // rollout model (timestep); the parameters are checked as the scenario's are.
  void set_planner_params(const PlannerParams& params);
  const RunProgress& progress() const { return progress_; }
  // the planner's handle (with save, restore and step, its rollout interface): the correction
  // plan the next steps apply, part of the run's state; a rollout sets it, then steps
  CorrectionPlan& correction_plan() { return progress_.plan; }
  // set between steps by the viewer; reset() clears them
  ExternalForces& external_forces() { return progress_.external; }
  // what the controllers commanded in the last step (tau already scaled by torque_scale)
  const ControlOutput& last_output() const { return out_; }
  // the controllers' log values now, appended (signal_names order)
  void signals(std::vector<double>& values) const;
  double time() const { return engine_->time(); }
  // the planner of this run (src/plan/planner.h: planner_of); null when the scenario plans
  // nothing (and in rollouts)
  const CorrectionSource* planner() const { return planner_.get(); }
  // the correction applied in the last step, in each dimension's unit (planner's dimensions)
  const Eigen::VectorXd& correction() const { return correction_; }
  // benchmarks: add each controller's compute() wall time (s) into `seconds` (one entry per
  // controller) on every step; null: off
  void time_controllers(std::vector<double>* seconds) { controller_seconds_ = seconds; }

 private:
  void start_run();
  void detect_fall();
  void snapshot_controller_metrics();
  // the Reporting controllers' end-of-run metrics, merged into `metrics`
  void add_controller_metrics(nlohmann::json& metrics) const;
  void add_limits_per_dof(nlohmann::json& torque_limit) const;
  // the controllers' (and the planner's) outputs into out_; false (diverged) when non-finite
  bool compute_controls();
  void limit_torques();
  void send_velocity_commands(const Eigen::VectorXd& commands);
  // a non-finite command from controller i stops the run as a divergence
  bool check_output(size_t i, double t);
  // CPU seconds this run's stepping thread and its planners' threads have used so far
  double run_cpu_seconds() const;

  std::shared_ptr<const SimulationModel> model_;
  std::unique_ptr<Engine> engine_;
  std::vector<std::shared_ptr<const Controller>> controllers_;
  std::vector<std::unique_ptr<ControllerState>> states_;
  RunProgress progress_;
  ControlOutput out_;
  std::vector<StepObserver*> observers_;
  RunOptions run_files_;  // out_dir and progress for run()
  std::vector<double>* controller_seconds_ = nullptr;
  Eigen::VectorXd correction_;                 // this step's correction, dim planner dimensions
  std::unique_ptr<CorrectionSource> planner_;  // made when the model plans
  double retired_planners_cpu_s_ = 0;          // own threads' CPU of planners replaced by retuning
  // a rollout's steps that still hold out_ (planner.control_every)
  int held_steps_left_ = 0;
  // the generalised force the controls ask for (actuators' moment^T ctrl), when a controller
  // drives actuators (LQR): its request counts against the limits as torques do
  Eigen::MatrixXd ctrl_moment_;
  Eigen::VectorXd ctrl_request_;
  bool ctrl_measurable_ = true;
};

// build the engine of a scenario with its initial pose applied (no controllers)
// (`loaded`, when given, locates an unknown initial_pose dof at its line in the file)
std::unique_ptr<Engine> make_scenario_engine(const Scenario& s, const std::string& engine_name,
                                             const LoadedScenario* loaded = nullptr);

// the one lock around model loading (MuJoCo's XML compiler is not reentrant)
std::mutex& model_load_mutex();

// parse "body,fx,fy,fz,start,duration"
Perturbation parse_push(const std::string& text);

}  // namespace stance
