// Stable PD: the formula against a hand solve, root dofs left alone, and SPD's advantage over
// plain PD on the fullbody1 biped at the seed's gains.
#include "control/stable_pd.h"

#include <gtest/gtest.h>

#include "engine/world_spec.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> chain_engine() {
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file("spd_chain.xml", test::kFloatingChainMjcf)});
  return make_mujoco_engine(spec);
}

TEST(StablePd, MatchesTheFormulaAndLeavesRootDofsAlone) {
  auto e = chain_engine();
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(e->nv(), -0.4, 0.5);
  e->set_velocities(v);
  e->set_dof_position(e->require_dof("hinge2"), 0.3);
  e->forward();
  JointPdParams params;
  params.kp = 300;
  params.kd = 20;
  params.target["hinge2"] = -0.2;
  StablePd spd(params, {}, *e);
  auto state = spd.make_state(*e);
  ControlOutput out;
  out.resize(e->nv(), e->nu());
  spd.compute(*state, *e, out);

  // hand solve: dense, with the same ingredients
  const int nv = e->nv();
  const double dt = e->timestep();
  Eigen::VectorXd q(e->nq()), q_pred(e->nq()), q_target(e->nq()), err(nv), c(nv), f(nv);
  e->get_positions(q);
  q_target = q;
  q_target[e->joint(e->dof_joint(e->require_dof("hinge2"))).qpos_adr] = -0.2;
  e->integrate_positions(q, v, dt, q_pred);
  e->difference_positions(q_target, q_pred, err);
  Eigen::VectorXd kp = spd.model().kp, kd = spd.model().kd;
  Eigen::MatrixXd m(nv, nv);
  e->mass_matrix(m);
  e->bias_forces(c);
  e->constraint_forces(f);
  Eigen::VectorXd p = -kp.cwiseProduct(err), d = -kd.cwiseProduct(v);
  Eigen::MatrixXd a = m;
  a.diagonal() += kd * dt;
  Eigen::VectorXd acc = a.ldlt().solve(-c + p + d + f);
  Eigen::VectorXd tau = p + d - (kd * dt).cwiseProduct(acc);
  EXPECT_LT((out.tau - tau).norm(), 1e-9 * (1 + tau.norm()));
  // free joint: zero gains and zero torque
  for (int i = 0; i < nv; ++i)
    if (e->dof_is_root(i)) {
      EXPECT_EQ(spd.model().kp[i], 0);
      EXPECT_EQ(out.tau[i], 0);
    }
  EXPECT_NE(out.tau[e->require_dof("hinge2")], 0);
}

// fullbody1 has hinges only below its free root, so SPD takes the per-dof position error; it
// must give what the manifold difference gives
TEST(StablePd, PerDofErrorMatchesTheManifoldDifferenceOnHinges) {
  RunOptions opt;
  opt.quiet = true;
  Simulation run(load_scenario(test::scenario_path("biped_stand.yaml")), opt);
  Engine& e = run.engine();
  JointPdParams params;
  JointPdModel fast = make_joint_pd_model(params, e);
  ASSERT_TRUE(fast.scalar_gains_only);
  JointPdModel manifold = fast;
  manifold.scalar_gains_only = false;
  StablePdState s_fast, s_manifold;
  s_fast.resize(e.nq(), e.nv());
  s_manifold.resize(e.nq(), e.nv());
  e.get_positions(s_fast.q_target);
  s_manifold.q_target = s_fast.q_target;
  // move away from the target, root included, so both paths have work to do
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(e.nv(), -0.7, 0.9);
  Eigen::VectorXd q(e.nq());
  e.get_positions(q);
  e.integrate_positions(q, v, 0.05, q);
  e.set_positions(q);
  e.set_velocities(v);
  e.forward();
  ControlOutput out_fast, out_manifold;
  out_fast.resize(e.nv(), e.nu());
  out_manifold.resize(e.nv(), e.nu());
  compute_stable_pd(fast, s_fast, e, out_fast);
  compute_stable_pd(manifold, s_manifold, e, out_manifold);
  EXPECT_GT(out_fast.tau.norm(), 1.0);
  EXPECT_LT((out_fast.tau - out_manifold.tau).norm(), 1e-9 * out_manifold.tau.norm());
  compute_plain_pd(fast, s_fast, e, out_fast);
  compute_plain_pd(manifold, s_manifold, e, out_manifold);
  EXPECT_LT((out_fast.tau - out_manifold.tau).norm(), 1e-9 * out_manifold.tau.norm());
}

TEST(StablePd, RejectsUnknownDofsAndNegativeGains) {
  auto e = chain_engine();
  JointPdParams bad_name;
  bad_name.free_dofs = {"no_such_dof"};
  EXPECT_ANY_THROW(StablePd(bad_name, {}, *e));
  JointPdParams bad_gain;
  bad_gain.kp_dofs["hinge2"] = -1;
  EXPECT_THROW(StablePd(bad_gain, {}, *e), InputError);
}

// the seed's point: at Kp 400, Kd 40 and dt 1 ms, plain PD on fullbody1's light feet is unstable
// (Kd dt exceeds the feet's inertia), SPD stands
TEST(StablePd, StandsWherePlainPdDiverges) {
  const std::string path = test::scenario_path("biped_stand.yaml");
  RunOptions opt;
  opt.engine = "mujoco";
  opt.duration = 3.0;
  RunResult spd = Simulation(load_scenario(path), opt).run();
  EXPECT_FALSE(spd.diverged) << spd.divergence;
  EXPECT_FALSE(spd.fell) << spd.fall_reason;
  RunResult pd = Simulation(load_scenario(path, {"controllers.0.type=pd"}), opt).run();
  EXPECT_TRUE(pd.diverged || pd.fell);
  EXPECT_LT(pd.sim_time, 1.0);  // it goes within the first second
}

}  // namespace
}  // namespace stance
