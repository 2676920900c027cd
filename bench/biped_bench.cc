// S0's standing biped (scenarios/biped_stand.yaml, fullbody1, dt 1 ms) per engine: the bare
// engine step against the step with SPD + ankle strategy, measured in one run so that the
// ratios do not depend on how busy the shared machine was between benchmarks.
// One iteration is 100 bare steps from a saved standing state (zero torques; restored before
// each block so the biped does not fall) followed by 100 controlled steps of the standing run.
//   step_us           one bare step (forward + step), microseconds
//   controlled_us     one controlled step (forward + controllers + step)
//   controller_us     the controllers' compute() calls within a controlled step
//   <type>_us         the same per controller (stable_pd_us, ankle_strategy_us)
//   controller_share  controller_us / controlled_us (target <= 5%)
//   cpu_per_wall      this process's CPU time over wall time (1 on an idle core)
#include <benchmark/benchmark.h>

#include <string>

#include "step_share.h"

namespace {

using stance::bench::ControlledLoop;

const std::string kScenario = std::string(STANCE_SOURCE_DIR) + "/scenarios/biped_stand.yaml";

void biped_stand(benchmark::State& state, const std::string& engine_name) {
  // settled for 1 s; the controlled copy stands on (it is not restored)
  // (bench/report.sh compares controlled_us with the seed's loop, run beside it)
  stance::bench::measure_step_share(state, kScenario, engine_name, 1000, false);
  state.SetLabel(engine_name + ", 1 iteration = 100 bare + 100 controlled 1 ms steps");
}

// the controllers' compute() alone, on a fixed standing state
void biped_controllers(benchmark::State& state, const std::string& engine_name) {
  stance::LoadedScenario loaded = stance::load_scenario(kScenario);
  stance::RunOptions options;
  options.engine = engine_name;
  options.quiet = true;
  stance::Simulation run(loaded, options);
  ControlledLoop loop(run);
  for (int k = 0; k < 1000; ++k) loop.step(false);
  stance::Engine& e = run.engine();
  e.forward();
  stance::ControlOutput out;
  out.resize(e.nv(), e.nu());
  for (auto _ : state) {
    out.clear();
    for (size_t i = 0; i < run.controllers().size(); ++i)
      run.controllers()[i]->compute(run.controller_state(i), e, out);
    benchmark::DoNotOptimize(out.tau.data());
  }
  state.SetLabel(engine_name + ", SPD + ankle strategy compute()");
}

void BM_BipedStandMujoco(benchmark::State& state) {
  biped_stand(state, "mujoco");
}
BENCHMARK(BM_BipedStandMujoco)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_BipedControllersMujoco(benchmark::State& state) {
  biped_controllers(state, "mujoco");
}
BENCHMARK(BM_BipedControllersMujoco)->Unit(benchmark::kMicrosecond);

#ifdef STANCE_HAVE_DART
void BM_BipedStandDart(benchmark::State& state) {
  biped_stand(state, "dart");
}
BENCHMARK(BM_BipedStandDart)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_BipedControllersDart(benchmark::State& state) {
  biped_controllers(state, "dart");
}
BENCHMARK(BM_BipedControllersDart)->Unit(benchmark::kMicrosecond);
#endif

}  // namespace
