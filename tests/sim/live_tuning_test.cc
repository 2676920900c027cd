// Live tuning: the viewer's parameter path (tunable_params -> retune_controller) reaches the
// running controller and changes the behaviour.
#include "sim/live_tuning.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "control/controller.h"
#include "control/lqr.h"
#include "core/error.h"
#include "params/param_list.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

LoadedScenario biped_stand() {
  return load_scenario(test::scenario_path("biped_stand.yaml"));
}

// the lowest COM height over `seconds`
double min_com_height(Simulation& run, double seconds) {
  Engine& e = run.engine();
  double lowest = 1e9;
  while (e.time() < seconds) {
    EXPECT_TRUE(run.step());
    e.forward();
    lowest = std::min(lowest, -e.gravity().normalized().dot(e.com()));
  }
  return lowest;
}

TEST(ParamList, FlattensNestedStructsWithMeta) {
  RunOptions opt;
  opt.quiet = true;
  Simulation run(biped_stand(), opt);
  std::vector<ParamEntry> pd = tunable_params(*run.controllers()[0]);
  const ParamEntry* kp = nullptr;
  for (const auto& e : pd)
    if (e.path == "kp") kp = &e;
  ASSERT_NE(kp, nullptr);
  EXPECT_EQ(kp->value, 400);
  EXPECT_EQ(kp->meta.min, 0);  // from the visit, not from YAML
  EXPECT_EQ(kp->meta.unit, "N m/rad");
  // 3-vectors become three entries in --set syntax
  std::vector<ParamEntry> ankle = tunable_params(*run.controllers()[1]);
  bool found = false;
  for (const auto& e : ankle) found |= e.path == "heel_point.0" && e.value == 0.05;
  EXPECT_TRUE(found);
}

TEST(ParamList, DefaultListsYamlNumbers) {
  YAML::Node n = YAML::Load("{type: x, a: 1.5, b: {c: true, d: [1, 2]}, name: foo}");
  std::vector<ParamEntry> out;
  list_yaml_params(n, "", out);
  ASSERT_EQ(out.size(), 4u);
  EXPECT_EQ(out[0].path, "a");
  EXPECT_EQ(out[1].path, "b.c");
  EXPECT_EQ(out[1].kind, ParamEntry::Kind::kBool);
  EXPECT_EQ(out[3].path, "b.d.1");
  EXPECT_EQ(out[3].value, 2);
}

TEST(LiveTuning, GainChangeReachesTheRunningController) {
  RunOptions opt;
  opt.quiet = true;
  LoadedScenario loaded = biped_stand();
  Simulation stiff(loaded, opt), soft(loaded, opt);
  // soften the stance PD through the panel's path, 0.1 s into the run
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(soft.step());
  retune_controller(soft, loaded, 0, "kp", 20);
  EXPECT_EQ(soft.controllers()[0]->params_yaml()["kp"].as<double>(), 20);
  double stiff_low = min_com_height(stiff, 1.0);
  double soft_low = min_com_height(soft, 1.0);
  // with a twentieth of the gain the character sags clearly lower
  EXPECT_LT(soft_low, stiff_low - 0.05) << "stiff " << stiff_low << " soft " << soft_low;
}

TEST(LiveTuning, BadValueKeepsTheController) {
  RunOptions opt;
  opt.quiet = true;
  LoadedScenario loaded = biped_stand();
  Simulation run(loaded, opt);
  const Controller* before = run.controllers()[0].get();
  EXPECT_THROW(retune_controller(run, loaded, 0, "kp", -5), InputError);  // kp >= 0
  EXPECT_THROW(retune_controller(run, loaded, 0, "no_such", 1), InputError);
  EXPECT_EQ(run.controllers()[0].get(), before);
}

TEST(LiveTuning, SavedScenarioLoadsWithTheTunedValue) {
  RunOptions opt;
  opt.quiet = true;
  LoadedScenario loaded = biped_stand();
  Simulation run(loaded, opt);
  retune_controller(run, loaded, 0, "kd", 33);
  YAML::Node doc = tuned_scenario_yaml(run, loaded);
  LoadedScenario again = parse_scenario(doc, "tuned", test::source_dir() + "/scenarios");
  EXPECT_EQ(again.controllers[0]["kd"].as<double>(), 33);
  Simulation rerun(again, opt);
  EXPECT_TRUE(rerun.step());
}

