// The per-run States of the controllers that own one: a run written to a state file mid-way
// and read back goes on bit for bit, and a live parameter edit keeps the State where its layout
// and meaning stay (a walk in its FSM phase) and starts a fresh one where they do not.
#include <gtest/gtest.h>

#include <filesystem>

#include "control/control_noise.h"
#include "control/hold_pose_pd.h"
#include "control/simbicon.h"
#include "control/skateboard_drive.h"
#include "control/stable_pd.h"
#include "run_support.h"
#include "sim/live_tuning.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

// the physics state and the controllers' log values, to compare two runs exactly
struct Snapshot {
  Eigen::VectorXd q, v;
  std::vector<double> signals;
};
Snapshot snapshot(const Simulation& run) {
  Snapshot s;
  s.q.resize(run.engine().nq());
  s.v.resize(run.engine().nv());
  run.engine().get_positions(s.q);
  run.engine().get_velocities(s.v);
  run.signals(s.signals);
  return s;
}

// run to t1, save the state in memory and to a file, run on to t2. Two new runs, one restored
// from memory and one read from the file, must reach the same state at t2 as the run that went on.
void expect_state_file_resumes(const LoadedScenario& loaded, double t1, double t2) {
  // one file per test: tests on the same scenario run in parallel under ctest -j
  const std::string file =
      (fs::temp_directory_path() /
       ("stance_state_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name())))
          .string();
  Simulation run(loaded, test::quiet());
  test::step_to(run, t1);
  SimulationState saved;
  run.save(saved);
  run.write_state(file);
  test::step_to(run, t2);
  Simulation restored(loaded, test::quiet()), resumed(loaded, test::quiet());
  restored.restore(saved);
  resumed.read_state(file);
  EXPECT_EQ(resumed.time(), restored.time());
  test::step_to(restored, t2);
  test::step_to(resumed, t2);
  const Snapshot a = snapshot(restored), b = snapshot(resumed);
  EXPECT_EQ(restored.time(), resumed.time());
  EXPECT_EQ(a.q, b.q);
  EXPECT_EQ(a.v, b.v);
  EXPECT_EQ(a.signals, b.signals);
  EXPECT_EQ(restored.result().metrics.dump(), resumed.result().metrics.dump());
  {
    const Snapshot c = snapshot(run);
    EXPECT_EQ(c.q, b.q);
    EXPECT_EQ(c.signals, b.signals);
    EXPECT_EQ(run.result().metrics.dump(), resumed.result().metrics.dump());
  }
  fs::remove(file);
}

TEST(ControllerStateFile, HoldPosePdAcrossThePush) {
  expect_state_file_resumes(load_scenario(test::scenario_path("pd_hold.yaml")), 1.9, 2.5);
}

TEST(ControllerStateFile, PlainPd) {
  expect_state_file_resumes(
      load_scenario(test::scenario_path("pd_hold.yaml"),
                    {"controllers=[{type: pd, kp: 60, kd: 3, target: {shoulder: 0.1}}]"}),
      0.5, 1.0);
}

TEST(ControllerStateFile, StablePdAnkleStrategyAndSkateboardDrive) {
  expect_state_file_resumes(load_scenario(test::scenario_path("biped_skateboard.yaml")), 1.0, 1.5);
}

TEST(ControllerStateFile, SimbiconMidWalk) {
  expect_state_file_resumes(load_scenario(test::scenario_path("simbicon_walk.yaml")), 1.0, 2.0);
}

TEST(ControllerStateFile, SlopeWalkerMidWalk) {
  expect_state_file_resumes(load_scenario(test::scenario_path("slope_walk.yaml")), 2.0, 3.0);
}

// the noise's random stream (engine and normal distribution) is in its State
TEST(ControllerStateFile, ControlNoiseStream) {
  const std::string humanoid = "/usr/share/mujoco/model/humanoid/humanoid.xml";
  if (!fs::exists(humanoid)) GTEST_SKIP() << humanoid << " missing (libmujoco-samples)";
  expect_state_file_resumes(
      load_scenario(test::scenario_path("lqr_one_leg.yaml"),
                    {"controllers=[{type: stable_pd}, {type: control_noise, other_std: 0.3}]"}),
      0.3, 0.6);
}

TEST(ControllerLiveEdit, SimbiconKeepsItsFsmPhaseAndSteps) {
  LoadedScenario loaded = load_scenario(test::scenario_path("simbicon_walk.yaml"));
  Simulation run(loaded, test::quiet());
  test::step_to(run, 2.0);
  const Simbicon::State* before = &run.state_as<Simbicon::State>(0);
  const Simbicon::State copy = *before;
  ASSERT_GT(copy.steps.size(), 0u);
  retune_controller(run, loaded, 0, "gait.gains.torso.kp", 900);
  EXPECT_EQ(&run.state_as<Simbicon::State>(0), before);
  EXPECT_EQ(run.state_as<Simbicon::State>(0).fsm, copy.fsm);
  EXPECT_EQ(run.state_as<Simbicon::State>(0).steps.size(), copy.steps.size());
  EXPECT_EQ(run.state_as<Simbicon::State>(0).state_start_s, copy.state_start_s);
  test::step_to(run, 3.0);
  EXPECT_GT(run.state_as<Simbicon::State>(0).steps.size(), copy.steps.size());
}

// the speed is read from the model: a kept State's command follows an edit
TEST(ControllerLiveEdit, SkateboardCommandFollowsTheSpeed) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_skateboard.yaml"));
  Simulation run(loaded, test::quiet());
  test::step_to(run, 2.6);  // past the ramp
  const auto* before = &run.state_as<SkateboardDrive::State>(2);
  EXPECT_DOUBLE_EQ(before->command, -2.0);
  const double distance = before->distance;
  retune_controller(run, loaded, 2, "speed", -1.5);
  ASSERT_TRUE(run.step());
  EXPECT_EQ(&run.state_as<SkateboardDrive::State>(2), before);
  EXPECT_DOUBLE_EQ(before->command, -1.5);
  EXPECT_GT(std::abs(before->distance), std::abs(distance) - 1e-3);  // no restart from zero
  EXPECT_EQ(dynamic_cast<const SkateboardDrive&>(*run.controllers()[2]).speed(), -1.5);
}

// the held target is captured at reset: a gain edit keeps it, a target edit starts afresh
TEST(ControllerLiveEdit, HoldPosePdKeepsItsTargetUnlessTheTargetChanges) {
  LoadedScenario loaded = load_scenario(test::scenario_path("pd_hold.yaml"));
  Simulation run(loaded, test::quiet());
  test::step_to(run, 0.5);
  const auto* before = &run.state_as<HoldPosePd::State>(0);
  retune_controller(run, loaded, 0, "kp", 80);
  EXPECT_EQ(&run.state_as<HoldPosePd::State>(0), before);
  retune_controller(run, loaded, 0, "target.shoulder", 0.2);
  const auto& fresh = run.state_as<HoldPosePd::State>(0);
  const int adr =
      run.engine().joint(run.engine().dof_joint(run.engine().require_dof("shoulder"))).qpos_adr;
  EXPECT_EQ(fresh.q_target[adr], 0.2);
}

TEST(ControllerLiveEdit, StablePdKeepsItsStateOverAGainEdit) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  Simulation run(loaded, test::quiet());
  test::step_to(run, 0.2);
  const auto* before = &run.state_as<StablePd::State>(0);
  const long samples = before->error_samples;
  retune_controller(run, loaded, 0, "kd", 30);
  EXPECT_EQ(&run.state_as<StablePd::State>(0), before);
  EXPECT_EQ(run.state_as<StablePd::State>(0).error_samples, samples);
}

