// SIMBICON: the shipped gaits walk, the balance feedback matters, and the walk survives pushes.
#include "control/simbicon.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include "core/error.h"
#include "engine/world_spec.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

struct WalkOutcome {
  RunResult result;
  std::vector<SimbiconStep> steps;
};

WalkOutcome run_scenario(const std::string& file, const std::vector<std::string>& sets = {},
                         const RunOptions& options = {}) {
  LoadedScenario loaded = load_scenario(test::scenario_path(file), sets);
  Simulation run(loaded, options);
  WalkOutcome out;
  out.result = run.run();
  out.steps = run.state_as<Simbicon::State>(0).steps;
  return out;
}

TEST(SimbiconPitch, MatchesHingeAngleAboutMinusY) {
  for (double a : {-1.2, -0.3, 0.0, 0.4, 2.0}) {
    Eigen::Quaterniond q(Eigen::AngleAxisd(a, -Eigen::Vector3d::UnitY()));
    EXPECT_NEAR(pitch_about_minus_y(q), a, 1e-12);
  }
}

TEST(SimbiconGaitStats, MeansStdAndAsymmetry) {
  // right steps 0.6 m / 0.5 s / 0.3 m wide, left steps 0.4 m / 0.3 s / 0.1 m wide, after two
  // start-up steps
  std::vector<SimbiconStep> steps = {{0.1, 0, 0, 5.0, 9.0}, {0.2, 1, 0, 5.0, 9.0}};
  for (int i = 0; i < 10; ++i)
    steps.push_back({1.0 + i, i % 2, 0, i % 2 ? 0.4 : 0.6, i % 2 ? 0.3 : 0.5, i % 2 ? 0.1 : 0.3});
  SimbiconGaitStats s = simbicon_gait_stats(steps, 2);
  EXPECT_EQ(s.steps, 10);
  EXPECT_NEAR(s.step_length_mean, 0.5, 1e-12);
  EXPECT_NEAR(s.step_length_std, 0.1, 1e-12);
  EXPECT_NEAR(s.step_duration_mean, 0.4, 1e-12);
  EXPECT_NEAR(s.step_duration_std, 0.1, 1e-12);
  EXPECT_NEAR(s.step_width_mean, 0.2, 1e-12);
  EXPECT_NEAR(s.length_asymmetry, 0.2 / 0.5, 1e-12);
  EXPECT_NEAR(s.duration_asymmetry, 0.2 / 0.4, 1e-12);
}

TEST(SimbiconParams, RejectsBadGaits) {
  auto build = [](const std::string& set) {
    LoadedScenario l = load_scenario(test::scenario_path("simbicon_walk.yaml"), {set});
    Simulation run(l, {});
  };
  // a half cycle has exactly two states
  EXPECT_THROW(build("controllers.0.gait.states=[{duration_s: 0.3}]"), InputError);
  EXPECT_THROW(build("controllers.0.balance_point=knee"), InputError);
  EXPECT_THROW(build("controllers.0.skeleton.left_knee=left_kne"), InputError);
  EXPECT_THROW(build("controllers.0.gait.gains.torso.kp=-1"), InputError);
}

// priority 1: the paper's walk, 60 s at 1700 Hz
TEST(SimbiconWalk, WalksSixtySecondsAtHalfAMetrePerSecond) {
  WalkOutcome w = run_scenario("simbicon_walk.yaml");
  const RunResult& r = w.result;
  ASSERT_FALSE(r.diverged) << r.divergence;
  EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
  EXPECT_NEAR(r.sim_time, 60.0, 1e-6);
  EXPECT_GE(test::metric(r, "mean_speed_mps"), 0.5);
  EXPECT_GE(test::metric(r, "distance_m"), 30.0);
  // a steady gait: many strikes of both feet, regular lengths
  EXPECT_GT(r.metrics.at("step_count").get<int>(), 60);
  EXPECT_GT(test::metric(r, "step_length_mean_m"), 0.2);
  EXPECT_LT(test::metric(r, "step_length_std_m"), 0.5 * test::metric(r, "step_length_mean_m"));
  EXPECT_LT(test::metric(r, "step_length_asymmetry"), 0.3);
  for (const auto& st : r.metrics.at("simbicon_states")) EXPECT_GT(st.at("count").get<int>(), 30);
}

