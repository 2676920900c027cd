// The sampling planner: compute per simulated second on 1 and 2 threads, and what a rollout step
// costs against the bare engine step of the same model (the planner's overhead: restores, the
// spline, the cost, the base policy inside the rollout). One iteration is 0.2 s simulated from
// the scenario's start. Counters:
//   compute_s_per_sim_s    wall seconds per simulated second (the goal: <= 10 on 2 threads)
//   rollout_us             wall time of plan() per rollout step, per thread (us)
//   step_us, controlled_us a bare / base-policy step of the rollout model, at the rollouts'
//                          timestep (us)
//   overhead_vs_step       rollout_us / step_us - 1
//   overhead_vs_controlled rollout_us / controlled_us - 1
#include <benchmark/benchmark.h>

#include <string>

#include "step_share.h"

namespace {

std::string scenario(const char* name) {
  return std::string(STANCE_SOURCE_DIR) + "/scenarios/" + name;
}

void measure_planner(benchmark::State& state, const std::string& file,
                     const std::vector<std::string>& sets) {
  using namespace stance;
  const int threads = static_cast<int>(state.range(0));
  std::vector<std::string> all = sets;
  all.push_back("planner.threads=" + std::to_string(threads));
  all.push_back("perturbations=[]");
  LoadedScenario loaded = load_scenario(file, all);
  RunOptions options;
  options.quiet = true;
  double sim_s = 0, wall_s = 0, plan_s = 0;
  long rollout_steps = 0;
  for (auto _ : state) {
    state.PauseTiming();
    Simulation sim(loaded, options);
    state.ResumeTiming();
    const auto t0 = bench::Clock::now();
    const double t_end = sim.time() + 0.2;
    while (sim.time() < t_end - 1e-9 && sim.step()) {
    }
    wall_s += bench::seconds_since(t0);
    sim_s += 0.2;
    plan_s += sim.planner()->plan_seconds();
    rollout_steps += sim.planner()->rollout_steps();
  }
  state.counters["compute_s_per_sim_s"] = sim_s > 0 ? wall_s / sim_s : 0.0;
  const double rollout_us = rollout_steps ? 1e6 * plan_s * threads / rollout_steps : 0.0;
  state.counters["rollout_us"] = rollout_us;
  // the bare and the base-policy step of the same model at the rollouts' timestep, measured now
  std::vector<std::string> base_sets = sets;
  base_sets.insert(base_sets.end(), {"planner.enabled=false", "perturbations=[]"});
  if (loaded.scenario.planner.timestep > 0)
    base_sets.push_back("timestep=" + std::to_string(loaded.scenario.planner.timestep));
  LoadedScenario base = load_scenario(file, base_sets);
  Simulation controlled(base, options), bare(base, options);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(bare.engine().nv());
  SimulationState start;
  controlled.save(start);
  double bare_s = 0, controlled_s = 0;
  for (int rep = 0; rep < 5; ++rep) {
    bare.engine().restore_state(start.engine);
    auto t0 = bench::Clock::now();
    for (int k = 0; k < bench::kBlock; ++k) {
      bare.engine().forward();
      bare.engine().set_generalized_forces(zero);
      bare.engine().step();
    }
    bare_s += bench::seconds_since(t0);
    controlled.restore(start);
    t0 = bench::Clock::now();
    for (int k = 0; k < bench::kBlock; ++k) controlled.step();
    controlled_s += bench::seconds_since(t0);
  }
  const double steps = 5.0 * bench::kBlock;
  const double step_us = 1e6 * bare_s / steps, controlled_us = 1e6 * controlled_s / steps;
  state.counters["step_us"] = step_us;
  state.counters["controlled_us"] = controlled_us;
  state.counters["overhead_vs_step"] = step_us > 0 ? rollout_us / step_us - 1 : 0.0;
  state.counters["overhead_vs_controlled"] =
      controlled_us > 0 ? rollout_us / controlled_us - 1 : 0.0;
}

void BM_PlannerBipedStand(benchmark::State& state) {
  measure_planner(state, scenario("biped_stand_planner.yaml"), {});
  state.SetLabel("biped_stand_planner, MuJoCo, 1 ms step, 2 ms rollouts");
}
BENCHMARK(BM_PlannerBipedStand)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(2);

void BM_PlannerMocap(benchmark::State& state) {
  measure_planner(state, scenario("mocap_track_planner.yaml"), {});
  state.SetLabel("mocap_track_planner, MuJoCo, 2 ms step");
}
BENCHMARK(BM_PlannerMocap)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(2);

}  // namespace
