// SIMBICON on one-axis ankles (issue 45): MuJoCo's humanoid with its ankle roll hinges removed
// (models/humanoid_pitch_ankles.xml) walks 60 s with the 3D controller, which turns its ankle
// roll servos off and says so at load. Held at the shipped gait, with the SIMBICON gains x0.8
// and x1.2, every torque x0.8 and x1.2 (torque_scale), and the timestep halved and doubled.
// MuJoCo only: DART 6.12's MJCF parser rejects several joints in one body.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "batch/tune.h"
#include "control/simbicon.h"
#include "core/error.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

constexpr const char* kScenario = "simbicon_pitch_ankles.yaml";
constexpr int kSimbicon = 2;  // the controller's index in the scenario

const Simbicon& simbicon_of(const Simulation& run) {
  return dynamic_cast<const Simbicon&>(*run.controllers().at(kSimbicon));
}

// every kp and kd of the SIMBICON gains times factor, as --set lines
std::vector<std::string> scaled_gains(double factor) {
  const LoadedScenario l = load_scenario(test::scenario_path(kScenario), {});
  const std::string base = "controllers." + std::to_string(kSimbicon) + ".gait.gains.";
  std::vector<std::string> sets;
  for (const char* servo :
       {"torso", "swing_hip", "swing_knee", "swing_ankle", "stance_knee", "stance_ankle"})
    for (const char* gain : {"kp", "kd"}) {
      const std::string key = base + servo + "." + gain;
      const std::optional<double> value = yaml_number_at(l.document, key);
      if (value) sets.push_back(key + "=" + std::to_string(*value * factor));
    }
  return sets;
}

TEST(SimbiconPitchAnkles, ModelHasNoAnkleRollAndTheControllerRunsInThreeD) {
  const LoadedScenario l = load_scenario(test::scenario_path(kScenario), {"duration=0.01"});
  Simulation run(l, {});
  const Simbicon::Model& m = simbicon_of(run).model();
  EXPECT_TRUE(m.spatial);
  EXPECT_EQ(m.ankle_roll[0], -1);
  EXPECT_EQ(m.ankle_roll[1], -1);
  EXPECT_GE(m.hip_roll[0], 0);
  EXPECT_GE(m.hip_yaw[1], 0);
  // the model itself has no ankle roll dof left to name
  const std::string k = "controllers.2.skeleton.";
  EXPECT_THROW(Simulation(load_scenario(test::scenario_path(kScenario),
                                        {k + "right_ankle_roll=right_ankle_x",
                                         k + "left_ankle_roll=left_ankle_x"}),
                          {}),
               InputError);
}

// the note at load names what is off, in one line; a scenario copy of its own name, since the
// note is printed once per message per process
TEST(SimbiconPitchAnkles, SaysAtLoadWhatItTurnedOff) {
  std::string yaml = test::read_file(test::scenario_path(kScenario));
  const std::string models = test::source_dir() + "/models/";
  yaml.replace(yaml.find("../models/"), 10, models);
  const std::string file = test::write_temp_file("pitch_ankles_note.yaml", yaml);
  const std::string k = "controllers.2.skeleton.";
  ::testing::internal::CaptureStderr();
  { Simulation run(load_scenario(file, {"duration=0.01"}), {}); }
  // without hip yaw as well (the humanoid's hip_z then hangs unservoed: built only)
  {
    Simulation run(
        load_scenario(file, {"duration=0.01", k + "left_hip_yaw=\"\"", k + "right_hip_yaw=\"\""}),
        {});
    EXPECT_EQ(simbicon_of(run).model().hip_yaw[0], -1);
  }
  const std::string err = ::testing::internal::GetCapturedStderr();
  const std::string ankle_only =
      "note: " + file +
      ": controllers[2]: simbicon: turned off for this model: ankle roll servos (no ankle roll: "
      "coronal balance by the swing hip's roll and foot placement)\n";
  EXPECT_NE(err.find(ankle_only), std::string::npos) << err;
  EXPECT_NE(err.find("foot placement); heading hold and path_gain (no hip yaw)\n"),
            std::string::npos)
      << err;
}

TEST(SimbiconPitchAnkles, HalfNamedPairsAreRefused) {
  const std::string k = "controllers.2.skeleton.";
  for (const std::string& set :
       {k + "left_hip_yaw=\"\"", k + "right_hip_roll=\"\"", k + "left_ankle_roll=left_ankle_y"}) {
    SCOPED_TRACE(set);
    try {
      Simulation run(load_scenario(test::scenario_path(kScenario), {set}), {});
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("name both or neither"), std::string::npos) << e.what();
    }
  }
}

