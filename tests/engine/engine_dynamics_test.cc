// The engine queries the LQR design needs, on both backends: inverse dynamics against M v' +
// bias and against a step, MuJoCo against DART on fullbody1, the subtree-COM Jacobian against
// finite differences of the subtree COM, keyframes by name, and actuator moments against
// applying the controls.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <filesystem>
#include <random>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

// a chain with a free, a ball, a hinge and a slide joint, without contacts; motors with gears on
// the hinge and the ball, and a general actuator with a gain on the slide
constexpr const char* kActuatedChainMjcf = R"(
<mujoco model="actuated_chain">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="base" pos="0 0 2">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="4"/>
      <body name="link1" pos="0.2 0 0">
        <joint name="ball1" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
        <body name="link2" pos="0.3 0 0">
          <joint name="hinge2" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.25 0.05 0" size="0.03" mass="0.7"/>
          <body name="link3" pos="0.25 0.05 0">
            <joint name="slide3" type="slide" axis="1 0 0"/>
            <geom type="sphere" size="0.05" mass="0.3"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="m_hinge2" joint="hinge2" gear="2"/>
    <general name="g_slide3" joint="slide3" gainprm="3"/>
    <motor name="m_ball1" joint="ball1" gear="0 0 1.5 0 0 0"/>
  </actuator>
  <keyframe>
    <key name="bent" time="0.5" qpos="0 0 2 1 0 0 0 0.8 0 0.6 0 0.7 0.05"
         qvel="0 0 0 0 0 0 0.1 0.2 0.3 -1 0.5" ctrl="0.1 -0.2 0.3"/>
    <key name="straight"/>
  </keyframe>
</mujoco>
)";

std::unique_ptr<Engine> load_on(const std::string& engine, const std::string& model) {
  WorldSpec spec;
  spec.models.push_back({model});
  return make_engine(engine, spec);
}

std::string chain_file() {
  return test::write_temp_file("actuated_chain.xml", kActuatedChainMjcf);
}

// a random configuration (a tangent step from the current one) and velocity
void randomize(Engine& e, std::mt19937& rng, double spread) {
  std::normal_distribution<double> n(0, spread);
  Eigen::VectorXd q(e.nq()), q2(e.nq()), v(e.nv());
  e.get_positions(q);
  for (int i = 0; i < e.nv(); ++i) v[i] = e.dof_is_root(i) ? 0.0 : n(rng);
  e.integrate_positions(q, v, 1.0, q2);
  e.set_positions(q2);
  for (int i = 0; i < e.nv(); ++i) v[i] = n(rng);
  e.set_velocities(v);
  e.forward();
}

Eigen::VectorXd random_vector(int n, std::mt19937& rng, double scale) {
  std::normal_distribution<double> g(0.0, scale);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = g(rng);
  return v;
}

class EngineDynamicsTest : public ::testing::TestWithParam<std::string> {
 protected:
  // the chain on MuJoCo; fullbody1 (lifted off its ground) on DART, whose MJCF parser has no
  // ball joints
  std::unique_ptr<Engine> load_model() {
    if (GetParam() == "mujoco") return load_on("mujoco", chain_file());
    if (!test::have_dart_data()) return nullptr;
    auto e = load_on("dart", test::kFullbodySkel);
    lift(*e);
    return e;
  }
  static void lift(Engine& e) {
    for (const char* axis : {"_pos_x", "_pos_y", "_pos_z"}) {
      for (int j = 0; j < e.njoint(); ++j) {
        if (e.joint(j).type != JointType::kFree) continue;
        int dof = e.require_dof(e.joint(j).name + axis);
        e.set_dof_position(dof, e.dof_position(dof) + 2.0);
      }
    }
    e.forward();
  }
};

