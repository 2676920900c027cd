// A parameter sweep: one scenario run for each value of any `--set` key path, on several
// threads, each run with its own engine. Results come back in the order of the values and do
// not depend on the thread count (runs share nothing and no run reads a clock or a global RNG).
//
// Outputs (write_sweep_outputs):
//  - sweep.csv:  one row per value: "<param>,fell,diverged,sim_time,error,<scalar metrics...>";
//                the metric columns are the union of every run's scalar metrics, in key order;
//                timing metrics (realtime_factor) are left out so that the file is reproducible
//  - points.csv: "<param>,metric,index,y": every element of every list-valued metric (e.g. the
//                slope walker's steady_step_lengths_m, the points of a bifurcation diagram)
//  - <metric>.png and .gp with plot_sweep(): the points of one list metric against the value
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "batch/batch_options.h"
#include "sim/simulation.h"

namespace stance {

struct SweepPoint {
  double value = 0;
  RunResult result;
  std::string error;  // non-empty: this run failed (it has no result)
  bool done = false;  // ran to its end (false only when the sweep was interrupted)
};

// a point as JSON and back (MPI gathering, the resume file); numbers round-trip exactly
nlohmann::json sweep_point_to_json(const SweepPoint& point);
SweepPoint sweep_point_from_json(const nlohmann::json& j);

// `steps` values from `from` to `to` inclusive (steps >= 1; steps == 1 gives `from`)
std::vector<double> linspace(double from, double to, int steps);

// parse "1,2.5,4" into numbers; throws InputError naming the bad entry
std::vector<double> parse_value_list(const std::string& text);

// the override text for one value: shortest form that reads back exactly
std::string format_sweep_value(double value);

// runs every value. Bad input (scenario, key path, first value) throws InputError before any
// thread starts. on_done (optional) is called under a lock as each run finishes, with its index.
// `finished` (a resumed sweep's points by index, as saved from on_done) are not run again.
std::vector<SweepPoint> run_sweep(
    const SweepOptions& options,
    const std::function<void(const SweepPoint&, int index, int done, int total)>& on_done = {},
    const std::map<int, SweepPoint>& finished = {});

// shared with the tuner (batch/tune.h):
// builds the run under a process-wide lock (model loading is not guaranteed thread-safe), then
// runs it with wall_time_s zeroed so that results are reproducible
RunResult run_without_timing(const LoadedScenario& loaded, const RunOptions& options);

// writes sweep.csv and points.csv into dir (created if needed)
void write_sweep_outputs(const std::string& dir, const std::string& param,
                         const std::vector<SweepPoint>& points);

// the list metrics present in the points, in key order
std::vector<std::string> sweep_list_metrics(const std::vector<SweepPoint>& points);

// plots points.csv's `metric` against the value with gnuplot into dir/<png_name>; writes the
// script beside it. Throws InputError when gnuplot is missing or fails. Returns the PNG path.
std::string plot_sweep(const std::string& dir, const std::string& param, const std::string& metric,
                       const std::string& title, const std::string& png_name);

// writes `script` as dir/<script_name> and runs gnuplot on it, which must write the PNG named by
// its variable `png` (set on the command line to a temporary, renamed to dir/<png_name> when
// gnuplot is done). Throws InputError when gnuplot is missing or fails. Returns the PNG path.
std::string render_gnuplot(const std::string& dir, const std::string& script_name,
                           const std::string& script, const std::string& png_name);

}  // namespace stance
