// The sampling planner: the spline, the dimensions it finds, thread-count determinism, branching
// with a plan, and what it is for: a standing biped taking pushes its ankle strategy cannot.
#include "plan/planner.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <functional>
#include <iostream>
#include <memory>

#include "core/error.h"
#include "plan/objective.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

TEST(CorrectionPlan, EvaluatesAPiecewiseLinearSplineAndHoldsItsEnds) {
  CorrectionPlan plan;
  plan.knots.resize(2, 3);
  plan.knots << 0, 1, 3,  //
      2, 2, -2;
  plan.t0 = 1.0;
  plan.knot_dt = 0.1;
  Eigen::VectorXd x(2);
  plan.evaluate(1.0, x);
  EXPECT_DOUBLE_EQ(x[0], 0);
  EXPECT_DOUBLE_EQ(x[1], 2);
  plan.evaluate(1.05, x);
  EXPECT_NEAR(x[0], 0.5, 1e-12);
  EXPECT_NEAR(x[1], 2, 1e-12);
  plan.evaluate(1.15, x);
  EXPECT_NEAR(x[0], 2, 1e-12);
  EXPECT_NEAR(x[1], 0, 1e-12);
  plan.evaluate(0.5, x);  // before the first knot: the first
  EXPECT_DOUBLE_EQ(x[0], 0);
  plan.evaluate(7.0, x);  // after the last: the last
  EXPECT_DOUBLE_EQ(x[0], 3);
  EXPECT_DOUBLE_EQ(x[1], -2);
  CorrectionPlan empty;
  empty.evaluate(1.0, x);
  EXPECT_EQ(x.squaredNorm(), 0);
}

// a short planning run of biped_stand; its trace of positions (and its rescue count)
std::vector<double> planned_trace(int threads, const std::vector<std::string>& extra = {},
                                  long* rescues = nullptr) {
  std::vector<std::string> sets = {"planner.enabled=true", "planner.samples=6",
                                   "planner.horizon_s=0.2", "planner.interval_s=0.05",
                                   "planner.threads=" + std::to_string(threads)};
  sets.insert(sets.end(), extra.begin(), extra.end());
  Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml"), sets), test::quiet());
  std::vector<double> out;
  Eigen::VectorXd q(sim.engine().nq());
  for (int k = 0; k < 300; ++k) {
    EXPECT_TRUE(sim.step());
    sim.engine().get_positions(q);
    out.insert(out.end(), q.data(), q.data() + q.size());
  }
  EXPECT_GE(sim.progress().plan.plans, 6);
  if (rescues) *rescues = sim.progress().plan.rescues;
  return out;
}

TEST(Planner, SamePlanForAnyThreadCount) {
  const std::vector<std::string> push = {
      "perturbations=[{body: h_spine, force: [80, 0, 0], "
      "start: 0.05, duration: 0.1}]"};
  std::vector<double> one = planned_trace(1, push);
  EXPECT_EQ(planned_trace(2, push), one);
  EXPECT_EQ(planned_trace(3, push), one);
  // with rescue rounds (the push moves the capture point more than 2 cm)
  const std::vector<std::string> rescued = {push[0], "planner.rescue_error_m=0.02"};
  long rescues = 0;
  std::vector<double> one_rescued = planned_trace(1, rescued, &rescues);
  EXPECT_GT(rescues, 0);
  EXPECT_NE(one_rescued, one);
  EXPECT_EQ(planned_trace(3, rescued), one_rescued);
  // and the planner does something: without it the run differs
  std::vector<double> base = planned_trace(1, {"planner.samples=1", push[0]});
  EXPECT_NE(base, one);
}