// in the air, with no damping, limits or contacts: tau = M vdot + bias, and applying tau for
// one step gives vdot
TEST_P(EngineDynamicsTest, InverseDynamicsIsMassTimesAccelerationPlusBias) {
  auto e = load_model();
  if (!e) GTEST_SKIP() << "dart-doc not installed";
  std::mt19937 rng(3);
  const int nv = e->nv();
  Eigen::MatrixXd m(nv, nv);
  Eigen::VectorXd bias(nv), tau(nv), vdot(nv), v0(nv), v1(nv), constraint(nv);
  for (int trial = 0; trial < 5; ++trial) {
    randomize(*e, rng, GetParam() == "mujoco" ? 0.5 : 0.1);
    ASSERT_EQ(e->num_contacts(), 0);
    vdot = random_vector(nv, rng, 2.0);
    e->inverse_dynamics(vdot, tau);
    e->mass_matrix(m);
    e->bias_forces(bias);
    Eigen::VectorXd expected = m * vdot + bias;
    EXPECT_LE((tau - expected).norm(), 1e-9 * std::max(1.0, expected.norm())) << trial;
    // the acceleration a step takes under tau (semi-implicit Euler: v+ = v + dt vdot)
    e->get_velocities(v0);
    e->set_generalized_forces(tau);
    e->step();
    e->get_velocities(v1);
    Eigen::VectorXd measured = (v1 - v0) / e->timestep();
    // DART's FreeJoint::integrateVelocities is not v + dt vdot: compare its joint dofs only
    if (GetParam() == "dart")
      for (int i = 0; i < nv; ++i)
        if (e->dof_is_root(i)) measured[i] = vdot[i];
    EXPECT_LE((measured - vdot).norm(), 1e-6 * vdot.norm()) << trial;
  }
}

// the query leaves the simulation alone: the next step is what it would have been
TEST_P(EngineDynamicsTest, InverseDynamicsLeavesTheStateAlone) {
  auto a = load_model();
  if (!a) GTEST_SKIP() << "dart-doc not installed";
  auto b = load_model();
  std::mt19937 rng_a(8), rng_b(8);
  randomize(*a, rng_a, 0.3);
  randomize(*b, rng_b, 0.3);
  const int nv = a->nv();
  Eigen::VectorXd tau(nv), qa(a->nq()), qb(b->nq()), fa(nv), fb(nv);
  a->step();
  b->step();
  a->forward();
  a->inverse_dynamics(Eigen::VectorXd::Constant(nv, 3.0), tau);
  a->constraint_forces(fa);
  b->constraint_forces(fb);
  EXPECT_EQ(fa, fb);
  a->step();
  b->step();
  a->get_positions(qa);
  b->get_positions(qb);
  EXPECT_EQ(qa, qb);
}

