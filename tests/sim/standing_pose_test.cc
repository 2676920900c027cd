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

// a biped holding 8 kg on a pole 0.7 m to its left: in its zero pose the COM is 0.14 m left of
// the feet's centre, beyond the left foot's outer edge (0.12 m), and it falls sideways
constexpr const char* kSideLoaded = R"(<mujoco model="side_load">
  <option timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="20 20 0.1"/>
    <body name="trunk" pos="0 0 1.001">
      <freejoint name="root"/>
      <geom type="box" size="0.1 0.15 0.15" mass="20"/>
      <geom name="pole" type="capsule" fromto="0 0.15 0.1 0 0.7 0.1" size="0.01" mass="0.1"/>
      <geom name="load" type="sphere" pos="0 0.7 0.1" size="0.06" mass="8"/>
      <body name="l_thigh" pos="0 0.08 -0.15">
        <joint name="l_hip_x" type="hinge" axis="1 0 0"/>
        <joint name="l_hip_y" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04" mass="3"/>
        <body name="l_shin" pos="0 0 -0.4">
          <joint name="l_knee" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.035" mass="2"/>
          <body name="l_foot" pos="0 0 -0.4">
            <joint name="l_ankle_y" type="hinge" axis="0 1 0"/>
            <joint name="l_ankle_x" type="hinge" axis="1 0 0"/>
            <geom type="box" pos="0.03 0 -0.03" size="0.1 0.04 0.02" mass="1"/>
          </body>
        </body>
      </body>
      <body name="r_thigh" pos="0 -0.08 -0.15">
        <joint name="r_hip_x" type="hinge" axis="1 0 0"/>
        <joint name="r_hip_y" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04" mass="3"/>
        <body name="r_shin" pos="0 0 -0.4">
          <joint name="r_knee" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.035" mass="2"/>
          <body name="r_foot" pos="0 0 -0.4">
            <joint name="r_ankle_y" type="hinge" axis="0 1 0"/>
            <joint name="r_ankle_x" type="hinge" axis="1 0 0"/>
            <geom type="box" pos="0.03 0 -0.03" size="0.1 0.04 0.02" mass="1"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>)";

std::string side_loaded_scenario(const std::string& extra) {
  const std::string model = test::write_temp_file("side_loaded.xml", kSideLoaded);
  return test::write_temp_file("side_loaded.yaml",
                               "name: side_loaded\nengine: mujoco\nmodel: " + model + extra + R"(
duration: 3
seed: 1
stand_pose: auto
controllers:
  - {type: stable_pd, kp: 3000, kd: 150}
fall: {com_height_fraction: 0.8, allowed_contacts: [l_foot, r_foot]}
)");
}

TEST(StandPoseAuto, LeansSidewaysUntilTheComIsOverTheFeet) {
  const LoadedScenario l = load_scenario(side_loaded_scenario(""), {"stand_pose=off"});
  std::unique_ptr<Engine> e = make_scenario_engine(l.scenario, "mujoco", &l);
  const int left = e->require_body("l_foot"), right = e->require_body("r_foot");
  const Eigen::Quaterniond left_before = e->body_pose(left).quat;
  const StandingPose pose = find_standing_pose(*e, {});
  ASSERT_TRUE(pose.roll_searched);
  EXPECT_EQ(e->dof_name(pose.hip_roll[0]) + " " + e->dof_name(pose.ankle_roll[1]),
            "l_hip_x r_ankle_x");
  EXPECT_GT(pose.lateral_before_m, 0.13);
  EXPECT_GT(pose.roll_rad, 0.1) << "the legs lean so that the trunk moves right";
  // the engine is left in the pose: the COM over the feet both ways, the feet as they were
  const Eigen::Vector3d centre = 0.5 * (e->body_com(left) + e->body_com(right));
  EXPECT_NEAR(e->com().y() - centre.y(), 0, 1e-4);
  EXPECT_NEAR(e->com().x() - centre.x(), 0, 1e-4);
  EXPECT_NEAR(pose.lateral_m, e->com().y() - centre.y(), 1e-12);
  EXPECT_LT(e->body_pose(left).quat.angularDistance(left_before), 1e-9);
  EXPECT_LT(e->body_pose(right).quat.angularDistance(left_before), 1e-9);
  EXPECT_NE(describe_standing_pose(pose, *e).find("sideways +0.2"), std::string::npos)
      << describe_standing_pose(pose, *e);
}

// one-axis ankles (the ankle rolls locked): no flat-footed sideways lean exists, and it says so
TEST(StandPoseAuto, OneAxisAnklesAreNotLeanedSideways) {
  const LoadedScenario l = load_scenario(side_loaded_scenario(""), {"stand_pose=off"});
  Scenario locked = l.scenario;
  locked.model.front().lock_joints = {"l_ankle_x", "r_ankle_x"};
  std::unique_ptr<Engine> e = make_scenario_engine(locked, "mujoco", &l);
  const StandingPose pose = find_standing_pose(*e, {});
  EXPECT_FALSE(pose.roll_searched);
  EXPECT_EQ(pose.roll_rad, 0);
  EXPECT_NE(describe_standing_pose(pose, *e).find("not leaned sideways (no roll hinge"),
            std::string::npos);
}

TEST(StandPoseAuto, SideLoadedBipedFallsAsGivenAndStandsOnceLeaned) {
  const std::string file = side_loaded_scenario("");
  Simulation off(load_scenario(file, {"stand_pose=off"}), test::quiet());
  EXPECT_TRUE(off.run().fell);
  for (const auto& [what, sets] : nearby(3000, 150, {"0.0005", "0.002"})) {
    SCOPED_TRACE(what);
    Simulation run(load_scenario(file, sets), test::quiet());
    expect_stands(run.run(), 3);
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
