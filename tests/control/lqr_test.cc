// LQR balance on one leg: the root finder, the cost, the set-point on MuJoCo's humanoid, the
// design's DARE and closed loop, and the scenario's own checks (stands with LQR, falls with
// ctrl0 only, stands under seeded smoothed noise with identical summaries).
#include "control/lqr.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "control/control_noise.h"
#include "core/error.h"
#include "math/dare.h"
#include "params/yaml_params.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::string scenario_path() {
  return test::scenario_path("lqr_one_leg.yaml");
}

// the scenario, or a skip when Debian's libmujoco-samples is absent
#define REQUIRE_HUMANOID()                          \
  if (!std::filesystem::exists(test::kHumanoidXml)) \
    GTEST_SKIP() << test::kHumanoidXml << " missing (Debian package libmujoco-samples)";

LoadedScenario one_leg(const std::vector<std::string>& sets = {}) {
  // no PNG in tests: gnuplot is a demo dependency
  std::vector<std::string> all = {"controllers.0.force_plot=false"};
  all.insert(all.end(), sets.begin(), sets.end());
  return load_scenario(scenario_path(), all);
}

// the one-leg scenario with a control_noise controller appended
LoadedScenario one_leg_with_noise(double balance_std, double other_std) {
  YAML::Node doc = load_yaml_file(scenario_path());
  doc["controllers"][0]["force_plot"] = false;
  YAML::Node noise(YAML::NodeType::Map);
  noise["type"] = "control_noise";
  noise["balance_std"] = balance_std;
  noise["other_std"] = other_std;
  doc["controllers"].push_back(noise);
  return parse_scenario(doc, scenario_path(), test::source_dir() + "/scenarios");
}

TEST(LqrRootFinder, BrentConvergesFasterThanBisection) {
  auto f = [](double x) { return x * x * x - 2 * x - 5; };  // root 2.0945514815423265
  RootResult r = find_root_brent(f, 2, 3, f(2), f(3), 1e-12);
  EXPECT_NEAR(r.x, 2.0945514815423265, 1e-12);
  EXPECT_LE(r.bracket_width, 1e-12);
  // bisection would need log2(1 / 1e-12) = 40 evaluations
  EXPECT_LT(r.evaluations, 15);
  // a step function: only bisection-like progress is possible, the bracket still closes
  auto step = [](double x) { return x < 0.3 ? -1.0 : 1.0; };
  r = find_root_brent(step, 0, 1, -1, 1, 1e-9);
  EXPECT_NEAR(r.x, 0.3, 1e-9);
  EXPECT_THROW(find_root_brent(f, 3, 4, f(3), f(4), 1e-9), std::invalid_argument);
}

TEST(LqrCost, RootFreeBalanceStiffVelocityEps) {
  LqrParams p;
  const int nv = 5;
  Eigen::MatrixXd jc = Eigen::MatrixXd::Zero(3, nv), jf = Eigen::MatrixXd::Zero(3, nv);
  jc(0, 0) = 1;  // COM moves with dof 0
  jf(0, 0) = 0.25;
  jc(1, 3) = 0.5;
  std::vector<bool> is_root = {true, true, false, false, false};
  Eigen::MatrixXd q = lqr_state_cost(p, jc, jf, is_root, {2});
  ASSERT_EQ(q.rows(), 2 * nv);
  const double eps = p.velocity_cost;
  EXPECT_NEAR(q(0, 0), 1000 * 0.75 * 0.75 + eps, 1e-9);  // root: balance only
  EXPECT_NEAR(q(1, 1), eps, 1e-15);                      // root, no balance term
  EXPECT_NEAR(q(2, 2), 3 + eps, 1e-12);                  // balance joint
  EXPECT_NEAR(q(3, 3), 1000 * 0.25 + 0.3 + eps, 1e-9);   // other joint + balance
  EXPECT_NEAR(q(4, 4), 0.3 + eps, 1e-12);
  for (int i = nv; i < 2 * nv; ++i) EXPECT_NEAR(q(i, i), eps, 1e-15);  // velocities
  EXPECT_TRUE(q.isApprox(q.transpose()));
}

