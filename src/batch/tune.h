// Robust parameter search: a few `--set` key paths tuned together so that a scenario survives
// (and scores well) not only at its nominal setting but also on perturbed neighbours.
//
// Objective (lower is better). One run scores
//     fall_penalty * (duration - time_up) + metric
// where time_up is the fall time (the duration when the run stays up, 0 when it diverged or
// failed) and metric is a number from RunResult::metrics (0 without --metric). A candidate's
// robust score is the maximum over its runs: the nominal point and every neighbour.
//
// Search, in the box normalised to [0, 1] per parameter (log-scaled where asked), by one of:
//  - "cem", a cross-entropy method (math/cem.h; the default): generation 0 is the scenario's
//    current point followed by a Latin-hypercube sample of the box; later generations sample a
//    Gaussian around the mean of the elite candidates so far, with a spread that shrinks to
//    theirs;
//  - "cmaes", CMA-ES (math/cmaes.h) started at the scenario's current point with step 0.3 of
//    the box and lambda = population; candidate 0 of generation 0 is the start itself. Points
//    outside the box are drawn again (up to 10 times), then clamped. A last generation cut
//    short by the budget is evaluated but not told to the optimiser (nothing follows it).
// All random numbers come from one std::mt19937_64 seeded by `seed` on the calling thread, and
// the runs of a generation share nothing, so the result is identical for any thread count.
//
// Resuming: after each generation TuneResult::checkpoint holds everything needed to go on (the
// options that matter, every candidate with its runs, the optimiser's state and the generator's);
// run_tune given it continues with the next generation and ends with the same result as an
// uninterrupted search.
//
// Outputs (write_tune_outputs):
//  - tune.csv:           one row per candidate: generation, index, each value, robust score,
//                        worst time up, mean metric, failed runs
//  - best.yaml:          the best point as key path: value, with its `--set` lines in comments
//  - best_scenario.yaml: the scenario (after --set) with the best point applied
#pragma once

#include <nlohmann/json.hpp>

#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "batch/batch_options.h"
#include "sim/simulation.h"

namespace stance {

// parse "--param key=lo:hi[:log]"; throws InputError naming --param and the text
TuneParam parse_tune_param(const std::string& text);
// parse "--neighbour a*=0.85,b=0.001"; throws InputError naming --neighbour and the text
Neighbour parse_neighbour(const std::string& text);

// the number at a dotted key path of a YAML tree ("controllers.0.kp"), if there is one
std::optional<double> yaml_number_at(const YAML::Node& root, const std::string& key);
// applies a neighbour to a scenario tree: "k*=f" multiplies the number at k (InputError when
// there is none), "k=v" is apply_yaml_override
void apply_neighbour(YAML::Node& root, const Neighbour& n);

// a number at a dotted path into a run's metrics ("mocap.mean_joint_error_deg"); also accepts a
// top-level key that itself contains dots, weighted sums of such paths
// ("mocap.mean_joint_error_deg+2*mocap.mean_root_error_m") and one-sided penalties,
// below(path,c) = max(0, c - value) and above(path,c) = max(0, value - c)
std::optional<double> metric_at(const nlohmann::json& metrics, const std::string& path);

// the score of one run
struct TuneRun {
  double score = 0;
  double time_up = 0;  // s
  std::optional<double> metric;
  bool fell = false, diverged = false;
  std::string error;  // non-empty: the run threw (or its metric was not a finite number)
};

// scores a finished run: `duration` is the run's full length (s)
TuneRun score_run(const RunResult& r, double duration, const std::string& metric,
                  double fall_penalty);
// a failed run (threw or diverged before producing a result)
TuneRun failed_run(const std::string& error, double duration, double fall_penalty);

struct TuneCandidate {
  int generation = 0, index = 0;  // index within its generation
  std::vector<double> values;     // one per TuneOptions::params
  std::vector<TuneRun> runs;      // nominal, then one per neighbour
  double robust_score = 0;        // max of the runs' scores
  double worst_time_up = 0;       // min of the runs' time up
  double mean_metric = 0;         // over runs with a metric; NaN when none has one
  int failed_runs = 0;            // runs that diverged or threw
};

// fills robust_score, worst_time_up, mean_metric and failed_runs from runs
void aggregate_runs(TuneCandidate& c);

struct TuneResult {
  std::vector<TuneCandidate> candidates;  // in evaluation order; candidates[0] is the start
  int best = 0;                           // index into candidates
  int generations = 0;                    // planned: ceil(budget / population)
  int finished_generations = 0;           // done (less than generations only when interrupted)
  bool interrupted = false;               // stopped by TuneOptions::interrupt
  double duration = 0;                    // s, of the nominal run
  std::vector<std::string> notes;         // e.g. a start value outside its range, clamped
  std::string scenario_yaml;              // the scenario after --set and the best point, as YAML
  nlohmann::json checkpoint;              // after the last finished generation: the resume state
};

// the `--set` assignments of a candidate, "key=value" with the shortest exact number text
std::vector<std::string> tune_assignments(const TuneOptions& o, const TuneCandidate& c);

// validates everything (params, keys, neighbours, metric, engine) before the long work and
// throws InputError naming the argument; then searches. on_generation (optional) is called
// after each generation with the result so far (its checkpoint and scenario_yaml filled in).
// resume_from (optional) is a checkpoint of an interrupted search with the same options
// (check_tune_resume): its generations are kept and the search goes on from there.
TuneResult run_tune(
    const TuneOptions& options,
    const std::function<void(const TuneResult& so_far, int generation)>& on_generation = {},
    const nlohmann::json* resume_from = nullptr);

// throws InputError "--resume <where>: option 'x' was A in the interrupted run, now B" when a
// checkpoint was made with other options (threads do not count), or "<where>: not a stance tune
// resume file" when it is not one
void check_tune_resume(const TuneOptions& options, const nlohmann::json& checkpoint,
                       const std::string& where);

// writes tune.csv, best.yaml and best_scenario.yaml into dir (created if needed)
void write_tune_outputs(const std::string& dir, const TuneOptions& options,
                        const TuneResult& result);

}  // namespace stance
