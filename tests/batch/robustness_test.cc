#include "batch/robustness.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "batch/push_threshold.h"
#include "core/error.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::string write_temp(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "stance_robustness_test";
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path.string();
}

TEST(PushOutcome, CodesFollowTheFallTimeAndTheSteps) {
  EXPECT_EQ(push_outcome(std::nullopt, 2.0, false), PushOutcome::kSuccess);
  EXPECT_EQ(push_outcome(std::nullopt, 2.0, true), PushOutcome::kManySteps);
  EXPECT_EQ(push_outcome(1.5, 2.0, false), PushOutcome::kFellBefore);
  EXPECT_EQ(push_outcome(1.5, 2.0, true), PushOutcome::kFellBefore);
  EXPECT_EQ(push_outcome(2.0, 2.0, false), PushOutcome::kFellAfter);
  EXPECT_EQ(push_outcome(3.0, 2.0, true), PushOutcome::kFellAfter);
}

TEST(PushPoint, ParsedFromTheCliAndTheScenario) {
  std::string point;
  Eigen::Vector3d offset(9, 9, 9);
  parse_push_point("com", point, offset);
  EXPECT_EQ(point, "com");
  EXPECT_TRUE(offset.isZero());
  parse_push_point("origin", point, offset);
  EXPECT_EQ(point, "origin");
  parse_push_point("0.1,-2,3e-1", point, offset);
  EXPECT_EQ(point, "origin");
  EXPECT_EQ(offset, Eigen::Vector3d(0.1, -2, 0.3));
  for (const char* bad : {"", "middle", "1,2", "1,2,x", "1,2,nan", "1,2,3,4"})
    EXPECT_THROW(parse_push_point(bad, point, offset), InputError) << bad;
}

// a free box in zero gravity: a push through its centre of mass moves it without turning it; the
// same push at a point off the centre also spins it by r x F dt / I (a short hard push, so that
// the point fixed to the body barely turns while it acts)
TEST(PushPoint, AForceOffTheCentreTurnsTheBody) {
  const std::string model = write_temp("box.xml", R"(<mujoco>
<option timestep="0.001" gravity="0 0 0"/>
<worldbody>
<body name="box" pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.2 0.3" mass="1"/></body>
</worldbody>
</mujoco>
)");
  auto scenario = [&](const std::string& point) {
    return write_temp("box_" + std::to_string(point.size()) + ".yaml",
                      "name: box\nengine: mujoco\nmodel: " + model +
                          "\ntimestep: 0.001\nduration: 0.2\ngravity: [0, 0, 0]\n"
                          "controllers: []\nfall: {enabled: false}\nperturbations:\n"
                          "  - {body: box, force: [0, 100, 0], start: 0, duration: 0.01" +
                          point + "}\n");
  };
  for (const std::string& point : {std::string(""), std::string(", point: com"),
                                   std::string(", point: origin, offset: [0.1, 0, 0]")}) {
    Simulation sim(load_scenario(scenario(point)), RunOptions{.quiet = true});
    sim.run();
    const auto v = sim.engine().body_velocity(0);  // (angular, linear)
    EXPECT_NEAR(v[4], 1.0, 1e-6) << point;         // 100 N for 0.01 s on 1 kg
    // I_zz of a 0.2 x 0.4 box of 1 kg is (0.04 + 0.16) / 12; the point turns with the body
    // (by 0.03 rad during the push), which shortens the lever a little
    const double spin = point.find("offset") != std::string::npos ? 0.1 / (0.2 / 12) : 0.0;
    EXPECT_NEAR(v[2], spin, 1e-6 + 1e-3 * spin) << point;
    EXPECT_NEAR(v[0], 0.0, 1e-9) << point;
  }
  try {
    Simulation sim(load_scenario(scenario(", point: middle")), RunOptions{.quiet = true});
    FAIL() << "a bad point loaded";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(".yaml:10: perturbations.0.point"), std::string::npos) << m;
    EXPECT_NE(m.find("'middle' is not a push point"), std::string::npos) << m;
  }
}

