// URDF and SDF robots on both engines, as fullbody1 is checked (cross_engine_test.cc): DART's
// Atlas (dart-doc) through DART's own parsers and through stance's MJCF translation on MuJoCo.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <random>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/robot_model.h"
#include "test_support.h"

namespace stance {
namespace {

constexpr const char* kAtlasUrdf = "dart://sample/sdf/atlas/atlas_v3_no_head.urdf";
constexpr const char* kAtlasSdf = "dart://sample/sdf/atlas/atlas_v3_no_head.sdf";

std::unique_ptr<Engine> load_robot(const std::string& engine, const std::string& model,
                                   const RobotOptions& options = {}) {
  WorldSpec spec;
  spec.models.push_back({model, Eigen::Vector3d::Zero(), options});
  return make_engine(engine, spec);
}

// every body's pose and COM at 20 random configurations; returns the worst position error (m)
double worst_fk_error(Engine& mj, Engine& dart, double& worst_rot) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> angle(-0.8, 0.8);
  double worst_pos = 0;
  worst_rot = 0;
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::VectorXd q(dart.nq());
    q.setZero();
    dart.set_positions(q);
    Eigen::VectorXd mj_q(mj.nq());
    mj_q.setZero();
    for (int j = 0; j < mj.njoint(); ++j)
      if (mj.joint(j).type == JointType::kFree) mj_q[mj.joint(j).qpos_adr + 3] = 1;
    mj.set_positions(mj_q);
    for (int i = 0; i < dart.nv(); ++i) {
      const double value = angle(rng);
      dart.set_dof_position(i, value);
      mj.set_dof_position(mj.require_dof(dart.dof_name(i)), value);
    }
    mj.forward();
    dart.forward();
    for (int b = 0; b < dart.nbody(); ++b) {
      const int bm = mj.require_body(dart.body_name(b));
      const BodyPose pd = dart.body_pose(b), pm = mj.body_pose(bm);
      worst_pos = std::max(worst_pos, (pd.pos - pm.pos).norm());
      worst_pos = std::max(worst_pos, (dart.body_com(b) - mj.body_com(bm)).norm());
      worst_rot = std::max(worst_rot, pd.quat.angularDistance(pm.quat));
    }
    worst_pos = std::max(worst_pos, (dart.com() - mj.com()).norm());
  }
  return worst_pos;
}

// the joint-space block of the mass matrices (the free joints' velocity conventions differ)
double mass_matrix_difference(Engine& mj, Engine& dart) {
  mj.forward();
  dart.forward();
  Eigen::MatrixXd mm(mj.nv(), mj.nv()), md(dart.nv(), dart.nv());
  mj.mass_matrix(mm);
  dart.mass_matrix(md);
  double worst = 0;
  for (int i = 0; i < dart.nv(); ++i) {
    if (dart.dof_is_root(i)) continue;
    for (int j = 0; j < dart.nv(); ++j) {
      if (dart.dof_is_root(j)) continue;
      const int a = mj.require_dof(dart.dof_name(i)), b = mj.require_dof(dart.dof_name(j));
      worst = std::max(worst, std::abs(md(i, j) - mm(a, b)));
    }
  }
  return worst;
}

void expect_same_structure(Engine& mj, Engine& dart) {
  EXPECT_EQ(mj.nv(), dart.nv());
  EXPECT_EQ(mj.nbody(), dart.nbody());
  for (int b = 0; b < dart.nbody(); ++b)
    EXPECT_GE(mj.body_index(dart.body_name(b)), 0) << dart.body_name(b);
  for (int i = 0; i < dart.nv(); ++i)
    EXPECT_GE(mj.dof_index(dart.dof_name(i)), 0) << dart.dof_name(i);
  EXPECT_NEAR(mj.total_mass(), dart.total_mass(), 1e-9);
  for (int b = 0; b < dart.nbody(); ++b)
    EXPECT_NEAR(mj.body_mass(mj.require_body(dart.body_name(b))), dart.body_mass(b), 1e-12)
        << dart.body_name(b);
}

TEST(RobotCrossEngine, AtlasUrdfSameBodiesMassesAndLimits) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_robot("mujoco", kAtlasUrdf);
  auto dart = load_robot("dart", kAtlasUrdf);
  // 34 links (3 optical frames without <inertial>: 1 kg each, as DART gives them), a free root
  EXPECT_EQ(dart->nbody(), 34);
  EXPECT_EQ(dart->nv(), 33);
  EXPECT_EQ(mj->nq(), 34);
  EXPECT_NEAR(dart->total_mass(), 149.554, 1e-9);
  EXPECT_EQ(mj->body_mass(mj->require_body("l_situational_awareness_camera_optical_frame")), 1);
  EXPECT_EQ(mj->dof_index("rootJoint_rot_x"), 3);
  expect_same_structure(*mj, *dart);
  // URDF effort limits: 260 N m at the hip pitch, on both engines
  for (Engine* e : {mj.get(), dart.get()}) {
    EXPECT_EQ(e->joint(e->require_joint("l_leg_hpy")).force_limit, 260) << e->engine_name();
    EXPECT_EQ(e->joint(e->require_joint("back_bkx")).force_limit, 200) << e->engine_name();
  }
}