// CEM's refits add candidates around the elites: the plan it chooses costs no more than the
// plan predictive sampling chooses from the same state (its first round draws the same streams)
TEST(Planner, CemRoundsOnlyLowerTheChosenCost) {
  auto make = [](const std::string& method) {
    return std::make_unique<Simulation>(
        load_scenario(test::scenario_path("biped_stand.yaml"),
                      {"planner.enabled=true", "planner.samples=6", "planner.horizon_s=0.2",
                       "planner.interval_s=0.05", "planner.threads=2", "planner.method=" + method,
                       "planner.iterations=3", "planner.elites=2",
                       "perturbations=[{body: h_spine, force: [80, 0, 0], start: 0.05, "
                       "duration: 0.1}]"}),
        test::quiet());
  };
  std::unique_ptr<Simulation> sampling = make("sampling"), cem = make("cem");
  while (sampling->time() < 0.1) ASSERT_TRUE(sampling->step());
  SimulationState state;
  bool lower = false;
  for (int k = 0; k < 4; ++k) {
    SCOPED_TRACE(k);
    sampling->save(state);
    cem->restore(state);
    const CorrectionPlan& a = sampling->progress().plan;
    const CorrectionPlan& b = cem->progress().plan;
    const long plans = a.plans;
    const double before_a = a.cost_sum, before_b = b.cost_sum;
    while (sampling->progress().plan.plans == plans) ASSERT_TRUE(sampling->step());
    while (cem->progress().plan.plans == plans) ASSERT_TRUE(cem->step());
    EXPECT_LE(b.cost_sum - before_b, a.cost_sum - before_a + 1e-12);
    lower = lower || b.cost_sum - before_b < a.cost_sum - before_a;
  }
  EXPECT_TRUE(lower) << "the refits never found a cheaper plan";
}

// what a planning step spends and the plan it keeps, from the same states, at planner settings
// `option`, and of every sample (full) and of the warm start alone (one sample)
void expect_plans_between_the_full_draw_and_the_warm_start(
    const std::vector<std::string>& options) {
  SCOPED_TRACE(options.front());
  auto make = [](int samples, const std::vector<std::string>& extra, int threads) {
    std::vector<std::string> sets = {
        "planner.enabled=true",
        "planner.samples=" + std::to_string(samples),
        "planner.horizon_s=0.2",
        "planner.interval_s=0.05",
        "planner.rescue_error_m=0",
        "planner.threads=" + std::to_string(threads),
        "perturbations=[{body: h_spine, force: [80, 0, 0], start: 0.05, duration: 0.1}]"};
    sets.insert(sets.end(), extra.begin(), extra.end());
    return std::make_unique<Simulation>(
        load_scenario(test::scenario_path("biped_stand.yaml"), sets), test::quiet());
  };
  std::unique_ptr<Simulation> full = make(30, {}, 2), saving = make(30, options, 2),
                              warm = make(1, {}, 1);
  while (full->time() < 0.1) ASSERT_TRUE(full->step());
  SimulationState state;
  int saved = 0;
  for (int k = 0; k < 6; ++k) {
    SCOPED_TRACE(k);
    full->save(state);
    long steps[3] = {};
    double costs[3] = {};
    Simulation* runs[3] = {full.get(), saving.get(), warm.get()};
    for (int r = 0; r < 3; ++r) {
      if (r > 0) runs[r]->restore(state);
      const CorrectionPlan& plan = runs[r]->progress().plan;
      const long plans = plan.plans, steps0 = plan.rollout_steps;
      const double cost0 = plan.cost_sum;
      while (runs[r]->progress().plan.plans == plans) ASSERT_TRUE(runs[r]->step());
      costs[r] = plan.cost_sum - cost0;
      steps[r] = plan.rollout_steps - steps0;
    }
    // the same candidates, fewer of them rolled out in full: never costlier than the warm start
    EXPECT_LE(costs[0], costs[1]);
    EXPECT_LE(costs[1], costs[2]);
    EXPECT_LE(steps[1], steps[0]);
    saved += steps[1] < steps[0];
  }
  EXPECT_GT(saved, 0) << "no rollout step was saved";
  // its decisions read costs only: the same run on 3 threads as on 2
  saving = make(30, options, 2);
  std::unique_ptr<Simulation> three = make(30, options, 3);
  while (saving->time() < 0.6) ASSERT_TRUE(saving->step());
  while (three->time() < 0.6) ASSERT_TRUE(three->step());
  Eigen::VectorXd a(saving->engine().nq()), b(three->engine().nq());
  saving->engine().get_positions(a);
  three->engine().get_positions(b);
  EXPECT_EQ(a, b);
  EXPECT_EQ(saving->progress().plan.cost_sum, three->progress().plan.cost_sum);
  EXPECT_EQ(saving->progress().plan.rollout_steps, three->progress().plan.rollout_steps);
}

// sampling stops once a batch stops paying (planner.stop_margin)
TEST(Planner, StoppingSamplingEarlyKeepsAPlanBetweenTheFullDrawAndTheWarmStart) {
  expect_plans_between_the_full_draw_and_the_warm_start({"planner.stop_margin=0.5"});
}

// rollouts trailing the best at the same time are stopped (planner.race_margin) and never chosen
TEST(Planner, RacingRolloutsKeepAPlanBetweenTheFullDrawAndTheWarmStart) {
  expect_plans_between_the_full_draw_and_the_warm_start({"planner.race_margin=0.05"});
}

