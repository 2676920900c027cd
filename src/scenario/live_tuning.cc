#include "scenario/live_tuning.h"

#include <fmt/format.h>

#include "control/controller.h"
#include "core/error.h"

namespace stance {

void retune_controller(ScenarioRun& run, const LoadedScenario& loaded, int index,
                       const std::string& path, double value) {
  auto& controllers = run.controllers();
  if (index < 0 || index >= static_cast<int>(controllers.size()))
    throw InputError(
        fmt::format("controller {} does not exist ({} controllers)", index, controllers.size()));
  Controller& old = *controllers[index];
  std::vector<ParamEntry> entries = old.tunable_params();
  const ParamEntry* entry = nullptr;
  for (const auto& e : entries)
    if (e.path == path) entry = &e;
  if (!entry) throw InputError(fmt::format("{}: no tunable parameter '{}'", old.type(), path));

  // edit the YAML form and rebuild through the registry, as loading the scenario does
  YAML::Node node = old.params_yaml();
  apply_yaml_override(node, param_assignment(*entry, value));
  const ControllerType& type = find_controller_type(node["type"].Scalar());
  // the same seed as the runner gives this controller, so noise streams stay reproducible
  ControllerContext ctx{{loaded.source.empty() ? "viewer" : loaded.source},
                        fmt::format("controllers[{}]", index),
                        static_cast<uint64_t>(run.scenario().seed) * 1000003ull + index};
  Engine& engine = run.engine();
  std::unique_ptr<Controller> fresh = type.make(node, ctx, engine);
  engine.forward();
  fresh->reset(engine);
  controllers[index] = std::move(fresh);
}

YAML::Node tuned_scenario_yaml(ScenarioRun& run, const LoadedScenario& loaded) {
  YAML::Node doc = YAML::Clone(loaded.document);
  YAML::Node list(YAML::NodeType::Sequence);
  for (const auto& c : run.controllers()) list.push_back(c->params_yaml());
  doc["controllers"] = list;
  return doc;
}

}  // namespace stance
