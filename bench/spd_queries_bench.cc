// Where S0's controller time goes on each engine: the engine queries stable PD makes every step,
// timed one by one on the standing biped (scenarios/biped_stand.yaml, settled 1 s), each right
// after a step so that nothing is served from a cache the step has not invalidated. One
// iteration is 100 steps; each is then stepped as usual (Simulation::step) so the biped stands on.
//   state_us          get_positions + get_velocities
//   bias_us           bias_forces (Coriolis, centrifugal, gravity)
//   constraint_us     constraint_forces (contact and limit forces of the last step)
//   shifted_solve_us  solve_mass_shifted: (M + Kd dt)^-1 x, SPD's solve
//   step_us           the controlled step that follows (Simulation::step)
#include <benchmark/benchmark.h>

#include <string>

#include "step_share.h"

namespace {

using stance::bench::Clock;
using stance::bench::seconds_since;

const std::string kScenario = std::string(STANCE_SOURCE_DIR) + "/scenarios/biped_stand.yaml";

void spd_queries(benchmark::State& state, const std::string& engine_name) {
  stance::LoadedScenario loaded = stance::load_scenario(kScenario);
  stance::RunOptions options;
  options.engine = engine_name;
  options.quiet = true;
  stance::Simulation run(loaded, options);
  stance::bench::ControlledLoop loop(run);
  for (int k = 0; k < 1000; ++k) loop.step(false);
  stance::Engine& e = run.engine();
  const int nq = e.nq(), nv = e.nv();
  Eigen::VectorXd q(nq), v(nv), c(nv), f(nv), x(nv);
  const Eigen::VectorXd kd_dt = Eigen::VectorXd::Constant(nv, 40.0 * e.timestep());

  double state_s = 0, bias_s = 0, constraint_s = 0, solve_s = 0, step_s = 0;
  long steps = 0;
  for (auto _ : state) {
    for (int k = 0; k < stance::bench::kBlock; ++k) {
      e.forward();
      auto t0 = Clock::now();
      e.get_positions(q);
      e.get_velocities(v);
      state_s += seconds_since(t0);
      t0 = Clock::now();
      e.bias_forces(c);
      bias_s += seconds_since(t0);
      t0 = Clock::now();
      e.constraint_forces(f);
      constraint_s += seconds_since(t0);
      x = f - c;
      t0 = Clock::now();
      e.solve_mass_shifted(kd_dt, x);
      solve_s += seconds_since(t0);
      benchmark::DoNotOptimize(x.data());
      t0 = Clock::now();
      loop.step(false);
      step_s += seconds_since(t0);
      ++steps;
    }
  }
  const double per = steps > 0 ? 1e6 / static_cast<double>(steps) : 0.0;
  state.counters["state_us"] = state_s * per;
  state.counters["bias_us"] = bias_s * per;
  state.counters["constraint_us"] = constraint_s * per;
  state.counters["shifted_solve_us"] = solve_s * per;
  state.counters["step_us"] = step_s * per;
  state.SetLabel(engine_name + ", fullbody1 standing, 1 iteration = 100 steps");
}

void BM_SpdQueriesMujoco(benchmark::State& state) {
  spd_queries(state, "mujoco");
}
BENCHMARK(BM_SpdQueriesMujoco)->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef STANCE_HAVE_DART
void BM_SpdQueriesDart(benchmark::State& state) {
  spd_queries(state, "dart");
}
BENCHMARK(BM_SpdQueriesDart)->Unit(benchmark::kMillisecond)->UseRealTime();
#endif

}  // namespace