// calm steps (planner.calm_plans) plan with fewer candidates, racing: the first candidates of
// the same streams, so never costlier than the warm start nor cheaper than every sample
TEST(Planner, CalmStepsKeepAPlanBetweenTheFullDrawAndTheWarmStart) {
  expect_plans_between_the_full_draw_and_the_warm_start(
      {"planner.calm_plans=1", "planner.calm_error_m=10", "planner.calm_samples=12"});
}

// biped_stand planned with 8 samples and pushed at 0.3 s: calm after `calm_plans` quiet planning
// steps (its capture point within 4 cm; 0: never calm)
std::unique_ptr<Simulation> calm_run(int threads, int calm_plans,
                                     const std::vector<std::string>& extra = {}) {
  std::vector<std::string> sets = {
      "planner.enabled=true",
      "planner.samples=8",
      "planner.horizon_s=0.2",
      "planner.interval_s=0.05",
      "planner.threads=" + std::to_string(threads),
      "planner.rescue_error_m=0",
      "planner.calm_error_m=0.04",
      "planner.calm_plans=" + std::to_string(calm_plans),
      "planner.calm_samples=3",
      "perturbations=[{body: h_spine, force: [120, 0, 0], start: 0.3, duration: 0.1}]"};
  sets.insert(sets.end(), extra.begin(), extra.end());
  return std::make_unique<Simulation>(load_scenario(test::scenario_path("biped_stand.yaml"), sets),
                                      test::quiet());
}

// positions from the run's time on to t
std::vector<double> trace_to(Simulation& sim, double t) {
  std::vector<double> out;
  Eigen::VectorXd q(sim.engine().nq());
  while (sim.time() < t - 1e-9) {
    EXPECT_TRUE(sim.step());
    sim.engine().get_positions(q);
    out.insert(out.end(), q.data(), q.data() + q.size());
  }
  return out;
}

// quiet standing turns calm and plans cheaply; the push ends the streak and brings the full
// budget back while it lasts. The decisions read the run's state only: the same run on any
// thread count, and the streak is carried in the state file.
TEST(Planner, CalmRunsPlanCheaplyUntilTroubleAndTheSameOnAnyThreadCount) {
  std::unique_ptr<Simulation> one = calm_run(1, 3);
  const CorrectionPlan& plan = one->progress().plan;
  trace_to(*one, 0.2);
  const long streak_written = plan.calm_streak;
  EXPECT_GE(streak_written, 3);
  const std::string file = test::write_temp_file("planner_calm_streak.state", "");
  one->write_state(file);
  std::vector<double> after = trace_to(*one, 0.45);
  EXPECT_GE(plan.calm, 2);
  EXPECT_EQ(plan.calm_streak, 0) << "the push did not end the calm streak";
  const long calm_in_push = plan.calm;
  const std::vector<double> rest = trace_to(*one, 0.7);
  after.insert(after.end(), rest.begin(), rest.end());
  EXPECT_EQ(plan.calm, calm_in_push) << "calm while the push lasts";
  // the same run on 3 threads, and read back from the state file on 2
  std::unique_ptr<Simulation> three = calm_run(3, 3), resumed = calm_run(2, 3);
  trace_to(*three, 0.2);
  EXPECT_EQ(trace_to(*three, 0.7), after);
  EXPECT_EQ(three->progress().plan.rollout_steps, plan.rollout_steps);
  resumed->read_state(file);
  EXPECT_EQ(resumed->progress().plan.calm_streak, streak_written);
  EXPECT_EQ(trace_to(*resumed, 0.7), after);
  EXPECT_EQ(resumed->progress().plan.calm, plan.calm);
  // the full budget at every step spends more
  std::unique_ptr<Simulation> full = calm_run(1, 0);
  trace_to(*full, 0.7);
  EXPECT_EQ(full->progress().plan.calm, 0);
  EXPECT_LT(plan.rollout_steps, full->progress().plan.rollout_steps);
}

