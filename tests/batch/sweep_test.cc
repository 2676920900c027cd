// The parameter sweep: values in order, and byte-identical outputs for 1 and 2 threads.
#include "batch/sweep.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "control/lqr.h"
#include "core/error.h"
#include "test_support.h"

namespace stance {
namespace {

TEST(Sweep, ValuesAndTheirText) {
  std::vector<double> v = linspace(2, 12, 41);
  ASSERT_EQ(v.size(), 41u);
  EXPECT_EQ(v.front(), 2);
  EXPECT_EQ(v.back(), 12);
  EXPECT_EQ(format_sweep_value(v[1]), "2.25");
  EXPECT_EQ(format_sweep_value(10), "10");
  EXPECT_EQ(format_sweep_value(0.1), "0.1");
  EXPECT_EQ(parse_value_list("4, 10,2.5"), (std::vector<double>{4, 10, 2.5}));
  EXPECT_THROW(parse_value_list("4,x"), InputError);
  EXPECT_THROW(linspace(1, 2, 0), InputError);
}

TEST(Sweep, SameCsvsWhateverTheThreadCount) {
  SweepOptions o;
  o.scenario = test::scenario_path("slope_walk.yaml");
  o.param = "controllers.0.hip_kp";
  o.values = {11, 9, 10};
  o.duration = 20;
  auto base = std::filesystem::temp_directory_path() / "stance_tests";
  std::string out[2];
  for (int threads : {1, 2}) {
    o.threads = threads;
    std::vector<SweepPoint> points = run_sweep(o);
    ASSERT_EQ(points.size(), 3u);
    // results stay in the order of the values
    EXPECT_EQ(points[0].value, 11);
    EXPECT_EQ(points[1].value, 9);
    for (const auto& p : points) EXPECT_TRUE(p.error.empty()) << p.error;
    // different gains give different gaits: the runs really used the swept value
    EXPECT_NE(points[0].result.metrics["mean_step_length_m"],
              points[1].result.metrics["mean_step_length_m"]);
    auto dir = base / ("sweep_threads_" + std::to_string(threads));
    write_sweep_outputs(dir.string(), o.param, points);
    out[threads - 1] = test::read_file(dir / "sweep.csv") + test::read_file(dir / "points.csv");
  }
  EXPECT_GT(out[0].size(), 200u);
  EXPECT_EQ(out[0], out[1]);
}

TEST(Sweep, BadKeyPathFailsBeforeRunning) {
  SweepOptions o;
  o.scenario = test::scenario_path("slope_walk.yaml");
  o.param = "controllers.0.hip_kpp";
  o.values = {1, 2};
  try {
    run_sweep(o);
    FAIL() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("hip_kpp"), std::string::npos) << e.what();
  }
}

// the LQR design is the costly part of its model: a sweep over a push force designs it once, a
// sweep over the timestep (another world) once per value
TEST(Sweep, DesignsTheLqrOncePerWorld) {
  if (!std::filesystem::exists("/usr/share/mujoco/model/humanoid/humanoid.xml"))
    GTEST_SKIP() << "humanoid.xml missing (Debian package libmujoco-samples)";
  SweepOptions o;
  o.scenario = test::scenario_path("lqr_one_leg.yaml");
  o.sets = {"controllers.0.force_plot=false",
            "perturbations=[{body: torso, force: [0, 0, 0], start: 0.1, duration: 0.1}]"};
  o.param = "perturbations.0.force.0";
  o.values = linspace(0, 40, 8);
  o.duration = 0.3;
  o.threads = 2;
  long before = lqr_designs_made();
  std::vector<SweepPoint> points = run_sweep(o);
  ASSERT_EQ(points.size(), 8u);
  for (const auto& p : points) EXPECT_TRUE(p.error.empty()) << p.error;
  EXPECT_EQ(lqr_designs_made() - before, 1);
  // the pushes really differed
  EXPECT_NE(points[0].result.metrics["max_com_foot_distance_m"],
            points[7].result.metrics["max_com_foot_distance_m"]);
  o.param = "timestep";
  o.values = {0.004, 0.005, 0.006};
  before = lqr_designs_made();
  points = run_sweep(o);
  for (const auto& p : points) EXPECT_TRUE(p.error.empty()) << p.error;
  EXPECT_EQ(lqr_designs_made() - before, 3);
}

}  // namespace
}  // namespace stance
