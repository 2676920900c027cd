// Controllers: the runtime face of the Model/Data split.
//
// A concrete controller keeps immutable Params and a Model (indices, gains, K) built once from
// the engine, and a State (FSM state, previous offsets, work vectors) made by reset(). compute()
// reads the engine and *adds* its outputs, so controllers compose by summing; it must not
// allocate.
#pragma once

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "control/marker.h"
#include "params/param_list.h"
#include "params/yaml_params.h"

namespace stance {

class Engine;

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

class Controller {
 public:
  virtual ~Controller() = default;
  virtual std::string_view type() const = 0;

  // fresh per-run state; called before the first compute() and on replay
  virtual void reset(const Engine& engine) = 0;
  // add this step's outputs; engine.forward() has been called. No allocation.
  virtual void compute(const Engine& engine, ControlOutput& out) = 0;

  // key signals for log.csv: names fixed after construction, values filled per log row
  virtual void signal_names(std::vector<std::string>& names) const {}
  virtual void signals(std::vector<double>& values) const {}
  // end-of-run metrics, merged into summary.json "metrics"
  virtual void add_metrics(nlohmann::json& metrics) const {}
  // extra output files (e.g. steps.csv) into the run's output folder, at the end of a run
  virtual void write_outputs(const std::string& out_dir) const {}
  // the parameters as YAML (for saving a tuned scenario)
  virtual YAML::Node params_yaml() const = 0;
  // the numeric parameters for live tuning, in params_yaml()'s key paths (the viewer's panel).
  // The default lists params_yaml()'s numbers without units or ranges; controllers override it
  // with list_params(params) to give the visit's units, ranges and help.
  virtual std::vector<ParamEntry> tunable_params() const {
    std::vector<ParamEntry> out;
    list_yaml_params(params_yaml(), "", out);
    return out;
  }
  // what the viewer and the recorder draw for this controller (appended to `out`, world frame)
  virtual void markers(const Engine& engine, std::vector<Marker>& out) const {}
  // the pose being tracked (dim nq, the engine's layout) at the engine's time, drawn as a ghost;
  // false when the controller tracks no pose
  virtual bool reference_qpos(const Engine& engine, Eigen::VectorXd& qpos) const { return false; }
  // the state a run should start from (dim nq and nv), applied by the runner once the
  // controllers are built (a tracked clip's first frame); false: the scenario's own start
  virtual bool initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                             Eigen::VectorXd& qvel) const {
    return false;
  }
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
};

using ControllerFactory = std::function<std::unique_ptr<Controller>(
    const YAML::Node& params, const ControllerContext& ctx, const Engine& engine)>;

struct ControllerType {
  std::string name;
  std::string summary;
  ControllerFactory make;
};

const std::vector<ControllerType>& controller_registry();
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
