// SIMBICON on DART's Atlas with one-axis ankles (issue 45): the SDF's ankle roll hinges welded by
// the model entry's lock_joints on both engines, and the 3D controller without ankle roll walks
// 60 s at the shipped gait and with every torque x0.8 and x1.2 (torque_scale scales all the gains
// of both controllers), on MuJoCo and DART. Without hip yaw as well (its hinges welded too), it
// walks 60 s at the gait and at the SIMBICON gains x0.8 and x1.2 (20 s of those on DART, for CPU).
#include <gtest/gtest.h>

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

constexpr const char* kScenario = "simbicon_atlas_pitch_ankles.yaml";

// the locked joints are gone from the engine's dofs, their links still there; the pitch hinges
// of the ankles remain
void expect_ankles_pitch_only(const std::string& engine) {
  const LoadedScenario l = load_scenario(test::scenario_path(kScenario), {});
  std::unique_ptr<Engine> e = make_scenario_engine(l.scenario, engine, &l);
  EXPECT_EQ(e->dof_index("l_leg_akx"), -1);
  EXPECT_EQ(e->dof_index("r_leg_akx"), -1);
  EXPECT_GE(e->dof_index("l_leg_aky"), 0);
  EXPECT_GE(e->body_index("l_foot"), 0);
  // the unlocked model has them
  const LoadedScenario full = load_scenario(test::scenario_path("simbicon_atlas.yaml"), {});
  std::unique_ptr<Engine> f = make_scenario_engine(full.scenario, engine, &full);
  EXPECT_GE(f->dof_index("l_leg_akx"), 0);
  EXPECT_EQ(f->nv(), e->nv() + 2);
  EXPECT_NEAR(f->total_mass(), e->total_mass(), 1e-9);
}

void expect_walks_sixty_seconds(const std::string& engine) {
  for (const std::string& scale : {"1", "0.8", "1.2"}) {
    SCOPED_TRACE(engine + " torque_scale " + scale);
    const LoadedScenario l =
        load_scenario(test::scenario_path(kScenario), {"torque_scale=" + scale});
    Simulation run(l, test::quiet(engine));
    const RunResult r = run.run();
    ASSERT_FALSE(r.diverged) << r.divergence;
    EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
    EXPECT_NEAR(r.sim_time, 60.0, 1e-6);
    EXPECT_GT(test::metric(r, "mean_speed_mps"), 0.4);
    EXPECT_LT(test::metric(r, "drift_per_10m"), 3.0);
    EXPECT_GT(r.metrics.at("step_count").get<int>(), 120);
    const Simbicon& s = dynamic_cast<const Simbicon&>(*run.controllers().at(0));
    EXPECT_EQ(s.model().ankle_roll[0], -1);
  }
}

// the hip yaw hinges welded as well and left out of the skeleton; the SIMBICON gains (every kp
// and kd) times gain_factor
std::vector<std::string> without_hip_yaw(double gain_factor) {
  const std::string k = "controllers.0.skeleton.";
  std::vector<std::string> sets = {"model.0.lock_joints=[l_leg_akx,r_leg_akx,l_leg_hpz,r_leg_hpz]",
                                   k + "left_hip_yaw=\"\"", k + "right_hip_yaw=\"\""};
  const LoadedScenario l = load_scenario(test::scenario_path(kScenario), {});
  for (const char* servo :
       {"torso", "swing_hip", "swing_knee", "swing_ankle", "stance_knee", "stance_ankle"})
    for (const char* gain : {"kp", "kd"}) {
      const std::string key = std::string("controllers.0.gait.gains.") + servo + "." + gain;
      const std::optional<double> value = yaml_number_at(l.document, key);
      if (!value) ADD_FAILURE() << key << " is not in the scenario";
      if (value) sets.push_back(key + "=" + std::to_string(*value * gain_factor));
    }
  return sets;
}

void expect_walks_without_hip_yaw(const std::string& engine, double neighbours_s) {
  for (const double factor : {1.0, 0.8, 1.2}) {
    SCOPED_TRACE(engine + " gains x" + std::to_string(factor));
    std::vector<std::string> sets = without_hip_yaw(factor);
    const double duration = factor == 1.0 ? 60.0 : neighbours_s;
    sets.push_back("duration=" + std::to_string(duration));
    Simulation run(load_scenario(test::scenario_path(kScenario), sets), test::quiet(engine));
    const RunResult r = run.run();
    ASSERT_FALSE(r.diverged) << r.divergence;
    EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
    EXPECT_NEAR(r.sim_time, duration, 1e-6);
    EXPECT_GT(test::metric(r, "mean_speed_mps"), 0.4);
    EXPECT_LT(test::metric(r, "drift_per_10m"), 3.0);
    EXPECT_GT(r.metrics.at("step_count").get<int>(), 2.5 * duration);
    const Simbicon::Model& m = dynamic_cast<const Simbicon&>(*run.controllers().at(0)).model();
    EXPECT_EQ(m.hip_yaw[0], -1);
    EXPECT_EQ(m.ankle_roll[1], -1);
    EXPECT_EQ(run.engine().dof_index("r_leg_hpz"), -1);
  }
}

TEST(SimbiconAtlasPitchAnkles, LockJointsWeldsTheAnkleRollsOnMujoco) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  expect_ankles_pitch_only("mujoco");
}

TEST(SimbiconAtlasPitchAnkles, LockingAJointTheFileHasNotIsAnError) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  const LoadedScenario l =
      load_scenario(test::scenario_path(kScenario), {"model.0.lock_joints=[l_leg_akz]"});
  try {
    make_scenario_engine(l.scenario, "mujoco", &l);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lock_joints: no joint 'l_leg_akz'"), std::string::npos)
        << e.what();
  }
}

TEST(SimbiconAtlasPitchAnkles, MujocoWalksSixtySecondsAtTheGaitAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  expect_walks_sixty_seconds("mujoco");
}

TEST(SimbiconAtlasPitchAnkles, MujocoWalksWithoutHipYawAtTheGaitAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  expect_walks_without_hip_yaw("mujoco", 60);
}

#ifdef STANCE_HAVE_DART
TEST(SimbiconAtlasPitchAnkles, LockJointsWeldsTheAnkleRollsOnDart) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  expect_ankles_pitch_only("dart");
}

TEST(SimbiconAtlasPitchAnkles, DartWalksSixtySecondsAtTheGaitAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  expect_walks_sixty_seconds("dart");
}

TEST(SimbiconAtlasPitchAnkles, DartWalksWithoutHipYawAtTheGaitAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  expect_walks_without_hip_yaw("dart", 20);
}
#endif

}  // namespace
}  // namespace stance
