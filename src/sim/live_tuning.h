// Live tuning of a running scenario's controllers, as the viewer's parameter panel does it.
//
// Controllers are immutable models with a per-run State (CONVENTIONS.md), so a changed parameter
// rebuilds the model: its params_yaml() gets the edit and the registry builds a new model from
// it. The run's State goes on under the new model when the model keeps_state_of the old one (a
// walk stays in its FSM phase); otherwise a fresh State starts at the current physics state. The
// physics state itself is untouched.
#pragma once

#include <yaml-cpp/yaml.h>

#include <future>
#include <memory>
#include <string>
#include <vector>

#include "params/param_list.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace stance {

// set controller `index`'s parameter `path` (a path from its tunable_params()) to `value` and
// swap the rebuilt controller into `run`. Throws InputError when the value is rejected; the
// running controller is then kept.
void retune_controller(Simulation& run, const LoadedScenario& loaded, int index,
                       const std::string& path, double value);

// the planner's parameters for the panel (empty when the run does not plan)
std::vector<ParamEntry> planner_params(const Simulation& run);
// set the planner's parameter `path` (a path from planner_params()) to `value` for the rest of
// the run (Simulation::set_planner_params); InputError when it is rejected (the planner is kept)
void retune_planner(Simulation& run, const std::string& path, double value);

// a controller rebuilt on a worker thread, for parameters whose rebuild is slow (the LQR costs
// re-solve the set-point, the linearisation and the DARE): the running controller keeps
// stepping until the new one is ready, and swap_into() puts it in between two steps.
//
// The worker builds on its own engine of the scenario at its initial pose, as loading does, so
// the running engine is never read off its thread.
class BackgroundRetune {
 public:
  // checks index, path and the value's range at once (InputError); other rejections (from the
  // controller's own checks) come from swap_into(). `base`: the parameters to edit, when an earlier
  // edit of the same controller is still pending; otherwise the running controller's.
  BackgroundRetune(Simulation& run, const LoadedScenario& loaded, int index,
                   const std::string& path, double value, const YAML::Node* base = nullptr);
  ~BackgroundRetune();  // waits for the worker
  BackgroundRetune(const BackgroundRetune&) = delete;
  BackgroundRetune& operator=(const BackgroundRetune&) = delete;

  // true once the worker has finished (built or failed)
  bool ready() const;
  // blocks until ready()
  void wait() const;
  // when ready: swap the new controller into `run`, reset at the run's current state, and
  // return true; false when not ready yet. Rethrows the build's error (the old controller is
  // then kept). Call between steps.
  bool swap_into(Simulation& run);

  int index() const { return index_; }
  const std::string& path() const { return path_; }
  double value() const { return value_; }
  // the edited parameters the worker builds from
  const YAML::Node& params() const { return node_; }

 private:
  struct Built;
  int index_;
  std::string path_;
  double value_;
  YAML::Node node_;
  std::future<std::shared_ptr<Built>> future_;
};

// true when rebuilding `controller` is slow enough to run in the background: the LQR designs
bool rebuild_is_slow(const Controller& controller);

// the scenario document with each controller block replaced by the running controller's
// params_yaml() (what "save scenario" writes)
YAML::Node tuned_scenario_yaml(Simulation& run, const LoadedScenario& loaded);

}  // namespace stance
