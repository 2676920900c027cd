#include "analysis/finite_difference.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// the parts of Engine a finite-difference routine needs; the rest is inert
class FakeEngine : public Engine {
 public:
  FakeEngine(int nq, int nv, int nu) : q_(VectorXd::Zero(nq)), v_(VectorXd::Zero(nv)) {
    ctrl_ = VectorXd::Zero(nu);
    tau_ = VectorXd::Zero(nv);
  }
  std::string_view engine_name() const override { return "fake"; }
  int nq() const override { return static_cast<int>(q_.size()); }
  int nv() const override { return static_cast<int>(v_.size()); }
  int nu() const override { return static_cast<int>(ctrl_.size()); }
  int nbody() const override { return 0; }
  int njoint() const override { return 0; }
  double total_mass() const override { return 0; }
  int body_index(std::string_view) const override { return -1; }
  int joint_index(std::string_view) const override { return -1; }
  int dof_index(std::string_view) const override { return -1; }
  int actuator_index(std::string_view) const override { return -1; }
  const std::string& body_name(int) const override { return none_; }
  const std::string& dof_name(int) const override { return none_; }
  const std::string& actuator_name(int) const override { return none_; }
  const JointInfo& joint(int) const override { return joint_; }
  int dof_joint(int) const override { return -1; }
  double body_mass(int) const override { return 0; }
  int body_parent(int) const override { return -1; }
  double time() const override { return time_; }
  double timestep() const override { return dt_; }
  void set_timestep(double dt) override { dt_ = dt; }
  Eigen::Vector3d gravity() const override { return Eigen::Vector3d::Zero(); }
  void set_gravity(const Eigen::Vector3d&) override {}
  void get_positions(Eigen::Ref<VectorXd> q) const override { q = q_; }
  void get_velocities(Eigen::Ref<VectorXd> v) const override { v = v_; }
  void set_positions(const Eigen::Ref<const VectorXd>& q) override { q_ = q; }
  void set_velocities(const Eigen::Ref<const VectorXd>& v) override { v_ = v; }
  double dof_position(int dof) const override { return q_[dof]; }
  double dof_velocity(int dof) const override { return v_[dof]; }
  void set_dof_position(int dof, double value) override { q_[dof] = value; }
  void difference_positions(const Eigen::Ref<const VectorXd>& q0,
                            const Eigen::Ref<const VectorXd>& q1,
                            Eigen::Ref<VectorXd> v) const override {
    v = q1 - q0;
  }
  void integrate_positions(const Eigen::Ref<const VectorXd>& q, const Eigen::Ref<const VectorXd>& v,
                           double dt, Eigen::Ref<VectorXd> q_out) const override {
    q_out = q + dt * v;
  }
  void forward() override {}
  void mass_matrix(Eigen::Ref<MatrixXd> m) const override { m.setIdentity(); }
  void solve_mass(Eigen::Ref<VectorXd>) const override {}
  void bias_forces(Eigen::Ref<VectorXd> c) const override { c.setZero(); }
  void constraint_forces(Eigen::Ref<VectorXd> f) const override { f.setZero(); }
  void inverse_dynamics(const Eigen::Ref<const VectorXd>& vdot,
                        Eigen::Ref<VectorXd> tau) const override {
    tau = vdot;
  }
  Eigen::Vector3d com() const override { return Eigen::Vector3d::Zero(); }
  Eigen::Vector3d com_velocity() const override { return Eigen::Vector3d::Zero(); }
  BodyPose body_pose(int) const override { return {}; }
  Eigen::Vector3d body_com(int) const override { return Eigen::Vector3d::Zero(); }
  Eigen::Matrix<double, 6, 1> body_velocity(int) const override {
    return Eigen::Matrix<double, 6, 1>::Zero();
  }
  void point_jacobian(int, const Eigen::Vector3d&, Eigen::Ref<MatrixXd>,
                      Eigen::Ref<MatrixXd>) const override {}
  void com_jacobian(Eigen::Ref<MatrixXd>) const override {}
  void subtree_com_jacobian(int, Eigen::Ref<MatrixXd>) const override {}
  Eigen::Vector3d subtree_com(int) const override { return Eigen::Vector3d::Zero(); }
  int num_contacts() const override { return 0; }
  Contact contact(int) const override { return {}; }
  void set_generalized_forces(const Eigen::Ref<const VectorXd>& tau) override { tau_ = tau; }
  void set_controls(const Eigen::Ref<const VectorXd>& ctrl) override { ctrl_ = ctrl; }
  void get_controls(Eigen::Ref<VectorXd> ctrl) const override { ctrl = ctrl_; }
  void actuator_moment(Eigen::Ref<MatrixXd> moment) const override { moment.setIdentity(); }
  void apply_external_force(int, const Eigen::Vector3d&, const Eigen::Vector3d&) override {}
  void set_dof_velocity_command(int, double) override {}
  void save_state(EngineState& s) const override {
    s.time = time_;
    s.q = q_;
    s.v = v_;
    s.ctrl = ctrl_;
  }
  void restore_state(const EngineState& s) override {
    time_ = s.time;
    q_ = s.q;
    v_ = s.v;
    ctrl_ = s.ctrl;
    tau_.setZero();
  }
  void step() override {
    advance();
    tau_.setZero();  // per-step input consumed
    time_ += dt_;
    ++steps;
  }
  bool state_is_finite() const override { return q_.allFinite() && v_.allFinite(); }