// calm steps roll out the calm model (planner.calm_timestep 4 ms against the run's 1 ms, over
// calm_horizon_s 0.1 of the 0.2 s horizon): at most calm_samples (3) rollouts of 25 steps. A step
// that is not calm rolls out the full model over the whole horizon: its warm start and "no
// correction" at least, 200 steps each. The same plans on any thread count.
TEST(Planner, CalmStepsRollOutTheCoarserShorterModelAndOtherStepsTheFullOne) {
  const std::vector<std::string> cheap = {"planner.calm_timestep=0.004",
                                          "planner.calm_horizon_s=0.1"};
  std::unique_ptr<Simulation> one = calm_run(1, 3, cheap);
  const CorrectionPlan& plan = one->progress().plan;
  int calm_steps = 0, full_steps = 0;
  std::vector<double> trace;
  while (one->time() < 0.7 - 1e-9) {
    const long plans = plan.plans, calm = plan.calm, steps = plan.rollout_steps;
    while (plan.plans == plans && one->time() < 0.7 - 1e-9) {
      const std::vector<double> q = trace_to(*one, one->time() + 0.001);
      trace.insert(trace.end(), q.begin(), q.end());
    }
    if (plan.plans == plans) break;
    const long spent = plan.rollout_steps - steps;
    if (plan.calm > calm) {
      ++calm_steps;
      EXPECT_LE(spent, 3 * 27) << "a calm step at " << one->time();
    } else {
      ++full_steps;
      EXPECT_GE(spent, 2 * 200) << "a full step at " << one->time();
    }
  }
  EXPECT_GE(calm_steps, 2);
  EXPECT_GE(full_steps, 4);
  EXPECT_EQ(plan.calm_streak, 0) << "the push did not end the calm streak";
  // the same run on 2 threads
  std::unique_ptr<Simulation> two = calm_run(2, 3, cheap);
  EXPECT_EQ(trace_to(*two, 0.7), trace);
  EXPECT_EQ(two->progress().plan.rollout_steps, plan.rollout_steps);
  EXPECT_EQ(two->progress().plan.cost_sum, plan.cost_sum);
}

// while calm, a new plan every calm_every-th interval (the plan kept in between); the push
// ends the streak as without it. The skips read the streak, which the state file carries.
TEST(Planner, CalmRunsPlanEveryNthIntervalUntilTrouble) {
  std::unique_ptr<Simulation> every = calm_run(1, 3),
                              second = calm_run(1, 3, {"planner.calm_every=2"});
  trace_to(*every, 0.3);
  trace_to(*second, 0.3);
  const CorrectionPlan& a = every->progress().plan;
  const CorrectionPlan& b = second->progress().plan;
  // 3 full steps, then calm ones: every interval against every second
  EXPECT_GE(a.calm, 2);
  EXPECT_LT(b.plans, a.plans);
  EXPECT_LT(b.rollout_steps, a.rollout_steps);
  EXPECT_EQ(b.plans - 3, (a.plans - 3 + 1) / 2);
  const std::string file = test::write_temp_file("planner_calm_every.state", "");
  second->write_state(file);
  std::vector<double> after = trace_to(*second, 0.45);
  EXPECT_EQ(b.calm_streak, 0) << "the push did not end the calm streak";
  const std::vector<double> rest = trace_to(*second, 0.7);
  after.insert(after.end(), rest.begin(), rest.end());
  // read back from the state file, on 2 threads
  std::unique_ptr<Simulation> resumed = calm_run(2, 3, {"planner.calm_every=2"});
  resumed->read_state(file);
  EXPECT_EQ(trace_to(*resumed, 0.7), after);
  EXPECT_EQ(resumed->progress().plan.plans, b.plans);
}

// a step whose chosen rollout ends at least calm_predicted_error_m off is not calm: with a
// threshold no rollout ends under, the run never turns calm; with a wide one it turns calm as
// without it
TEST(Planner, ForeseenTroubleKeepsTheFullBudget) {
  auto calm_steps = [](const std::string& predicted) {
    std::unique_ptr<Simulation> run =
        calm_run(2, 3, {"planner.calm_predicted_error_m=" + predicted});
    trace_to(*run, 0.3);
    return run->progress().plan.calm;
  };
  std::unique_ptr<Simulation> plain = calm_run(2, 3);
  trace_to(*plain, 0.3);
  EXPECT_GE(plain->progress().plan.calm, 2);
  EXPECT_EQ(calm_steps("1e-9"), 0);
  EXPECT_EQ(calm_steps("10"), plain->progress().plan.calm);
}

