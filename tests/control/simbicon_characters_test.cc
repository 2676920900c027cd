// SIMBICON on characters that users bring (issue 19): each shipped walk holds for 20 s at its
// gait, with the controller's gains x0.8 and x1.2 and the timestep halved and doubled, and
// survives 100 N for 0.2 s on the torso forward, back and to either side at one phase.
#include <gtest/gtest.h>

#include <cmath>

#include "control/simbicon.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "scenario/tune.h"
#include "test_support.h"

namespace stance {
namespace {

// one walk: its scenario, the engine, and the character's forward and left axes (world)
struct Character {
  const char* file;
  const char* engine;
  const char* torso;  // body pushed
  Eigen::Vector3d forward, left;
};

std::string scenario_path(const char* name) {
  return test::source_dir() + "/scenarios/" + name;
}

int simbicon_index(const LoadedScenario& l) {
  for (size_t i = 0; i < l.controllers.size(); ++i)
    if (l.controllers[i]["type"].as<std::string>() == "simbicon") return static_cast<int>(i);
  return -1;
}

struct Walk {
  RunResult result;
  std::vector<SimbiconStep> steps;
};

Walk walk(const Character& c, const std::vector<std::string>& sets, RunOptions opt = {}) {
  LoadedScenario loaded = load_scenario(scenario_path(c.file), sets);
  opt.engine = c.engine;
  Simulation run(loaded, opt);
  Walk w;
  w.result = run.run();
  w.steps = run.state_as<Simbicon::State>(simbicon_index(loaded)).steps;
  return w;
}

// every kp and kd of the SIMBICON gains times factor, as --set lines
std::vector<std::string> scaled_gains(const Character& c, double factor) {
  LoadedScenario l = load_scenario(scenario_path(c.file), {});
  const std::string base = "controllers." + std::to_string(simbicon_index(l)) + ".gait.gains.";
  std::vector<std::string> sets;
  for (const char* servo :
       {"torso", "swing_hip", "swing_knee", "swing_ankle", "stance_knee", "stance_ankle"})
    for (const char* gain : {"kp", "kd"}) {
      const std::string key = base + servo + "." + gain;
      std::optional<double> value = yaml_number_at(l.document, key);
      if (value) sets.push_back(key + "=" + std::to_string(*value * factor));
    }
  return sets;
}

double metric(const RunResult& r, const char* name) {
  return r.metrics.at(name).get<double>();
}

void expect_walks(const Walk& w, double duration) {
  const RunResult& r = w.result;
  ASSERT_FALSE(r.diverged) << r.divergence;
  EXPECT_FALSE(r.fell) << "fell at " << r.fall_time.value_or(-1) << ": " << r.fall_reason;
  EXPECT_NEAR(r.sim_time, duration, 1e-6);
  EXPECT_GT(metric(r, "mean_speed_mps"), 0.2);
  EXPECT_LT(metric(r, "drift_per_10m"), 2.0);
  EXPECT_GT(r.metrics.at("step_count").get<int>(), 20);
}

// 20 s at the shipped gait and nearby; then the pushes, from the nominal walk's strike times
void check_character(const Character& c) {
  LoadedScenario l = load_scenario(scenario_path(c.file), {});
  const double dt = l.scenario.timestep;
  ASSERT_GT(dt, 0) << "the scenario sets its timestep";
  Walk nominal = walk(c, {"duration=20"});
  {
    SCOPED_TRACE("shipped gait");
    expect_walks(nominal, 20);
  }
  const std::vector<std::pair<std::string, std::vector<std::string>>> nearby = {
      {"gains x0.8", scaled_gains(c, 0.8)},
      {"gains x1.2", scaled_gains(c, 1.2)},
      {"timestep / 2", {"timestep=" + std::to_string(dt / 2)}},
      {"timestep x 2", {"timestep=" + std::to_string(dt * 2)}}};
  for (const auto& [what, sets] : nearby) {
    SCOPED_TRACE(what);
    std::vector<std::string> all = sets;
    all.push_back("duration=20");
    expect_walks(walk(c, all), 20);
  }

  // the phase: 0.1 s after the first right-foot strike after 6 s, when the gait is steady
  double start = -1;
  for (const SimbiconStep& s : nominal.steps)
    if (s.time_s > 6.0 && s.foot == Simbicon::kRight) {
      start = s.time_s + 0.1;
      break;
    }
  ASSERT_GT(start, 0) << "no right-foot strike after 6 s";
  for (const auto& [what, direction] :
       std::vector<std::pair<const char*, Eigen::Vector3d>>{{"forward", c.forward},
                                                            {"back", -c.forward},
                                                            {"left", c.left},
                                                            {"right", -c.left}}) {
    SCOPED_TRACE(::testing::Message() << "100 N " << what << " at " << start << " s");
    RunOptions opt;
    Perturbation p;
    p.body = c.torso;
    p.force = 100 * direction;
    p.start = start;
    p.duration = 0.2;
    opt.extra_pushes.push_back(p);
    opt.duration = start + 5.0;
    Walk w = walk(c, {}, opt);
    ASSERT_FALSE(w.result.diverged) << w.result.divergence;
    EXPECT_FALSE(w.result.fell) << "fell at " << w.result.fall_time.value_or(-1);
    EXPECT_EQ(w.result.metrics.at("pushes_survived").get<int>(), 1);
  }
}

// MuJoCo's humanoid.xml (z-up, +x forward; MuJoCo only: DART 6.12's MJCF parser rejects
// several joints in one body)
TEST(SimbiconCharacters, HumanoidWalksNearbyAndSurvivesPushes) {
  check_character({"simbicon_humanoid.yaml", "mujoco", "torso", Eigen::Vector3d::UnitX(),
                   Eigen::Vector3d::UnitY()});
}

}  // namespace
}  // namespace stance