void expect_walks_sixty_seconds(const RunResult& r) {
  ASSERT_FALSE(r.diverged) << r.divergence;
  EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
  EXPECT_NEAR(r.sim_time, 60.0, 1e-6);
  EXPECT_GT(test::metric(r, "mean_speed_mps"), 0.3);
  EXPECT_GT(test::metric(r, "step_length_mean_m"), 0.1);
  EXPECT_LT(test::metric(r, "drift_per_10m"), 2.0);
  // about two strikes a second
  EXPECT_GT(r.metrics.at("step_count").get<int>(), 60);
}

TEST(SimbiconPitchAnkles, WalksSixtySecondsAtTheGaitAndNearby) {
  const std::vector<std::pair<std::string, std::vector<std::string>>> settings = {
      {"shipped gait", {}},
      {"gains x0.8", scaled_gains(0.8)},
      {"gains x1.2", scaled_gains(1.2)},
      {"torques x0.8", {"torque_scale=0.8"}},
      {"torques x1.2", {"torque_scale=1.2"}},
      {"timestep / 2", {"timestep=0.0005"}},
      {"timestep x 2", {"timestep=0.002"}}};
  for (const auto& [what, sets] : settings) {
    SCOPED_TRACE(what);
    Simulation run(load_scenario(test::scenario_path(kScenario), sets), {});
    expect_walks_sixty_seconds(run.run());
  }
}

// without hip yaw as well, made from humanoid.xml by the model entry's lock_joints (MJCF): the
// ankle rolls and hip yaws welded, neither named in the skeleton; 60 s at the gait and at the
// SIMBICON gains x0.8 and x1.2 (MuJoCo only, as the humanoid is; about 4 s of CPU)
TEST(SimbiconPitchAnkles, WalksWithoutHipYawAtTheGaitAndNearby) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "humanoid.xml missing";
  const std::string k = "controllers.2.skeleton.";
  const std::vector<std::string> without_hip_yaw = {
      std::string("model=[{file: ") + test::kHumanoidXml +
          ", lock_joints: [right_ankle_x, left_ankle_x, right_hip_z, left_hip_z]}]",
      k + "left_hip_yaw=\"\"", k + "right_hip_yaw=\"\""};
  for (const double factor : {1.0, 0.8, 1.2}) {
    SCOPED_TRACE("gains x" + std::to_string(factor));
    std::vector<std::string> sets = without_hip_yaw;
    if (factor != 1.0)
      for (const std::string& set : scaled_gains(factor)) sets.push_back(set);
    Simulation run(load_scenario(test::scenario_path(kScenario), sets), {});
    EXPECT_EQ(run.engine().dof_index("right_hip_z"), -1);
    EXPECT_EQ(run.engine().dof_index("left_ankle_x"), -1);
    EXPECT_EQ(simbicon_of(run).model().hip_yaw[0], -1);
    expect_walks_sixty_seconds(run.run());
  }
}

// a robot of a model collection's kind (tests/models/pitch_ankle_robot*.xml: hips 0.34 m apart,
// one-axis ankles, motors in N m) walks with docs/robots.md's gait: 20 s at the SIMBICON gains,
// x0.8 and x1.2 (about 2 s of CPU); with the humanoid's cd_lateral (0.7, 2.2) it falls at once
TEST(SimbiconPitchAnkles, WalksAWideHippedRobotWithTheGuidesGait) {
  const std::string scenario = test::source_dir() + "/tests/models/pitch_ankle_robot_walk.yaml";
  const std::string gains = "controllers.2.gait.gains.";
  for (const double factor : {1.0, 0.8, 1.2}) {
    SCOPED_TRACE("gains x" + std::to_string(factor));
    std::vector<std::string> sets;
    const LoadedScenario plain = load_scenario(scenario, {});
    for (const char* servo :
         {"torso", "swing_hip", "swing_knee", "swing_ankle", "stance_knee", "stance_ankle"})
      for (const char* gain : {"kp", "kd"}) {
        const std::string key = gains + servo + "." + gain;
        sets.push_back(key + "=" + std::to_string(*yaml_number_at(plain.document, key) * factor));
      }
    const RunResult r = Simulation(load_scenario(scenario, sets), {.duration = 20.0}).run();
    EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1);
    EXPECT_NEAR(r.sim_time, 20.0, 1e-6);
    EXPECT_GT(r.metrics.at("mean_speed_mps").get<double>(), 0.05);
  }
  const std::string states = "controllers.2.gait.states.";
  const RunResult wide =
      Simulation(
          load_scenario(scenario, {states + "0.cd_lateral=0.7", states + "1.cd_lateral=2.2"}),
          {.duration = 5.0})
          .run();
  EXPECT_TRUE(wide.fell);
}

}  // namespace
}  // namespace stance
