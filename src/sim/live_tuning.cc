#include "sim/live_tuning.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include "control/controller.h"
#include "core/error.h"
#include "engine/engine.h"
#include "params/param_list.h"
#include "params/yaml_params.h"

namespace stance {

namespace {

// the tunable entry of controller `index` at `path`; throws InputError
ParamEntry find_entry(Simulation& run, int index, const std::string& path) {
  auto& controllers = run.controllers();
  if (index < 0 || index >= static_cast<int>(controllers.size()))
    throw InputError(
        fmt::format("controller {} does not exist ({} controllers)", index, controllers.size()));
  const Controller& c = *controllers[index];
  for (const auto& e : tunable_params(c))
    if (e.path == path) return e;
  throw InputError(fmt::format("{}: no tunable parameter '{}'", c.type(), path));
}

}  // namespace

void retune_controller(Simulation& run, const LoadedScenario& loaded, int index,
                       const std::string& path, double value) {
  ParamEntry entry = find_entry(run, index, path);
  // edit the YAML form and rebuild through the registry, as loading the scenario does
  YAML::Node node = run.controllers()[index]->params_yaml();
  apply_yaml_override(node, param_assignment(entry, value));
  const ControllerType& type = find_controller_type(node["type"].Scalar());
  Engine& engine = run.engine();
  std::shared_ptr<const Controller> fresh =
      type.make(node, controller_context(run.model(), index), engine);
  engine.forward();
  run.replace_controller(index, std::move(fresh));
}

std::vector<ParamEntry> planner_params(const Simulation& run) {
  if (!run.model().plans) return {};
  return list_params(run.model().planner->params);
}

void retune_planner(Simulation& run, const std::string& path, double value) {
  if (!run.model().plans) throw InputError("planner: this run does not plan");
  const PlannerParams& now = run.model().planner->params;
  std::vector<ParamEntry> entries = list_params(now);
  auto it = std::find_if(entries.begin(), entries.end(),
                         [&](const ParamEntry& e) { return e.path == path; });
  if (it == entries.end())
    throw InputError(fmt::format("planner: no tunable parameter '{}'", path));
  // through the YAML form, as the scenario's planner block is read: the same range checks
  YAML::Node node(YAML::NodeType::Map);
  PlannerParams edited = now;
  YamlParamWriter(node).write(edited);
  apply_yaml_override(node, param_assignment(*it, value));
  PlannerParams fresh;
  YamlParamReader(node, {"planner"}, "planner").read(fresh);
  run.set_planner_params(fresh);
}

YAML::Node tuned_scenario_yaml(Simulation& run, const LoadedScenario& loaded) {
  YAML::Node doc = YAML::Clone(loaded.document);
  YAML::Node list(YAML::NodeType::Sequence);
  for (const auto& c : run.controllers()) list.push_back(c->params_yaml());
  doc["controllers"] = list;
  if (run.model().plans) {
    YAML::Node planner(YAML::NodeType::Map);
    PlannerParams params = run.model().planner->params;
    YamlParamWriter(planner).write(params);
    doc["planner"] = planner;
  }
  return doc;
}

struct BackgroundRetune::Built {
  std::unique_ptr<Engine> engine;  // what the controller was built on
  std::shared_ptr<const Controller> controller;
};

BackgroundRetune::BackgroundRetune(Simulation& run, const LoadedScenario& loaded, int index,
                                   const std::string& path, double value, const YAML::Node* base)
    : index_(index), path_(path), value_(value) {
  ParamEntry entry = find_entry(run, index, path);
  // a value out of the visit's range fails here, not later on the worker
  if ((std::isfinite(entry.meta.min) && value < entry.meta.min) ||
      (std::isfinite(entry.meta.max) && value > entry.meta.max))
    throw InputError(fmt::format("{}: {} is out of range [{}, {}]", path, value, entry.meta.min,
                                 entry.meta.max));
  // the worker owns deep copies: yaml-cpp nodes are not safe to share across threads
  node_ = YAML::Clone(base ? *base : run.controllers()[index]->params_yaml());
  apply_yaml_override(node_, param_assignment(entry, value));
  YAML::Node node = YAML::Clone(node_);
  ControllerContext ctx = controller_context(run.model(), index);
  Scenario scenario = run.scenario();
  std::string engine_name(run.engine().engine_name());
  future_ = std::async(std::launch::async, [node, ctx, scenario, engine_name] {
    auto built = std::make_shared<Built>();
    const ControllerType& type = find_controller_type(node["type"].Scalar());
    {
      std::lock_guard<std::mutex> lock(model_load_mutex());
      built->engine = make_scenario_engine(scenario, engine_name);
    }
    built->controller = type.make(node, ctx, *built->engine);
    return built;
  });
}

BackgroundRetune::~BackgroundRetune() {
  if (future_.valid()) future_.wait();
}

bool BackgroundRetune::ready() const {
  return future_.valid() && future_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

void BackgroundRetune::wait() const {
  if (future_.valid()) future_.wait();
}

bool BackgroundRetune::swap_into(Simulation& run) {
  if (!ready()) return false;
  std::shared_ptr<Built> built = future_.get();  // rethrows the worker's error
  Engine& engine = run.engine();
  engine.forward();
  run.replace_controller(index_, std::move(built->controller));
  return true;
}

bool rebuild_is_slow(const Controller& controller) {
  const Retunable* r = controller.as<Retunable>();
  return r && r->slow_to_rebuild();
}

}  // namespace stance