// priority 2: without feedback the same gait is not stable
TEST(SimbiconWalk, WithoutBalanceFeedbackFallsWithinFifteenSeconds) {
  WalkOutcome w = run_scenario(
      "simbicon_walk.yaml",
      {"duration=15", "controllers.0.gait.states.0.cd=0", "controllers.0.gait.states.0.cv=0",
       "controllers.0.gait.states.1.cd=0", "controllers.0.gait.states.1.cv=0"});
  ASSERT_FALSE(w.result.diverged) << w.result.divergence;
  EXPECT_TRUE(w.result.fell) << "speed " << test::metric(w.result, "mean_speed_mps");
  if (w.result.fell) EXPECT_LT(*w.result.fall_time, 15.0);
}

TEST(SimbiconGaits, RunAndCrouchWalkThirtySeconds) {
  for (const char* file : {"simbicon_run.yaml", "simbicon_crouch.yaml"}) {
    WalkOutcome w = run_scenario(file, {"duration=30"});
    SCOPED_TRACE(file);
    ASSERT_FALSE(w.result.diverged) << w.result.divergence;
    EXPECT_FALSE(w.result.fell) << "fell at " << w.result.fall_time.value_or(-1);
    EXPECT_NEAR(w.result.sim_time, 30.0, 1e-6);
    EXPECT_GT(test::metric(w.result, "mean_speed_mps"), 0.3);
    EXPECT_GT(w.result.metrics.at("step_count").get<int>(), 30);
  }
}

// priority 5: 100 N forward and backward on the torso for 0.2 s at 4 phases of one stride
TEST(SimbiconWalk, SurvivesHundredNewtonPushesAtFourPhases) {
  // the unpushed walk gives the strike times; runs are deterministic up to the push
  WalkOutcome ref = run_scenario("simbicon_walk.yaml", {"duration=10"});
  // a stride from the first right-foot strike after 6 s: the gait is steady by then
  size_t k = 0;
  while (k < ref.steps.size() &&
         (ref.steps[k].time_s < 6.0 || ref.steps[k].foot != Simbicon::kRight))
    ++k;
  ASSERT_LT(k + 2, ref.steps.size());
  const double t0 = ref.steps[k].time_s, stride = ref.steps[k + 2].time_s - t0;
  for (double phase : {0.0, 0.25, 0.5, 0.75}) {
    for (double fx : {100.0, -100.0}) {
      RunOptions opt;
      Perturbation p;
      p.body = "torso";
      p.force = Eigen::Vector3d(fx, 0, 0);
      p.start = t0 + phase * stride;
      p.duration = 0.2;
      opt.extra_pushes.push_back(p);
      opt.duration = p.start + 6.0;
      WalkOutcome w = run_scenario("simbicon_walk.yaml", {}, opt);
      SCOPED_TRACE(::testing::Message() << "phase " << phase << " force " << fx);
      ASSERT_FALSE(w.result.diverged);
      EXPECT_FALSE(w.result.fell) << "fell at " << w.result.fall_time.value_or(-1);
      EXPECT_EQ(w.result.metrics.at("pushes_survived").get<int>(), 1);
    }
  }
}

// priority 7: the 3D walker. Drift is measured over the whole run, start-up included.
TEST(Simbicon3d, WalksTwentySecondsStraight) {
  WalkOutcome w = run_scenario("simbicon_walk_3d.yaml");
  const RunResult& r = w.result;
  ASSERT_FALSE(r.diverged) << r.divergence;
  EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
  EXPECT_NEAR(r.sim_time, 20.0, 1e-6);
  EXPECT_GT(test::metric(r, "distance_m"), 10.0);
  EXPECT_LT(test::metric(r, "drift_per_10m"), 1.0);
  EXPECT_GT(r.metrics.at("step_count").get<int>(), 40);
}

TEST(Simbicon3d, SurvivesFiftyNewtonLateralPushes) {
  // left and right, in two different phases of the stride
  for (double start : {10.0, 10.17}) {
    for (double fy : {50.0, -50.0}) {
      RunOptions opt;
      Perturbation p;
      p.body = "torso";
      p.force = Eigen::Vector3d(0, fy, 0);
      p.start = start;
      p.duration = 0.2;
      opt.extra_pushes.push_back(p);
      WalkOutcome w = run_scenario("simbicon_walk_3d.yaml", {}, opt);
      SCOPED_TRACE(::testing::Message() << "push " << fy << " N at " << start << " s");
      ASSERT_FALSE(w.result.diverged);
      EXPECT_FALSE(w.result.fell) << "fell at " << w.result.fall_time.value_or(-1);
      EXPECT_EQ(w.result.metrics.at("pushes_survived").get<int>(), 1);
      EXPECT_LT(test::metric(w.result, "drift_per_10m"), 1.0);
    }
  }
}