// rollouts stop once they cannot beat the cheapest known: the plans are those of rollouts run
// in full (CEM with one round draws the same candidates and rolls every one out in full), for
// fewer model steps
TEST(Planner, RolloutsStoppedEarlyChooseThePlansFullRolloutsWould) {
  auto run = [](const std::string& method) {
    Simulation sim(
        load_scenario(test::scenario_path("biped_stand.yaml"),
                      {"planner.enabled=true", "planner.samples=8", "planner.horizon_s=0.2",
                       "planner.interval_s=0.05", "planner.threads=2", "planner.method=" + method,
                       "planner.iterations=1", "planner.rescue_error_m=0.02",
                       "perturbations=[{body: h_spine, force: [80, 0, 0], start: 0.05, "
                       "duration: 0.1}]"}),
        test::quiet());
    std::vector<double> trace;
    Eigen::VectorXd q(sim.engine().nq());
    for (int k = 0; k < 300; ++k) {
      EXPECT_TRUE(sim.step());
      sim.engine().get_positions(q);
      trace.insert(trace.end(), q.data(), q.data() + q.size());
    }
    return std::make_pair(trace, sim.progress().plan);
  };
  const auto [stopped, stopped_plan] = run("sampling");
  const auto [full, full_plan] = run("cem");
  EXPECT_EQ(stopped, full);
  EXPECT_EQ(stopped_plan.cost_sum, full_plan.cost_sum);
  EXPECT_GT(stopped_plan.rescues, 0);
  EXPECT_LT(stopped_plan.rollout_steps, full_plan.rollout_steps);
}

// the planner's rollouts run the model's torque limits as the run does: a pendulum held by PD
// against gravity (9.81 N m) with a 5 N m effort limit, clamped in the rollouts' own steps
TEST(Planner, RolloutsClampTorquesToTheLimitsAsTheRunDoes) {
  const std::string urdf = test::write_temp_file("planner_pendulum.urdf", R"(<robot name="p">
  <link name="base"/>
  <link name="rod">
    <inertial><origin xyz="0.5 0 0"/><mass value="2"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="rod"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="5" velocity="10"/>
    <dynamics damping="2"/></joint>
</robot>
)");
  const std::string yaml = "name: planner_pendulum\nmodel:\n  - {file: " + urdf +
                           ", fixed_base: true}\nduration: 1\ntimestep: 0.002\n"
                           "torque_limits: on\nfall: {enabled: false}\n"
                           "controllers:\n  - {type: pd, kp: 200, kd: 20}\n"
                           "planner: {enabled: true, samples: 4, horizon_s: 0.1, "
                           "interval_s: 0.05, threads: 1, residual_torque: 50}\n";
  Simulation run(parse_scenario(YAML::Load(yaml), "planner_pendulum.yaml", ""), test::quiet());
  const auto& rollout_model = run.model().planner->rollout;
  ASSERT_TRUE(rollout_model);
  EXPECT_TRUE(rollout_model->clamp_torques);
  EXPECT_EQ(rollout_model->force_limit, run.model().force_limit);
  // a rollout simulation steps the rollout model: its torques never pass the limit
  Simulation rollout(rollout_model);
  for (int k = 0; k < 200; ++k) {
    ASSERT_TRUE(rollout.step());
    EXPECT_LE(std::abs(rollout.last_output().tau[0]), 5.0 + 1e-12) << k;
  }
  EXPECT_GT(rollout.progress().clamped_steps, 100);
  const RunResult r = run.run();
  EXPECT_LE(r.metrics["max_abs_torque"].get<double>(), 5.0 + 1e-12);
}

