// The seed's slope walker on MuJoCo: it walks 100+ steps at the scenario defaults, and with the
// knee FSM removed its swing foot scuffs and it falls.
#include "control/slope_walker.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::string scenario_path() {
  return test::scenario_path("slope_walk.yaml");
}

RunResult run_walker(const std::vector<std::string>& sets, double duration,
                     const std::string& out_dir = "") {
  LoadedScenario loaded = load_scenario(scenario_path(), sets);
  RunOptions opt;
  opt.duration = duration;
  opt.out_dir = out_dir;
  opt.quiet = true;
  Simulation run(loaded, opt);
  return run.run();
}

TEST(SlopeWalker, WalksAHundredStepsDownTheDefaultSlope) {
  std::string out = (std::filesystem::temp_directory_path() / "stance_tests/slope_walk").string();
  RunResult r = run_walker({}, 80, out);
  ASSERT_FALSE(r.diverged) << r.divergence;
  const auto& m = r.metrics;
  EXPECT_GE(m["steps_taken"].get<int>(), 100);
  EXPECT_FALSE(m["walker_fell"].get<bool>());
  EXPECT_FALSE(m["walker_stalled"].get<bool>());
  // downhill is +x, and the steps are real strides, not shuffles
  EXPECT_GT(m["distance_m"].get<double>(), 30.0);
  EXPECT_GT(m["mean_step_length_m"].get<double>(), 0.3);
  EXPECT_LT(m["scuff_fraction"].get<double>(), 0.05);

  // steps.csv: one row per step, legs alternating
  std::ifstream steps(out + "/steps.csv");
  std::string header, line;
  std::getline(steps, header);
  EXPECT_EQ(header, "step,time_s,stance_leg,step_length_m,step_duration_s");
  int rows = 0;
  while (std::getline(steps, line)) ++rows;
  EXPECT_EQ(rows, m["steps_taken"].get<int>());
  std::ifstream log(out + "/log.csv");
  std::getline(log, header);
  for (const char* col : {"leg1_angle", "foot2_z", "hip_fsm", "knee1_fsm", "step_count"})
    EXPECT_NE(header.find(col), std::string::npos) << col;
}

TEST(SlopeWalker, LockedKneesScuffTheSwingFootAndFall) {
  RunResult walking = run_walker({}, 10);
  RunResult locked = run_walker({"controllers.0.knee_fsm=false"}, 10);
  const auto& m = locked.metrics;
  EXPECT_TRUE(m["walker_fell"].get<bool>() || m["walker_stalled"].get<bool>());
  EXPECT_GT(m["scuff_fraction"].get<double>(), 0.2);
  EXPECT_LT(walking.metrics["scuff_fraction"].get<double>(), 0.05);
  EXPECT_LT(m["distance_m"].get<double>(), 0.3 * walking.metrics["distance_m"].get<double>());
}

TEST(SlopeWalker, TwistAngleIsTheRotationAboutTheAxis) {
  const Eigen::Vector3d axis(0, -1, 0);
  for (double a : {-2.0, -0.3, 0.0, 0.7, 3.0}) {
    Eigen::Quaterniond q(Eigen::AngleAxisd(a, axis));
    EXPECT_NEAR(twist_angle(q, axis), a, 1e-12);
    // the double cover gives the same angle
    Eigen::Quaterniond neg(-q.w(), -q.x(), -q.y(), -q.z());
    EXPECT_NEAR(twist_angle(neg, axis), a, 1e-12);
  }
  // a leg at +0.4 about -y has its foot ahead (+x) of the hip
  Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, axis));
  EXPECT_GT((q * Eigen::Vector3d(0, 0, -1)).x(), 0);
}

TEST(SlopeWalker, RejectsDofsOfTheWrongKind) {
  LoadedScenario loaded = load_scenario(scenario_path(), {"controllers.0.knee1_dof=hip"});
  RunOptions opt;
  try {
    Simulation run(loaded, opt);
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("knee1_dof 'hip' must be a slide"), std::string::npos)
        << e.what();
  }
  // a value out of its range fails when the scenario is loaded (parameters are typed at load)
  EXPECT_THROW(load_scenario(scenario_path(), {"controllers.0.first_swing_leg=3"}), InputError);
}

}  // namespace
}  // namespace stance
