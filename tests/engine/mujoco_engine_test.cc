#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstring>
#include <random>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/mujoco/mujoco_engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> load_chain() {
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file("chain.xml", test::kFloatingChainMjcf)});
  return make_mujoco_engine(spec);
}

// a random configuration: random tangent step from the model's reference pose
void randomize(Engine& e, std::mt19937& rng) {
  std::normal_distribution<double> n(0, 0.5);
  Eigen::VectorXd q(e.nq()), q2(e.nq()), v(e.nv());
  e.get_positions(q);
  for (int i = 0; i < e.nv(); ++i) v[i] = n(rng);
  e.integrate_positions(q, v, 1.0, q2);
  e.set_positions(q2);
  for (int i = 0; i < e.nv(); ++i) v[i] = n(rng);
  e.set_velocities(v);
  e.forward();
}

TEST(MujocoEngine, SizesNamesAndMass) {
  auto e = load_chain();
  EXPECT_EQ(e->engine_name(), "mujoco");
  EXPECT_EQ(e->nq(), 7 + 4 + 1 + 1);
  EXPECT_EQ(e->nv(), 6 + 3 + 1 + 1);
  EXPECT_EQ(e->nu(), 2);
  EXPECT_EQ(e->nbody(), 4);  // the floor and world are not mobile
  EXPECT_NEAR(e->total_mass(), 4 + 1 + 0.7 + 0.3, 1e-12);
  EXPECT_EQ(e->dof_index("root_pos_x"), 0);
  EXPECT_EQ(e->dof_index("root_rot_z"), 5);
  EXPECT_EQ(e->dof_index("ball1_y"), 7);
  EXPECT_EQ(e->dof_index("hinge2"), 9);
  EXPECT_TRUE(e->dof_is_root(3));
  EXPECT_FALSE(e->dof_is_root(9));
  EXPECT_EQ(e->actuator_index("m_slide3"), 1);
  EXPECT_EQ(e->body_index("link2"), 2);
  EXPECT_THROW(e->require_dof("hinge_2"), InputError);
  try {
    e->require_body("lnk2");
    FAIL();
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("did you mean 'link2'"), std::string::npos);
  }
}

TEST(MujocoEngine, MassSolveMatchesDenseSolve) {
  auto e = load_chain();
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    randomize(*e, rng);
    Eigen::MatrixXd m(e->nv(), e->nv());
    e->mass_matrix(m);
    EXPECT_LT((m - m.transpose()).norm(), 1e-12);
    Eigen::VectorXd b = Eigen::VectorXd::Random(e->nv());
    Eigen::VectorXd x = b;
    e->solve_mass(x);
    Eigen::VectorXd dense = m.ldlt().solve(b);
    EXPECT_LT((x - dense).norm() / dense.norm(), 1e-9);
  }
}

// the sparse shifted solve equals a dense one, and leaves MuJoCo's own factorisation intact
TEST(MujocoEngine, ShiftedMassSolveMatchesDenseAndRestoresTheFactor) {
  auto e = load_chain();
  std::mt19937 rng(7);
  randomize(*e, rng);
  Eigen::MatrixXd m(e->nv(), e->nv());
  e->mass_matrix(m);
  Eigen::VectorXd shift = Eigen::VectorXd::Random(e->nv()).cwiseAbs() * 0.05;
  Eigen::VectorXd b = Eigen::VectorXd::Random(e->nv());
  Eigen::VectorXd x = b;
  e->solve_mass_shifted(shift, x);
  Eigen::MatrixXd shifted = m;
  shifted.diagonal() += shift;
  Eigen::VectorXd dense = shifted.ldlt().solve(b);
  EXPECT_LT((x - dense).norm() / dense.norm(), 1e-10);
  Eigen::MatrixXd after(e->nv(), e->nv());
  e->mass_matrix(after);
  EXPECT_EQ(after, m);
  Eigen::VectorXd y = b;
  e->solve_mass(y);
  EXPECT_LT((y - m.ldlt().solve(b)).norm(), 1e-10);
}

TEST(MujocoEngine, DifferenceInvertsIntegrate) {
  auto e = load_chain();
  std::mt19937 rng(4);
  randomize(*e, rng);
  Eigen::VectorXd q(e->nq()), q2(e->nq()), v = Eigen::VectorXd::Random(e->nv()), back(e->nv());
  e->get_positions(q);
  e->integrate_positions(q, v, 0.3, q2);
  e->difference_positions(q, q2, back);
  EXPECT_LT((back - 0.3 * v).norm(), 1e-10);
}

