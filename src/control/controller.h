// Controllers: the runtime face of the Model/Data split.
//
// A controller is an immutable Model (Params and what is resolved from them once: indices, gains,
// K, tables), shared by every run of a scenario, and a per-run State (FSM state, previous
// offsets, work vectors, metrics) that it makes. compute() reads the engine and *adds* its
// outputs, so controllers compose by summing; it must not allocate.
#pragma once

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

#include "control/marker.h"
#include "core/state_archive.h"
#include "params/param_doc.h"
#include "params/param_list.h"
#include "params/yaml_params.h"

namespace stance {

class Engine;

// one dimension of the low-dimensional correction a controller lets the planner make (an offset
// of one of its targets), with the size of one unit of the planner's noise
struct CorrectionDim {
  std::string name;    // e.g. "swing_hip_pitch"
  double scale = 0.1;  // the offset one unit of noise makes, in `unit`
  std::string unit;    // rad, m, ...
};

// how far a run is from what a controller tracks, now (the planner's cost terms)
struct TrackingError {
  double joint_rad = 0;      // mean over tracked joints of the geodesic angle error
  double root_m = 0;         // root position error
  double body_m = 0;         // mean world position error of the tracked bodies
  double root_tilt_rad = 0;  // root orientation error about horizontal axes
};

// a controller's verdict on a fall, judged against what it tracks
enum class FallVerdict { kNoOpinion, kUp, kFell };

// what the controllers produce for one step; sized once per run
struct ControlOutput {
  Eigen::VectorXd tau;   // generalised forces, dim nv; summed over controllers
  Eigen::VectorXd ctrl;  // actuator controls, dim nu; summed over controllers
  bool ctrl_used = false;
  // velocity servo commands per dof (Engine::set_dof_velocity_command), dim nv; NaN: none.
  // Set by the controller that owns the dof, not summed; they persist until a controller
  // changes them.
  Eigen::VectorXd dof_velocity;
  bool dof_velocity_used = false;

  void resize(int nv, int nu) {
    tau = Eigen::VectorXd::Zero(nv);
    ctrl = Eigen::VectorXd::Zero(nu);
    dof_velocity = Eigen::VectorXd::Constant(nv, std::numeric_limits<double>::quiet_NaN());
  }
  void clear() {
    tau.setZero();
    ctrl.setZero();
    ctrl_used = false;
  }
};

// a controller's per-run data (FSM, previous offsets, accumulated metrics, work vectors): made by
// Controller::make_state(), copied to branch a run, written to a state file
class ControllerState {
 public:
  virtual ~ControllerState() = default;
  virtual std::unique_ptr<ControllerState> clone() const = 0;
  // become a copy of `other` (a state of the same controller type); no allocation when the
  // sizes match
  virtual void assign(const ControllerState& other) = 0;
  // the persistent fields, for the state file
  virtual void write(std::string& out) const = 0;
  virtual void read(const std::string& in, size_t& offset) = 0;
};

// `a` and `b` are states of the same controller type (so `a.assign(b)` copies in place)
inline bool same_state_type(const ControllerState& a, const ControllerState& b) {
  return typeid(a) == typeid(b);
}

// what a controller's planner rollouts need at each step of a planning horizon that depends on
// the time only (a tracked reference's samples): made by the controller, filled once per
// planning step by the planner and read by every rollout of that step, instead of being
// recomputed in each rollout. Read-only while the rollouts run.
class ReferenceHorizon {
 public:
  virtual ~ReferenceHorizon() = default;
};

// the optional interfaces a controller may offer (Controller::as<I>())
enum class ControllerInterface {
  kReporting,
  kDrawable,
  kTracking,
  kFallJudge,
  kCorrectable,
  kHorizonSampling,
  kInitialState,
  kRetunable,
};

// A controller is its immutable Model: parameters and what was resolved from them once (indices,
// gains, LQR K, tables). It is const after construction and can be shared by many runs on many
// threads; each run holds its own ControllerState.
//
// Controller holds what every controller does; what only some offer is an optional interface
// (below) that a client asks for: `if (const auto* t = c.as<Tracking>()) ...`.
class Controller {
 public:
  virtual ~Controller() = default;
  virtual std::string_view type() const = 0;

