// Live tuning of a running scenario's controllers, as the viewer's parameter panel does it.
//
// Controllers are immutable Model + State (CONVENTIONS.md), so a changed parameter rebuilds the
// controller: its params_yaml() gets the edit, the registry builds a new controller from it on
// the same engine, and the new controller starts from a fresh State (reset()) at the current
// physics state. The physics state itself is untouched.
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

#include "params/param_list.h"
#include "scenario/runner.h"
#include "scenario/scenario.h"

namespace stance {

// set controller `index`'s parameter `path` (a path from its tunable_params()) to `value` and
// swap the rebuilt controller into `run`. Throws InputError when the value is rejected; the
// running controller is then kept.
void retune_controller(ScenarioRun& run, const LoadedScenario& loaded, int index,
                       const std::string& path, double value);

// the scenario document with each controller block replaced by the running controller's
// params_yaml() (what "save scenario" writes)
YAML::Node tuned_scenario_yaml(ScenarioRun& run, const LoadedScenario& loaded);

}  // namespace stance
