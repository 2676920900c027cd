// Engine::render_model: what the viewer draws, through the engine interface on both engines
// (MuJoCo: its own model and data; DART: a MuJoCo copy posed as DART's bodies), and
// Engine::applied_joint_forces, which the viewer's torque plot reads.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

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

// every joint dof (not the root) at a random angle, then forward()
void random_pose(Engine& e, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(-0.6, 0.6);
  for (int j = 0; j < e.njoint(); ++j) {
    const JointInfo& joint = e.joint(j);
    if (joint.type != JointType::kHinge) continue;
    e.set_dof_position(joint.dof_adr, angle(rng));
  }
  e.forward();
}

// each engine body's drawn frame is the engine's body pose, and a geom follows its body
void expect_drawn_as_engine(Engine& e) {
  const RenderModel drawn = e.render_model();
  ASSERT_NE(drawn.model, nullptr);
  ASSERT_NE(drawn.data, nullptr);
  ASSERT_NE(drawn.body_ids, nullptr);
  ASSERT_EQ(static_cast<int>(drawn.body_ids->size()), e.nbody());
  const mjModel* m = drawn.model;
  const mjData* d = drawn.data;
  for (int b = 0; b < e.nbody(); ++b) {
    const int id = (*drawn.body_ids)[b];
    ASSERT_GE(id, 0) << e.body_name(b);
    const BodyPose pose = e.body_pose(b);
    EXPECT_LT((Eigen::Map<const Eigen::Vector3d>(d->xpos + 3 * id) - pose.pos).norm(), 1e-9)
        << e.body_name(b);
    const Eigen::Quaterniond q(d->xquat[4 * id], d->xquat[4 * id + 1], d->xquat[4 * id + 2],
                               d->xquat[4 * id + 3]);
    EXPECT_LT(q.angularDistance(pose.quat), 1e-9) << e.body_name(b);
  }
  for (int g = 0; g < m->ngeom; ++g) {
    const int body = m->geom_bodyid[g];
    mjtNum expected[3];
    mju_rotVecMat(expected, m->geom_pos + 3 * g, d->xmat + 9 * body);
    mju_addTo3(expected, d->xpos + 3 * body);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(d->geom_xpos[3 * g + k], expected[k], 1e-9);
  }
}

TEST(RenderModel, MujocoDrawsItsOwnState) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_fullbody("mujoco");
  random_pose(*mj, 3);
  expect_drawn_as_engine(*mj);
}

TEST(RenderModel, DartIsDrawnThroughAMujocoCopyPosedAsItsBodies) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto dart = load_fullbody("dart");
  random_pose(*dart, 5);
  expect_drawn_as_engine(*dart);
  // a new pose is drawn at the next call
  random_pose(*dart, 6);
  expect_drawn_as_engine(*dart);
}

TEST(RenderModel, AppliedJointForcesAreTheTauOfTheLastStep) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_fullbody("mujoco");
  Eigen::VectorXd tau = Eigen::VectorXd::LinSpaced(mj->nv(), -5, 5), applied(mj->nv());
  for (int i = 0; i < mj->nv(); ++i)
    if (mj->dof_is_root(i)) tau[i] = 0;
  mj->set_generalized_forces(tau);
  mj->step();
  ASSERT_TRUE(mj->applied_joint_forces(applied));
  EXPECT_LT((applied - tau).norm(), 1e-9);
  // DART does not tell them: the viewer plots the controllers' tau
  auto dart = load_fullbody("dart");
  Eigen::VectorXd unused(dart->nv());
  EXPECT_FALSE(dart->applied_joint_forces(unused));
}

}  // namespace
}  // namespace stance