// the planner's sliders: its parameters are listed from its visit, an edit reaches the running
// planner and the saved scenario, a bad one is refused and the planner kept
TEST(LiveTuning, PlannerParametersRetuneMidRunAndSave) {
  RunOptions opt;
  opt.quiet = true;
  LoadedScenario loaded = load_scenario(
      test::scenario_path("biped_stand.yaml"),
      {"planner.enabled=true", "planner.samples=4", "planner.horizon_s=0.1", "planner.threads=1"});
  Simulation run(loaded, opt);
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(run.step());
  std::vector<ParamEntry> entries = planner_params(run);
  auto has = [&](const std::string& path) {
    return std::any_of(entries.begin(), entries.end(),
                       [&](const ParamEntry& e) { return e.path == path; });
  };
  EXPECT_TRUE(has("samples"));
  EXPECT_TRUE(has("cost.fall"));
  retune_planner(run, "samples", 6);
  retune_planner(run, "cost.fall", 50);
  EXPECT_EQ(run.model().planner->params.samples, 6);
  EXPECT_EQ(run.model().planner->params.cost.fall, 50);
  const long plans = run.progress().plan.plans;
  ASSERT_TRUE(run.step());
  EXPECT_EQ(run.progress().plan.plans, plans + 1);  // it planned again at once
  EXPECT_THROW(retune_planner(run, "samples", -1), InputError);
  EXPECT_THROW(retune_planner(run, "no_such_key", 1), InputError);
  EXPECT_EQ(run.model().planner->params.samples, 6);
  YAML::Node doc = tuned_scenario_yaml(run, loaded);
  LoadedScenario again = parse_scenario(doc, "tuned", test::source_dir() + "/scenarios");
  EXPECT_EQ(again.scenario.planner.samples, 6);
  EXPECT_EQ(again.scenario.planner.cost.fall, 50);
  Simulation plain(biped_stand(), opt);
  EXPECT_TRUE(planner_params(plain).empty());
  EXPECT_THROW(retune_planner(plain, "samples", 6), InputError);
}

// an LQR cost change built on a worker: the old controller keeps stepping, then the new gain
// is swapped in, and it is the gain that loading the scenario with that cost gives
TEST(BackgroundRetune, LqrCostIsSwappedInBetweenSteps) {
  const std::string file = test::scenario_path("lqr_one_leg.yaml");
  LoadedScenario loaded = load_scenario(file);
  RunOptions opt;
  opt.quiet = true;
  Simulation run(loaded, opt);
  ASSERT_TRUE(rebuild_is_slow(*run.controllers()[0]));
  const Controller* old = run.controllers()[0].get();
  Eigen::MatrixXd k0 = dynamic_cast<const Lqr&>(*old).design().K;
  BackgroundRetune job(run, loaded, 0, "balance_cost", 4000);
  // the run goes on with the old controller meanwhile
  for (int i = 0; i < 20 && !job.ready(); ++i) ASSERT_TRUE(run.step());
  EXPECT_EQ(run.controllers()[0].get(), old);
  job.wait();
  ASSERT_TRUE(job.swap_into(run));
  ASSERT_NE(run.controllers()[0].get(), old);
  const auto& fresh = dynamic_cast<const Lqr&>(*run.controllers()[0]);
  EXPECT_GT((fresh.design().K - k0).norm(), 1e-3 * k0.norm());
  // the same gain as a scenario loaded with that cost (the design is at the initial pose)
  Simulation reference(load_scenario(file, {"controllers.0.balance_cost=4000"}), opt);
  const auto& expected = dynamic_cast<const Lqr&>(*reference.controllers()[0]);
  EXPECT_LT((fresh.design().K - expected.design().K).norm(), 1e-9 * k0.norm());
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(run.step());
}

TEST(BackgroundRetune, BadRequestsFailAtOnceAndKeepTheController) {
  LoadedScenario loaded = load_scenario(test::scenario_path("lqr_one_leg.yaml"));
  RunOptions opt;
  opt.quiet = true;
  Simulation run(loaded, opt);
  const Controller* old = run.controllers()[0].get();
  EXPECT_THROW(BackgroundRetune(run, loaded, 0, "no_such_cost", 1), InputError);
  EXPECT_THROW(BackgroundRetune(run, loaded, 3, "balance_cost", 1), InputError);
  // a value the controller rejects (balance_cost >= 0) fails on the worker: the error comes
  // with the swap, and the running controller stays
  BackgroundRetune job(run, loaded, 0, "balance_cost", -1);
  job.wait();
  EXPECT_THROW(job.swap_into(run), InputError);
  EXPECT_EQ(run.controllers()[0].get(), old);
  EXPECT_TRUE(run.step());
}

}  // namespace
}  // namespace stance
