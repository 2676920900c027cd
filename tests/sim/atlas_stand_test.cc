// DART's Atlas (URDF, box feet fitted to its STL meshes) stands on the ground under stable PD on
// both engines, at the shipped gains and nearby, within its effort limits, and the two engines
// agree on where it stands.
#include <gtest/gtest.h>

#include <filesystem>

#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

struct Stood {
  RunResult result;
  Eigen::Vector3d com;
};

Stood stand(const std::string& engine, const std::vector<std::string>& overrides) {
  std::vector<std::string> all = {"duration=3"};
  all.insert(all.end(), overrides.begin(), overrides.end());
  LoadedScenario s = load_scenario(test::scenario_path("atlas_stand.yaml"), all);
  RunOptions opt;
  opt.engine = engine;
  Simulation run(s, opt);
  Stood out;
  out.result = run.run();
  out.com = run.engine().com();
  return out;
}

TEST(AtlasStand, StandsOnBothEnginesAtTheGainsAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  for (const char* engine : {"mujoco", "dart"}) {
    for (const std::vector<std::string>& set :
         {std::vector<std::string>{},
          {"controllers.0.kp=4800", "controllers.0.kd=240"},
          {"controllers.0.kp=7200", "controllers.0.kd=360"}}) {
      const Stood s = stand(engine, set);
      const std::string what = std::string(engine) + (set.empty() ? "" : " " + set[0]);
      EXPECT_FALSE(s.result.fell) << what << " " << s.result.fall_reason;
      EXPECT_FALSE(s.result.diverged) << what;
      EXPECT_LT(s.result.metrics["com_displacement_m"].get<double>(), 0.05) << what;
      // the feet rest on the ground: the COM stays at its start height, 1.149 m
      EXPECT_NEAR(s.com.z(), 1.149, 0.02) << what;
      // no torque asked for reaches a limit: the soles start on the ground (from 3 mm above,
      // DART's touchdown asked 1.33x l_leg_hpx's 180 N m)
      EXPECT_LT(s.result.metrics["torque_limit"]["peak_ratio"].get<double>(), 1) << what;
      EXPECT_EQ(s.result.metrics["torque_limit"]["clamped_steps"].get<long>(), 0) << what;
    }
  }
}

TEST(AtlasStand, EnginesAgreeAndOtherTimestepsHold) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  const Stood mj = stand("mujoco", {});
  const Stood dart = stand("dart", {});
  EXPECT_LT((mj.com - dart.com).norm(), 0.02);
  for (const char* dt : {"timestep=0.0005", "timestep=0.002"}) {
    const Stood s = stand("mujoco", {dt});
    EXPECT_FALSE(s.result.fell) << dt;
  }
}

}  // namespace
}  // namespace stance