  int steps = 0;

 protected:
  virtual void advance() = 0;

  VectorXd q_, v_, ctrl_, tau_;
  double time_ = 0, dt_ = 0.01;

 private:
  std::string none_;
  JointInfo joint_;
};

// x+ = Ax x + Bu u + Bf tau + c * tau.^2 (on the velocity rows), with nq == nv
class LinearEngine final : public FakeEngine {
 public:
  LinearEngine(const MatrixXd& Ax, const MatrixXd& Bu, const MatrixXd& Bf, double c)
      : FakeEngine(static_cast<int>(Ax.rows() / 2), static_cast<int>(Ax.rows() / 2),
                   static_cast<int>(Bu.cols())),
        Ax_(Ax),
        Bu_(Bu),
        Bf_(Bf),
        c_(c) {}

 private:
  void advance() override {
    const int n = nv();
    VectorXd x(2 * n);
    x << q_, v_;
    VectorXd xn = Ax_ * x + Bu_ * ctrl_ + Bf_ * tau_;
    xn.tail(n) += c_ * tau_.array().square().matrix();
    q_ = xn.head(n);
    v_ = xn.tail(n);
  }
  MatrixXd Ax_, Bu_, Bf_;
  double c_;
};

// one ball joint: q is a unit quaternion (w, x, y, z; nq 4), v the local angular velocity
// (nv 3), positions compose as MuJoCo's: q (+) w dt = q * exp(w dt). The step is
// semi-implicit: v+ = v + dt u, q+ = q (+) v+ dt.
class BallEngine final : public FakeEngine {
 public:
  BallEngine() : FakeEngine(4, 3, 3) { q_ << 1, 0, 0, 0; }

  static Eigen::Quaterniond to_quat(const Eigen::Ref<const VectorXd>& q) {
    return Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  }
  static Eigen::Quaterniond exp(const Eigen::Vector3d& phi) {
    double angle = phi.norm();
    if (angle < 1e-300) return Eigen::Quaterniond::Identity();
    return Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
  }
  void difference_positions(const Eigen::Ref<const VectorXd>& q0,
                            const Eigen::Ref<const VectorXd>& q1,
                            Eigen::Ref<VectorXd> v) const override {
    Eigen::AngleAxisd aa(to_quat(q0).conjugate() * to_quat(q1));
    double angle = aa.angle() > M_PI ? aa.angle() - 2 * M_PI : aa.angle();
    v = angle * aa.axis();
  }
  void integrate_positions(const Eigen::Ref<const VectorXd>& q, const Eigen::Ref<const VectorXd>& v,
                           double dt, Eigen::Ref<VectorXd> q_out) const override {
    Eigen::Quaterniond r = (to_quat(q) * exp(Eigen::Vector3d(v) * dt)).normalized();
    q_out << r.w(), r.x(), r.y(), r.z();
  }

