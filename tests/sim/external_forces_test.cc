// Forces set from outside while a run goes (the viewer's keys and mouse spring) are part of the
// run's state: they act as the scenario's pushes do, a saved state carries them (restoring it
// and the state file reproduce the run), and the planner, whose rollouts branch from that state,
// keeps a tracked walk up under them.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "app/commands.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

// the scenario `stance bvh track` writes for the synthetic walk, looped
std::string tracked_walk_scenario() {
  BvhTrackCommand cmd;
  cmd.bvh = test::source_dir() + "/models/synthetic_walk.bvh";
  cmd.loop = true;
  cmd.duration = 3.0;
  cmd.out_dir =
      (fs::temp_directory_path() / "stance_tests" / ("external_" + std::to_string(::getpid())))
          .string();
  return write_bvh_track_scenario(cmd);
}

Eigen::VectorXd positions(const Simulation& sim) {
  Eigen::VectorXd q(sim.engine().nq());
  sim.engine().get_positions(q);
  return q;
}

void step_to(Simulation& sim, double t) {
  while (sim.time() < t - 0.5 * sim.engine().timestep()) ASSERT_TRUE(sim.step());
}

// off the timestep's grid, so that the scheduled push and the one set between steps start and
// end on the same steps
constexpr double kPushStart = 0.3005, kPushEnd = 0.4505;

// to the first step time at or after t
void step_past(Simulation& sim, double t) {
  while (sim.time() < t) ASSERT_TRUE(sim.step());
}
const Eigen::Vector3d kPushForce(150, 0, 0);  // N, across the walk (along -y)

TEST(ExternalForces, KeyPushActsAsAScenarioPushAndIsInTheSavedState) {
  const std::string scenario = tracked_walk_scenario();
  RunOptions options;
  options.quiet = true;
  const std::vector<std::string> no_planner = {"planner.enabled=false", "duration=1"};

  // the scenario's own push on the hips
  RunOptions scheduled = options;
  scheduled.extra_pushes.push_back(parse_push("Hips,150,0,0,0.3005,0.15"));
  Simulation reference(load_scenario(scenario, no_planner), scheduled);
  step_to(reference, 0.6);

  // the same push set through the run's state when its time comes, as the viewer's key does
  Simulation run(load_scenario(scenario, no_planner), options);
  const int hips = run.engine().body_index("Hips");
  ASSERT_GE(hips, 0);
  step_past(run, kPushStart);
  run.external_forces().pushes.push_back(
      {hips, {kPushForce.x(), kPushForce.y(), kPushForce.z()}, kPushEnd});
  step_to(run, 0.35);
  SimulationState mid_push;
  run.save(mid_push);
  ASSERT_EQ(mid_push.progress.external.pushes.size(), 1u);
  EXPECT_EQ(mid_push.progress.external.pushes[0].body, hips);
  step_to(run, 0.6);
  const Eigen::VectorXd pushed = positions(run);
  EXPECT_LT((pushed - positions(reference)).norm(), 1e-9);

  // restoring the saved state (in this run, or in another from the state file) replays the push
  const fs::path file =
      fs::temp_directory_path() / ("stance_external_" + std::to_string(::getpid()) + ".state");
  run.restore(mid_push);
  run.write_state(file.string());
  step_to(run, 0.6);
  EXPECT_EQ(positions(run), pushed);
  Simulation other(load_scenario(scenario, no_planner), options);
  other.read_state(file.string());
  fs::remove(file);
  ASSERT_EQ(other.progress().external.pushes.size(), 1u);
  step_to(other, 0.6);
  EXPECT_EQ(positions(other), pushed);

  // and the push mattered: the hips went elsewhere than unpushed
  Simulation unpushed(load_scenario(scenario, no_planner), options);
  step_to(unpushed, 0.6);
  EXPECT_GT((positions(unpushed) - pushed).head<3>().norm(), 0.01);
}

TEST(ExternalForces, SpringPullsTheBodyTowardsItsTarget) {
  const std::string scenario = tracked_walk_scenario();
  RunOptions options;
  options.quiet = true;
  Simulation run(load_scenario(scenario, {"planner.enabled=false"}), options);
  const int hips = run.engine().body_index("Hips");
  const Eigen::Vector3d start = run.engine().body_pose(hips).pos;
  ExternalForces::Spring& spring = run.external_forces().spring;
  spring.body = hips;
  spring.target = {start.x() + 1.0, start.y(), start.z()};
  spring.stiffness = 70 * 100.0;
  spring.damping = 70 * 10.0;
  step_to(run, 0.3);
  // pulled sideways (the walk goes along -y)
  SimulationState state;
  run.save(state);
  EXPECT_EQ(state.progress.external.spring.body, hips);
  Simulation free(load_scenario(scenario, {"planner.enabled=false"}), options);
  step_to(free, 0.3);
  EXPECT_GT(run.engine().body_pose(hips).pos.x() - free.engine().body_pose(hips).pos.x(), 0.05);
  // reset() lets go
  run.reset();
  EXPECT_EQ(run.external_forces().spring.body, -1);
}

TEST(ExternalForces, PlannerKeepsTheTrackedWalkUpUnderAPushThroughTheState) {
  const std::string scenario = tracked_walk_scenario();
  RunOptions options;
  options.quiet = true;
  const std::vector<std::string> settings = {"planner.threads=2", "duration=2"};
  Simulation run(load_scenario(scenario, settings), options);
  Simulation calm(load_scenario(scenario, settings), options);
  const int hips = run.engine().body_index("Hips");
  step_past(run, kPushStart);
  run.external_forces().pushes.push_back(
      {hips, {kPushForce.x(), kPushForce.y(), kPushForce.z()}, kPushEnd});
  step_past(run, kPushEnd);
  step_past(calm, kPushEnd);
  // the push moved the character against the same run unpushed (22.5 N s on ~60 kg, less what
  // the planner already answers while it lasts) ...
  EXPECT_GT(run.engine().com_velocity().x() - calm.engine().com_velocity().x(), 0.1);
  // ... and the planner, which sees it in the state its rollouts start from, recovers
  const RunResult r = run.run();
  EXPECT_FALSE(r.fell) << r.fall_reason << " at " << r.fall_time.value_or(-1);
  EXPECT_TRUE(r.metrics["mocap"]["success"].get<bool>()) << r.metrics["mocap"].dump();
}

}  // namespace
}  // namespace stance
