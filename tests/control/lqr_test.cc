// LQR balance on one leg: the root finder, the cost, the set-point on MuJoCo's humanoid, the
// design's DARE and closed loop, and the scenario's own checks (stands with LQR, falls with
// ctrl0 only, stands under seeded smoothed noise with identical summaries). On two feet: the
// feet by side, the set-point's tilt, the error for a pose the named feet cannot hold, and the
// humanoid and Atlas standing 30 s at the defaults and nearby.
#include "control/lqr.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "control/control_noise.h"
#include "core/error.h"
#include "engine/world_spec.h"
#include "math/dare.h"
#include "params/yaml_params.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
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

// ---- on two feet (issue 45): the humanoid's two-foot scenario and Atlas's ----

LoadedScenario two_feet(const std::vector<std::string>& sets = {}) {
  return load_scenario(test::scenario_path("lqr_two_feet.yaml"), sets);
}

std::string design_error(const std::vector<std::string>& sets) {
  try {
    LoadedScenario l = two_feet(sets);
    Simulation run(l, {});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(LqrStanceFeet, NamesSidesBothAndLists) {
  REQUIRE_HUMANOID();
  LoadedScenario l = one_leg();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  const int left = engine->body_index("left_foot"), right = engine->body_index("right_foot");
  EXPECT_EQ(find_stance_feet("left_foot", *engine), std::vector<int>({left}));
  EXPECT_EQ(find_stance_feet("left", *engine), std::vector<int>({left}));
  EXPECT_EQ(find_stance_feet("right", *engine), std::vector<int>({right}));
  EXPECT_EQ(find_stance_feet("both", *engine), std::vector<int>({left, right}));
  EXPECT_EQ(find_stance_feet(" right_foot , left", *engine), std::vector<int>({right, left}));
  EXPECT_EQ(find_stance_feet("left_foot,left", *engine), std::vector<int>({left}));
  EXPECT_THROW(find_stance_feet("left_foot,", *engine), InputError);
  EXPECT_THROW(find_stance_feet("middle", *engine), InputError);
  // "left" and its body name design the same controller, bit for bit
  LqrParams by_side;
  by_side.stance_foot = "left";
  const LqrDesign a = design_lqr(LqrParams{}, *engine), b = design_lqr(by_side, *engine);
  EXPECT_EQ(a.K, b.K);
  EXPECT_EQ(a.setpoint.ctrl0, b.setpoint.ctrl0);
}

std::string stance_feet_error(const std::string& stance_foot, const std::string& xml) {
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file("lqr_feet.xml", xml)});
  auto engine = make_engine("mujoco", spec);
  try {
    find_stance_feet(stance_foot, *engine);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(LqrStanceFeet, ASideWithNoFootOrTwoIsAnErrorNamingTheBodies) {
  EXPECT_NE(stance_feet_error("left", test::kFloatingChainMjcf).find("none"), std::string::npos);
  // a toe body below the foot is not a second foot; two sibling left feet are ambiguous
  const std::string xml = R"(<mujoco><worldbody><body name="pelvis"><freejoint/>
    <geom size="0.1"/>
    <body name="l_foot"><joint/><geom size="0.05"/>
      <body name="l_foot_toe"><joint/><geom size="0.02"/></body></body>
    <body name="LeftFoot"><joint/><geom size="0.05"/></body>
    <body name="r_foot"><joint/><geom size="0.05"/></body>
  </body></worldbody></mujoco>)";
  EXPECT_EQ(stance_feet_error("right", xml), "");
  const std::string both = stance_feet_error("both", xml);
  EXPECT_NE(both.find("ambiguous (l_foot, LeftFoot)"), std::string::npos) << both;
}

// a robot of a public collection's kind names no body a foot (its feet are "left_sole_link"):
// both takes each side's lowest body, and LQR holds the scene's own keyframe 30 s at the costs,
// +-20 % and a 4 ms step (tests/models/pitch_ankle_robot*.xml: our own numbers)
LoadedScenario pitch_ankle_robot_lqr(const std::vector<std::string>& sets = {}) {
  const std::string yaml = fmt::format(R"yaml(name: pitch_ankle_robot_lqr
engine: mujoco
model: {}/tests/models/pitch_ankle_robot_scene.xml
keyframe: home
timestep: 0.002
duration: 30
controllers:
  - {{type: lqr, root_body: base, stance_foot: both, balance_cost: 1.0e+6,
     balance_joint_cost: 3000, other_joint_cost: 300,
     balance_dofs: ["waist_yaw", "(left|right)_(hip_.*|knee|ankle)"]}}
fall: {{com_height_fraction: 0.8, allowed_contacts: [left_sole_link, right_sole_link]}}
)yaml",
                                       test::source_dir());
  return load_scenario(test::write_temp_file("pitch_ankle_robot_lqr.yaml", yaml), sets);
}

