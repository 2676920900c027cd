// What the planner scores a rollout by: an objective, chosen by the scenario's
// `planner.objective` from a registry (objective.cc), as an MJPC task supplies its residual. A
// new objective is a new file and one registry line; the planner adds the terms every objective
// shares (the correction's effort and change, the fall penalty) around it.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "control/controller.h"
#include "sim/planner_params.h"

namespace stance {

class Engine;
class Simulation;
struct SimulationModel;

// where a planning model's runs start, resolved once: the anchors of balance costs
struct RunStart {
  int root_body = -1;  // the first mobile body: its path and tilt
  Eigen::Vector3d root_up_local = Eigen::Vector3d::UnitZ();  // `up` in the root's frame at start
  // standing keeps the COM where it started over the feet (fall.allowed_contacts), so a step
  // moves the balance target with the feet; without feet, where it started in the world
  std::vector<int> support_bodies;
  Eigen::Vector3d com_over_support0 = Eigen::Vector3d::Zero();  // horizontal, at the start
};

// the start of a run of `model`, from an engine of its world at the initial state
RunStart resolve_run_start(const SimulationModel& model, const Engine& start);

// a rollout's cost terms; immutable, shared by the planner's rollout threads
class PlannerObjective {
 public:
  virtual ~PlannerObjective() = default;
  // the cost of the run's state now (>= 0: the planner stops a rollout early on a lower bound),
  // sampled every planner.cost_interval_s of a rollout
  virtual double stage_cost(const Simulation& sim) const = 0;
  // how far off the run is now (m): at planner.rescue_error_m the planner plans harder
  virtual double balance_error(const Simulation& sim) const = 0;
};

// makes an objective from the planner's parameters (its cost weights) and the run's start
using ObjectiveFactory = std::unique_ptr<const PlannerObjective> (*)(const PlannerParams& params,
                                                                     const RunStart& start);
struct ObjectiveEntry {
  std::string_view name;
  ObjectiveFactory make;
  std::string_view help;
};

// every objective, in the order `stance list` would show them
const std::vector<ObjectiveEntry>& planner_objectives();
// the entry named `name`; null when there is none
const ObjectiveEntry* find_objective(std::string_view name);
// planner.objective checked against the registry: InputError prefixed with `where` when unknown
void check_objective(const std::string& name, const std::string& where);

// the controllers' tracking errors, summed; false when none tracks a reference
bool tracking_error(const Simulation& sim, TrackingError& total);

}  // namespace stance
