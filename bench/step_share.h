// Shared by the benchmarks: Simulation::step with each controller's compute() timed, and
// the bare-step / controlled-step measurement whose ratio is the controllers' share of a step.
// Both are measured in one run, so the ratios do not depend on how busy the shared machine was
// between benchmarks.
#pragma once

#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace stance::bench {

using Clock = std::chrono::steady_clock;

constexpr int kBlock = 100;  // steps per block

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Simulation::step with each controller's compute() timed on its own
struct ControlledLoop {
  Simulation& run;
  std::vector<double> controller_s;  // per controller

  explicit ControlledLoop(Simulation& r) : run(r), controller_s(r.controllers().size(), 0.0) {
    run.time_controllers(&controller_s);
  }
  ~ControlledLoop() { run.time_controllers(nullptr); }
  void step(bool timed) {
    if (timed) {
      run.step();
      return;
    }
    std::vector<double> kept = controller_s;
    run.step();
    controller_s = kept;
  }
  double total_controller_s() const {
    double sum = 0;
    for (double s : controller_s) sum += s;
    return sum;
  }
};

// One iteration: 100 bare steps (zero torques) and 100 controlled steps, both from states saved
// after `settle_steps` controlled steps and restored before each block (so neither falls and
// every block is the same motion). Counters:
//   step_us, controlled_us, controller_us  one bare / controlled step, and the controllers'
//                                          compute() calls within a controlled step (us)
//   <type>_us                              the same per controller
//   controller_share                       controller_us / controlled_us
//   realtime_factor                        simulated over wall time of the controlled steps
//   cpu_per_wall                           this process's CPU over wall time (1 on an idle core)
// Returns the controlled step time (us).
inline double measure_step_share(benchmark::State& state, const std::string& scenario,
                                 const std::string& engine_name, int settle_steps,
                                 bool restore_controlled = true,
                                 const std::vector<std::string>& sets = {}) {
  LoadedScenario loaded = load_scenario(scenario, sets);
  RunOptions options;
  options.engine = engine_name;
  options.quiet = true;
  Simulation controlled(loaded, options);
  Simulation bare(loaded, options);
  ControlledLoop loop(controlled);
  for (int k = 0; k < settle_steps; ++k) loop.step(false);
  SimulationState start_all;
  controlled.save(start_all);
  const EngineState& start = start_all.engine;
  Engine& b = bare.engine();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(b.nv());

  double bare_s = 0, controlled_s = 0;
  long blocks = 0;
  const auto wall0 = Clock::now();
  const std::clock_t cpu0 = std::clock();
  for (auto _ : state) {
    b.restore_state(start);
    auto t0 = Clock::now();
    for (int k = 0; k < kBlock; ++k) {
      b.forward();
      b.set_generalized_forces(zero);
      b.step();
    }
    bare_s += seconds_since(t0);
    if (restore_controlled) controlled.restore(start_all);
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
  state.counters["realtime_factor"] =
      controlled_us > 0 ? 1e6 * controlled.engine().timestep() / controlled_us : 0.0;
  return controlled_us;
}

}  // namespace stance::bench