// Jacobians against central differences of positions along tangent directions
TEST(MujocoEngine, JacobiansMatchFiniteDifferences) {
  auto e = load_chain();
  std::mt19937 rng(5);
  randomize(*e, rng);
  const int nv = e->nv();
  int body = e->body_index("link3");
  Eigen::VectorXd q0(e->nq()), qp(e->nq()), qm(e->nq());
  e->get_positions(q0);
  // a point fixed to link3, off its origin
  BodyPose pose = e->body_pose(body);
  Eigen::Vector3d local(0.02, -0.01, 0.03);
  Eigen::Vector3d point = pose.pos + pose.quat * local;
  Eigen::MatrixXd jp(3, nv), jr(3, nv), jcom(3, nv);
  e->point_jacobian(body, point, jp, jr);
  e->com_jacobian(jcom);
  const double h = 1e-6;
  for (int i = 0; i < nv; ++i) {
    Eigen::VectorXd dv = Eigen::VectorXd::Zero(nv);
    dv[i] = 1;
    e->integrate_positions(q0, dv, h, qp);
    e->integrate_positions(q0, dv, -h, qm);
    e->set_positions(qp);
    e->forward();
    BodyPose pp = e->body_pose(body);
    Eigen::Vector3d xp = pp.pos + pp.quat * local, cp = e->com();
    e->set_positions(qm);
    e->forward();
    BodyPose pm = e->body_pose(body);
    Eigen::Vector3d xm = pm.pos + pm.quat * local, cm = e->com();
    Eigen::Vector3d fd = (xp - xm) / (2 * h);
    EXPECT_LT((fd - jp.col(i)).norm(), 1e-6) << "dof " << e->dof_name(i);
    EXPECT_LT(((cp - cm) / (2 * h) - jcom.col(i)).norm(), 1e-6) << "dof " << e->dof_name(i);
    // rotational part: relative rotation pm^-1 pp ~ exp(J_rot dq) in world frame
    Eigen::AngleAxisd aa(pp.quat * pm.quat.conjugate());
    Eigen::Vector3d w = aa.angle() * aa.axis() / (2 * h);
    EXPECT_LT((w - jr.col(i)).norm(), 1e-6) << "dof " << e->dof_name(i);
  }
  // the COM velocity is the COM Jacobian times v
  e->set_positions(q0);
  e->forward();
  Eigen::VectorXd v(nv);
  e->get_velocities(v);
  EXPECT_LT((e->com_velocity() - jcom * v).norm(), 1e-9);
}

// the COM Jacobian is the mass-weighted sum of the bodies' COM Jacobians to the bit (it walks
// only each body's dofs; the run's controllers and logs must not move)
TEST(MujocoEngine, ComJacobianIsTheMassWeightedSumOfBodyJacobiansToTheBit) {
  auto e = load_chain();
  std::mt19937 rng(11);
  for (int trial = 0; trial < 3; ++trial) {
    randomize(*e, rng);
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(3, e->nv()), body(3, e->nv()), none(3, 0);
    for (int b = 0; b < e->nbody(); ++b) {
      e->point_jacobian(b, e->body_com(b), body, none);
      sum += (e->body_mass(b) / e->total_mass()) * body;
    }
    Eigen::MatrixXd jac(3, e->nv());
    e->com_jacobian(jac);
    EXPECT_EQ(jac, sum);
  }
}

// a model without springs, dampers or a fluid skips mj_passive (its forces are zeros either
// way): the steps are those of the same model computing them, to the bit
TEST(MujocoEngine, SkippingZeroPassiveForcesKeepsTheStepsToTheBit) {
  auto skipping = load_chain();
  auto computing = load_chain();
  auto& a = dynamic_cast<MujocoEngine&>(*skipping);
  auto& b = dynamic_cast<MujocoEngine&>(*computing);
  ASSERT_TRUE(a.model()->opt.disableflags & mjDSBL_PASSIVE);
  b.mutable_model()->opt.disableflags &= ~mjDSBL_PASSIVE;
  std::mt19937 rng_a(9), rng_b(9);
  randomize(a, rng_a);
  randomize(b, rng_b);
  for (int k = 0; k < 200; ++k) {
    a.step();
    b.step();
  }
  Eigen::VectorXd qa(a.nq()), qb(b.nq()), va(a.nv()), vb(b.nv());
  a.get_positions(qa);
  b.get_positions(qb);
  a.get_velocities(va);
  b.get_velocities(vb);
  EXPECT_EQ(qa, qb);
  EXPECT_EQ(va, vb);
}

TEST(MujocoEngine, ADamperKeepsThePassiveForces) {
  std::string xml = test::kFloatingChainMjcf;
  const std::string hinge = "<joint name=\"hinge2\"";
  ASSERT_NE(xml.find(hinge), std::string::npos);
  xml.replace(xml.find(hinge), hinge.size(), hinge + " damping=\"2\"");
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file("damped_chain.xml", xml)});
  auto e = make_mujoco_engine(spec);
  EXPECT_FALSE(dynamic_cast<MujocoEngine&>(*e).model()->opt.disableflags & mjDSBL_PASSIVE);
}

