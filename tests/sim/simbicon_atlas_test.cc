// SIMBICON walks DART's Atlas (SDF, box feet, torques clamped to its effort limits) on both
// engines: 20 s at the shipped gait, with every torque x0.8 and x1.2 (torque_scale scales all
// the gains of both controllers) and with the timestep halved and doubled; and 100 N pushes on
// the torso for 0.2 s, forward, back and to either side, at one phase of the stride.
#include <gtest/gtest.h>

#include <filesystem>

#include "control/simbicon.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

RunResult walk(const std::string& engine, const std::vector<std::string>& overrides,
               const std::vector<Perturbation>& pushes = {}) {
  LoadedScenario s = load_scenario(test::scenario_path("simbicon_atlas.yaml"), overrides);
  RunOptions opt;
  opt.engine = engine;
  opt.extra_pushes = pushes;
  Simulation run(s, opt);
  return run.run();
}

void expect_walks(const RunResult& r, const std::string& what) {
  ASSERT_FALSE(r.diverged) << what << " " << r.divergence;
  EXPECT_FALSE(r.fell) << what << " fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
  EXPECT_NEAR(r.sim_time, 20.0, 1e-6) << what;
  // forward at more than 0.4 m/s, straight: less than 1 m sideways per 10 m
  EXPECT_GT(r.metrics.at("distance_m").get<double>(), 8.0) << what;
  EXPECT_LT(r.metrics.at("drift_per_10m").get<double>(), 1.0) << what;
  EXPECT_GT(r.metrics.at("step_count").get<int>(), 40) << what;
  // the SDF's effort limits hold: every requested torque above one was clamped
  EXPECT_TRUE(r.metrics.at("torque_limit").at("clamping").get<bool>()) << what;
}

void walks_at_the_gait_and_nearby(const std::string& engine) {
  for (const std::vector<std::string>& set : {std::vector<std::string>{},
                                              {"torque_scale=0.8"},
                                              {"torque_scale=1.2"},
                                              {"timestep=0.0005"},
                                              {"timestep=0.002"}}) {
    const std::string what = engine + (set.empty() ? "" : " " + set[0]);
    expect_walks(walk(engine, set), what);
  }
}

void survives_pushes(const std::string& engine) {
  // 100 N for 0.2 s on the upper torso at 8 s, in four directions
  for (const Eigen::Vector3d& f : {Eigen::Vector3d(100, 0, 0), Eigen::Vector3d(-100, 0, 0),
                                   Eigen::Vector3d(0, 100, 0), Eigen::Vector3d(0, -100, 0)}) {
    Perturbation p;
    p.body = "utorso";
    p.force = f;
    p.start = 8.0;
    p.duration = 0.2;
    const RunResult r = walk(engine, {"duration=12"}, {p});
    SCOPED_TRACE(::testing::Message() << engine << " push " << f.transpose() << " N");
    ASSERT_FALSE(r.diverged);
    EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
    EXPECT_EQ(r.metrics.at("pushes_applied").get<int>(), 1);
    EXPECT_EQ(r.metrics.at("pushes_survived").get<int>(), 1);
  }
}

TEST(SimbiconAtlas, MujocoWalksTwentySecondsAtTheGaitAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  walks_at_the_gait_and_nearby("mujoco");
}

TEST(SimbiconAtlas, MujocoSurvivesHundredNewtonPushes) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  survives_pushes("mujoco");
}

#ifdef STANCE_HAVE_DART
TEST(SimbiconAtlas, DartWalksTwentySecondsAtTheGaitAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  walks_at_the_gait_and_nearby("dart");
}

TEST(SimbiconAtlas, DartSurvivesHundredNewtonPushes) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  survives_pushes("dart");
}
#endif

}  // namespace
}  // namespace stance