 private:
  void advance() override {
    v_ += dt_ * ctrl_;
    VectorXd q = q_;
    integrate_positions(q, v_, dt_, q_);
  }
};

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d s;
  s << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return s;
}

// right Jacobian of SO(3): log(exp(phi)^-1 exp(phi + d)) = Jr(phi) d + O(d^2)
Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi) {
  double t = phi.norm();
  Eigen::Matrix3d S = skew(phi);
  return Eigen::Matrix3d::Identity() - (1 - std::cos(t)) / (t * t) * S +
         (t - std::sin(t)) / (t * t * t) * S * S;
}

MatrixXd random_matrix(unsigned seed, int rows, int cols) {
  std::srand(seed);
  return MatrixXd::Random(rows, cols);
}

TEST(FiniteDifferenceTest, RecoversLinearSystemExactly) {
  const int n = 4, m = 3;
  MatrixXd Ax = random_matrix(1, 2 * n, 2 * n), Bu = random_matrix(2, 2 * n, m);
  LinearEngine engine(Ax, Bu, MatrixXd::Zero(2 * n, n), 0);
  engine.set_positions(VectorXd::LinSpaced(n, -1, 1));
  engine.set_velocities(VectorXd::LinSpaced(n, 0.5, 2));
  EngineState x0;
  engine.save_state(x0);
  VectorXd u0 = VectorXd::LinSpaced(m, -0.3, 0.7);
  for (bool centered : {false, true}) {
    MatrixXd A, B;
    engine.steps = 0;
    linearize_fd(engine, x0, u0, 1e-6, centered, A, B);
    ASSERT_EQ(A.rows(), 2 * n);
    ASSERT_EQ(A.cols(), 2 * n);
    ASSERT_EQ(B.rows(), 2 * n);
    ASSERT_EQ(B.cols(), m);
    EXPECT_LE((A - Ax).cwiseAbs().maxCoeff(), 1e-8) << "centered " << centered;
    EXPECT_LE((B - Bu).cwiseAbs().maxCoeff(), 1e-8) << "centered " << centered;
    // one step per column (plus the nominal) forward, two per column centred
    EXPECT_EQ(engine.steps, centered ? 2 * (2 * n + m) : 2 * n + m + 1);
  }
}

TEST(FiniteDifferenceTest, LeavesEngineAtX0AndIgnoresStaleInputs) {
  const int n = 2, m = 1;
  MatrixXd Ax = random_matrix(3, 2 * n, 2 * n), Bu = random_matrix(4, 2 * n, m);
  MatrixXd Bf = random_matrix(5, 2 * n, n);
  LinearEngine engine(Ax, Bu, Bf, 0);
  engine.set_positions(VectorXd::Constant(n, 0.25));
  EngineState x0;
  engine.save_state(x0);
  // move the engine elsewhere and leave a stale per-step force that must not leak in
  engine.set_positions(VectorXd::Constant(n, 9.0));
  engine.set_generalized_forces(VectorXd::Constant(n, 100.0));
  MatrixXd A, B;
  linearize_fd(engine, x0, VectorXd::Zero(m), 1e-6, false, A, B);
  EXPECT_LE((A - Ax).cwiseAbs().maxCoeff(), 1e-8);
  VectorXd q(n), v(n);
  engine.get_positions(q);
  engine.get_velocities(v);
  EXPECT_EQ(q, x0.q);
  EXPECT_EQ(v, x0.v);
}

