// The planar SIMBICON walk at 1700 Hz: real-time factor per engine (goal >= 30x headless) and
// the controller's share of a step. One iteration is one simulated second (1700 steps) of the
// steady walk, started after 3 s of walking.
//   rtf              simulated seconds per wall second
//   rtf_cpu          simulated seconds per CPU second of this process
//   controller_share fraction of the step's wall time spent in Simbicon::compute
//   controller_ns    nanoseconds per compute() call
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <string>

#include "control/controller.h"
#include "engine/engine.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace {

void simbicon_walk(benchmark::State& state, const std::string& engine_name) {
  stance::LoadedScenario loaded =
      stance::load_scenario(std::string(STANCE_SOURCE_DIR) + "/scenarios/simbicon_walk.yaml");
  stance::RunOptions options;
  options.engine = engine_name;
  stance::Simulation run(loaded, options);
  stance::Engine& e = run.engine();
  const int steps_per_second = static_cast<int>(std::lround(1.0 / e.timestep()));

  // the simulation's own step, with the controller timed on its own
  std::vector<double> timed_s(1, 0.0);
  run.time_controllers(&timed_s);
  double controller_s = 0;
  auto one_second = [&](bool timed) {
    for (int k = 0; k < steps_per_second; ++k) run.step();
    if (timed) controller_s += timed_s[0];
    timed_s[0] = 0;
  };
  for (int s = 0; s < 3; ++s) one_second(false);

  auto wall0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  long seconds = 0;
  for (auto _ : state) {
    one_second(true);
    ++seconds;
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
  // on a shared machine the CPU-time factor is the one to compare with an idle core
  state.counters["rtf_cpu"] = cpu > 0 ? seconds / cpu : 0.0;
  state.counters["rtf"] =
      benchmark::Counter(static_cast<double>(seconds), benchmark::Counter::kIsRate);
  state.counters["controller_share"] = wall > 0 ? controller_s / wall : 0.0;
  state.counters["controller_ns"] =
      seconds ? 1e9 * controller_s / (seconds * steps_per_second) : 0.0;
  state.SetLabel(engine_name + ", 1700 Hz, 1 iteration = 1 simulated s");
}

void BM_SimbiconWalkMujoco(benchmark::State& state) {
  simbicon_walk(state, "mujoco");
}
BENCHMARK(BM_SimbiconWalkMujoco)->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef STANCE_HAVE_DART
void BM_SimbiconWalkDart(benchmark::State& state) {
  simbicon_walk(state, "dart");
}
BENCHMARK(BM_SimbiconWalkDart)->Unit(benchmark::kMillisecond)->UseRealTime();
#endif

}  // namespace