// a character whose geoms touch only the floor collides its few geom pairs as predefined ones,
// without MuJoCo's broadphase: from random states, the contacts and the steps are those of the
// same file with the dynamic pass, to the bit
TEST(MujocoEngine, PredefinedFloorPairsCollideAsTheBroadphaseToTheBit) {
  const std::string file = test::source_dir() + "/models/synthetic_walk.xml";
  WorldSpec spec;
  spec.models.push_back({file});
  auto engine = make_mujoco_engine(spec);
  auto& e = dynamic_cast<MujocoEngine&>(*engine);
  const mjModel* m = e.model();
  EXPECT_EQ(m->opt.collision, mjCOL_PAIR);
  EXPECT_EQ(m->npair, 18);  // the character's geoms with the floor
  char err[1000] = "";
  mjModel* dynamic = mj_loadXML(file.c_str(), nullptr, err, sizeof(err));
  ASSERT_NE(dynamic, nullptr) << err;
  EXPECT_EQ(dynamic->npair, 0);
  dynamic->opt.disableflags = m->opt.disableflags;
  mjData* a = mj_makeData(m);
  mjData* b = mj_makeData(dynamic);
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0, 1);
  std::uniform_real_distribution<double> height(0.2, 1.2);
  int touching = 0;
  for (int trial = 0; trial < 300; ++trial) {
    mj_resetData(m, a);
    mj_resetData(dynamic, b);
    a->qpos[2] = height(rng);
    for (int i = 3; i < m->nq; ++i) a->qpos[i] += 0.4 * n(rng);
    for (int j = 0; j < m->njnt; ++j)
      if (m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE)
        mju_normalize4(a->qpos + m->jnt_qposadr[j] + (m->jnt_type[j] == mjJNT_FREE ? 3 : 0));
    for (int i = 0; i < m->nv; ++i) a->qvel[i] = n(rng);
    std::copy(a->qpos, a->qpos + m->nq, b->qpos);
    std::copy(a->qvel, a->qvel + m->nv, b->qvel);
    for (int k = 0; k < 3; ++k) {
      mj_step(m, a);
      mj_step(dynamic, b);
    }
    touching += a->ncon > 1;
    ASSERT_EQ(a->ncon, b->ncon) << "trial " << trial;
    EXPECT_EQ(std::memcmp(a->contact, b->contact, sizeof(mjContact) * a->ncon), 0);
    EXPECT_TRUE(std::equal(a->qpos, a->qpos + m->nq, b->qpos)) << "trial " << trial;
    EXPECT_TRUE(std::equal(a->qvel, a->qvel + m->nv, b->qvel)) << "trial " << trial;
  }
  EXPECT_GT(touching, 50);  // several contacts at once, on several bodies
  mj_deleteData(a);
  mj_deleteData(b);
  mj_deleteModel(dynamic);
}

TEST(MujocoEngine, SelfCollidingOrUnnamedGeomsKeepTheBroadphase) {
  auto chain = load_chain();  // unnamed geoms
  const mjModel* m = dynamic_cast<MujocoEngine&>(*chain).model();
  EXPECT_EQ(m->opt.collision, mjCOL_ALL);
  EXPECT_EQ(m->npair, 0);
}

TEST(MujocoEngine, SaveRestoreIsBitExact) {
  auto e = load_chain();
  std::mt19937 rng(6);
  randomize(*e, rng);
  EngineState s;
  e->save_state(s);
  for (int k = 0; k < 50; ++k) e->step();
  Eigen::VectorXd q1(e->nq());
  e->get_positions(q1);
  e->restore_state(s);
  for (int k = 0; k < 50; ++k) e->step();
  Eigen::VectorXd q2(e->nq());
  e->get_positions(q2);
  EXPECT_EQ(q1, q2);
}

TEST(MujocoEngine, SolverSettingsChangeOnlyThisEngine) {
  auto run = load_chain();
  auto planning = load_chain();
  const SolverSettings model = run->solver_settings();
  EXPECT_EQ(model.solver, "newton");  // MuJoCo's defaults, as the file sets none
  EXPECT_EQ(model.cone, "pyramidal");
  EXPECT_EQ(model.iterations, 100);
  SolverSettings cheap;
  cheap.iterations = 4;
  cheap.tolerance = 1e-4;
  cheap.cone = "elliptic";
  EXPECT_TRUE(planning->set_solver_settings(cheap));
  const SolverSettings got = planning->solver_settings();
  EXPECT_EQ(got.iterations, 4);
  EXPECT_EQ(got.tolerance, 1e-4);
  EXPECT_EQ(got.cone, "elliptic");
  EXPECT_EQ(got.solver, "newton");  // left at the model's
  EXPECT_EQ(got.noslip_iterations, model.noslip_iterations);
  // the other engine of the same file keeps the file's settings
  EXPECT_EQ(run->solver_settings().iterations, 100);
  EXPECT_EQ(run->solver_settings().cone, "pyramidal");
  // a bad name is refused and changes nothing
  SolverSettings bad;
  bad.iterations = 7;
  bad.solver = "newtn";
  EXPECT_THROW(planning->set_solver_settings(bad), InputError);
  EXPECT_EQ(planning->solver_settings().iterations, 4);
  EXPECT_EQ(planning->solver_settings().solver, "newton");
}