// planner.solver makes the rollouts' constraint solver cheaper and leaves the run's alone: the
// rollouts' engines have it, the run's keeps the model's, and a run whose plan is always "no
// correction" (one sample) moves the same to the bit with and without it
TEST(Planner, RolloutsRunTheirOwnSolverAndTheRunKeepsTheModels) {
  auto planned = [](const std::vector<std::string>& extra) {
    std::vector<std::string> sets = {"planner.enabled=true", "planner.samples=1",
                                     "planner.horizon_s=0.1", "planner.interval_s=0.05",
                                     "planner.threads=1"};
    sets.insert(sets.end(), extra.begin(), extra.end());
    return std::make_unique<Simulation>(
        load_scenario(test::scenario_path("biped_stand.yaml"), sets), test::quiet());
  };
  auto trace = [](Simulation& sim) {
    std::vector<double> out;
    Eigen::VectorXd q(sim.engine().nq());
    for (int k = 0; k < 200; ++k) {
      EXPECT_TRUE(sim.step());
      sim.engine().get_positions(q);
      out.insert(out.end(), q.data(), q.data() + q.size());
    }
    return out;
  };
  const std::vector<std::string> cheap = {"planner.solver.type=cg", "planner.solver.iterations=2",
                                          "planner.solver.tolerance=0.001",
                                          "planner.solver.cone=elliptic"};
  auto full_sim = planned({});
  auto cheap_sim = planned(cheap);
  const SolverSettings model = full_sim->engine().solver_settings();
  EXPECT_EQ(model.solver, "newton");
  EXPECT_EQ(model.iterations, 100);
  // the run's engine keeps the model's settings; the rollouts' engines have the planner's
  const SolverSettings run = cheap_sim->engine().solver_settings();
  EXPECT_EQ(run.solver, model.solver);
  EXPECT_EQ(run.iterations, model.iterations);
  EXPECT_EQ(run.tolerance, model.tolerance);
  EXPECT_EQ(run.cone, model.cone);
  Simulation cheap_rollout(cheap_sim->model().planner->rollout);
  const SolverSettings planning = cheap_rollout.engine().solver_settings();
  EXPECT_EQ(planning.solver, "cg");
  EXPECT_EQ(planning.iterations, 2);
  EXPECT_EQ(planning.tolerance, 0.001);
  EXPECT_EQ(planning.cone, "elliptic");
  // the rollouts move differently; the runs (their plan always none) to the bit the same
  Simulation full_rollout(full_sim->model().planner->rollout);
  EXPECT_NE(trace(cheap_rollout), trace(full_rollout));
  EXPECT_EQ(trace(*cheap_sim), trace(*full_sim));
  EXPECT_GE(cheap_sim->progress().plan.plans, 3);
  // a solver the engine does not know is named with its key
  try {
    planned({"planner.solver.type=newtn"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("planner.solver.type"), std::string::npos) << e.what();
  }
}

TEST(Planner, DimensionsAreResidualTorquesWhereNoControllerOffersOne) {
  Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml"),
                               {"planner.enabled=true", "planner.samples=2",
                                "planner.residual_dofs=[j_shin_left, j_shin_right]"}),
                 test::quiet());
  ASSERT_TRUE(sim.model().planner);
  const auto& dims = sim.model().planner->dimensions;
  ASSERT_EQ(dims.size(), 2u);
  EXPECT_EQ(dims[0].name, "residual.j_shin_left");
  EXPECT_EQ(dims[0].dof, sim.engine().dof_index("j_shin_left"));
  EXPECT_EQ(dims[0].controller, -1);
  try {
    Simulation bad(load_scenario(test::scenario_path("biped_stand.yaml"),
                                 {"planner.enabled=true", "planner.residual_dofs=[j_shin_lft]"}),
                   test::quiet());
    FAIL() << "an unknown dof was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("planner.residual_dofs: unknown dof 'j_shin_lft'"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("j_shin_left"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Simulation(load_scenario(test::scenario_path("biped_stand.yaml"),
                                        {"planner.enabled=true", "planner.method=cmaes"}),
                          test::quiet()),
               InputError);
}

// the viewer's sliders: new parameters take effect at the next step; the same parameters set at
// a planning time change nothing, other ones change the run from there on
TEST(Planner, NewParametersTakeEffectMidRun) {
  const std::vector<std::string> sets = {
      "planner.enabled=true",
      "planner.samples=4",
      "planner.horizon_s=0.2",
      "planner.interval_s=0.05",
      "planner.threads=1",
      "perturbations=[{body: h_spine, force: [80, 0, 0], start: 0.0, duration: 0.1}]"};
  const LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"), sets);
  auto trace = [&](const std::function<void(Simulation&)>& at_switch) {
    Simulation sim(loaded, test::quiet());
    std::vector<double> out;
    Eigen::VectorXd q(sim.engine().nq());
    for (int k = 0; k < 200; ++k) {
      if (k == 100) at_switch(sim);  // t = 0.1 s: a planning time
      EXPECT_TRUE(sim.step());
      sim.engine().get_positions(q);
      out.insert(out.end(), q.data(), q.data() + q.size());
    }
    return out;
  };
  const std::vector<double> base = trace([](Simulation&) {});
  const PlannerParams params = Simulation(loaded, test::quiet()).model().planner->params;
  EXPECT_EQ(trace([&](Simulation& sim) { sim.set_planner_params(params); }), base);
  PlannerParams more = params;
  more.samples = 8;
  more.cost.fall = 50;
  std::vector<double> changed = trace([&](Simulation& sim) {
    sim.set_planner_params(more);
    EXPECT_EQ(sim.model().planner->params.samples, 8);
  });
  ASSERT_EQ(changed.size(), base.size());
  const size_t half = base.size() / 2;
  EXPECT_TRUE(std::equal(base.begin(), base.begin() + half, changed.begin()));
  EXPECT_NE(changed, base);
  // switched off: no correction from the next step on
  PlannerParams off = params;
  off.enabled = false;
  trace([&](Simulation& sim) {
    sim.set_planner_params(off);
    EXPECT_EQ(sim.planner(), nullptr);
    sim.step();
    EXPECT_EQ(sim.correction().squaredNorm(), 0.0);
  });
  // what needs a new run is refused, and so are parameters that do not fit together
  Simulation sim(loaded, test::quiet());
  PlannerParams bad = params;
  bad.timestep = 0.004;
  EXPECT_THROW(sim.set_planner_params(bad), InputError);
  bad = params;
  bad.interval_s = 1;
  EXPECT_THROW(sim.set_planner_params(bad), InputError);
  Simulation plain(load_scenario(test::scenario_path("biped_stand.yaml")), test::quiet());
  EXPECT_THROW(plain.set_planner_params(params), InputError);
}

