#include "plan/objective.h"

#include <fmt/format.h>

#include "core/error.h"
#include "engine/engine.h"
#include "plan/track_or_balance.h"
#include "sim/simulation.h"

namespace stance {

const std::vector<ObjectiveEntry>& planner_objectives() {
  static const std::vector<ObjectiveEntry> entries = {
      {"track_or_balance", make_track_or_balance,
       "a tracked reference's errors, else balance where the run started"},
  };
  return entries;
}

const ObjectiveEntry* find_objective(std::string_view name) {
  for (const ObjectiveEntry& e : planner_objectives())
    if (e.name == name) return &e;
  return nullptr;
}

void check_objective(const std::string& name, const std::string& where) {
  if (find_objective(name)) return;
  std::vector<std::string> names;
  for (const ObjectiveEntry& e : planner_objectives()) names.emplace_back(e.name);
  const std::string msg =
      fmt::format("planner.objective: unknown objective '{}'{}", name, did_you_mean(name, names));
  throw InputError(where.empty() ? msg : fmt::format("{}: {}", where, msg));
}

RunStart resolve_run_start(const SimulationModel& model, const Engine& e) {
  RunStart start;
  if (e.nbody() > 0) {
    start.root_body = 0;
    start.root_up_local = e.body_pose(0).quat.conjugate() * model.up;
  }
  for (int b = 0; b < static_cast<int>(model.allowed_contact.size()); ++b)
    if (model.allowed_contact[b]) start.support_bodies.push_back(b);
  if (!start.support_bodies.empty())
    start.com_over_support0 = horizontal(e.com() - support_center(start, e), model.up);
  return start;
}

bool tracking_error(const Simulation& sim, TrackingError& total) {
  total = TrackingError{};
  bool tracked = false;
  TrackingError one;
  for (size_t i = 0; i < sim.controllers().size(); ++i) {
    one = TrackingError{};
    const Tracking* tracking = sim.controllers()[i]->as<Tracking>();
    if (!tracking || !tracking->tracking_error(sim.controller_state(i), sim.engine(), one))
      continue;
    tracked = true;
    total.joint_rad += one.joint_rad;
    total.root_m += one.root_m;
    total.body_m += one.body_m;
    total.root_tilt_rad += one.root_tilt_rad;
  }
  return tracked;
}

}  // namespace stance