// the subtree COM and its Jacobian: finite differences, and the whole tree's is the COM's
TEST_P(EngineDynamicsTest, SubtreeComJacobianMatchesFiniteDifferences) {
  auto e = load_model();
  if (!e) GTEST_SKIP() << "dart-doc not installed";
  std::mt19937 rng(5);
  randomize(*e, rng, GetParam() == "mujoco" ? 0.5 : 0.3);
  const int nv = e->nv();
  Eigen::VectorXd q0(e->nq()), qp(e->nq()), qm(e->nq());
  e->get_positions(q0);
  std::vector<std::string> bodies =
      GetParam() == "mujoco"
          ? std::vector<std::string>{"base", "link1", "link3"}
          : std::vector<std::string>{"h_pelvis", "h_thigh_left", "h_spine", "h_hand_right"};
  for (const std::string& name : bodies) {
    SCOPED_TRACE(name);
    const int body = e->require_body(name);
    e->set_positions(q0);
    e->forward();
    Eigen::MatrixXd jac(3, nv);
    e->subtree_com_jacobian(body, jac);
    const double h = 1e-6;
    double worst = 0;
    for (int i = 0; i < nv; ++i) {
      Eigen::VectorXd dv = Eigen::VectorXd::Zero(nv);
      dv[i] = 1;
      e->integrate_positions(q0, dv, h, qp);
      e->integrate_positions(q0, dv, -h, qm);
      e->set_positions(qp);
      e->forward();
      Eigen::Vector3d cp = e->subtree_com(body);
      e->set_positions(qm);
      e->forward();
      Eigen::Vector3d cm = e->subtree_com(body);
      worst = std::max(worst, ((cp - cm) / (2 * h) - jac.col(i)).norm());
    }
    EXPECT_LT(worst, 1e-6);
    // the leaf's subtree is the body itself: its COM
    if (name == "link3") {
      e->set_positions(q0);
      e->forward();
      EXPECT_LT((e->subtree_com(body) - e->body_com(body)).norm(), 1e-12);
    }
  }
  // the root body's subtree is every mobile body
  e->set_positions(q0);
  e->forward();
  const int root = e->require_body(GetParam() == "mujoco" ? "base" : "h_pelvis");
  Eigen::MatrixXd jac(3, nv), jcom(3, nv);
  e->subtree_com_jacobian(root, jac);
  e->com_jacobian(jcom);
  EXPECT_LT((jac - jcom).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((e->subtree_com(root) - e->com()).norm(), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(BothEngines, EngineDynamicsTest, ::testing::Values("mujoco", "dart"));

// MuJoCo (SKEL translated) and DART (native) on fullbody1, in the air with the root at rest:
// the same forces on every joint dof, and subtree-COM Jacobians on the joint columns
TEST(EngineDynamicsCross, Fullbody1InverseDynamicsAndSubtreeJacobianAgree) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto mj = load_on("mujoco", test::kFullbodySkel);
  auto dart = load_on("dart", test::kFullbodySkel);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::VectorXd tau_mj(mj->nv()), tau_dart(dart->nv());
  double worst_tau = 0, worst_jac = 0, scale = 0;
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::VectorXd v_mj = Eigen::VectorXd::Zero(mj->nv()), a_mj = v_mj;
    Eigen::VectorXd v_dart = Eigen::VectorXd::Zero(dart->nv()), a_dart = v_dart;
    for (int i = 0; i < dart->nv(); ++i) {
      const std::string& name = dart->dof_name(i);
      const int k = mj->require_dof(name);
      double q = 0;
      if (dart->dof_is_root(i)) {
        // lifted 2 m along every axis, turned a little: clear of the ground
        q = name.find("_pos_") != std::string::npos ? 2.0 : 0.2 * u(rng);
      } else {
        // inside the joint's limits, so that MuJoCo's limit constraints stay inactive
        const JointInfo& j = dart->joint(dart->dof_joint(i));
        q = 0.4 * u(rng);
        if (j.has_limits) q = std::clamp(q, j.lower + 0.05, j.upper - 0.05);
        v_dart[i] = v_mj[k] = 1.5 * u(rng);
        a_dart[i] = a_mj[k] = 4.0 * u(rng);
      }
      dart->set_dof_position(i, q);
      mj->set_dof_position(k, q);
    }
    mj->set_velocities(v_mj);
    dart->set_velocities(v_dart);
    mj->forward();
    dart->forward();
    ASSERT_EQ(mj->num_contacts(), 0);
    mj->inverse_dynamics(a_mj, tau_mj);
    dart->inverse_dynamics(a_dart, tau_dart);
    const int spine_mj = mj->require_body("h_spine"), spine_dart = dart->require_body("h_spine");
    Eigen::MatrixXd jac_mj(3, mj->nv()), jac_dart(3, dart->nv());
    mj->subtree_com_jacobian(spine_mj, jac_mj);
    dart->subtree_com_jacobian(spine_dart, jac_dart);
    for (int i = 0; i < dart->nv(); ++i) {
      if (dart->dof_is_root(i)) continue;
      const int k = mj->require_dof(dart->dof_name(i));
      worst_tau = std::max(worst_tau, std::abs(tau_mj[k] - tau_dart[i]));
      scale = std::max(scale, std::abs(tau_dart[i]));
      worst_jac = std::max(worst_jac, (jac_mj.col(k) - jac_dart.col(i)).norm());
    }
  }
  EXPECT_GT(scale, 1.0);
  EXPECT_LT(worst_tau, 1e-9 * scale);
  EXPECT_LT(worst_jac, 1e-9);
}

// the generalised force of the controls is moment^T ctrl: a step under the controls and a
// step under that force agree
TEST(EngineActuators, MomentTimesControlsIsTheActuatorForce) {
  auto with_ctrl = load_on("mujoco", chain_file());
  auto with_tau = load_on("mujoco", chain_file());
  ASSERT_EQ(with_ctrl->nu(), 3);
  const int nv = with_ctrl->nv(), nu = with_ctrl->nu();
  std::mt19937 rng_a(21), rng_b(21);
  randomize(*with_ctrl, rng_a, 0.5);
  randomize(*with_tau, rng_b, 0.5);
  Eigen::MatrixXd moment(nu, nv);
  with_ctrl->actuator_moment(moment);
  // gear and gain: the motor on the hinge (gear 2), the general actuator on the slide (gain 3),
  // the ball's motor about its local z (gear 1.5)
  EXPECT_DOUBLE_EQ(moment(0, with_ctrl->require_dof("hinge2")), 2.0);
  EXPECT_DOUBLE_EQ(moment(1, with_ctrl->require_dof("slide3")), 3.0);
  EXPECT_DOUBLE_EQ(moment(2, with_ctrl->require_dof("ball1_z")), 1.5);
  EXPECT_DOUBLE_EQ(moment.cwiseAbs().sum(), 6.5);
  Eigen::VectorXd ctrl(nu);
  ctrl << 0.7, -0.4, 0.25;
  with_ctrl->set_controls(ctrl);
  with_tau->set_generalized_forces(moment.transpose() * ctrl);
  with_ctrl->step();
  with_tau->step();
  Eigen::VectorXd va(nv), vb(nv);
  with_ctrl->get_velocities(va);
  with_tau->get_velocities(vb);
  EXPECT_LT((va - vb).norm(), 1e-12 * va.norm());
}

TEST(EngineActuators, DartHasNoneAndSaysSo) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto e = load_on("dart", test::kFullbodySkel);
  EXPECT_EQ(e->nu(), 0);
  Eigen::MatrixXd moment(0, e->nv());
  EXPECT_THROW(e->actuator_moment(moment), InputError);
}