TEST(FiniteDifferenceTest, QuaternionStateUsesTangentSpace) {
  BallEngine engine;
  VectorXd q0(4);
  Eigen::Quaterniond r0(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -1).normalized()));
  q0 << r0.w(), r0.x(), r0.y(), r0.z();
  engine.set_positions(q0);
  engine.set_velocities(Eigen::Vector3d(2.0, -1.0, 3.0));
  EngineState x0;
  engine.save_state(x0);
  Eigen::Vector3d u0(0.5, 0.2, -0.4);
  MatrixXd A, B;
  linearize_fd(engine, x0, u0, 1e-6, true, A, B);
  ASSERT_EQ(A.rows(), 6);
  ASSERT_EQ(A.cols(), 6);
  ASSERT_EQ(B.cols(), 3);

  // analytic: phi = v+ dt; dq+/dq = exp(phi)^T, dq+/dv = dt Jr(phi), dq+/du = dt^2 Jr(phi)
  const double dt = engine.timestep();
  Eigen::Vector3d phi = (x0.v + dt * u0) * dt;
  Eigen::Matrix3d rot = BallEngine::exp(phi).toRotationMatrix();
  MatrixXd A_expected = MatrixXd::Zero(6, 6), B_expected = MatrixXd::Zero(6, 3);
  A_expected.topLeftCorner(3, 3) = rot.transpose();
  A_expected.topRightCorner(3, 3) = dt * right_jacobian(phi);
  A_expected.bottomRightCorner(3, 3).setIdentity();
  B_expected.topRows(3) = dt * dt * right_jacobian(phi);
  B_expected.bottomRows(3) = dt * Eigen::Matrix3d::Identity();
  EXPECT_LE((A - A_expected).cwiseAbs().maxCoeff(), 1e-8) << A << "\n\n" << A_expected;
  EXPECT_LE((B - B_expected).cwiseAbs().maxCoeff(), 1e-8) << B << "\n\n" << B_expected;
  // a plain subtraction of quaternions could not give a 6 x 6 A at all; check the rotation
  // block is not the identity, so the test sees the tangent-space transport
  EXPECT_GT((A.topLeftCorner(3, 3) - Eigen::Matrix3d::Identity()).norm(), 1e-3);
}

TEST(FiniteDifferenceTest, ForcesVariantSelectsDofsAndAppliesNominalForce) {
  const int n = 3;
  MatrixXd Ax = random_matrix(6, 2 * n, 2 * n), Bf = random_matrix(7, 2 * n, n);
  const double c = 0.5;  // quadratic force term: its derivative depends on tau0
  LinearEngine engine(Ax, MatrixXd::Zero(2 * n, 1), Bf, c);
  EngineState x0;
  engine.save_state(x0);
  VectorXd tau0(n);
  tau0 << 1.0, -2.0, 3.0;
  std::vector<int> dofs = {2, 0};
  int callbacks = 0;
  MatrixXd A, B;
  linearize_fd_forces(engine, x0, dofs, tau0, 1e-6, true, A, B, [&](Engine& e) { ++callbacks; });
  ASSERT_EQ(B.rows(), 2 * n);
  ASSERT_EQ(B.cols(), 2);
  EXPECT_LE((A - Ax).cwiseAbs().maxCoeff(), 1e-8);
  for (int j = 0; j < 2; ++j) {
    VectorXd expected = Bf.col(dofs[j]);
    expected[n + dofs[j]] += 2 * c * tau0[dofs[j]];
    EXPECT_LE((B.col(j) - expected).cwiseAbs().maxCoeff(), 1e-8) << "column " << j;
  }
  EXPECT_EQ(callbacks, 2 * (2 * n + 2));
}