TEST(Planner, ARestoredRunPlansAsTheRunThatWentOn) {
  const std::vector<std::string> sets = {"planner.enabled=true", "planner.samples=4",
                                         "planner.horizon_s=0.15", "planner.interval_s=0.03",
                                         "planner.threads=2"};
  Simulation a(load_scenario(test::scenario_path("biped_stand.yaml"), sets), test::quiet());
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(a.step());
  SimulationState mid;
  a.save(mid);
  for (int k = 0; k < 150; ++k) ASSERT_TRUE(a.step());
  Simulation b(load_scenario(test::scenario_path("biped_stand.yaml"), sets), test::quiet());
  b.restore(mid);
  for (int k = 0; k < 150; ++k) ASSERT_TRUE(b.step());
  Eigen::VectorXd qa(a.engine().nq()), qb(b.engine().nq());
  a.engine().get_positions(qa);
  b.engine().get_positions(qb);
  EXPECT_EQ(qa, qb);
  EXPECT_EQ(a.progress().plan.plans, b.progress().plan.plans);
}

// standing's balance target moves with the feet: the same stance moved 0.5 m along the floor
// after the start plans at the same cost (anchored to the start COM, it would pay 20 x 0.5^2 = 5)
TEST(Planner, StandingBalanceTargetFollowsTheFeet) {
  const std::vector<std::string> sets = {"planner.enabled=true", "planner.samples=4",
                                         "planner.horizon_s=0.15", "planner.threads=1",
                                         "planner.cost.capture=20"};
  auto first_plan_cost = [&](double shift) {
    Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml"), sets), test::quiet());
    Eigen::VectorXd q(sim.engine().nq());
    sim.engine().get_positions(q);
    q[0] += shift;  // the free root's x, along the floor (the model is y-up)
    sim.engine().set_positions(q);
    sim.engine().forward();
    EXPECT_TRUE(sim.step());
    return sim.progress().plan.cost_sum;
  };
  const double here = first_plan_cost(0), moved = first_plan_cost(0.5);
  EXPECT_GT(here, 0);
  EXPECT_NEAR(moved, here, 0.05);
}

// every run of a planning model gets the plan layer's planner (installed before main), a clone
// too; a run that does not plan has none, and neither have the planner's rollouts
TEST(Planner, EveryRunOfAPlanningModelHasThePlanner) {
  Simulation planned(load_scenario(test::scenario_path("biped_stand.yaml"),
                                   {"planner.enabled=true", "planner.threads=1"}),
                     test::quiet());
  const Planner* planner = planner_of(planned);
  ASSERT_NE(planner, nullptr);
  EXPECT_NE(planner_of(*planned.clone()), nullptr);
  EXPECT_NE(planner_of(*planned.clone()), planner);
  Simulation rollout(planned.model().planner->rollout);
  EXPECT_EQ(rollout.planner(), nullptr);
  Simulation plain(load_scenario(test::scenario_path("biped_stand.yaml")), test::quiet());
  EXPECT_EQ(plain.planner(), nullptr);
}

