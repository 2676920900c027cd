// Every file in scenarios/ states what it shows (its `expect` block) and this checks it: one test
// per file, on the scenario's own engine, for `expect.test_duration` where the file shortens the
// run for the tests (the file says why), else for its whole duration. A new scenario without an
// expectation fails here.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "sim/expectation.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::vector<std::string> shipped_scenarios() {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(test::source_dir() + "/scenarios"))
    if (entry.path().extension() == ".yaml") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

class ScenarioExpectation : public testing::TestWithParam<std::string> {};

// the Debian packages whose models a scenario names (dart-doc, libmujoco-samples) are installed
bool models_installed(const std::string& scenario_text) {
  const bool dart = scenario_text.find("dart://") != std::string::npos;
  const bool mujoco = scenario_text.find("mujoco://") != std::string::npos ||
                      scenario_text.find("/usr/share/mujoco/") != std::string::npos;
  return (!dart || (test::have_dart_data() && test::have_atlas())) &&
         (!mujoco || std::filesystem::exists(test::kHumanoidXml));
}

TEST_P(ScenarioExpectation, Holds) {
  const std::string path = test::scenario_path(GetParam() + ".yaml");
  if (!models_installed(test::read_file(path))) GTEST_SKIP() << "its models are not installed";
  LoadedScenario s = load_scenario(path);
  const Expectation& e = s.scenario.expect;
  ASSERT_TRUE(e.given) << path << " has no 'expect' block: say what the scenario shows "
                       << "(docs/scenarios.md)";
  RunOptions opt;
  opt.quiet = true;
  opt.check_expect_names = true;  // as stance run does
  if (e.test_duration > 0) {
    EXPECT_LT(e.test_duration, s.scenario.duration)
        << "test_duration shortens the run; leave it out to run the whole";
    opt.duration = e.test_duration;
  }
  const RunResult r = Simulation(s, opt).run();
  ASSERT_FALSE(r.expectation.is_null());
  EXPECT_TRUE(r.expectation.at("held").get<bool>()) << expectation_line(r.expectation) << "\n"
                                                    << r.expectation.dump(2);
}

INSTANTIATE_TEST_SUITE_P(ShippedScenario, ScenarioExpectation,
                         testing::ValuesIn(shipped_scenarios()),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

}  // namespace
}  // namespace stance