TEST(MujocoEngine, GravityAndExternalForce) {
  auto e = load_chain();
  e->forward();
  Eigen::Vector3d c0 = e->com();
  // a free fall of 0.1 s (nothing touches the floor yet)
  for (int k = 0; k < 50; ++k) e->step();
  e->forward();
  EXPECT_NEAR(e->com().z(), c0.z() - 0.5 * 9.81 * 0.01, 2e-3);
  // an upward force equal to the weight through the COM cancels gravity's effect on the COM
  auto e2 = load_chain();
  e2->forward();
  Eigen::Vector3d v0 = e2->com_velocity();
  for (int k = 0; k < 50; ++k) {
    e2->forward();
    e2->apply_external_force(0, Eigen::Vector3d(0, 0, 9.81 * e2->total_mass()), e2->com());
    e2->step();
  }
  e2->forward();
  // free fall would reach -0.98 m/s; what remains is the integrator's O(dt) momentum error
  // from the links swinging about the base
  EXPECT_NEAR(e2->com_velocity().z(), v0.z(), 0.01);
}

// an absurd force on one dof, then up to four steps: MuJoCo resets itself on the bad acceleration
void blow_up(Engine& e) {
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(e.nv());
  tau[9] = 1e30;
  e.set_generalized_forces(tau);
  e.step();
  for (int k = 0; k < 3 && e.state_is_finite(); ++k) e.step();
}

TEST(MujocoEngine, DivergenceIsReported) {
  auto e = load_chain();
  blow_up(*e);
  EXPECT_FALSE(e->state_is_finite());
  EXPECT_NE(e->last_warning().find("t="), std::string::npos);
}

// MuJoCo's reset clears its warning counters: a second blow-up after a restore (a planner's
// rollouts restore one start state again and again) must still be reported, not run on from
// t = 0 (a rollout then ran its horizon again from 0: a 0.3 s run took over 300 s)
TEST(MujocoEngine, DivergenceAfterARestoreIsReportedToo) {
  auto e = load_chain();
  EngineState start;
  for (int k = 0; k < 10; ++k) e->step();
  e->save_state(start);
  const double t0 = e->time();
  for (int round = 0; round < 3; ++round) {
    SCOPED_TRACE(round);
    e->restore_state(start);
    blow_up(*e);
    EXPECT_FALSE(e->state_is_finite());
  }
  e->restore_state(start);
  EXPECT_TRUE(e->state_is_finite());
  EXPECT_DOUBLE_EQ(e->time(), t0);
}

TEST(MujocoEngine, BadInput) {
  WorldSpec missing;
  missing.models.push_back({"/nonexistent/model.xml"});
  try {
    make_mujoco_engine(missing);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/model.xml"), std::string::npos);
  }
  WorldSpec bad;
  bad.models.push_back(
      {test::write_temp_file("bad.xml", "<mujoco>\n<worldbody>\n<body>\n</worldbody>\n")});
  try {
    make_mujoco_engine(bad);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.xml"), std::string::npos) << e.what();
  }
}

// a .xml file whose root is <robot> is refused with its line before MuJoCo sees it, on both
// engines: mj_loadXML would hand it to MuJoCo's own URDF importer, which segfaulted on a
// fuzzed file (fuzz_model), and stance reads URDF through its own reader (.urdf)
TEST(MujocoEngine, AnXmlFileWithARobotRootIsRefusedWithItsLine) {
  WorldSpec spec;
  spec.models.push_back(
      {test::write_temp_file("robot_as.xml",
                             "<?xml version=\"1.0\"?>\n<!-- a URDF -->\n<robot name=\"r\">\n"
                             "  <link name=\"a\"/>\n</robot>\n")});
  for (const char* engine : {"mujoco", "dart"}) {
#ifndef STANCE_HAVE_DART
    if (std::string(engine) == "dart") continue;
#endif
    try {
      make_engine(engine, spec);
      ADD_FAILURE() << engine << ": loaded";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("robot_as.xml:3: root element <robot>: an MJCF file's root is "
                          "<mujoco>; a URDF file must be named .urdf"),
                std::string::npos)
          << engine << ": " << what;
    }
  }
}

}  // namespace
}  // namespace stance