TEST(EngineKeyframes, ListedAndAppliedByName) {
  auto e = load_on("mujoco", chain_file());
  EXPECT_EQ(e->keyframe_names(), (std::vector<std::string>{"bent", "straight"}));
  e->step();
  e->apply_keyframe("bent");
  EXPECT_DOUBLE_EQ(e->time(), 0.5);
  Eigen::VectorXd q(e->nq()), v(e->nv()), ctrl(e->nu());
  e->get_positions(q);
  e->get_velocities(v);
  e->get_controls(ctrl);
  EXPECT_DOUBLE_EQ(q[7], 0.8);
  EXPECT_DOUBLE_EQ(q[12], 0.05);
  EXPECT_DOUBLE_EQ(v[e->require_dof("hinge2")], -1.0);
  EXPECT_EQ(ctrl, Eigen::Vector3d(0.1, -0.2, 0.3));
  // derived quantities follow: the link hangs where the keyframe put it
  e->forward();
  const Eigen::Vector3d at_key = e->body_pose(e->require_body("link3")).pos;
  e->apply_keyframe("straight");
  e->forward();
  EXPECT_GT((e->body_pose(e->require_body("link3")).pos - at_key).norm(), 0.05);
  EXPECT_DOUBLE_EQ(e->time(), 0.0);
  // an unknown name says which exist
  try {
    e->apply_keyframe("bnet");
    FAIL() << "no error";
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("unknown keyframe 'bnet'"), std::string::npos);
    EXPECT_NE(std::string(err.what()).find("bent"), std::string::npos) << err.what();
  }
}

TEST(EngineKeyframes, DartHasNoneAndSaysSo) {
  if (!test::have_dart_data()) GTEST_SKIP() << "dart-doc not installed";
  auto e = load_on("dart", test::kFullbodySkel);
  EXPECT_TRUE(e->keyframe_names().empty());
  try {
    e->apply_keyframe("init");
    FAIL() << "no error";
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("dart engine has no keyframes"), std::string::npos)
        << err.what();
  }
}

}  // namespace
}  // namespace stance
