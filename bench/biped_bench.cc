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
//   speedup_vs_dartpy 1150 us (the seed's dartpy loop per 1 ms step) / controlled_us
#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"
#include "scenario/runner.h"
#include "scenario/scenario.h"

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kBlock = 100;               // steps per block
constexpr double kDartpyStepUs = 1150.0;  // the seed's loop, measured on these machines

const std::string kScenario = std::string(STANCE_SOURCE_DIR) + "/scenarios/biped_stand.yaml";

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// the controllers of ScenarioRun::step, each compute() timed on its own
struct ControlledLoop {
  stance::ScenarioRun& run;
  stance::ControlOutput out;
  std::vector<double> controller_s;  // per controller

  explicit ControlledLoop(stance::ScenarioRun& r) : run(r) {
    out.resize(r.engine().nv(), r.engine().nu());
    controller_s.assign(r.controllers().size(), 0.0);
  }
  void step(bool timed) {
    stance::Engine& e = run.engine();
    e.forward();
    out.clear();
    for (size_t i = 0; i < run.controllers().size(); ++i) {
      auto t0 = Clock::now();
      run.controllers()[i]->compute(e, out);
      if (timed) controller_s[i] += seconds_since(t0);
    }
    out.tau *= run.scenario().torque_scale;
    e.set_generalized_forces(out.tau);
    e.step();
  }
  double total_controller_s() const {
    double sum = 0;
    for (double s : controller_s) sum += s;
    return sum;
  }
};

void biped_stand(benchmark::State& state, const std::string& engine_name) {
  stance::LoadedScenario loaded = stance::load_scenario(kScenario);
  stance::RunOptions options;
  options.engine = engine_name;
  options.quiet = true;
  // two copies of the same scenario: one stands under control, one takes bare steps
  stance::ScenarioRun controlled(loaded, options);
  stance::ScenarioRun bare(loaded, options);
  ControlledLoop loop(controlled);
  for (int k = 0; k < 1000; ++k) loop.step(false);  // settle for 1 s
  stance::EngineState standing;
  controlled.engine().save_state(standing);
  stance::Engine& b = bare.engine();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(b.nv());

  double bare_s = 0, controlled_s = 0;
  long blocks = 0;
  const auto wall0 = Clock::now();
  const std::clock_t cpu0 = std::clock();
  for (auto _ : state) {
    b.restore_state(standing);
    auto t0 = Clock::now();
    for (int k = 0; k < kBlock; ++k) {
      b.forward();
      b.set_generalized_forces(zero);
      b.step();
    }
    bare_s += seconds_since(t0);
    t0 = Clock::now();
    for (int k = 0; k < kBlock; ++k) loop.step(true);
    controlled_s += seconds_since(t0);
    ++blocks;
  }
  const double steps = static_cast<double>(blocks) * kBlock;
  // below 1 when other processes share the core: the *_us figures are then inflated by about
  // 1 / cpu_per_wall, while the ratios between them hold
  const double wall = seconds_since(wall0);
  state.counters["cpu_per_wall"] =
      wall > 0 ? (double(std::clock() - cpu0) / CLOCKS_PER_SEC) / wall : 0.0;
  const double controlled_us = steps > 0 ? 1e6 * controlled_s / steps : 0.0;
  state.counters["step_us"] = steps > 0 ? 1e6 * bare_s / steps : 0.0;
  state.counters["controlled_us"] = controlled_us;
  const double controller_s = loop.total_controller_s();
  state.counters["controller_us"] = steps > 0 ? 1e6 * controller_s / steps : 0.0;
  state.counters["controller_share"] = controlled_s > 0 ? controller_s / controlled_s : 0.0;
  for (size_t i = 0; i < loop.controller_s.size(); ++i)
    state.counters[std::string(controlled.controllers()[i]->type()) + "_us"] =
        steps > 0 ? 1e6 * loop.controller_s[i] / steps : 0.0;
  state.counters["speedup_vs_dartpy"] = controlled_us > 0 ? kDartpyStepUs / controlled_us : 0.0;
  state.counters["com_y"] = controlled.engine().com().y();  // still standing: about -0.2 m
  state.SetLabel(engine_name + ", 1 iteration = 100 bare + 100 controlled 1 ms steps");
}

// the controllers' compute() alone, on a fixed standing state
void biped_controllers(benchmark::State& state, const std::string& engine_name) {
  stance::LoadedScenario loaded = stance::load_scenario(kScenario);
  stance::RunOptions options;
  options.engine = engine_name;
  options.quiet = true;
  stance::ScenarioRun run(loaded, options);
  ControlledLoop loop(run);
  for (int k = 0; k < 1000; ++k) loop.step(false);
  stance::Engine& e = run.engine();
  e.forward();
  for (auto _ : state) {
    loop.out.clear();
    for (auto& c : run.controllers()) c->compute(e, loop.out);
    benchmark::DoNotOptimize(loop.out.tau.data());
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