// the coronal feedback is what keeps it up: without it the 3D walk falls
TEST(Simbicon3d, WithoutCoronalFeedbackFalls) {
  WalkOutcome w = run_scenario(
      "simbicon_walk_3d.yaml",
      {"controllers.0.gait.states.0.cd_lateral=0", "controllers.0.gait.states.0.cv_lateral=0",
       "controllers.0.gait.states.1.cd_lateral=0", "controllers.0.gait.states.1.cv_lateral=0"});
  EXPECT_TRUE(w.result.fell);
}

// any biped: a model whose pitch hinges turn the other way, or that stands along y, walks the
// same gait. The variants are made from the shipped models by rewriting their text.
// the scenario's model replaced by `model_xml`, written beside a copy of the scenario
std::string scenario_with_model(const std::string& scenario, const std::string& model_xml,
                                const std::string& tag) {
  const std::string model = test::write_temp_file(tag + ".xml", model_xml);
  std::string text = test::read_file(test::scenario_path(scenario));
  text = std::regex_replace(text, std::regex("model: \\.\\./models/simbicon_[23]d\\.xml"),
                            "model: " + model);
  return test::write_temp_file(tag + ".yaml", text);
}

// every leg pitch hinge of a shipped biped about +y instead of -y (ranges mirrored)
std::string flipped_model(const std::string& file) {
  std::string xml = test::read_file(test::source_dir() + "/models/" + file);
  for (const char* side : {"right", "left"})
    for (const char* joint : {"hip", "knee", "ankle"}) {
      const std::string name =
          fmt::format("name=\"{}_{}\" type=\"hinge\" axis=\"0 -1 0\"", side, joint);
      const size_t at = xml.find(name);
      EXPECT_NE(at, std::string::npos) << name;
      if (at != std::string::npos) xml.erase(at + name.size() - 5, 1);  // the minus sign
    }
  return std::regex_replace(xml, std::regex("range=\"-2.6 0.05\""), "range=\"-0.05 2.6\"");
}

// simbicon_2d.xml turned -90 degrees about x: up is +y, gravity (0, -9.81, 0), and the legs'
// hinges turn about +z, the character's right. Vectors (x, y, z) become (x, z, -y); box sizes
// and diagonal inertias swap their y and z.
std::string y_up_2d_model() {
  std::string xml = test::read_file(test::source_dir() + "/models/simbicon_2d.xml");
  const std::string num = "(-?[0-9.e-]+)";
  const std::regex vec("(pos|axis)=\"" + num + " " + num + " " + num + "\"");
  const std::regex diag("(size|diaginertia)=\"" + num + " " + num + " " + num + "\"");
  auto negate = [](const std::string& x) { return x[0] == '-' ? x.substr(1) : "-" + x; };
  std::string out;
  auto it = std::sregex_iterator(xml.begin(), xml.end(), vec);
  size_t last = 0;
  for (; it != std::sregex_iterator(); ++it) {
    const std::smatch& m = *it;
    out += xml.substr(last, m.position() - last);
    out += fmt::format("{}=\"{} {} {}\"", m[1].str(), m[2].str(), m[4].str(), negate(m[3]));
    last = m.position() + m.length();
  }
  out += xml.substr(last);
  out = std::regex_replace(out, diag, "$1=\"$2 $4 $3\"");
  out = std::regex_replace(out, std::regex("gravity=\"0 0 -9.81\""), "gravity=\"0 -9.81 0\"");
  // the floor's normal along +y (its extents are not a vector)
  out = std::regex_replace(out, std::regex("size=\"200 0.1 5\""),
                           "size=\"200 5 0.1\" zaxis=\"0 1 0\"");
  return out;
}

void expect_same_walk(const WalkOutcome& a, const WalkOutcome& b) {
  ASSERT_FALSE(b.result.fell) << "fell at " << b.result.fall_time.value_or(-1);
  ASSERT_GE(b.steps.size(), 10u);
  ASSERT_EQ(a.steps.size(), b.steps.size());
  for (size_t i = 0; i < a.steps.size(); ++i) {
    EXPECT_NEAR(a.steps[i].time_s, b.steps[i].time_s, 0.01) << "step " << i;
    EXPECT_NEAR(a.steps[i].length_m, b.steps[i].length_m, 0.01) << "step " << i;
    EXPECT_EQ(a.steps[i].foot, b.steps[i].foot) << "step " << i;
  }
}