TEST(FiniteDifferenceTest, RejectsBadArguments) {
  const int n = 2;
  LinearEngine engine(MatrixXd::Identity(2 * n, 2 * n), MatrixXd::Zero(2 * n, 1),
                      MatrixXd::Zero(2 * n, n), 0);
  EngineState x0;
  engine.save_state(x0);
  MatrixXd A, B;
  EXPECT_THROW(linearize_fd(engine, x0, VectorXd::Zero(2), 1e-6, true, A, B),
               std::invalid_argument);  // nu is 1
  EXPECT_THROW(linearize_fd(engine, x0, VectorXd::Zero(1), 0.0, true, A, B), std::invalid_argument);
  EngineState bad = x0;
  bad.q = VectorXd::Zero(3);
  EXPECT_THROW(linearize_fd(engine, bad, VectorXd::Zero(1), 1e-6, true, A, B),
               std::invalid_argument);
  EXPECT_THROW(linearize_fd_forces(engine, x0, {5}, VectorXd::Zero(n), 1e-6, true, A, B),
               std::invalid_argument);
  EXPECT_THROW(linearize_fd_forces(engine, x0, {0}, VectorXd::Zero(n + 1), 1e-6, true, A, B),
               std::invalid_argument);
}

// ---- cross-check against MuJoCo's own mjd_transitionFD, through the MuJoCo backend ----

constexpr const char* kPendulumXml = R"(
<mujoco model="pendulum3">
  <option timestep="0.002"/>
  <worldbody>
    <body name="l1" pos="0 0 2">
      <joint name="j1" type="hinge" axis="0 1 0" damping="0.2"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.05"/>
      <body name="l2" pos="0 0 -0.5">
        <joint name="j2" type="hinge" axis="0 1 0" damping="0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.04"/>
        <body name="l3" pos="0 0 -0.5">
          <joint name="j3" type="hinge" axis="1 0 0"/>
          <geom type="capsule" fromto="0 0 0 0 0.1 -0.4" size="0.03"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="j1" gear="2"/>
    <motor joint="j2" gear="1"/>
    <motor joint="j3" gear="0.5"/>
  </actuator>
</mujoco>
)";

// a free-floating body with a motorised arm: quaternion in q, nq = 8 != nv = 7
constexpr const char* kFreeXml = R"(
<mujoco model="floating">
  <option timestep="0.005"/>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="3"/>
      <body name="arm" pos="0.2 0 0">
        <joint name="shoulder" type="hinge" axis="0 0 1" damping="0.05"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="shoulder" gear="1"/>
  </actuator>
</mujoco>
)";

// a box resting on the floor: contacts and the constraint solver's warm start
constexpr const char* kContactXml = R"(
<mujoco model="box_on_floor">
  <option timestep="0.002"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="box" pos="0 0 0.1">
      <freejoint name="root"/>
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
      <body name="lid" pos="0 0 0.1">
        <joint name="hinge" type="hinge" axis="1 0 0" damping="0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0.2 0" size="0.02" mass="0.2"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="hinge" gear="1"/>
  </actuator>
</mujoco>
)";

std::string write_model(const std::string& name, const char* xml) {
  return test::write_temp_file("fd_" + name + ".xml", xml);
}

struct MjModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct MjDataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};

