// The sampling planner: compute per simulated second on 1 and 2 threads, and what a rollout step
// costs against the bare engine step of the same model (the planner's overhead: restores, the
// spline, the cost, the base policy inside the rollout). One iteration is 0.2 s simulated from
// the scenario's start. Counters:
//   compute_s_per_sim_s    wall seconds per simulated second (the goal: <= 10 on 2 threads)
//   cpu_s_per_sim_s        the run's own CPU seconds per simulated second: its stepping
//                          thread's and its rollout workers' thread clocks (true on a shared
//                          machine, where the wall time also holds other jobs' share)
//   model_steps_per_sim_s  rollout steps the planner took per simulated second
//   rollout_us             wall time of plan() per rollout step, per thread (us)
//   step_us                a bare engine step (mj_step, no control) of the rollout model, at the
//                          rollouts' timestep, from each state the planned run passed through:
//                          the character as it moves, in its contacts, not lying or collapsing
//   controlled_us          a base-policy step of the rollout model from the start (us)
//   limit_s_per_sim_s      the physical limit: model_steps_per_sim_s bare steps, spread over the
//                          threads (s per simulated second)
//   over_limit             compute_s_per_sim_s / limit_s_per_sim_s: the distance to that limit
//   overhead_vs_step       rollout_us / step_us - 1
//   overhead_vs_controlled rollout_us / controlled_us - 1
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "app/commands.h"
#include "core/executor.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"
#include "plan/planner.h"
#include "step_share.h"

namespace {

std::string scenario(const char* name) {
  return std::string(STANCE_SOURCE_DIR) + "/scenarios/" + name;
}

void measure_planner(benchmark::State& state, const std::string& file,
                     const std::vector<std::string>& sets, double sim_length_s = 0.2) {
  using namespace stance;
  const int threads = static_cast<int>(state.range(0));
  std::vector<std::string> all = sets;
  all.push_back("planner.threads=" + std::to_string(threads));
  all.push_back("perturbations=[]");
  LoadedScenario loaded = load_scenario(file, all);
  RunOptions options;
  options.quiet = true;
  double sim_s = 0, wall_s = 0, cpu_s = 0, plan_s = 0;
  long rollout_steps = 0;
  std::vector<EngineState> track;  // the planned run's states, for the bare steps
  for (auto _ : state) {
    state.PauseTiming();
    Simulation sim(loaded, options);
    track.clear();
    state.ResumeTiming();
    const auto t0 = bench::Clock::now();
    const double cpu0 = thread_cpu_seconds() + planner_of(sim)->own_threads_cpu_seconds();
    const double t_end = sim.time() + sim_length_s;
    while (sim.time() < t_end - 1e-9 && sim.step())
      sim.engine().save_state(track.emplace_back());  // ~1 us against a planning step's ms
    wall_s += bench::seconds_since(t0);
    cpu_s += thread_cpu_seconds() + planner_of(sim)->own_threads_cpu_seconds() - cpu0;
    sim_s += sim_length_s;
    plan_s += planner_of(sim)->plan_seconds();
    rollout_steps += planner_of(sim)->rollout_steps();
  }
  const double compute = sim_s > 0 ? wall_s / sim_s : 0.0;
  const double model_steps = sim_s > 0 ? rollout_steps / sim_s : 0.0;
  state.counters["compute_s_per_sim_s"] = compute;
  state.counters["cpu_s_per_sim_s"] = sim_s > 0 ? cpu_s / sim_s : 0.0;
  state.counters["model_steps_per_sim_s"] = model_steps;
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
  // one bare step from each state of the planned run: a walking character's contacts and
  // constraints, not a collapse from the start
  Engine& e = bare.engine();
  double bare_s = 0, controlled_s = 0;
  long bare_steps = 0;
  for (int rep = 0; rep < 5; ++rep)
    for (const EngineState& at : track) {
      e.restore_state(at);
      const auto t0 = bench::Clock::now();
      e.forward();
      e.set_generalized_forces(zero);
      e.step();
      bare_s += bench::seconds_since(t0);
      ++bare_steps;
    }
  for (int rep = 0; rep < 5; ++rep) {
    controlled.restore(start);
    const auto t0 = bench::Clock::now();
    for (int k = 0; k < bench::kBlock; ++k) controlled.step();
    controlled_s += bench::seconds_since(t0);
  }
  const double step_us = bare_steps ? 1e6 * bare_s / bare_steps : 0.0;
  const double controlled_us = 1e6 * controlled_s / (5.0 * bench::kBlock);
  const double limit = model_steps * step_us * 1e-6 / threads;
  state.counters["limit_s_per_sim_s"] = limit;
  state.counters["over_limit"] = limit > 0 ? compute / limit : 0.0;
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

// a synthetic clip as `stance bvh track` runs it (its character and scenario), for 1 s: long
// enough that the planner's budget on track and in trouble both show, not only the start
std::string bvh_track_scenario(const std::string& name, const stance::SyntheticWalkOptions& o) {
  using namespace stance;
  const auto dir = std::filesystem::temp_directory_path() / ("stance_bench_" + name);
  std::filesystem::create_directories(dir);
  const std::string bvh = (dir / (name + ".bvh")).string();
  write_bvh(make_synthetic_walk_clip(o), bvh);
  BvhTrackCommand cmd;
  cmd.bvh = bvh;
  cmd.loop = true;
  cmd.duration = 3.0;
  cmd.out_dir = (dir / "track").string();
  return write_bvh_track_scenario(cmd);
}

void BM_PlannerTrackedWalk(benchmark::State& state) {
  static const std::string file =
      bvh_track_scenario("synthetic_walk", stance::SyntheticWalkOptions{});
  measure_planner(state, file, {}, 1.0);
  state.SetLabel("bvh track of the synthetic walk, MuJoCo, 1 s");
}
BENCHMARK(BM_PlannerTrackedWalk)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

// the synthetic run: a flight phase
void BM_PlannerMocapRun(benchmark::State& state) {
  static const std::string file =
      bvh_track_scenario("synthetic_run", stance::synthetic_run_options());
  measure_planner(state, file, {}, 1.0);
  state.SetLabel("bvh track of the synthetic run, MuJoCo, 1 s");
}
BENCHMARK(BM_PlannerMocapRun)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