TEST(LqrSetPoint, HumanoidOffsetResidualAndCtrl0) {
  REQUIRE_HUMANOID();
  LoadedScenario l = one_leg();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  LqrParams p;
  LqrSetPoint sp = find_lqr_setpoint(p, *engine);
  // the foot just rests on the floor: within the seed's +-1 mm window, bracketed to 1 nm
  EXPECT_LT(std::abs(sp.height_offset_m), 1e-3);
  const double weight = engine->total_mass() * 9.81;
  EXPECT_NEAR(sp.weight_N, weight, 1e-6 * weight);
  EXPECT_LT(std::abs(sp.residual_vertical_force_N), 1e-3 * weight);
  // the curve: pushed down it is negative, lifted it climbs towards the weight
  ASSERT_EQ(sp.curve_force_N.size(), sp.curve_offset_m.size());
  EXPECT_LT(sp.curve_force_N.front(), 0);
  EXPECT_GT(sp.curve_force_N.back(), 0);
  EXPECT_LE(sp.curve_force_N.back(), weight * 1.0001);
  // ctrl0 reproduces the inverse-dynamics forces on every actuated dof
  EXPECT_LT(sp.mismatch_actuated_N, 1e-6);
  EXPECT_EQ(sp.ctrl0.size(), engine->nu());
  // the scenario's engine is untouched
  Eigen::VectorXd q(engine->nq());
  engine->get_positions(q);
  EXPECT_NEAR((q - sp.q0).norm(), std::abs(sp.height_offset_m), 1e-12);
}

TEST(LqrDesign, DareResidualAndStableClosedLoop) {
  REQUIRE_HUMANOID();
  LoadedScenario l = one_leg();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  LqrParams p;
  LqrDesign d = design_lqr(p, *engine);
  const int nv = engine->nv(), nu = engine->nu();
  ASSERT_EQ(d.K.rows(), nu);
  ASSERT_EQ(d.K.cols(), 2 * nv);
  EXPECT_LE(d.dare_residual, 1e-9);
  EXPECT_LT(d.spectral_radius, 1.0);
  // the open loop is unstable: that is why the LQR is needed
  EXPECT_GT(spectral_radius(d.plant.A), 1.0);
  // the balance set: abdomen x3 and left hip x3, knee, ankle x2
  EXPECT_EQ(d.balance_dofs.size(), 9u);
  // K is what the DARE's P gives: recompute from a fresh solve
  DareResult dare = solve_dare(d.plant.A, d.plant.B, d.Q, d.R);
  EXPECT_TRUE(d.K.isApprox(dare.K, 1e-9));
}

TEST(LqrDesign, RejectsBadNames) {
  REQUIRE_HUMANOID();
  auto build = [](const std::string& set) {
    LoadedScenario l = one_leg({set});
    Simulation run(l, {});
  };
  EXPECT_THROW(build("controllers.0.stance_foot=left_fot"), InputError);
  EXPECT_THROW(build("controllers.0.root_body=pelvis"), InputError);  // no free joint
  EXPECT_THROW(build("controllers.0.balance_dofs=[nothing_.*]"), InputError);
  EXPECT_THROW(build("controllers.0.balance_dofs=['(']"), InputError);
}

TEST(LqrBalance, StandsWithLqrAndFallsWithCtrl0Only) {
  REQUIRE_HUMANOID();
  {
    LoadedScenario l = one_leg();
    Simulation run(l, {});
    RunResult r = run.run();
    ASSERT_FALSE(r.diverged) << r.divergence;
    EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
    EXPECT_NEAR(r.sim_time, 30.0, 1e-6);
    EXPECT_LT(r.metrics.at("max_com_foot_distance_m").get<double>(), 0.1);
  }
  {
    LoadedScenario l = one_leg({"controllers.0.feedback=false"});
    Simulation run(l, {});
    RunResult r = run.run();
    ASSERT_TRUE(r.fell);
    EXPECT_LT(*r.fall_time, 3.0);
  }
}

TEST(LqrBalance, SurvivesSmallPushesBothWays) {
  REQUIRE_HUMANOID();
  // 0.1 s pushes on the torso at 3 s; measured limits: 40 N forward, 20 N sideways
  for (const char* push : {"torso,40,0,0,3,0.1", "torso,0,20,0,3,0.1"}) {
    LoadedScenario l = one_leg();
    RunOptions o;
    o.duration = 8.0;
    o.extra_pushes = {parse_push(push)};
    Simulation run(l, o);
    RunResult r = run.run();
    EXPECT_FALSE(r.fell) << push << ": fell at " << r.fall_time.value_or(-1);
  }
}

