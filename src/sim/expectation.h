// What a scenario shows, stated in its own file (key `expect`) and checked after every run:
// the verdict goes into summary.json ("expectation"), `stance run` prints it in one line
// (`--check` makes a miss exit 4), `make demo` lists it per scenario, and the test
// ShippedScenario/Expectation runs every file in scenarios/ against its own.
#pragma once

#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <limits>
#include <string>
#include <vector>

#include "params/params.h"

namespace stance {

// a bound on one number of summary.json's "metrics", named by its path ("min_com_height_m",
// "mocap.mean_root_error_m", "planner.rescues"); true and false count as 1 and 0
struct MetricBound {
  std::string name;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();

  template <class V>
  void visit(V& v) {
    v("name", name, {.help = "a metric of summary.json, nested ones as a.b"});
    v("min", min, {.help = "the metric is at least this"});
    v("max", max, {.help = "the metric is at most this"});
  }
};

struct Expectation {
  bool fell = false;  // the run falls (true) or stays up (false)
  std::vector<MetricBound> metrics;
  // s: how long the shipped-scenario test runs it (0: the whole duration); the file says why
  // when it is shorter, and the expectation must hold at both lengths
  double test_duration = 0;
  // whether the scenario has an `expect` block (set at load, not a key)
  bool given = false;

  template <class V>
  void visit(V& v) {
    v("fell", fell, {.help = "whether the run falls"});
    v("metrics", metrics, {.help = "bounds on summary.json's metrics"});
    v("test_duration", test_duration,
      {.unit = "s", .min = 0, .help = "the shipped-scenario test's run length; 0: the whole"});
  }
};

// the bounds' own consistency (a name, a bound, min <= max): InputError naming `source` and the
// line of the offending entry in `expect_node` (the scenario's `expect` block)
void check_expectation(const Expectation& e, const std::string& source,
                       const YAML::Node& expect_node);

// the named metrics exist in `metrics` (a run's, e.g. as it starts) as numbers that do not depend
// on the wall clock: InputError with the file and line and the nearest name otherwise
void check_expectation_metrics(const Expectation& e, const nlohmann::json& metrics,
                               const std::string& source, const YAML::Node& expect_node);

// the verdict on a run: {"held", "sim_time", "checks": [{"check", "expected" or "min"/"max",
// "found", "held"}, ...]}. A diverged or interrupted run does not hold.
nlohmann::json evaluate_expectation(const Expectation& e, const nlohmann::json& run_summary);

// one line for people: "expectation held at 10.000 s: no fall; min_com_height_m 0.91 >= 0.8"
std::string expectation_line(const nlohmann::json& verdict);

}  // namespace stance
