// Robustness maps (after Park et al. 2022): how hard, from which side and at which moment of the
// gait a scenario can be pushed. For every horizontal direction and every phase, the largest push
// survived is found by the same bisection as push-threshold (bisect_push); each trial is a fresh
// run with one extra push and gets an outcome code.
//
// Definitions (docs/robustness.md):
//  - feet: the scenario's fall.allowed_contacts, else the bodies that touch the ground in the
//    unpushed run; a body below another foot body (a toe under a heel) is the same foot.
//  - touchdown: a foot touching the ground after at least min_air_s off it.
//  - walker: the unpushed run has at least two touchdowns after the warm-up (`at`). Phase j of n
//    starts the push at t0 + (j / n) (t1 - t0), t0 and t1 the first two touchdowns after `at`
//    (phase 0 is a touchdown). A standing scenario's phase j starts at at + j * phase_spacing_s.
//  - outcome: 0 success; 1 fell before the push; 2 fell after it (or diverged); 3 survived but
//    needed more than max_recovery_steps recovery steps (walkers) or took a step (standing: a foot
//    that was down at the push start left the ground).
//  - recovery steps: touchdowns in the recovery window after the push ends minus those of the
//    unpushed run over the same time.
//  - detour: the largest horizontal distance between the pushed and the unpushed root (body 0's
//    origin) at the same time, from the push start to the trial's end.
//  - survived (for the bisection): outcome 0 or 3.
//  - directions: evenly spaced in the plane normal to gravity, angle 0 along world x projected
//    on it, counterclockwise seen from above. A planar model (its pushed point can move along one
//    horizontal direction only) gets that direction's two senses.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "batch/batch_options.h"
#include "sim/scenario.h"

namespace stance {

enum class PushOutcome { kSuccess = 0, kFellBefore = 1, kFellAfter = 2, kManySteps = 3 };

// one trial's code: a fall (or divergence) at fall_time before push_start is 1, at or after it
// 2; else 3 when the run stepped more than allowed (walkers) or took a step (standing), else 0
PushOutcome push_outcome(std::optional<double> fall_time, double push_start, bool stepped);

struct RobustnessTrial {
  int direction = 0, phase = 0;
  double force = 0;  // N, magnitude along the direction
  int outcome = 0;
  std::optional<double> fall_time;  // s
  int touchdowns = 0;               // in the recovery window
  int recovery_steps = 0;           // touchdowns minus the unpushed run's
  double detour_m = 0;
  bool survived() const { return outcome == 0 || outcome == 3; }
};

struct RobustnessCell {
  bool done = false;  // searched (false only in an interrupted result)
  int direction = 0, phase = 0;
  double threshold = 0;        // N, largest force survived (0 when even 0 falls)
  std::optional<double> fell;  // N, smallest found to fall; none: max_force survived
  int outcome_at_threshold = 0;
  bool falls_unpushed = false;
  std::vector<RobustnessTrial> trials;  // in the order they ran
};

struct RobustnessResult {
  std::string scenario, engine;
  bool walker = false;
  bool planar = false;
  double step_period_s = 0;                  // walkers: t1 - t0
  double duration_s = 0;                     // of every run
  std::vector<std::string> feet;             // one name per foot (its top body)
  std::vector<Eigen::Vector3d> directions;   // unit, world frame
  std::vector<double> angles_deg;            // of each direction in the horizontal plane
  std::vector<double> phase_fractions;       // j / n
  std::vector<double> push_starts;           // s, per phase
  std::optional<double> unpushed_fall_time;  // s
  std::vector<RobustnessCell> cells;         // direction-major: cell(d, p) = d * phases + p
  std::vector<std::string> notes;            // what the command chose and why
  bool interrupted = false;  // stopped by RobustnessOptions::interrupt: some cells not done

  const RobustnessCell& cell(int direction, int phase) const {
    return cells.at(direction * phase_fractions.size() + phase);
  }
  // min, mean and max threshold, and the weakest cell
  nlohmann::json summary() const;
};

// the whole map. Bad input (body, counts, bounds) throws InputError before any trial runs.
// on_cell (optional) is called under a lock as each direction and phase finishes. `finished`
// (a resumed run's cells, as saved from on_cell) are taken as they are, not searched again;
// searching is deterministic, so the result equals an uninterrupted run's.
RobustnessResult run_robustness(
    const LoadedScenario& loaded, const RobustnessOptions& options,
    const std::function<void(const RobustnessCell&, int done, int total)>& on_cell = {},
    const std::vector<RobustnessCell>& finished = {});

// a cell as JSON and back (the resume file): numbers round-trip exactly
nlohmann::json cell_to_json(const RobustnessCell& cell);
RobustnessCell cell_from_json(const nlohmann::json& j);

// summary.json's content: the result's summary with the options and what was chosen
nlohmann::json robustness_summary(const RobustnessOptions& options, const RobustnessResult& result);

// robustness.csv, thresholds.csv and summary.json into dir (created if needed)
void write_robustness_outputs(const std::string& dir, const RobustnessOptions& options,
                              const RobustnessResult& result);
// robustness.png (and its .gp): threshold against direction, one curve per phase (gnuplot); with
// two directions (a planar model) bars per phase instead.
// Returns the PNG path; InputError when gnuplot is missing or fails.
std::string plot_robustness(const std::string& dir, const RobustnessResult& result);

}  // namespace stance