  // a fresh per-run state at the engine's current state (called at the start and on replay)
  virtual std::unique_ptr<ControllerState> make_state(const Engine& engine) const = 0;
  // restart `state` from the engine's current state, reusing its storage
  virtual void reset(ControllerState& state, const Engine& engine) const = 0;
  // add this step's outputs; engine.forward() has been called. No allocation.
  virtual void compute(ControllerState& state, const Engine& engine, ControlOutput& out) const = 0;
  // the parameters as YAML (for saving a tuned scenario; a live edit rebuilds from it)
  virtual YAML::Node params_yaml() const = 0;

  // the optional interface I (one of those below) when this controller offers it, else null.
  // No allocation, no dynamic_cast: cheap enough for the step loop.
  template <class I>
  const I* as() const {
    return static_cast<const I*>(find_interface(I::kInterface));
  }

 protected:
  // `this` as the interface `id` (a pointer to the interface's class), or null
  virtual const void* find_interface(ControllerInterface id) const { return nullptr; }
};

// --- optional interfaces: a controller offers them by listing them in TypedController<S, ...>

// log.csv columns, summary.json metrics and extra output files (Simulation, observers)
class Reporting {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kReporting;
  // key signals for log.csv: names fixed after construction (appended), values per log row
  virtual void signal_names(std::vector<std::string>& names) const {}
  virtual void signals(const ControllerState& state, std::vector<double>& values) const {}
  // end-of-run metrics, merged into summary.json "metrics"
  virtual void add_metrics(const ControllerState& state, nlohmann::json& metrics) const {}
  // extra output files (e.g. steps.csv) into the run's output folder, at the end of a run
  virtual void write_outputs(const ControllerState& state, const std::string& out_dir) const {}

 protected:
  ~Reporting() = default;
};

// what the viewer and the recorder draw for this controller (appended to `out`, world frame)
class Drawable {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kDrawable;
  virtual void markers(const ControllerState& state, const Engine& engine,
                       std::vector<Marker>& out) const = 0;

 protected:
  ~Drawable() = default;
};

// a controller that tracks a pose (the viewer's ghost, the planner's cost terms)
class Tracking {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kTracking;
  // the pose being tracked (dim nq, the engine's layout) at the engine's time; false: none now
  virtual bool reference_qpos(const ControllerState& state, const Engine& engine,
                              Eigen::VectorXd& qpos) const = 0;
  // the error against what the controller tracks now; false when it tracks nothing
  virtual bool tracking_error(const ControllerState& state, const Engine& engine,
                              TrackingError& error) const = 0;

 protected:
  ~Tracking() = default;
};

// a controller that judges a fall itself (a crouch in a tracked clip is no fall); without it,
// or on kNoOpinion, the scenario's fall criterion decides
class FallJudge {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kFallJudge;
  // `reason` is set on kFell
  virtual FallVerdict fall_verdict(const ControllerState& state, const Engine& engine,
                                   std::string& reason) const = 0;

 protected:
  ~FallJudge() = default;
};

// the planner's hook: the dimensions of the correction this controller applies to its targets;
// without it the planner corrects with residual torques
class Correctable {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kCorrectable;
  // appended; may append none (then the planner uses residual torques)
  virtual void correction_dims(std::vector<CorrectionDim>& dims) const = 0;
  // compute() with the planner's correction: one value per correction_dims() entry, in its unit
  virtual void compute_corrected(ControllerState& state, const Engine& engine,
                                 const double* correction, ControlOutput& out) const = 0;

