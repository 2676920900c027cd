// stance's batch stepping against bare engine stepping of the same model: one iteration is a
// 1 s run of the planar SIMBICON model (1700 steps, no controllers) through Simulation::step
// (the step loop, fall detection, metrics), interleaved in blocks of 100 with as many bare
// Engine::step calls on the same engine (so both touch the same memory and contacts).
//   run_us, bare_us  one step of each
//   overhead         run_us / bare_us - 1 (goal: 10% or less)
#include <benchmark/benchmark.h>

#include <chrono>
#include <string>

#include "engine/engine.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace {

using Clock = std::chrono::steady_clock;

void BM_BatchLoopOverhead(benchmark::State& state) {
  const stance::LoadedScenario loaded =
      stance::load_scenario(std::string(STANCE_SOURCE_DIR) + "/scenarios/simbicon_walk.yaml",
                            {"controllers=[]", "duration=1", "fall.enabled=false"});
  stance::RunOptions options;
  options.quiet = true;
  const auto model = stance::make_simulation_model(loaded, options);
  double run_s = 0, bare_s = 0;
  long steps = 0;
  for (auto _ : state) {
    stance::Simulation sim(model);
    stance::Engine& e = sim.engine();
    while (!sim.done()) {
      auto t0 = Clock::now();
      for (int k = 0; k < 100; ++k) sim.step();
      run_s += std::chrono::duration<double>(Clock::now() - t0).count();
      t0 = Clock::now();
      for (int k = 0; k < 100; ++k) {
        e.forward();
        e.step();
      }
      bare_s += std::chrono::duration<double>(Clock::now() - t0).count();
      steps += 100;
    }
  }
  state.counters["run_us"] = steps ? 1e6 * run_s / steps : 0.0;
  state.counters["bare_us"] = steps ? 1e6 * bare_s / steps : 0.0;
  state.counters["overhead"] = bare_s > 0 ? run_s / bare_s - 1 : 0.0;
}
BENCHMARK(BM_BatchLoopOverhead)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
