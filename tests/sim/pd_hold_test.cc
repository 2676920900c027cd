// The PD-hold scenario on both engines: the first end-to-end use of the engine interface.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

RunResult run_pd_hold(const std::string& engine, const std::string& out_dir = "") {
  LoadedScenario s = load_scenario(test::scenario_path("pd_hold.yaml"));
  RunOptions opt;
  opt.engine = engine;
  opt.out_dir = out_dir;
  Simulation run(s, opt);
  RunResult r = run.run();
  // the arm ends near its horizontal target on either engine
  Eigen::VectorXd q(run.engine().nq());
  run.engine().get_positions(q);
  for (const char* dof : {"shoulder", "elbow", "wrist"})
    EXPECT_NEAR(run.engine().dof_position(run.engine().require_dof(dof)), 0.0, 0.05)
        << engine << " " << dof;
  return r;
}

TEST(PdHoldScenario, HoldsOnMujocoAndDart) {
  RunResult mj = run_pd_hold("mujoco");
  RunResult dart = run_pd_hold("dart");
  for (const RunResult* r : {&mj, &dart}) {
    EXPECT_FALSE(r->diverged);
    EXPECT_FALSE(r->fell);
    EXPECT_NEAR(r->sim_time, 5.0, 1e-9);
    EXPECT_EQ(r->metrics["pushes_survived"], 1);
  }
}

TEST(PdHoldScenario, WritesSummaryAndLog) {
  auto dir = std::filesystem::temp_directory_path() / "stance_pd_hold_out";
  std::filesystem::remove_all(dir);
  run_pd_hold("mujoco", dir.string());
  std::ifstream js(dir / "summary.json");
  nlohmann::json j = nlohmann::json::parse(js);
  for (const char* key :
       {"scenario", "engine", "seed", "sim_time", "fell", "fall_time", "wall_time_s", "metrics"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["scenario"], "pd_hold");
  EXPECT_EQ(j["engine"], "mujoco");
  EXPECT_TRUE(j["fall_time"].is_null());
  // 100 Hz for 5 s plus the initial row, and the push recorded with its arrow
  std::ifstream log(dir / "log.csv");
  std::string line;
  int rows = -1;
  bool saw_push = false;
  while (std::getline(log, line)) {
    ++rows;
    if (rows > 0 && line.find(",-20,") != std::string::npos) saw_push = true;
  }
  EXPECT_EQ(rows, 501);
  EXPECT_TRUE(saw_push);
}

TEST(PdHoldScenario, SameSeedSameOutputs) {
  RunResult a = run_pd_hold("mujoco");
  RunResult b = run_pd_hold("mujoco");
  a.wall_time_s = b.wall_time_s = 0;
  a.metrics = without_wall_clock(a.metrics);
  b.metrics = without_wall_clock(b.metrics);
  EXPECT_EQ(a.to_json().dump(), b.to_json().dump());
}

}  // namespace
}  // namespace stance
