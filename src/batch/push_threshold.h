// The largest push a scenario survives, by bisection: each trial is a fresh Simulation with one
// extra Perturbation (a force along +axis or -axis on one body) and asks whether the run fell.
// The two directions are independent bisections and can run on two threads.
// Survival need not be monotone in the force near the edge; the bracket is then one edge of
// possibly several, the one that bisection from [0, max] finds.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "batch/batch_options.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace stance {

// the outcome of one direction's bisection
struct PushBracket {
  double sign = 1;              // +1 along +axis, -1 along -axis
  double survived = 0;          // N, largest magnitude survived (0 when even 0 falls)
  std::optional<double> fell;   // N, smallest magnitude found to fall; none: max survived
  bool falls_unpushed = false;  // the run falls without the push: no threshold
  int trials = 0;
};

struct PushThresholdResult {
  PushBracket positive, negative;
};

// bisection on [0, max_force] of a predicate survives(force magnitude), assumed true at 0 until
// shown otherwise: tests max first, then 0, then halves until fell - survived <= tolerance
PushBracket bisect_push(const std::function<bool(double)>& survives, double max_force,
                        double tolerance);

// one trial: the scenario with the extra push of `signed_force` N along options.axis
bool survives_push(const LoadedScenario& loaded, const PushThresholdOptions& options,
                   double signed_force, ControllerCache* cache = nullptr);

// both directions. Bad input (body, axis, bounds) throws InputError before any thread starts.
// on_trial (optional) is called under a lock after each trial.
PushThresholdResult find_push_threshold(
    const LoadedScenario& loaded, const PushThresholdOptions& options,
    const std::function<void(double signed_force, bool survived)>& on_trial = {});

}  // namespace stance