// the defaults, the costs x0.8 and x1.2, and a 4 ms step: where a two-foot LQR must hold
std::vector<std::vector<std::string>> two_foot_cost_cases() {
  const std::string c = "controllers.0.";
  return {
      {},
      {c + "balance_cost=8e5", c + "balance_joint_cost=2400", c + "other_joint_cost=240"},
      {c + "balance_cost=1.2e6", c + "balance_joint_cost=3600", c + "other_joint_cost=360"},
      {"timestep=0.004"},
  };
}

TEST(LqrTwoFeet, PitchAnkleRobotNamingNoFootStandsOnEachSidesLowestBody) {
  LoadedScenario l = pitch_ankle_robot_lqr();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  const int left = engine->body_index("left_sole_link");
  const int right = engine->body_index("right_sole_link");
  EXPECT_EQ(find_stance_feet("both", *engine), std::vector<int>({left, right}));
  EXPECT_EQ(find_stance_feet("right", *engine), std::vector<int>({right}));
  const std::vector<std::vector<std::string>> cases = two_foot_cost_cases();
  for (const auto& sets : cases) {
    RunResult r = Simulation(pitch_ankle_robot_lqr(sets), {.quiet = true}).run();
    const std::string what = fmt::format("{}", fmt::join(sets, " "));
    ASSERT_FALSE(r.diverged) << what << ": " << r.divergence;
    EXPECT_FALSE(r.fell) << what << ": fell at " << r.fall_time.value_or(-1);
    EXPECT_NEAR(r.sim_time, 30.0, 1e-6) << what;
    EXPECT_LT(r.metrics.at("com_displacement_m").get<double>(), 0.02) << what;
    EXPECT_LT(r.metrics.at("ctrl0_mismatch_root_N").get<double>(), 1) << what;
  }
}

// the issue's fall: a two-foot pose designed on one foot was a silent fall at 1 s; now the
// design stops and names the force and the feet
TEST(LqrTwoFeet, OneFootOnATwoFootPoseIsAnErrorNamingTheFeet) {
  REQUIRE_HUMANOID();
  const std::string one = design_error({"controllers.0.stance_foot=left_foot"});
  EXPECT_NE(one.find("right_foot"), std::string::npos) << one;
  EXPECT_NE(one.find("left_foot"), std::string::npos) << one;
  EXPECT_NE(one.find("200 N"), std::string::npos) << one;
  // without the tilt the root keeps 47 N m: an error naming it and both feet
  const std::string flat = design_error({"controllers.0.root_tolerance_N=1000"});
  EXPECT_NE(flat.find("47.4 N on the root"), std::string::npos) << flat;
  EXPECT_NE(flat.find("left_foot, right_foot"), std::string::npos) << flat;
  // and, allowed, that set-point falls: what the error prevents
  LoadedScenario l =
      two_feet({"controllers.0.root_tolerance_N=1000", "controllers.0.max_root_residual_N=1000"});
  RunResult r = Simulation(l, {.duration = 5.0}).run();
  EXPECT_TRUE(r.fell);
}

TEST(LqrTwoFeet, SetPointTiltsOntoBothFeet) {
  REQUIRE_HUMANOID();
  LoadedScenario l = two_feet();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  LqrParams p;
  p.stance_foot = "both";
  p.balance_dofs = {"abdomen_.*", "(left|right)_(hip_.*|knee|ankle_.*)"};
  const LqrDesign d = design_lqr(p, *engine);
  const LqrSetPoint& sp = d.setpoint;
  EXPECT_GT(sp.tilt_iterations, 0);
  EXPECT_LT(sp.root_residual_N, 1.0);
  EXPECT_GT(sp.tilt_rad.norm(), 1e-3);  // the arms put the COM ahead: a visible tilt
  EXPECT_LT(sp.tilt_rad.norm(), 0.02);  // but the feet stay flat
  EXPECT_TRUE(sp.other_support_body.empty()) << sp.other_support_body;
  EXPECT_EQ(d.foot_bodies.size(), 2u);
  EXPECT_EQ(d.balance_dofs.size(), 3u + 12u);
  EXPECT_LE(d.dare_residual, 1e-9);
  EXPECT_LT(d.spectral_radius, 1.0);
  // the cost's foot Jacobian is the feet's mean
  Eigen::MatrixXd left(3, engine->nv()), right(3, engine->nv()), none(3, 0);
  engine->set_positions(sp.q0);
  engine->forward();
  const int lf = engine->body_index("left_foot"), rf = engine->body_index("right_foot");
  engine->point_jacobian(lf, engine->body_com(lf), left, none);
  engine->point_jacobian(rf, engine->body_com(rf), right, none);
  EXPECT_TRUE(d.plant.jac_foot.isApprox(0.5 * (left + right), 1e-12));
}

