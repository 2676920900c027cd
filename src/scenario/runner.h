// The generic runner: steps the engine, calls the controllers, applies pushes, checks the fall
// criterion, and records log.csv and summary.json.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"
#include "scenario/scenario.h"

namespace stance {

struct RunOptions {
  std::string engine;                      // overrides the scenario's engine when set
  std::optional<double> duration;          // s, overrides the scenario's
  std::string out_dir;                     // where summary.json and log.csv go; empty: no files
  std::vector<Perturbation> extra_pushes;  // from the CLI
  bool quiet = false;
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
  std::string divergence;  // message with time and cause
  double wall_time_s = 0;
  long steps = 0;
  nlohmann::json metrics = nlohmann::json::object();

  nlohmann::json to_json() const;
};

// a scenario made ready to step: engine loaded, pose set, controllers built.
class ScenarioRun {
 public:
  ScenarioRun(const LoadedScenario& loaded, const RunOptions& options);
  ~ScenarioRun();

  // one control + physics step; false once the run diverged
  bool step();
  // the whole run, writing outputs when options.out_dir is set
  RunResult run();

  Engine& engine() { return *engine_; }
  const Scenario& scenario() const { return scenario_; }
  std::vector<std::unique_ptr<Controller>>& controllers() { return controllers_; }
  const RunResult& result() const { return result_; }
  // what the controllers commanded in the last step (tau already scaled by torque_scale)
  const ControlOutput& last_output() const;
  // restart from the initial state (replay)
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  Scenario scenario_;
  RunOptions options_;
  std::unique_ptr<Engine> engine_;
  std::vector<std::unique_ptr<Controller>> controllers_;
  RunResult result_;
};

// build the engine of a scenario with its initial pose applied (no controllers)
std::unique_ptr<Engine> make_scenario_engine(const Scenario& s, const std::string& engine_name);

// parse "body,fx,fy,fz,start,duration"
Perturbation parse_push(const std::string& text);

}  // namespace stance
