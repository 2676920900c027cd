// S0, the standing biped (seed 000) on both engines with the seed's gains (SPD Kp 400, Kd 40):
// stands, survives pushes on the spine, needs the ankle strategy, and the engines agree on the
// standing COM height. DART runs near real time, so its runs are few and short.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

RunResult run_with_push(const std::string& engine, double fx, double duration,
                        const std::vector<std::string>& sets = {}) {
  RunOptions opt;
  opt.engine = engine;
  opt.duration = duration;
  Perturbation p;
  p.body = "h_spine";
  p.force = Eigen::Vector3d(fx, 0, 0);
  p.start = 2.0;
  p.duration = 0.1;
  opt.extra_pushes.push_back(p);
  return Simulation(load_scenario(test::scenario_path("biped_stand.yaml"), sets), opt).run();
}

// stands 10 s; returns the COM height after 5 s
double stand_ten_seconds(const std::string& engine) {
  RunOptions opt;
  opt.engine = engine;
  Simulation run(load_scenario(test::scenario_path("biped_stand.yaml")), opt);
  double com_height_5s = 0;
  const int steps = static_cast<int>(std::lround(10.0 / run.engine().timestep()));
  for (int k = 0; k < steps; ++k) {
    EXPECT_TRUE(run.step()) << engine << ": " << run.result().divergence;
    if (k + 1 == steps / 2) {
      run.engine().forward();
      com_height_5s = run.engine().com().y();  // the model is Y-up
    }
  }
  run.engine().forward();
  // upright: the COM stays near its standing height, not on the floor
  EXPECT_GT(run.engine().com().y(), com_height_5s - 0.05) << engine;
  EXPECT_NEAR(run.engine().com().y(), com_height_5s, 0.02) << engine;
  return com_height_5s;
}

TEST(BipedStand, StandsTenSecondsOnBothEnginesAndTheyAgreeOnComHeight) {
  double mujoco = stand_ten_seconds("mujoco");
  double dart = stand_ten_seconds("dart");
  // the ground's top face is at y = -0.895: the COM stands about 0.84 m above it
  EXPECT_GT(mujoco + 0.895, 0.8);
  EXPECT_NEAR(mujoco, dart, 0.02);
}

TEST(BipedStand, SurvivesFiftyNewtonsForwardOnBothEngines) {
  for (const char* engine : {"mujoco", "dart"}) {
    RunResult r = run_with_push(engine, 50, 4.5);
    EXPECT_FALSE(r.fell) << engine << ": " << r.fall_reason;
    EXPECT_EQ(r.metrics["pushes_survived"], 1) << engine;
  }
}

TEST(BipedStand, SurvivesOneHundredNewtonsBackwardOnDart) {
  RunResult r = run_with_push("dart", -100, 5.0);
  EXPECT_FALSE(r.fell) << r.fall_reason;
  EXPECT_EQ(r.metrics["pushes_survived"], 1);
}

// the scenario's capture term (docs/biped.md) meets the push before the backward band's 100 N m
// step tips the feet; without it MuJoCo falls backward about 1.2 s after the push
TEST(BipedStand, SurvivesOneHundredNewtonsBackwardOnMujoco) {
  RunResult r = run_with_push("mujoco", -100, 5.0);
  EXPECT_FALSE(r.fell) << r.fall_reason;
  EXPECT_EQ(r.metrics["pushes_survived"], 1);
  RunResult seed = run_with_push("mujoco", -100, 5.0, {"controllers.1.capture.gain=0"});
  EXPECT_TRUE(seed.fell);
}

TEST(BipedStand, FallsWithoutTheAnkleStrategy) {
  for (const char* engine : {"mujoco", "dart"}) {
    RunResult r = run_with_push(engine, 50, 4.0, {"controllers.1.enabled=false"});
    EXPECT_TRUE(r.fell) << engine;
    EXPECT_EQ(r.metrics["pushes_survived"], 0) << engine;
  }
}

