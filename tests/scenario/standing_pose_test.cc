// stand_pose: auto (control/standing_pose.h, issue 45): the legs lean at the hips, the ankles turn
// back by as much, until the COM is over the centre of the feet. The found pose has its COM
// there with the feet as they were; MuJoCo's humanoid and DART's Atlas stand from it at their
// shipped gains, at the gains x0.8 and x1.2 and at other timesteps (Atlas also bent forward at
// the back); the humanoid's legs slanted under its upright torso fall as given, stand once leaned.
#include "control/standing_pose.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

bool have_humanoid() {
  return std::filesystem::exists(test::kHumanoidXml);
}

// the humanoid's legs slanted by `a` under its upright torso (its root), the feet flat
std::vector<std::string> slanted(double a) {
  const std::string s = std::to_string(a), minus = std::to_string(-a);
  return {"initial_pose.abdomen_y=" + s, "initial_pose.right_ankle_y=" + minus,
          "initial_pose.left_ankle_y=" + minus};
}

double com_ahead_of_feet(const Engine& e, const char* foot_a, const char* foot_b) {
  const Eigen::Vector3d centre =
      0.5 * (e.body_com(e.require_body(foot_a)) + e.body_com(e.require_body(foot_b)));
  return e.com().x() - centre.x();
}

TEST(StandPoseAuto, PutsTheComOverTheFeetWithTheFeetAsTheyWere) {
  if (!have_humanoid()) GTEST_SKIP() << "humanoid.xml missing (libmujoco-samples)";
  std::vector<std::string> sets = slanted(0.15);
  sets.push_back("stand_pose=off");
  const LoadedScenario l = load_scenario(test::scenario_path("humanoid_stand.yaml"), sets);
  std::unique_ptr<Engine> e = make_scenario_engine(l.scenario, "mujoco", &l);
  const int right = e->require_body("right_foot"), left = e->require_body("left_foot");
  const Eigen::Quaterniond right_before = e->body_pose(right).quat;
  const Eigen::Quaterniond left_before = e->body_pose(left).quat;
  const double before = com_ahead_of_feet(*e, "right_foot", "left_foot");
  EXPECT_GT(before, 0.05) << "the slanted legs put the COM ahead of the feet";

  StandingPoseOptions options;  // the feet found as the two lowest bodies
  const StandingPose pose = find_standing_pose(*e, options);
  EXPECT_EQ(pose.feet[0] + " " + pose.feet[1], "right_foot left_foot");
  EXPECT_EQ(e->dof_name(pose.hip[0]), "right_hip_y");
  EXPECT_EQ(e->dof_name(pose.ankle[1]), "left_ankle_y");
  EXPECT_NEAR(pose.offset_before_m, before, 1e-12);
  EXPECT_LT(pose.lean_rad, -0.1) << "the legs lean back";
  // the engine is left in the pose: the COM over the feet, the feet turned by nothing
  EXPECT_NEAR(com_ahead_of_feet(*e, "right_foot", "left_foot"), 0.0, 1e-4);
  EXPECT_NEAR(pose.offset_m, com_ahead_of_feet(*e, "right_foot", "left_foot"), 1e-12);
  EXPECT_LT(e->body_pose(right).quat.angularDistance(right_before), 1e-9);
  EXPECT_LT(e->body_pose(left).quat.angularDistance(left_before), 1e-9);
  EXPECT_NEAR(e->dof_position(pose.hip[0]), pose.lean_rad, 1e-12);  // from 0
  EXPECT_NEAR(e->dof_position(pose.ankle[0]), -0.15 - pose.lean_rad, 1e-12);
}

