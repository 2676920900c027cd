// MuJoCo (through the SKEL->MJCF translation) against DART (native SKEL) on fullbody1.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "engine/engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> load_fullbody(const std::string& engine) {
  WorldSpec spec;
  spec.models.push_back({test::kFullbodySkel});
  return make_engine(engine, spec);
}

TEST(CrossEngine, Fullbody1SizesAndMassAgree) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_fullbody("mujoco");
  auto dart = load_fullbody("dart");
  EXPECT_EQ(mj->nv(), 37);
  EXPECT_EQ(dart->nv(), 37);
  EXPECT_EQ(mj->nq(), 38);  // the free joint's quaternion
  EXPECT_EQ(dart->nq(), 37);
  EXPECT_EQ(mj->nbody(), dart->nbody());
  EXPECT_NEAR(mj->total_mass(), 47.9028, 1e-6);
  EXPECT_NEAR(dart->total_mass(), 47.9028, 1e-6);
  // the same dof names on both engines
  for (int i = 0; i < dart->nv(); ++i)
    EXPECT_GE(mj->dof_index(dart->dof_name(i)), 0) << dart->dof_name(i);
}

// set each dof by name on both engines and compare every body's world pose
TEST(CrossEngine, ForwardKinematicsAgreeAtRandomConfigurations) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_fullbody("mujoco");
  auto dart = load_fullbody("dart");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> angle(-0.8, 0.8);
  double worst_pos = 0, worst_rot = 0;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd zero_q(dart->nq());
    zero_q.setZero();
    dart->set_positions(zero_q);
    Eigen::VectorXd mj_q(mj->nq());
    mj_q.setZero();
    mj_q[3] = 1;  // identity quaternion of the free joint
    mj->set_positions(mj_q);
    for (int i = 0; i < dart->nv(); ++i) {
      double value = angle(rng);
      const std::string& name = dart->dof_name(i);
      dart->set_dof_position(i, value);
      mj->set_dof_position(mj->require_dof(name), value);
    }
    mj->forward();
    dart->forward();
    for (int b = 0; b < dart->nbody(); ++b) {
      int bm = mj->require_body(dart->body_name(b));
      BodyPose pd = dart->body_pose(b), pm = mj->body_pose(bm);
      worst_pos = std::max(worst_pos, (pd.pos - pm.pos).norm());
      worst_rot = std::max(worst_rot, pd.quat.angularDistance(pm.quat));
      EXPECT_LT((dart->body_com(b) - mj->body_com(bm)).norm(), 1e-9) << dart->body_name(b);
    }
    EXPECT_LT((dart->com() - mj->com()).norm(), 1e-9);
  }
  EXPECT_LT(worst_pos, 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
}

// the same mass matrix up to the free joint's velocity convention: compare the actuated block
TEST(CrossEngine, JointSpaceMassMatrixAgrees) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_fullbody("mujoco");
  auto dart = load_fullbody("dart");
  mj->forward();
  dart->forward();
  Eigen::MatrixXd mm(mj->nv(), mj->nv()), md(dart->nv(), dart->nv());
  mj->mass_matrix(mm);
  dart->mass_matrix(md);
  double worst = 0;
  for (int i = 0; i < dart->nv(); ++i) {
    if (dart->dof_is_root(i)) continue;
    for (int j = 0; j < dart->nv(); ++j) {
      if (dart->dof_is_root(j)) continue;
      int mi = mj->require_dof(dart->dof_name(i)), mjj = mj->require_dof(dart->dof_name(j));
      worst = std::max(worst, std::abs(md(i, j) - mm(mi, mjj)));
    }
  }
  EXPECT_LT(worst, 1e-9);
}

// MuJoCo's sparse tree LDL and DART's articulated-body solve of M + diag(shift), on fullbody1,
// against dense solves: with the shift on every dof, and with SPD's (none on the root), at rest
// and in motion under a push
TEST(CrossEngine, ShiftedMassSolvesMatchDenseSolves) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  for (const char* name : {"mujoco", "dart"}) {
    auto e = load_fullbody(name);
    Eigen::VectorXd spd_shift = Eigen::VectorXd::Constant(e->nv(), 0.04);
    for (int i = 0; i < e->nv(); ++i)
      if (e->dof_is_root(i)) spd_shift[i] = 0;
    for (int trial = 0; trial < 2; ++trial) {
      if (trial == 1) {
        e->set_velocities(Eigen::VectorXd::LinSpaced(e->nv(), -2, 3));
        // a push on the spine: the solve is of M alone, whatever else acts
        e->apply_external_force(e->require_body("h_spine"), Eigen::Vector3d(-100, 20, 0),
                                Eigen::Vector3d::Zero());
      }
      e->forward();
      for (const Eigen::VectorXd& shift :
           {Eigen::VectorXd(Eigen::VectorXd::Constant(e->nv(), 0.04)), spd_shift}) {
        Eigen::MatrixXd m(e->nv(), e->nv());
        e->mass_matrix(m);
        Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(e->nv(), -1, 1), x = b;
        e->solve_mass_shifted(shift, x);
        m.diagonal() += shift;
        EXPECT_LT((m * x - b).norm(), 1e-9) << name << " trial " << trial;
      }
    }
  }
}

// DART's shifted solve borrows the joints' damping and forces; the simulation must not notice
TEST(CrossEngine, ShiftedMassSolveLeavesTheSimulationAlone) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  for (const char* name : {"mujoco", "dart"}) {
    auto plain = load_fullbody(name), solving = load_fullbody(name);
    const int nv = plain->nv();
    Eigen::VectorXd tau = Eigen::VectorXd::LinSpaced(nv, -3, 3), shift(nv), x(nv);
    shift.setConstant(0.04);
    for (int k = 0; k < 50; ++k) {
      for (Engine* e : {plain.get(), solving.get()}) {
        e->forward();
        if (e == solving.get()) {
          x.setOnes();
          e->solve_mass_shifted(shift, x);
        }
        e->set_generalized_forces(tau);
        e->step();
      }
    }
    Eigen::VectorXd q0(plain->nq()), q1(plain->nq()), v0(nv), v1(nv);
    plain->get_positions(q0);
    solving->get_positions(q1);
    plain->get_velocities(v0);
    solving->get_velocities(v1);
    EXPECT_LT((q0 - q1).norm(), 1e-12) << name;
    EXPECT_LT((v0 - v1).norm(), 1e-12) << name;
    EXPECT_GT(v0.norm(), 0.1) << name;  // something happened
  }
}

}  // namespace
}  // namespace stance