TEST(SimbiconCharacter, HingesTurningTheOtherWayWalkTheSame) {
  const std::vector<std::string> ten_s = {"duration=10"};
  for (const char* scenario : {"simbicon_walk.yaml", "simbicon_walk_3d.yaml"}) {
    SCOPED_TRACE(scenario);
    const std::string model =
        std::string(scenario) == "simbicon_walk.yaml" ? "simbicon_2d.xml" : "simbicon_3d.xml";
    const std::string xml = flipped_model(model);
    const std::string flipped = scenario_with_model(scenario, xml, "simbicon_flipped");
    // the initial pose is in the dofs' own sign: the bent knees are now positive
    std::vector<std::string> sets = ten_s;
    sets.insert(sets.end(), {"initial_pose.right_knee=0.05", "initial_pose.left_knee=0.05"});
    LoadedScenario loaded = load_scenario(flipped, sets);
    Simulation run(loaded, {});
    WalkOutcome b;
    b.result = run.run();
    b.steps = run.state_as<Simbicon::State>(0).steps;
    const Simbicon& c = dynamic_cast<const Simbicon&>(*run.controllers()[0]);
    EXPECT_EQ(c.model().knee_sign[Simbicon::kLeft], -1.0);
    EXPECT_EQ(c.model().hip_sign[Simbicon::kRight], -1.0);
    expect_same_walk(run_scenario(scenario, ten_s), b);
  }
}

TEST(SimbiconCharacter, YUpModelWalksTheSameAlongX) {
  const std::string y_up =
      scenario_with_model("simbicon_walk.yaml", y_up_2d_model(), "simbicon_yup");
  LoadedScenario loaded = load_scenario(y_up, {"duration=10"});
  Simulation run(loaded, {});
  WalkOutcome b;
  b.result = run.run();
  b.steps = run.state_as<Simbicon::State>(0).steps;
  const Simbicon& c = dynamic_cast<const Simbicon&>(*run.controllers()[0]);
  EXPECT_LT((c.model().up - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_EQ(c.model().hip_sign[Simbicon::kLeft], 1.0);
  expect_same_walk(run_scenario("simbicon_walk.yaml", {"duration=10"}), b);
  EXPECT_GT(test::metric(b.result, "distance_m"), 4.0);
}

TEST(SimbiconCharacter, RejectsAForwardAxisAlongUpAndARollHingeAsPitch) {
  EXPECT_THROW(run_scenario("simbicon_walk_3d.yaml", {"controllers.0.skeleton.forward=[0, 0, 2]"}),
               InputError);
  try {
    run_scenario("simbicon_walk_3d.yaml", {"controllers.0.skeleton.right_hip=right_hip_roll",
                                           "controllers.0.skeleton.right_hip_roll=right_hip"});
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("dof 'right_hip_roll' turns about (1 0 0)"),
              std::string::npos)
        << e.what();
  }
}

#ifdef STANCE_HAVE_DART
// priority 6: the same model and walk on DART (loaded through DART's own MJCF parser)
TEST(SimbiconDart, ModelMatchesMujocoBodyForBody) {
  WorldSpec spec;
  spec.models.push_back({test::source_dir() + "/models/simbicon_2d.xml", Eigen::Vector3d::Zero()});
  auto mj = make_engine("mujoco", spec);
  auto dt = make_engine("dart", spec);
  mj->forward();
  dt->forward();
  ASSERT_EQ(mj->nbody(), dt->nbody());
  ASSERT_EQ(mj->nv(), dt->nv());
  EXPECT_NEAR(mj->total_mass(), 70.0, 1e-9);
  EXPECT_NEAR(dt->total_mass(), 70.0, 1e-9);
  for (int b = 0; b < mj->nbody(); ++b) {
    int d = dt->require_body(mj->body_name(b));
    EXPECT_LT((mj->body_pose(b).pos - dt->body_pose(d).pos).norm(), 1e-9) << mj->body_name(b);
    EXPECT_LT((mj->body_com(b) - dt->body_com(d)).norm(), 1e-9) << mj->body_name(b);
  }
  EXPECT_LT((mj->com() - dt->com()).norm(), 1e-9);
}

TEST(SimbiconDart, WalksTwentySeconds) {
  RunOptions opt;
  opt.engine = "dart";
  WalkOutcome w = run_scenario("simbicon_walk.yaml", {"duration=20"}, opt);
  ASSERT_FALSE(w.result.diverged) << w.result.divergence;
  EXPECT_FALSE(w.result.fell) << "fell at " << w.result.fall_time.value_or(-1);
  EXPECT_GE(test::metric(w.result, "mean_speed_mps"), 0.5);
  EXPECT_GT(w.result.metrics.at("step_count").get<int>(), 20);
}
#endif

}  // namespace
}  // namespace stance
