// planner.control_every: the rollouts' controllers run every n-th step and hold their output in
// between; a restored rollout computes at once; the run itself always computes every step.
#include <gtest/gtest.h>

#include <memory>

#include "core/error.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Simulation> planned_stand(int control_every) {
  return std::make_unique<Simulation>(
      load_scenario(test::scenario_path("biped_stand.yaml"),
                    {"planner.enabled=true", "planner.samples=1", "planner.horizon_s=0.1",
                     "planner.interval_s=0.05", "planner.threads=1",
                     "planner.control_every=" + std::to_string(control_every)}),
      test::quiet());
}

TEST(PlannerControlRate, RolloutsHoldTheControlsBetweenComputedSteps) {
  auto run = planned_stand(3);
  Simulation rollout(run->model().planner->rollout);
  SimulationState start;
  rollout.save(start);
  std::vector<Eigen::VectorXd> taus;
  for (int k = 0; k < 9; ++k) {
    ASSERT_TRUE(rollout.step());
    taus.push_back(rollout.last_output().tau);
  }
  for (int k = 0; k < 9; ++k)
    if (k % 3)
      EXPECT_EQ(taus[k], taus[k - 1]) << "step " << k;
    else if (k > 0)
      EXPECT_NE(taus[k], taus[k - 1]) << "step " << k;
  // a restore mid-hold computes at once: the first step is the one of a rollout at every step
  ASSERT_TRUE(rollout.step());
  rollout.restore(start);
  ASSERT_TRUE(rollout.step());
  auto every_step = planned_stand(1);
  Simulation reference(every_step->model().planner->rollout);
  ASSERT_TRUE(reference.step());
  EXPECT_EQ(rollout.last_output().tau, reference.last_output().tau);
  ASSERT_TRUE(reference.step());
  EXPECT_NE(reference.last_output().tau, taus[0]);  // at every step, the second one differs
}

TEST(PlannerControlRate, TheRunComputesEveryStepAndTheRateIsFixedWhenMade) {
  auto held = planned_stand(2), every = planned_stand(1);
  Eigen::VectorXd before;
  for (int k = 0; k < 50; ++k) {
    ASSERT_TRUE(held->step());
    ASSERT_TRUE(every->step());
    // one candidate keeps the plan at none: the runs are the same to the bit
    EXPECT_EQ(held->last_output().tau, every->last_output().tau) << "step " << k;
    if (k > 0) EXPECT_NE(held->last_output().tau, before) << "step " << k;
    before = held->last_output().tau;
  }
  PlannerParams p = held->model().planner->params;
  p.control_every = 1;
  EXPECT_THROW(held->set_planner_params(p), InputError);
}

}  // namespace
}  // namespace stance