TEST(StandPoseAuto, RefusesWhatItCannotLean) {
  if (!have_humanoid()) GTEST_SKIP() << "humanoid.xml missing (libmujoco-samples)";
  auto error_of = [](const std::vector<std::string>& sets) -> std::string {
    try {
      const LoadedScenario l = load_scenario(test::scenario_path("humanoid_stand.yaml"), sets);
      make_scenario_engine(l.scenario, "mujoco", &l);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(error_of({"stand_pose=sideways"})
                .find("stand_pose: expected auto or off, found "
                      "'sideways'"),
            std::string::npos);
  // a "foot" with no pitch hinge of its own between it and the other foot
  EXPECT_NE(error_of({"fall.allowed_contacts=[torso, right_foot]"}).find("a hip and an ankle"),
            std::string::npos);
  // the legs slanted further than a lean of 0.4 rad can bring back
  EXPECT_NE(error_of(slanted(-0.6)).find("no leg lean within +-0.4 rad"), std::string::npos);
}

RunResult stand(const char* file, const std::string& engine, std::vector<std::string> sets) {
  const LoadedScenario l = load_scenario(test::scenario_path(file), sets);
  Simulation run(l, test::quiet(engine));
  return run.run();
}

void expect_stands(const RunResult& r, double duration) {
  ASSERT_FALSE(r.diverged) << r.divergence;
  EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
  EXPECT_NEAR(r.sim_time, duration, 1e-6);
  EXPECT_LT(test::metric(r, "com_displacement_m"), 0.05);
}

// the settings a behaviour must hold under: the shipped one, gains x0.8 and x1.2, timesteps
std::vector<std::pair<std::string, std::vector<std::string>>> nearby(
    double kp, double kd, const std::vector<std::string>& timesteps) {
  std::vector<std::pair<std::string, std::vector<std::string>>> out = {{"shipped", {}}};
  for (double f : {0.8, 1.2})
    out.push_back({"gains x" + std::to_string(f),
                   {"controllers.0.kp=" + std::to_string(kp * f),
                    "controllers.0.kd=" + std::to_string(kd * f)}});
  for (const std::string& dt : timesteps) out.push_back({"timestep " + dt, {"timestep=" + dt}});
  return out;
}

TEST(StandPoseAuto, HumanoidStandsFromItsAutoPoseAndNearby) {
  if (!have_humanoid()) GTEST_SKIP() << "humanoid.xml missing (libmujoco-samples)";
  for (const auto& [what, sets] : nearby(800, 40, {"0.001", "0.004"})) {
    SCOPED_TRACE(what);
    expect_stands(stand("humanoid_stand.yaml", "mujoco", sets), 10);
  }
  // legs slanted either way under the upright torso: they fall as given, stand once leaned
  for (double a : {0.15, -0.15}) {
    SCOPED_TRACE(::testing::Message() << "legs slanted " << a << " rad");
    std::vector<std::string> sets = slanted(a);
    sets.push_back("stand_pose=off");
    EXPECT_TRUE(stand("humanoid_stand.yaml", "mujoco", sets).fell);
    sets.back() = "stand_pose=auto";
    expect_stands(stand("humanoid_stand.yaml", "mujoco", sets), 10);
  }
}

void atlas_stands_from_its_auto_pose(const std::string& engine) {
  std::vector<std::pair<std::string, std::vector<std::string>>> settings =
      nearby(6000, 300, {"0.0005"});
  settings.push_back({"bent forward at the back", {"initial_pose.back_bky=0.3"}});
  for (auto& [what, sets] : settings) {
    SCOPED_TRACE(engine + " " + what);
    sets.push_back("stand_pose=auto");
    expect_stands(stand("atlas_stand.yaml", engine, sets), 5);
  }
}

TEST(StandPoseAuto, AtlasStandsFromItsAutoPoseOnMujoco) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  atlas_stands_from_its_auto_pose("mujoco");
}

#ifdef STANCE_HAVE_DART
TEST(StandPoseAuto, AtlasStandsFromItsAutoPoseOnDart) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  atlas_stands_from_its_auto_pose("dart");
}
#endif

}  // namespace
}  // namespace stance