// run both on the same state. The routines do the same arithmetic through the same MuJoCo
// calls, so they agree to rounding (measured: <= 1.2e-16 on all three models).
void compare_with_mujoco(const std::string& name, const char* xml, int settle_steps,
                         bool expect_contacts) {
  const double tolerance = 1e-9;
  std::string path = write_model(name, xml);
  WorldSpec spec;
  spec.models.push_back({path});
  std::unique_ptr<Engine> engine;
  try {
    engine = make_mujoco_engine(spec);
  } catch (const std::exception& e) {
    if (std::string(e.what()).find("not implemented") != std::string::npos)
      GTEST_SKIP() << "MuJoCo backend not implemented yet: " << e.what();
    throw;
  }
  char error[1000] = "";
  std::unique_ptr<mjModel, MjModelDeleter> m(mj_loadXML(path.c_str(), nullptr, error, 1000));
  ASSERT_TRUE(m) << error;
  std::unique_ptr<mjData, MjDataDeleter> d(mj_makeData(m.get()));
  const int nq = m->nq, nv = m->nv, nu = m->nu;
  ASSERT_EQ(engine->nq(), nq);
  ASSERT_EQ(engine->nv(), nv);
  ASSERT_EQ(engine->nu(), nu);
  ASSERT_EQ(m->na, 0);

  // a generic state: turned joints, moving, controls on; free joints get a tilted orientation
  VectorXd q(nq), v(nv), u(nu);
  engine->get_positions(q);
  VectorXd dq = 0.3 * VectorXd::LinSpaced(nv, -1.0, 1.2);
  v = VectorXd::LinSpaced(nv, 0.4, -0.6);
  for (int i = 0; i < nv; ++i) {
    int j = m->dof_jntid[i];
    if (m->jnt_type[j] == mjJNT_FREE && i - m->jnt_dofadr[j] < 3) {
      dq[i] = 0;  // keep the base where the file put it (on the floor for the contact model)
      v[i] *= 0.1;
    }
  }
  VectorXd q_start(nq);
  engine->integrate_positions(q, dq, 1.0, q_start);
  u = VectorXd::LinSpaced(nu, 0.3, -0.2);
  engine->set_positions(q_start);
  engine->set_velocities(v);
  engine->set_controls(u);
  // settle a few steps so contacts and the warm start are those of a running simulation
  for (int i = 0; i < settle_steps; ++i) engine->step();
  if (expect_contacts) ASSERT_GT(engine->num_contacts(), 0);
  EngineState x0;
  engine->save_state(x0);

  // same state into MuJoCo's own data
  mju_copy(d->qpos, x0.q.data(), nq);
  mju_copy(d->qvel, x0.v.data(), nv);
  mju_copy(d->ctrl, x0.ctrl.data(), nu);
  // the backend's extra state: the warm start, then the last step's constraint forces
  ASSERT_EQ(static_cast<int>(x0.extra.size()), 2 * nv);
  mju_copy(d->qacc_warmstart, x0.extra.data(), nv);
  d->time = x0.time;

  for (bool centered : {true, false}) {
    SCOPED_TRACE(centered ? "centered" : "forward");
    const double eps = 1e-6;
    MatrixXd A, B;
    linearize_fd(*engine, x0, x0.ctrl, eps, centered, A, B);
    // MuJoCo writes row-major (2nv+na) x (2nv+na) and (2nv+na) x nu
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> A_mj(2 * nv, 2 * nv),
        B_mj(2 * nv, nu);
    mjd_transitionFD(m.get(), d.get(), eps, centered ? 1 : 0, A_mj.data(), B_mj.data(), nullptr,
                     nullptr);
    ASSERT_EQ(A.rows(), A_mj.rows());
    MatrixXd A_ref = A_mj, B_ref = B_mj;
    double a_err = (A - A_ref).cwiseAbs().maxCoeff();
    double b_err = (B - B_ref).cwiseAbs().maxCoeff();
    EXPECT_LE(a_err, tolerance * std::max(1.0, A_ref.cwiseAbs().maxCoeff())) << "ours:\n"
                                                                             << A << "\nmujoco:\n"
                                                                             << A_ref;
    EXPECT_LE(b_err, tolerance * std::max(1.0, B_ref.cwiseAbs().maxCoeff())) << "ours:\n"
                                                                             << B << "\nmujoco:\n"
                                                                             << B_ref;
    // the system is not trivially identity-like: the velocity block feels the dynamics
    EXPECT_GT((A.bottomLeftCorner(nv, nv)).cwiseAbs().maxCoeff(), 1e-3);
  }
}

TEST(FiniteDifferenceMujocoTest, PendulumMatchesTransitionFD) {
  compare_with_mujoco("fd_pendulum3", kPendulumXml, 0, false);
}