// plain PD with the seed's gains blows up within a few steps; DART used to abort in its
// FreeJoint transform assert, now the run stops as diverged and still writes its summary
TEST(BipedStand, PlainPdDivergenceIsReportedOnDart) {
  RunOptions opt;
  opt.engine = "dart";
  opt.duration = 0.5;
  opt.out_dir =
      (std::filesystem::temp_directory_path() / "stance_tests" / "biped_pd_dart").string();
  Simulation run(load_scenario(test::scenario_path("biped_stand.yaml"), {"controllers.0.type=pd"}),
                 opt);
  RunResult r = run.run();
  EXPECT_TRUE(r.diverged);
  EXPECT_LT(r.sim_time, 0.1);
  // caught while the speeds blow up, before DART's own step overflows to NaN and asserts
  EXPECT_NE(r.divergence.find("blown-up velocity"), std::string::npos) << r.divergence;
  // the cause, not the load's warnings: the engine, the time and the first bad dof
  EXPECT_EQ(r.divergence.rfind("DART instability at t=", 0), 0u) << r.divergence;
  EXPECT_NE(r.divergence.find(" on dof 'j_"), std::string::npos) << r.divergence;
  EXPECT_TRUE(std::filesystem::exists(opt.out_dir + "/summary.json"));
  // the engine does not step such a state; with its positions made non-finite, it answers
  // kinematic queries with NaN instead of aborting
  Engine& e = run.engine();
  EXPECT_FALSE(e.state_is_finite());
  Eigen::VectorXd q(e.nq());
  e.get_positions(q);
  q[0] = std::numeric_limits<double>::quiet_NaN();
  e.set_positions(q);
  EXPECT_FALSE(e.state_is_finite());
  EXPECT_TRUE(std::isnan(e.com().x()));
  EXPECT_TRUE(std::isnan(e.body_pose(e.require_body("h_spine")).pos.x()));
  const double t = e.time();
  e.step();
  EXPECT_EQ(e.time(), t);
}

TEST(BipedStand, PushScheduleIsLoggedAndCounted) {
  RunOptions opt;
  opt.engine = "mujoco";
  opt.duration = 5.0;
  opt.out_dir = (std::filesystem::temp_directory_path() / "stance_tests" / "biped_push").string();
  RunResult r = Simulation(load_scenario(test::scenario_path("biped_push.yaml")), opt).run();
  EXPECT_FALSE(r.fell) << r.fall_reason;
  EXPECT_EQ(r.metrics["pushes_applied"], 3);
  // the pushes at 2 s and 4 s are over by t = 5 s without a fall; the third is not applied yet
  EXPECT_EQ(r.metrics["pushes_survived"], 2);
  for (const char* key : {"max_com_offset_m", "mean_abs_ankle_offset_m", "torque_rms"})
    EXPECT_TRUE(r.metrics.contains(key)) << key;
  EXPECT_GT(r.metrics["max_com_offset_m"].get<double>(), 0.0);
  EXPECT_LT(r.metrics["max_com_offset_m"].get<double>(), 0.2);
}

// the skateboard scenario for 5 s on `engine`, with `overrides` (--set syntax)
RunResult run_skateboard(const std::string& engine,
                         const std::vector<std::string>& overrides = {}) {
  RunOptions opt;
  opt.engine = engine;
  opt.duration = 5.0;
  return Simulation(load_scenario(test::scenario_path("biped_skateboard.yaml"), overrides), opt)
      .run();
}

TEST(BipedSkateboard, BoardMovesForwardWithTheBipedUprightOnDart) {
  RunResult r = run_skateboard("dart");
  EXPECT_FALSE(r.fell) << r.fall_reason;
  EXPECT_GT(r.metrics["board_distance_m"].get<double>(), 0.1);
}

// the wheels' 2 rad/s at 0.04 m, ramped in over 0.5..2.5 s, give 0.28 m by t = 5 s without slip
TEST(BipedSkateboard, BoardMovesForwardWithTheBipedUprightOnMujoco) {
  RunResult r = run_skateboard("mujoco");
  EXPECT_FALSE(r.fell) << r.fall_reason;
  EXPECT_GT(r.metrics["board_distance_m"].get<double>(), 0.2);
  EXPECT_LT(r.metrics["board_distance_m"].get<double>(), 0.3);
}

// standing on the board is what failed on MuJoCo (the seed's pelvis yaw): speed 0 must hold
// still, and the seed's yaw must still fall so the test notices if the cause changes
TEST(BipedSkateboard, StandsStillAtSpeedZeroOnMujocoAndTheSeedsYawFalls) {
  RunResult still = run_skateboard("mujoco", {"controllers.2.speed=0"});
  EXPECT_FALSE(still.fell) << still.fall_reason;
  EXPECT_LT(std::abs(still.metrics["board_distance_m"].get<double>()), 0.01);
  RunResult yawed =
      run_skateboard("mujoco", {"controllers.2.speed=0", "initial_pose.j_pelvis_rot_y=-0.2"});
  EXPECT_TRUE(yawed.fell);
}

}  // namespace
}  // namespace stance