RobustnessOptions small_map(double at) {
  RobustnessOptions o;
  o.body = "h_spine";
  o.directions = 2;
  o.phases = 1;
  o.push_duration = 0.1;
  o.max_force = 400;
  o.tolerance = 4;
  o.at = at;
  o.recovery_window_s = 1.0;
  o.duration = at + 1.5;
  o.threads = 2;
  return o;
}

// the map's +-x thresholds are push-threshold's when both run with the same max, push,
// tolerance, start and criterion: on both engines, at two push times
TEST(RobustnessMap, PlusMinusXEqualPushThreshold) {
  const LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  for (const char* engine : {"mujoco", "dart"})
    for (double at : {std::string(engine) == "mujoco" ? 2.0 : 1.5}) {
      RobustnessOptions o = small_map(at);
      o.engine = engine;
      const RobustnessResult map = run_robustness(loaded, o);
      ASSERT_EQ(map.directions.size(), 2u);
      EXPECT_FALSE(map.walker);
      EXPECT_FALSE(map.planar);
      PushThresholdOptions p;
      p.body = o.body;
      p.axis = 0;
      p.engine = engine;
      p.duration = o.duration;
      p.max_force = o.max_force;
      p.push_duration = o.push_duration;
      p.at = at;
      p.tolerance = o.tolerance;
      const PushThresholdResult bisected = find_push_threshold(loaded, p);
      const std::string where = std::string(engine) + " at " + std::to_string(at);
      // z-up on MuJoCo: angle 0 is +x; on DART fullbody1 is y-up, and angle 0 is +x too
      EXPECT_EQ(map.directions[0], Eigen::Vector3d(1, 0, 0)) << where;
      EXPECT_EQ(map.directions[1], Eigen::Vector3d(-1, 0, 0)) << where;
      EXPECT_EQ(map.cell(0, 0).threshold, bisected.positive.survived) << where;
      EXPECT_EQ(map.cell(1, 0).threshold, bisected.negative.survived) << where;
      EXPECT_EQ(map.cell(0, 0).fell, bisected.positive.fell) << where;
      EXPECT_EQ(map.cell(1, 0).fell, bisected.negative.fell) << where;
      EXPECT_GT(map.cell(0, 0).threshold, 40) << where;
      EXPECT_GT(map.cell(1, 0).threshold, 40) << where;
      // the failing trials fell after the push; the survivors kept their feet or stepped
      for (const auto& c : map.cells)
        for (const auto& t : c.trials) {
          EXPECT_NE(t.outcome, 1) << where;
          if (t.force == 0) EXPECT_EQ(t.detour_m, 0) << where;
        }
    }
}

// with the joints unpowered the biped is down before a push at 2 s: every trial is outcome 1
TEST(RobustnessMap, APushAfterAFallIsOutcomeOne) {
  const LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"),
                                              {"controllers.0.kp=0", "controllers.0.kd=0"});
  RobustnessOptions o = small_map(2.0);
  o.engine = "mujoco";
  const RobustnessResult map = run_robustness(loaded, o);
  ASSERT_TRUE(map.unpushed_fall_time.has_value());
  EXPECT_LT(*map.unpushed_fall_time, 2.0);
  for (const auto& c : map.cells) {
    EXPECT_TRUE(c.falls_unpushed);
    EXPECT_EQ(c.threshold, 0);
    EXPECT_EQ(c.outcome_at_threshold, 1);
    ASSERT_EQ(c.trials.size(), 2u);  // the maximum, then 0
    for (const auto& t : c.trials) EXPECT_EQ(t.outcome, 1);
  }
}

