// A scenario's `expect` block: read and checked at load, its metric names checked against what a
// run reports before it starts, and the verdict on a run (scenario/expectation.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "sim/expectation.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

// pd_hold's arm (models/arm3.xml) for 0.2 s, with the given expect block (lines 9 on)
std::string expect_arm_scenario(const std::string& name, const std::string& expect) {
  return test::write_temp_file(name,
                               "name: arm\n"
                               "model: " +
                                   test::source_dir() +
                                   "/models/arm3.xml\n"
                                   "duration: 0.2\n"
                                   "controllers:\n"
                                   "  - type: hold_pose_pd\n"
                                   "    kp: 60\n"
                                   "    kd: 3\n"
                                   "fall: {enabled: false}\n" +
                                   expect);
}

// the InputError's message of building a run of `path`
std::string expect_load_error(const std::string& path) {
  try {
    LoadedScenario s = load_scenario(path);
    RunOptions opt;
    opt.check_expect_names = true;  // as stance run does
    Simulation run(s, opt);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

nlohmann::json expect_summary(bool fell, nlohmann::json metrics) {
  return {{"sim_time", 2.0},
          {"fell", fell},
          {"diverged", false},
          {"interrupted", false},
          {"metrics", std::move(metrics)}};
}

TEST(Expectation, EachBoundIsACheckAndAllMustHold) {
  Expectation e;
  e.metrics = {{"a", 0.5}, {"group.b", -1e300, 1.0}};
  const nlohmann::json v =
      evaluate_expectation(e, expect_summary(false, {{"a", 1}, {"group", {{"b", 2}}}}));
  EXPECT_FALSE(v["held"].get<bool>());
  ASSERT_EQ(v["checks"].size(), 4u);  // fell, diverged, a, group.b
  EXPECT_TRUE(v["checks"][0]["held"].get<bool>());
  EXPECT_TRUE(v["checks"][2]["held"].get<bool>());
  EXPECT_EQ(v["checks"][3]["check"], "metrics.group.b");
  EXPECT_FALSE(v["checks"][3]["held"].get<bool>());
  EXPECT_EQ(expectation_line(v),
            "expectation NOT held at 2.000 s: no fall; a 1 >= 0.5; group.b 2 not in [-1e+300, 1]");
  e.metrics[1].max = 2;
  EXPECT_TRUE(
      evaluate_expectation(e, expect_summary(false, {{"a", 1}, {"group", {{"b", 2}}}}))["held"]);
}

TEST(Expectation, AFallHoldsOnlyWhereOneIsExpected) {
  Expectation e;
  EXPECT_FALSE(evaluate_expectation(e, expect_summary(true, {}))["held"].get<bool>());
  e.fell = true;
  EXPECT_TRUE(evaluate_expectation(e, expect_summary(true, {}))["held"].get<bool>());
  EXPECT_FALSE(evaluate_expectation(e, expect_summary(false, {}))["held"].get<bool>());
  EXPECT_EQ(expectation_line(evaluate_expectation(e, expect_summary(false, {}))),
            "expectation NOT held at 2.000 s: no fall (expected a fall)");
}

TEST(Expectation, ADivergedOrInterruptedRunNeverHolds) {
  Expectation e;
  nlohmann::json diverged = expect_summary(false, {});
  diverged["diverged"] = true;
  EXPECT_FALSE(evaluate_expectation(e, diverged)["held"].get<bool>());
  nlohmann::json interrupted = expect_summary(false, {});
  interrupted["interrupted"] = true;
  const nlohmann::json v = evaluate_expectation(e, interrupted);
  EXPECT_FALSE(v["held"].get<bool>());
  EXPECT_EQ(expectation_line(v), "expectation NOT held at 2.000 s: no fall; interrupted");
}

TEST(Expectation, TrueAndFalseAreOneAndZeroAndAMissingMetricFails) {
  Expectation e;
  e.metrics = {{"success", 1}};
  EXPECT_TRUE(
      evaluate_expectation(e, expect_summary(false, {{"success", true}}))["held"].get<bool>());
  EXPECT_FALSE(
      evaluate_expectation(e, expect_summary(false, {{"success", false}}))["held"].get<bool>());
  EXPECT_FALSE(evaluate_expectation(e, expect_summary(false, {{"other", 1}}))["held"].get<bool>());
  EXPECT_FALSE(
      evaluate_expectation(e, expect_summary(false, {{"success", nullptr}}))["held"].get<bool>());
}

TEST(ScenarioExpect, AFileWithoutTheBlockHasNoExpectation) {
  EXPECT_FALSE(load_scenario(expect_arm_scenario("expect_none.yaml", "")).scenario.expect.given);
  const LoadedScenario s = load_scenario(
      expect_arm_scenario("expect_some.yaml",
                          "expect:\n  fell: false\n  metrics:\n    - {name: torque_rms, max: 50}\n"
                          "  test_duration: 0.1\n"));
  EXPECT_TRUE(s.scenario.expect.given);
  ASSERT_EQ(s.scenario.expect.metrics.size(), 1u);
  EXPECT_EQ(s.scenario.expect.metrics[0].max, 50);
  EXPECT_EQ(s.scenario.expect.test_duration, 0.1);
}

TEST(ScenarioExpect, BadBoundsAreNamedWithTheFileAndLine) {
  std::string path = expect_arm_scenario("expect_no_bound.yaml",
                                         "expect:\n  metrics:\n    - {name: torque_rms}\n");
  EXPECT_EQ(expect_load_error(path),
            path + ":11: expect.metrics[0] ('torque_rms'): needs a 'min' or a 'max'");
  path = expect_arm_scenario("expect_crossed.yaml",
                             "expect:\n  metrics:\n    - {name: torque_rms, min: 2, max: 1}\n");
  EXPECT_EQ(expect_load_error(path),
            path + ":11: expect.metrics[0] ('torque_rms'): min 2 is above max 1");
  path = expect_arm_scenario("expect_no_name.yaml", "expect:\n  metrics:\n    - {max: 1}\n");
  EXPECT_EQ(expect_load_error(path), path + ":11: expect.metrics[0]: needs a 'name' (a metric)");
  path = expect_arm_scenario("expect_unknown_key.yaml", "expect:\n  fall: false\n");
  EXPECT_EQ(expect_load_error(path),
            path + ":10: unknown parameter 'expect.fall' (did you mean 'fell'?)");
}

TEST(ScenarioExpect, MetricNamesAreThoseTheRunReports) {
  std::string path = expect_arm_scenario(
      "expect_misspelt.yaml",
      "expect:\n  metrics:\n    - {name: torque_rms, max: 50}\n    - {name: torque_rsm, max: 1}\n");
  EXPECT_EQ(expect_load_error(path),
            path +
                ":12: expect.metrics[1].name: unknown metric 'torque_rsm' (did "
                "you mean 'torque_rms'?)");
  path = expect_arm_scenario("expect_wall_clock.yaml",
                             "expect:\n  metrics:\n    - {name: realtime_factor, min: 1}\n");
  EXPECT_EQ(expect_load_error(path),
            path +
                ":11: expect.metrics[0].name: 'realtime_factor' is measured on "
                "the wall clock: an expectation cannot depend on the machine's "
                "speed");
  path = expect_arm_scenario("expect_known.yaml",
                             "expect:\n  metrics:\n    - {name: min_com_height_m, min: 0}\n");
  EXPECT_EQ(expect_load_error(path), "");
}

TEST(ScenarioExpect, TheVerdictGoesIntoSummaryJson) {
  const auto dir = std::filesystem::temp_directory_path() / "stance_expect_summary";
  std::filesystem::remove_all(dir);
  LoadedScenario s = load_scenario(expect_arm_scenario(
      "expect_summary.yaml", "expect:\n  metrics:\n    - {name: torque_rms, max: 1e-6}\n"));
  RunOptions opt;
  opt.out_dir = dir.string();
  opt.quiet = true;
  const RunResult r = Simulation(s, opt).run();
  const nlohmann::json j = nlohmann::json::parse(test::read_file(dir / "summary.json"));
  ASSERT_TRUE(j.contains("expectation"));
  EXPECT_EQ(j["expectation"], r.expectation);
  // holding the arm up takes torque: the bound misses
  EXPECT_FALSE(j["expectation"]["held"].get<bool>());
  EXPECT_EQ(j["expectation"]["checks"][2]["check"], "metrics.torque_rms");
  EXPECT_EQ(RunResult::from_json(r.to_json()).expectation, r.expectation);
}

}  // namespace
}  // namespace stance