// the same pose given as a MuJoCo keyframe (how other MJCF humanoids are used) designs the
// same controller
TEST(LqrDesign, KeyframeGivesTheSameDesignAsInitialPose) {
  REQUIRE_HUMANOID();
  LoadedScenario l = one_leg();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  Eigen::VectorXd q(engine->nq());
  engine->get_positions(q);
  std::ifstream in(test::kHumanoidXml);
  std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string key = "<keyframe><key name=\"one_leg\" qpos=\"";
  for (int i = 0; i < q.size(); ++i) key += fmt::format("{}{:.17g}", i ? " " : "", q[i]);
  key += "\"/></keyframe>\n</mujoco>";
  xml.replace(xml.rfind("</mujoco>"), 9, key);
  const std::string model = test::write_temp_file("humanoid_keyframe.xml", xml);

  Scenario s = l.scenario;
  s.model = {ModelEntry{model}};
  s.initial_pose.clear();
  s.keyframe = "one_leg";
  auto keyed = make_scenario_engine(s, "mujoco");
  LqrParams p;
  LqrDesign a = design_lqr(p, *engine), b = design_lqr(p, *keyed);
  EXPECT_NEAR(a.setpoint.height_offset_m, b.setpoint.height_offset_m, 1e-12);
  EXPECT_TRUE(a.K.isApprox(b.K, 1e-8));
}

nlohmann::json summary_without_timing(const std::string& dir) {
  std::ifstream in(dir + "/summary.json");
  nlohmann::json j = nlohmann::json::parse(in);
  j.erase("wall_time_s");
  // wall-clock measurements, not simulation results
  j["metrics"] = without_wall_clock(j["metrics"]);
  return j;
}

TEST(LqrBalance, StandsUnderSmoothedNoiseDeterministically) {
  REQUIRE_HUMANOID();
  const auto base = std::filesystem::temp_directory_path() / "stance_tests" / "lqr_noise";
  nlohmann::json summaries[2];
  for (int i = 0; i < 2; ++i) {
    LoadedScenario l = one_leg_with_noise(0.01, 0.08);
    RunOptions o;
    o.duration = 12.0;
    o.out_dir = (base / std::to_string(i)).string();
    o.quiet = true;
    Simulation run(l, o);
    RunResult r = run.run();
    EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
    EXPECT_NEAR(r.sim_time, 12.0, 1e-6);
    EXPECT_GT(r.metrics.at("control_noise_rms").get<double>(), 0.01);
    summaries[i] = summary_without_timing(o.out_dir);
    EXPECT_TRUE(std::filesystem::exists(o.out_dir + "/K.csv"));
  }
  EXPECT_EQ(summaries[0].dump(), summaries[1].dump());
  // another seed draws another sequence
  LoadedScenario l = one_leg_with_noise(0.01, 0.08);
  l.scenario.seed = 2;
  Simulation run(l, {.duration = 2.0});
  RunResult r = run.run();
  EXPECT_NE(r.metrics.at("max_com_foot_distance_m").get<double>(),
            summaries[0]["metrics"]["max_com_foot_distance_m"].get<double>());
}

TEST(ControlNoise, KernelUnitNormStdPerActuatorAndReplay) {
  REQUIRE_HUMANOID();
  LoadedScenario l = one_leg();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  ControlNoiseParams p;
  ControllerContext ctx;
  ctx.seed = 7;
  const ControlNoise noise(p, ctx, *engine);
  auto state = noise.make_state(*engine);
  EXPECT_NEAR(noise.kernel().norm(), 1.0, 1e-12);
  EXPECT_EQ(noise.kernel().size(), 160);  // 0.8 s at 5 ms
  EXPECT_EQ(noise.std_per_actuator()[engine->require_actuator("left_knee")], 0.01);
  EXPECT_EQ(noise.std_per_actuator()[engine->require_actuator("right_knee")], 0.08);
  // replay after reset gives the same sequence; the sample std matches the target
  ControlOutput out;
  out.resize(engine->nv(), engine->nu());
  const int n = 4000, knee = engine->require_actuator("right_knee");
  std::vector<double> first(n);
  double sq = 0;
  for (int i = 0; i < n; ++i) {
    out.clear();
    noise.compute(*state, *engine, out);
    first[i] = out.ctrl[knee];
    sq += first[i] * first[i];
  }
  EXPECT_NEAR(std::sqrt(sq / n), 0.08, 0.08 * 0.35);  // ~25 independent windows
  noise.reset(*state, *engine);
  for (int i = 0; i < n; ++i) {
    out.clear();
    noise.compute(*state, *engine, out);
    ASSERT_EQ(out.ctrl[knee], first[i]) << i;
  }
  // smooth: neighbouring samples are strongly correlated
  double lag1 = 0;
  for (int i = 1; i < n; ++i) lag1 += first[i] * first[i - 1];
  EXPECT_GT(lag1 / sq, 0.95);
}

}  // namespace
}  // namespace stance