TEST(FiniteDifferenceMujocoTest, FreeJointMatchesTransitionFD) {
  compare_with_mujoco("fd_floating", kFreeXml, 0, false);
}

TEST(FiniteDifferenceMujocoTest, ContactMatchesTransitionFD) {
  compare_with_mujoco("fd_box_on_floor", kContactXml, 50, true);
}

// ---- generalised-force variant on both backends: physics, not plumbing ----

// a 2-link arm without damping, contacts or limits
constexpr const char* kArmXml = R"(
<mujoco model="arm2">
  <option timestep="0.002" integrator="Euler"/>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.04" mass="1.5"/>
      <body name="lower" pos="0.4 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.8"/>
      </body>
    </body>
  </worldbody>
</mujoco>
)";

class FiniteDifferenceForcesTest : public ::testing::TestWithParam<std::string> {};

// at zero velocity a semi-implicit Euler step gives v+ = v + dt M^-1 (tau - bias) and
// q+ = q + dt v+, so d v+/d tau = dt M^-1 and d q+/d tau = dt^2 M^-1, exactly
TEST_P(FiniteDifferenceForcesTest, InputJacobianIsTimestepOverMass) {
  WorldSpec spec;
  spec.models.push_back({write_model("fd_arm2", kArmXml)});
  std::unique_ptr<Engine> engine;
  try {
    engine = make_engine(GetParam(), spec);
  } catch (const std::exception& e) {
    GTEST_SKIP() << GetParam() << " backend unavailable: " << e.what();
  }
  const int nv = engine->nv();
  ASSERT_EQ(nv, 2);
  engine->set_dof_position(engine->require_dof("shoulder"), 0.4);
  engine->set_dof_position(engine->require_dof("elbow"), -0.9);
  engine->set_velocities(VectorXd::Zero(nv));
  engine->forward();
  EngineState x0;
  engine->save_state(x0);
  MatrixXd M(nv, nv);
  engine->mass_matrix(M);
  const double dt = engine->timestep();
  MatrixXd Minv = M.inverse();

  // gravity compensation as the nominal force, both dofs as inputs (given in reverse order)
  VectorXd bias(nv);
  engine->bias_forces(bias);
  std::vector<int> dofs = {engine->require_dof("elbow"), engine->require_dof("shoulder")};
  MatrixXd A, B;
  // eps 1e-4: d q+/d tau ~ dt^2 M^-1 ~ 1e-5 is tiny, and rounding of q (~1e-16 / eps) must stay
  // well below 1e-6 of it; centred differences of this step are exact to second order anyway
  linearize_fd_forces(*engine, x0, dofs, bias, 1e-4, true, A, B);
  ASSERT_EQ(B.rows(), 2 * nv);
  ASSERT_EQ(B.cols(), 2);
  for (int j = 0; j < 2; ++j) {
    VectorXd expected_v = dt * Minv.col(dofs[j]);
    VectorXd expected_q = dt * dt * Minv.col(dofs[j]);
    EXPECT_LE((B.col(j).tail(nv) - expected_v).norm(), 1e-6 * expected_v.norm()) << GetParam();
    EXPECT_LE((B.col(j).head(nv) - expected_q).norm(), 1e-6 * expected_q.norm()) << GetParam();
  }
  // gravity compensated: the arm stays put, and d q+/d v = dt I at zero velocity
  EXPECT_LE((A.topRightCorner(nv, nv) - dt * MatrixXd::Identity(nv, nv)).norm(), 1e-6 * dt);
  engine->set_generalized_forces(bias);
  engine->step();
  VectorXd v(nv);
  engine->get_velocities(v);
  EXPECT_LE(v.norm(), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Engines, FiniteDifferenceForcesTest,
                         ::testing::Values(std::string("mujoco"), std::string("dart")));

}  // namespace
}  // namespace stance