// the objective is a name in a registry: an unknown one is bad input naming the key and the
// file, with the near name offered; it is fixed once the run is made
TEST(PlannerObjective, UnknownNameIsBadInputAndTheNameIsFixedMidRun) {
  const std::string path = test::scenario_path("biped_stand.yaml");
  try {
    Simulation sim(
        load_scenario(path, {"planner.enabled=true", "planner.objective=track_or_balanc"}),
        test::quiet());
    ADD_FAILURE() << "an unknown objective was accepted";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("biped_stand.yaml"), std::string::npos) << msg;
    EXPECT_NE(msg.find("planner.objective: unknown objective 'track_or_balanc'"), std::string::npos)
        << msg;
    EXPECT_NE(msg.find("'track_or_balance'"), std::string::npos) << msg;
  }
  Simulation sim(load_scenario(path, {"planner.enabled=true", "planner.threads=1"}), test::quiet());
  PlannerParams other = sim.model().planner->params;
  other.objective = "another";
  EXPECT_THROW(sim.set_planner_params(other), InputError);
  EXPECT_NE(planner_of(sim), nullptr);  // the run keeps its planner
}

// the default objective, while nothing is tracked: standing still where the run started costs
// (next to) nothing, and moving the COM costs (capture point and COM velocity)
TEST(PlannerObjective, BalanceCostsNothingAtTheStartAndAMovingComCosts) {
  const ObjectiveEntry* entry = find_objective(PlannerParams{}.objective);
  ASSERT_NE(entry, nullptr);
  EXPECT_EQ(entry->name, "track_or_balance");
  Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml")), test::quiet());
  const PlannerParams params;
  auto objective = entry->make(params, resolve_run_start(sim.model(), sim.engine()));
  EXPECT_NEAR(objective->stage_cost(sim), 0, 1e-9);
  EXPECT_NEAR(objective->balance_error(sim), 0, 1e-9);
  Eigen::VectorXd v = Eigen::VectorXd::Zero(sim.engine().nv());
  v[0] = 0.5;  // the free root, along the floor
  sim.engine().set_velocities(v);
  sim.engine().forward();
  EXPECT_GT(objective->stage_cost(sim), params.cost.com_velocity * 0.1 * 0.1);
  EXPECT_GT(objective->balance_error(sim), 0.01);
}

// how long biped_stand_planner stays up, up to `duration`, after a forward push on the spine at
// 2 s (the ankle strategy alone takes 92 N there; docs/biped.md)
double stays_up_s(bool plan, double force, double duration,
                  const std::vector<std::string>& setting) {
  std::vector<std::string> sets = {fmt::format("perturbations.0.force=[{}, 0, 0]", force),
                                   "perturbations.0.start=2.0",
                                   fmt::format("duration={}", duration), "planner.threads=2",
                                   std::string("planner.enabled=") + (plan ? "true" : "false")};
  sets.insert(sets.end(), setting.begin(), setting.end());
  RunResult r = Simulation(load_scenario(test::scenario_path("biped_stand_planner.yaml"), sets),
                           test::quiet())
                    .run();
  return r.fell ? *r.fall_time : r.sim_time;
}

// 1.5x the ankle strategy's threshold, not at one tuned point: at the defaults, another seed, kp
// 0.8x and 1.2x and a 2 ms step, the push floors the unplanned biped within 1.5 s, and the
// planned one stays up at least 0.8 s longer (each planned run stops 1 s after the unplanned one
// fell; measured: up at 12 s at these and at a 0.5 ms step; docs/planner.md). At the defaults it
// runs to 8 s: with an effort cost alone it stepped on after this push until it fell at 7.6 s.
TEST(PlannerStanding, OutlastsTheAnkleStrategyAfterOneAndAHalfTimesItsPush) {
  const double push = 1.5 * 92;
  for (const std::vector<std::string>& setting :
       std::vector<std::vector<std::string>>{{},
                                             {"seed=2"},
                                             {"controllers.0.kp=320"},
                                             {"controllers.0.kp=480"},
                                             {"timestep=0.002"}}) {
    SCOPED_TRACE(setting.empty() ? "defaults" : setting[0]);
    const double base = stays_up_s(false, push, 4.5, setting);
    EXPECT_LT(base, 3.5) << "the push should floor the unplanned biped";
    const double until = setting.empty() ? 8.0 : base + 1.0;
    const double planned = stays_up_s(true, push, until, setting);
    std::cout << (setting.empty() ? "defaults" : setting[0]) << ": unplanned falls at " << base
              << " s, planned " << planned << " s\n";
    EXPECT_GT(planned, setting.empty() ? until - 1e-6 : base + 0.8);
  }
}

// the planner must not unsettle quiet standing (with a near-free correction it swayed the
// biped sideways until it fell at 4-5 s with no push at all)
TEST(PlannerStanding, StandsUnpushed) {
  EXPECT_GT(stays_up_s(true, 0, 6.5, {}), 6.5 - 1e-6);
}

}  // namespace
}  // namespace stance