// the State's window is smoothing_s / dt samples: another window needs another State
TEST(ControllerLiveEdit, ControlNoiseKeepsItsStreamUnlessTheWindowChanges) {
  const std::string humanoid = "/usr/share/mujoco/model/humanoid/humanoid.xml";
  if (!fs::exists(humanoid)) GTEST_SKIP() << humanoid << " missing (libmujoco-samples)";
  LoadedScenario loaded =
      load_scenario(test::scenario_path("lqr_one_leg.yaml"),
                    {"controllers=[{type: stable_pd}, {type: control_noise, smoothing_s: 0.1}]"});
  Simulation run(loaded, test::quiet());
  test::step_to(run, 0.1);
  const auto* before = &run.state_as<ControlNoise::State>(1);
  const long samples = before->samples;
  retune_controller(run, loaded, 1, "other_std", 0.2);
  EXPECT_EQ(&run.state_as<ControlNoise::State>(1), before);
  EXPECT_EQ(before->samples, samples);
  retune_controller(run, loaded, 1, "smoothing_s", 0.2);
  const auto& fresh = run.state_as<ControlNoise::State>(1);
  EXPECT_EQ(fresh.samples, 0);
  const auto& noise = dynamic_cast<const ControlNoise&>(*run.controllers()[1]);
  EXPECT_EQ(fresh.white.cols(), noise.kernel().size());
  ASSERT_TRUE(run.step());
}

}  // namespace
}  // namespace stance