// the planar SIMBICON walker: a walker whose phases follow its touchdowns, pushed along its plane
// only; at the seed's 1700 Hz and at 1500 Hz
TEST(RobustnessMap, PlanarWalkerPhasesFollowTheGait) {
  for (const char* timestep : {"timestep=0.000588235294117647", "timestep=0.000666666666666667"}) {
    const LoadedScenario loaded =
        load_scenario(test::scenario_path("simbicon_walk.yaml"), {timestep});
    RobustnessOptions o;
    o.body = "torso";
    o.directions = 8;
    o.phases = 2;
    o.max_force = 400;
    o.tolerance = 25;
    o.at = 3;
    o.duration = 7;
    o.threads = 2;
    const RobustnessResult map = run_robustness(loaded, o);
    EXPECT_TRUE(map.walker) << timestep;
    EXPECT_TRUE(map.planar) << timestep;
    ASSERT_EQ(map.directions.size(), 2u) << timestep;
    EXPECT_EQ(map.directions[0], Eigen::Vector3d(1, 0, 0)) << timestep;
    EXPECT_EQ(map.directions[1], Eigen::Vector3d(-1, 0, 0)) << timestep;
    ASSERT_FALSE(map.notes.empty());
    EXPECT_NE(map.notes[0].find("planar"), std::string::npos) << map.notes[0];
    EXPECT_EQ(map.feet.size(), 2u) << timestep;
    // a step of the seed's gait lasts a few tenths of a second; phase 1/2 is half a step later
    EXPECT_GT(map.step_period_s, 0.2) << timestep;
    EXPECT_LT(map.step_period_s, 0.8) << timestep;
    EXPECT_GE(map.push_starts[0], 3.0) << timestep;
    EXPECT_NEAR(map.push_starts[1] - map.push_starts[0], map.step_period_s / 2, 1e-9);
    for (const auto& c : map.cells) {
      EXPECT_FALSE(c.falls_unpushed) << timestep;
      EXPECT_GT(c.threshold, 0) << timestep;
      // a push that is survived keeps walking: the recovery window sees steps
      for (const auto& t : c.trials)
        if (t.outcome == 0) EXPECT_GT(t.touchdowns, 2) << timestep;
    }
  }
}

TEST(RobustnessMap, SameFilesWhateverTheThreadCount) {
  const LoadedScenario loaded = load_scenario(test::scenario_path("simbicon_walk.yaml"));
  RobustnessOptions o;
  o.body = "torso";
  o.phases = 3;
  o.max_force = 400;
  o.tolerance = 50;
  o.at = 3;
  o.duration = 6.5;
  std::string files[2];
  for (int threads : {1, 3}) {
    o.threads = threads;
    const auto dir = std::filesystem::temp_directory_path() /
                     ("stance_robustness_threads" + std::to_string(threads));
    const RobustnessResult map = run_robustness(loaded, o);
    write_robustness_outputs(dir.string(), o, map);
    files[threads == 3] = test::read_file((dir / "robustness.csv").string()) +
                          test::read_file((dir / "thresholds.csv").string()) +
                          test::read_file((dir / "summary.json").string());
  }
  EXPECT_FALSE(files[0].empty());
  EXPECT_EQ(files[0], files[1]);
}

TEST(RobustnessMap, BadInputBeforeAnyTrial) {
  const LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  RobustnessOptions o = small_map(2.0);
  int cells = 0;
  auto count = [&](const RobustnessCell&, int, int) { ++cells; };
  o.body = "h_spline";
  EXPECT_THROW(run_robustness(loaded, o, count), InputError);
  o = small_map(2.0);
  o.directions = 0;
  EXPECT_THROW(run_robustness(loaded, o, count), InputError);
  o = small_map(2.0);
  o.max_force = std::nan("");
  EXPECT_THROW(run_robustness(loaded, o, count), InputError);
  o = small_map(2.0);
  o.point = "middle";
  EXPECT_THROW(run_robustness(loaded, o, count), InputError);
  EXPECT_EQ(cells, 0);
}

}  // namespace
}  // namespace stance
