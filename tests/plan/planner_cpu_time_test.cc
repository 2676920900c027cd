// A run's own CPU time (metrics.cpu_s_per_sim_s): its stepping thread and its planner's rollout
// workers, each read on its own thread's clock, so that runs sharing a process count their own.
// The bounds compare clocks with each other (the run's, its thread's, the process's), never with
// a time budget.
#include <gtest/gtest.h>
#include <time.h>

#include <string>
#include <thread>
#include <vector>

#include "core/executor.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// biped_stand with a small planner (or none), run for `steps` steps on this thread
struct MeasuredRun {
  double run_cpu_s = 0;      // what the run reports: cpu_s_per_sim_s x its simulated time
  double per_sim_s = 0;      // cpu_s_per_sim_s
  double this_thread_s = 0;  // the stepping thread's clock around run()
  double process_s = 0;      // the process's clock around run()
};
MeasuredRun run_stand(bool plan, int threads, long steps) {
  Simulation sim(
      load_scenario(test::scenario_path("biped_stand.yaml"),
                    {"planner.enabled=" + std::string(plan ? "true" : "false"), "planner.samples=8",
                     "planner.horizon_s=0.2", "planner.interval_s=0.05",
                     "planner.threads=" + std::to_string(threads)}),
      test::quiet());
  MeasuredRun m;
  const double thread0 = thread_cpu_seconds(), process0 = process_cpu_seconds();
  const RunResult r = sim.run(steps);
  m.this_thread_s = thread_cpu_seconds() - thread0;
  m.process_s = process_cpu_seconds() - process0;
  m.per_sim_s = r.metrics.at("cpu_s_per_sim_s").get<double>();
  m.run_cpu_s = m.per_sim_s * r.sim_time;
  EXPECT_TRUE(is_wall_clock_metric("cpu_s_per_sim_s"));
  return m;
}

// on 2 threads the run counts its rollout workers: about all the process used, at least the
// stepping thread's share, and more than the same run without the planner
TEST(PlannerCpuTime, CountsTheSteppingThreadAndTheRolloutWorkers) {
  const MeasuredRun planned = run_stand(true, 2, 400);
  EXPECT_GT(planned.run_cpu_s, 0);
  EXPECT_GE(planned.run_cpu_s, 0.9 * planned.this_thread_s);
  EXPECT_LE(planned.run_cpu_s, planned.process_s + 1e-3);
  EXPECT_GE(planned.run_cpu_s, 0.8 * planned.process_s);  // the workers' share is counted
  const MeasuredRun alone = run_stand(false, 2, 400);
  EXPECT_GT(alone.per_sim_s, 0);
  EXPECT_GT(planned.per_sim_s, alone.per_sim_s);
}

// two runs at once in one process: the one without a planner counts its own thread alone (the
// process's clock would count the planning run too), and the planning one about what it
// counts when it runs by itself
TEST(PlannerCpuTime, RunsAtOnceInOneProcessEachCountTheirOwn) {
  const MeasuredRun planned_alone = run_stand(true, 2, 400);
  MeasuredRun planned, unplanned;
  std::thread planning([&] { planned = run_stand(true, 2, 400); });
  std::thread stepping([&] { unplanned = run_stand(false, 1, 3000); });
  planning.join();
  stepping.join();
  EXPECT_GT(unplanned.run_cpu_s, 0);
  EXPECT_LE(unplanned.run_cpu_s, unplanned.this_thread_s + 1e-4);
  EXPECT_GT(planned.per_sim_s, planned_alone.per_sim_s / 3);
  EXPECT_LT(planned.per_sim_s, planned_alone.per_sim_s * 3);
}

}  // namespace
}  // namespace stance