 protected:
  ~Correctable() = default;
};

// the planner's per-step work (ReferenceHorizon) for controllers whose rollouts compute things
// that depend on the time only
class HorizonSampling {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kHorizonSampling;
  virtual std::unique_ptr<ReferenceHorizon> make_reference_horizon() const = 0;
  // fill `horizon` for `steps` steps of the engine's timestep from its time `t0` (the engine
  // gives the position arithmetic; its state is not read)
  virtual void sample_reference_horizon(ReferenceHorizon& horizon, const Engine& engine, double t0,
                                        int steps) const = 0;
  // a rollout's `state` reads `horizon` (null: none) at the times it holds, and computes other
  // times as a run does, so its outputs are the same to the bit either way. The horizon must
  // outlive the rollout.
  virtual void use_reference_horizon(ControllerState& state,
                                     const ReferenceHorizon* horizon) const = 0;

 protected:
  ~HorizonSampling() = default;
};

// a controller that gives the state a run starts from (a tracked clip's first frame), applied
// by the simulation once the controllers are built
class InitialState {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kInitialState;
  // dim nq and nv; false: the scenario's own start
  virtual bool initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                             Eigen::VectorXd& qvel) const = 0;

 protected:
  ~InitialState() = default;
};

// a controller whose parameters a live edit may change (the viewer's panel, live_tuning.h)
class Retunable {
 public:
  static constexpr ControllerInterface kInterface = ControllerInterface::kRetunable;
  // the numeric parameters, in params_yaml()'s key paths, with units, ranges and help
  virtual std::vector<ParamEntry> tunable_params() const = 0;
  // whether a state made by `previous` (the same type, other parameters) can go on under this
  // model, so that a live parameter edit keeps the walk in its FSM phase
  virtual bool keeps_state_of(const Controller& previous) const { return true; }
  // a rebuild slow enough to run in the background (the LQR designs)
  virtual bool slow_to_rebuild() const { return false; }

 protected:
  ~Retunable() = default;
};

// the tunable parameters of `c` (none when it is not Retunable)
inline std::vector<ParamEntry> tunable_params(const Controller& c) {
  const Retunable* r = c.as<Retunable>();
  return r ? r->tunable_params() : std::vector<ParamEntry>{};
}
// whether the state of `previous` goes on under `next` after a live edit: the same type, and
// `next` agrees when it is Retunable
inline bool keeps_state_of(const Controller& next, const Controller& previous) {
  if (previous.type() != next.type()) return false;
  const Retunable* r = next.as<Retunable>();
  return !r || r->keeps_state_of(previous);
}

// the per-run data of a TypedController: a value of type S. S lists its persistent fields with
// `template <class A> void serialize(A& a)` (see core/state_archive.h).
template <class S>
class StateOf final : public ControllerState {
 public:
  S value;

  template <class... Args>
  explicit StateOf(Args&&... args) : value(std::forward<Args>(args)...) {}

  std::unique_ptr<ControllerState> clone() const override {
    return std::make_unique<StateOf>(*this);
  }
  void assign(const ControllerState& other) override {
    value = static_cast<const StateOf&>(other).value;
  }
  void write(std::string& out) const override {
    StateWriter w(out);
    const_cast<S&>(value).serialize(w);
  }
  void read(const std::string& in, size_t& offset) override {
    StateReader r(in, offset);
    value.serialize(r);
    offset = r.position();
  }
};

// the base of every controller: the type-erased calls cast the state once and forward to the
// typed ones, which a controller overrides with its own State type. `Offers` are the optional
// interfaces it implements (Reporting, Tracking, ...); as<I>() finds exactly these.
template <class S, class... Offers>
class TypedController : public Controller, public Offers... {
 public:
  using State = S;

  std::unique_ptr<ControllerState> make_state(const Engine& engine) const final {
    auto s = allocate_state();
    reset_state(s->value, engine);
    return s;
  }
  void reset(ControllerState& state, const Engine& engine) const final {
    reset_state(cast(state), engine);
  }
  void compute(ControllerState& state, const Engine& engine, ControlOutput& out) const final {
    compute_step(cast(state), engine, out);
  }

  static S& cast(ControllerState& s) { return static_cast<StateOf<S>&>(s).value; }
  static const S& cast(const ControllerState& s) { return static_cast<const StateOf<S>&>(s).value; }