// every dof's torque limit is the URDF's effort on both engines, and one step under torques
// clamped to them (as Simulation::limit_torques clamps) moves every joint alike: neither engine
// scales or clamps the torques again, and both read the joints' damping (0.1)
TEST(RobotCrossEngine, AtlasUrdfEveryDofHasTheSameLimitAndStepsAlikeUnderIt) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  const RobotOptions fixed{.fixed_base = true};
  auto mj = load_robot("mujoco", kAtlasUrdf, fixed);
  auto dart = load_robot("dart", kAtlasUrdf, fixed);
  const RobotModel file =
      read_robot(kAtlasUrdf, "/usr/share/doc/dart/data/sdf/atlas/atlas_v3_no_head.urdf", fixed);
  std::map<std::string, double> effort;
  for (const RobotJoint& j : file.joints)
    if (j.type == RobotJointType::kRevolute) effort[j.name] = j.effort;
  ASSERT_EQ(dart->nv(), 27);
  ASSERT_EQ(effort.size(), 27u);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1, 1);
  Eigen::VectorXd tau_dart(27), tau_mj(27), v_dart(27), v_mj(27);
  for (int i = 0; i < 27; ++i) {
    const std::string& name = dart->dof_name(i);
    const int k = mj->require_dof(name);
    const double limit = dart->joint(dart->dof_joint(i)).force_limit;
    EXPECT_EQ(limit, effort.at(name)) << name;
    EXPECT_EQ(mj->joint(mj->dof_joint(k)).force_limit, limit) << name;
    dart->set_dof_position(i, 0.4 * unit(rng));
    mj->set_dof_position(k, dart->dof_position(i));
    v_dart[i] = v_mj[k] = unit(rng);
    tau_dart[i] = std::clamp(2 * limit * unit(rng), -limit, limit);
    tau_mj[k] = tau_dart[i];
  }
  mj->set_velocities(v_mj);
  dart->set_velocities(v_dart);
  mj->forward();
  dart->forward();
  mj->set_generalized_forces(tau_mj);
  dart->set_generalized_forces(tau_dart);
  mj->step();
  dart->step();
  ASSERT_EQ(mj->num_contacts(), 0);
  double worst = 0, largest = 0;
  for (int i = 0; i < 27; ++i) {
    const int k = mj->require_dof(dart->dof_name(i));
    worst = std::max(worst, std::abs(mj->dof_velocity(k) - dart->dof_velocity(i)));
    largest = std::max(largest, std::abs(dart->dof_velocity(i)));
  }
  EXPECT_GT(largest, 10);  // the torques moved the joints
  EXPECT_LT(worst, 1e-9);  // 6e-12 rad/s, where the fastest joint reaches 73 rad/s
}

TEST(RobotCrossEngine, AtlasUrdfForwardKinematicsAndMassMatrixAgree) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_robot("mujoco", kAtlasUrdf);
  auto dart = load_robot("dart", kAtlasUrdf);
  double worst_rot = 0;
  EXPECT_LT(worst_fk_error(*mj, *dart, worst_rot), 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
  EXPECT_LT(mass_matrix_difference(*mj, *dart), 1e-9);
}

TEST(RobotCrossEngine, AtlasSdfOnBothEngines) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_robot("mujoco", kAtlasSdf);
  auto dart = load_robot("dart", kAtlasSdf);
  EXPECT_EQ(dart->nbody(), 28);
  EXPECT_EQ(dart->nv(), 33);
  EXPECT_NEAR(dart->total_mass(), 146.554, 1e-9);
  EXPECT_GE(dart->dof_index("root_rot_x"), 0);
  expect_same_structure(*mj, *dart);
  double worst_rot = 0;
  EXPECT_LT(worst_fk_error(*mj, *dart, worst_rot), 1e-9);
  EXPECT_LT(worst_rot, 1e-9);
  EXPECT_LT(mass_matrix_difference(*mj, *dart), 1e-9);
  // the SDF's efforts, which DART's SdfParser does not read, are limits on DART too
  for (Engine* e : {mj.get(), dart.get()})
    EXPECT_EQ(e->joint(e->require_joint("l_leg_aky")).force_limit, 700) << e->engine_name();
}

TEST(RobotCrossEngine, FixedBaseWeldsTheRoot) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_robot("mujoco", kAtlasUrdf, {.fixed_base = true});
  auto dart = load_robot("dart", kAtlasUrdf, {.fixed_base = true});
  EXPECT_EQ(mj->nv(), 27);
  EXPECT_EQ(dart->nv(), 27);
  EXPECT_EQ(mj->dof_index("rootJoint_rot_x"), -1);
  EXPECT_LT(mass_matrix_difference(*mj, *dart), 1e-9);
}

// mesh feet as boxes: the boxes bound the STL's vertices, the same on both engines; the feet
// rest on the same height
TEST(RobotCrossEngine, MeshCollisionLoadsTheStlOnMujoco) {
  if (!test::have_atlas()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_robot("mujoco", kAtlasUrdf, {.mesh_collision = "mesh"});
  EXPECT_EQ(mj->nbody(), 34);
}

}  // namespace
}  // namespace stance
