// What the batch commands take: the options of a sweep (batch/sweep.h), a push threshold
// (batch/push_threshold.h), a robustness map (batch/robustness.h) and a tune (batch/tune.h),
// in one light header so that the CLI's command structs (app/commands.h) hold them as they are
// and bind their options to these fields, instead of copying them over one by one.
#pragma once

#include <Eigen/Core>

#include <atomic>
#include <optional>
#include <string>
#include <vector>

namespace stance {

struct SweepOptions {
  std::string scenario;           // YAML file
  std::vector<std::string> sets;  // overrides applied to every run ("a.b=value")
  std::string param;              // key path swept, as in --set ("controllers.0.hip_kp")
  std::vector<double> values;
  int threads = 0;                 // 0: every core (std::thread::hardware_concurrency)
  std::string engine;              // overrides the scenario's when set
  std::optional<double> duration;  // s, overrides the scenario's
  // false: every point builds its controllers' models afresh (bench/lqr_bench.cc measures what
  // the shared cache saves; nothing else needs to turn it off)
  bool share_models = true;
  // set (by a signal handler): no new run starts and the running ones stop; their points come
  // back not done (SweepPoint::done)
  const std::atomic<bool>* interrupt = nullptr;
};

struct PushThresholdOptions {
  std::string body;                // body pushed
  int axis = 0;                    // 0, 1, 2: world x, y, z
  std::string engine;              // overrides the scenario's when set
  std::optional<double> duration;  // s, of each run; overrides the scenario's
  double max_force = 400;          // N, upper end of the search
  double push_duration = 0.1;      // s
  double at = 2.0;                 // s, push start
  double tolerance = 2.0;          // N, final bracket width
  int threads = 2;                 // 1: the two directions one after the other
  std::string point = "com";       // where the push acts (Perturbation::point, offset)
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};

struct RobustnessOptions {
  std::string body;                // body pushed
  int directions = 8;              // evenly spaced in the horizontal plane
  int phases = 4;                  // gait phases (walkers) or start times (standing)
  double push_duration = 0.2;      // s
  double max_force = 800;          // N, upper end of each search
  double tolerance = 2;            // N, final bracket width
  double at = 2.0;                 // s: standing, the first push start; walkers, the warm-up
  double phase_spacing_s = 0.25;   // s between a standing scenario's push starts
  double recovery_window_s = 3.0;  // s after the push in which touchdowns are counted
  int max_recovery_steps = 3;      // more: outcome 3
  double min_air_s = 0.03;         // s off the ground before a contact counts as a touchdown
  std::string point = "com";       // com or origin (Perturbation::point)
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // m, body frame (Perturbation::offset)
  std::string engine;                                // overrides the scenario's when set
  std::optional<double> duration;  // s per run; default the scenario's, at least long enough
                                   // for the last push and its recovery window
  int threads = 0;                 // 0: every core
  // set (by a signal handler): no new direction or phase starts and the running ones are
  // abandoned; the result then holds the finished ones (RobustnessResult::interrupted)
  const std::atomic<bool>* interrupt = nullptr;
};

// one searched parameter: "key=lo:hi" or "key=lo:hi:log"
struct TuneParam {
  std::string key;
  double lo = 0, hi = 1;
  bool log = false;
};

// one override of a neighbour: "key*=factor" (times the value the run would otherwise use) or
// "key=value" (as --set)
struct NeighbourOverride {
  std::string key;
  bool multiply = false;
  double factor = 1;
  std::string value;  // when !multiply: YAML text
};

struct Neighbour {
  std::string text;  // as given, for messages and the CSV
  std::vector<NeighbourOverride> overrides;
};

struct TuneOptions {
  std::string scenario;           // YAML file
  std::vector<std::string> sets;  // overrides applied to every run ("a.b=value")
  std::vector<TuneParam> params;
  std::vector<Neighbour> neighbours;  // the nominal point is always run too
  int budget = 40;                    // candidates in all
  int population = 8;                 // candidates per generation
  unsigned long long seed = 1;
  int threads = 0;                 // 0: every core
  std::string engine;              // overrides the scenario's when set
  std::optional<double> duration;  // s, overrides the scenario's
  std::string metric;              // dotted path into RunResult::metrics; empty: none
  double fall_penalty = 100;       // score per second of the duration not stayed up
  std::string method = "cem";      // "cem" or "cmaes"
  // set (by a signal handler): no new generation starts, the running one is abandoned (its
  // cut-short runs are not scored) and run_tune returns with TuneResult::interrupted
  const std::atomic<bool>* interrupt = nullptr;
};

}  // namespace stance