// the chaos rule: 30 s at the defaults, at Q +-20 %, at other timesteps and under pushes
TEST(LqrTwoFeet, HumanoidHoldsThirtySecondsAtTheDefaultsAndNearby) {
  REQUIRE_HUMANOID();
  struct Case {
    std::vector<std::string> sets;
    const char* push;
  };
  const std::string c = "controllers.0.";
  const std::vector<Case> cases = {
      {{}, nullptr},
      {{c + "balance_cost=800", c + "balance_joint_cost=2.4", c + "other_joint_cost=0.24"},
       nullptr},
      {{c + "balance_cost=1200", c + "balance_joint_cost=3.6", c + "other_joint_cost=0.36"},
       nullptr},
      {{c + "balance_cost=800"}, nullptr},
      {{c + "balance_cost=1200"}, nullptr},
      {{"timestep=0.001"}, nullptr},
      {{"timestep=0.005"}, nullptr},
      {{}, "torso,40,0,0,3,0.1"},
      {{}, "torso,0,40,0,3,0.1"},
  };
  for (const Case& k : cases) {
    LoadedScenario l = two_feet(k.sets);
    RunOptions o;
    o.quiet = true;
    if (k.push) o.extra_pushes = {parse_push(k.push)};
    RunResult r = Simulation(l, o).run();
    const std::string what = fmt::format("{} {}", fmt::join(k.sets, " "), k.push ? k.push : "");
    ASSERT_FALSE(r.diverged) << what << ": " << r.divergence;
    EXPECT_FALSE(r.fell) << what << ": fell at " << r.fall_time.value_or(-1);
    EXPECT_NEAR(r.sim_time, 30.0, 1e-6) << what;
    EXPECT_LT(r.metrics.at("com_displacement_m").get<double>(), 0.02) << what;
  }
}

// the pose written as a keyframe into a copy of humanoid.xml designs the same controller
TEST(LqrTwoFeet, KeyframeGivesTheSameDesignAsInitialPose) {
  REQUIRE_HUMANOID();
  LoadedScenario l = two_feet();
  auto engine = make_scenario_engine(l.scenario, "mujoco");
  Eigen::VectorXd q(engine->nq());
  engine->get_positions(q);
  std::string xml = test::read_file(test::kHumanoidXml);
  std::string key = "<keyframe><key name=\"stand_two_feet\" qpos=\"";
  for (int i = 0; i < q.size(); ++i) key += fmt::format("{}{:.17g}", i ? " " : "", q[i]);
  key += "\"/></keyframe>\n</mujoco>";
  xml.replace(xml.rfind("</mujoco>"), 9, key);
  Scenario s = l.scenario;
  s.model = {ModelEntry{test::write_temp_file("humanoid_two_feet.xml", xml)}};
  s.initial_pose.clear();
  s.keyframe = "stand_two_feet";
  auto keyed = make_scenario_engine(s, "mujoco");
  LqrParams p;
  p.stance_foot = "both";
  LqrDesign a = design_lqr(p, *engine), b = design_lqr(p, *keyed);
  EXPECT_NEAR(a.setpoint.height_offset_m, b.setpoint.height_offset_m, 1e-12);
  EXPECT_TRUE(a.setpoint.tilt_rad.isApprox(b.setpoint.tilt_rad, 1e-9));
  EXPECT_TRUE(a.K.isApprox(b.K, 1e-8));
}

// DART's Atlas on MuJoCo (its URDF's motors), both feet by side: 30 s at the scenario's costs,
// at +-20 % and at another timestep
TEST(LqrTwoFeet, AtlasHoldsOnMujocoAtTheDefaultsAndNearby) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  const std::vector<std::vector<std::string>> cases = two_foot_cost_cases();
  for (const auto& sets : cases) {
    LoadedScenario l = load_scenario(test::scenario_path("lqr_two_feet_atlas.yaml"), sets);
    RunResult r = Simulation(l, {.quiet = true}).run();
    const std::string what = fmt::format("{}", fmt::join(sets, " "));
    ASSERT_FALSE(r.diverged) << what << ": " << r.divergence;
    EXPECT_FALSE(r.fell) << what << ": fell at " << r.fall_time.value_or(-1);
    EXPECT_LT(r.metrics.at("com_displacement_m").get<double>(), 0.02) << what;
  }
  // on DART the URDF has no actuators: a clear error at load
  LoadedScenario l = load_scenario(test::scenario_path("lqr_two_feet_atlas.yaml"));
  l.scenario.engine = "dart";
  EXPECT_THROW(Simulation(l, {}), InputError);
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