 protected:
  virtual std::unique_ptr<StateOf<S>> allocate_state() const {
    return std::make_unique<StateOf<S>>();
  }
  // (re)start a run: size the work vectors, capture targets, clear the FSM and the metrics
  virtual void reset_state(S& state, const Engine& engine) const = 0;
  virtual void compute_step(S& state, const Engine& engine, ControlOutput& out) const = 0;

  const void* find_interface(ControllerInterface id) const final {
    const void* found = nullptr;
    ((found = id == Offers::kInterface ? static_cast<const Offers*>(this) : found), ...);
    return found;
  }
};

// a TypedController that takes the planner's correction (Correctable): it implements
// compute_with(), which compute() calls with no correction and compute_corrected() with one
template <class S, class... Offers>
class CorrectedController : public TypedController<S, Correctable, Offers...> {
 public:
  void compute_corrected(ControllerState& state, const Engine& engine, const double* correction,
                         ControlOutput& out) const final {
    compute_with(this->cast(state), engine, correction, out);
  }

 protected:
  void compute_step(S& state, const Engine& engine, ControlOutput& out) const final {
    compute_with(state, engine, nullptr, out);
  }
  // one control step with the planner's correction (null: none)
  virtual void compute_with(S& state, const Engine& engine, const double* correction,
                            ControlOutput& out) const = 0;
};

// the registry: one line per controller type (see control/registry.cc)
struct ControllerContext {
  YamlSource source;  // scenario file, for messages
  std::string path;   // "controllers[1]"
  uint64_t seed = 0;  // the scenario's seed, mixed with the controller's position; no global RNG
  double duration_s = 0;  // the run's length; 0: unknown
  // a second engine of the same world, for controllers that probe the model's kinematics while
  // they are built (the run's own engine is const to them); empty: not available
  std::function<std::unique_ptr<Engine>()> scratch_engine;
  // built for the planner's rollouts, runs that are scored and thrown away: the controller may
  // skip its metrics, signals and recordings there (the run's own controllers keep them)
  bool rollout = false;
};

using ControllerFactory = std::function<std::shared_ptr<const Controller>(
    const YAML::Node& params, const ControllerContext& ctx, const Engine& engine)>;

// reads a controller block (a scenario's `controllers[i]` mapping, with "type") into the type's
// parameter struct and lists its numeric entries, defaults filled in; throws InputError with
// ctx.source's file and line and the key (unknown key, wrong type, out of range). No engine.
using ControllerParamsCheck =
    std::function<std::vector<ParamEntry>(const YAML::Node& params, const ControllerContext& ctx)>;

struct ControllerType {
  std::string name;
  std::string summary;
  ControllerFactory make;
  // its parameters with their defaults, units, ranges and help (`stance list NAME`)
  std::function<std::vector<ParamDoc>()> params;
  // the typed check of a block, run when a scenario is loaded (before any engine is built)
  ControllerParamsCheck check_params;
};

const std::vector<ControllerType>& controller_registry();
// the scenario entry type of controllers that live outside the registry: Python classes, built
// only when the scenario is loaded from the Python module (RunOptions::external_controllers)
inline constexpr std::string_view kExternalControllerType = "python";
// throws InputError naming the nearest type when `name` is unknown
const ControllerType& find_controller_type(const std::string& name);

// read Params from the YAML mapping `node`, minus the keys in `skip` (e.g. "type")
template <class Params>
Params read_params(const YAML::Node& node, const ControllerContext& ctx,
                   const std::vector<std::string>& skip = {"type"}) {
  Params p{};
  YamlParamReader reader(node, ctx.source, ctx.path);
  for (const auto& k : skip) reader.claim(k);
  reader.read(p);
  return p;
}

template <class Params>
YAML::Node params_to_yaml(const Params& p, std::string_view type) {
  YAML::Node out(YAML::NodeType::Map);
  out["type"] = std::string(type);
  Params copy = p;
  YamlParamWriter w(out);
  w.write(copy);
  return out;
}

}  // namespace stance
