// DART backend: sizes and names, the dynamics quantities against finite differences and dense
// algebra, position algebra on free joints, determinism of save/restore, and simple physics.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/bvh_to_mjcf.h"
#include "motion/bvh.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> load_fullbody() {
  WorldSpec spec;
  spec.models.push_back({test::kFullbodySkel, Eigen::Vector3d::Zero()});
  return make_dart_engine(spec);
}

// a file under the test temp dir holding `text`; returns its path
std::string write_temp(const std::string& name, const std::string& text) {
  return test::write_temp_file("dart_" + name, text);
}

// a 1 m pendulum: point-like 1 kg bob, hinge about y at the origin
std::string pendulum_mjcf(double angle0) {
  return R"(<mujoco model="pendulum">
  <option timestep="0.0005" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 0" euler="0 )" +
         std::to_string(angle0 * 180.0 / M_PI) + R"( 0">
      <joint name="swing" type="hinge" axis="0 1 0" pos="0 0 0"/>
      <inertial pos="0 0 -1" mass="1" diaginertia="1e-6 1e-6 1e-6"/>
      <geom type="sphere" size="0.05" pos="0 0 -1"/>
    </body>
  </worldbody>
</mujoco>
)";
}

// a configuration away from the rest pose: every dof perturbed
Eigen::VectorXd random_configuration(const Engine& e, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  Eigen::VectorXd q(e.nq());
  for (int i = 0; i < e.nq(); ++i) q[i] = u(rng);
  return q;
}

Eigen::VectorXd random_vector(int n, unsigned seed, double scale = 1.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, scale);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = g(rng);
  return v;
}

// rotation vector taking r0 to r1 in the world frame: log(r1 r0^T)
Eigen::Vector3d world_rotation_between(const Eigen::Matrix3d& r0, const Eigen::Matrix3d& r1) {
  Eigen::AngleAxisd aa(r1 * r0.transpose());
  return aa.angle() * aa.axis();
}

TEST(DartEngine, Fullbody1SizesAndNames) {
  auto e = load_fullbody();
  EXPECT_EQ(e->engine_name(), "dart");
  EXPECT_EQ(e->nv(), 37);
  EXPECT_EQ(e->nq(), 37);
  EXPECT_EQ(e->nu(), 0);
  EXPECT_NEAR(e->total_mass(), 47.9028, 1e-6);
  // 21 bodies in the file; the immobile "ground" is excluded
  EXPECT_EQ(e->nbody(), 20);
  EXPECT_EQ(e->body_index("ground"), -1);
  EXPECT_EQ(e->body_index("h_pelvis"), 0);
  EXPECT_NEAR(e->body_mass(e->require_body("h_pelvis")), 5.6154, 1e-12);

  // dart's own dof names and order
  EXPECT_EQ(e->dof_index("j_pelvis_rot_x"), 0);
  EXPECT_EQ(e->dof_index("j_pelvis_pos_z"), 5);
  EXPECT_EQ(e->dof_index("j_thigh_left_z"), 6);
  EXPECT_EQ(e->dof_index("j_shin_left"), 9);
  EXPECT_EQ(e->dof_index("j_heel_left_1"), 10);
  EXPECT_EQ(e->dof_index("no_such_dof"), -1);
  EXPECT_THROW(e->require_dof("j_shin_lft"), InputError);
  EXPECT_EQ(e->dof_name(9), "j_shin_left");

  // free root: one joint with 6 dofs; euler joints split into hinges named like the dofs
  const JointInfo& root = e->joint(e->require_joint("j_pelvis"));
  EXPECT_EQ(root.type, JointType::kFree);
  EXPECT_EQ(root.nq, 6);
  EXPECT_EQ(root.nv, 6);
  EXPECT_EQ(root.body, 0);
  EXPECT_TRUE(e->dof_is_root(e->require_dof("j_pelvis_pos_y")));
  EXPECT_FALSE(e->dof_is_root(e->require_dof("j_shin_left")));
  const JointInfo& thigh_y = e->joint(e->require_joint("j_thigh_left_y"));
  EXPECT_EQ(thigh_y.type, JointType::kHinge);
  EXPECT_EQ(thigh_y.nv, 1);
  EXPECT_EQ(thigh_y.dof_adr, e->dof_index("j_thigh_left_y"));
  EXPECT_EQ(thigh_y.body, e->body_index("h_thigh_left"));
  EXPECT_EQ(e->dof_joint(e->dof_index("j_heel_left_2")), e->joint_index("j_heel_left_2"));
  // every dof is owned by exactly one joint
  int covered = 0;
  for (int j = 0; j < e->njoint(); ++j) covered += e->joint(j).nv;
  EXPECT_EQ(covered, e->nv());

  // the file's physics settings are kept
  EXPECT_DOUBLE_EQ(e->timestep(), 0.001);
  EXPECT_TRUE(e->gravity().isApprox(Eigen::Vector3d(0, -9.81, 0)));
}

TEST(DartEngine, JointLimitsComeFromDofPositionLimits) {
  WorldSpec spec;
  spec.models.push_back({"dart://sample/skel/biped.skel", Eigen::Vector3d::Zero()});
  auto e = make_dart_engine(spec);
  // <limit><lower>-3.14</lower><upper>0.0</upper></limit> on the revolute knee
  const JointInfo& knee = e->joint(e->require_joint("j_shin_left"));
  EXPECT_EQ(knee.type, JointType::kHinge);
  EXPECT_TRUE(knee.has_limits);
  EXPECT_DOUBLE_EQ(knee.lower, -3.14);
  EXPECT_DOUBLE_EQ(knee.upper, 0.0);
  // the root has none
  EXPECT_FALSE(e->joint(e->require_joint("j_pelvis")).has_limits);
  // initial positions from the file are kept
  EXPECT_DOUBLE_EQ(e->dof_position(e->require_dof("j_shin_left")), -0.17);
}

TEST(DartEngine, SpecOverridesAndOffset) {
  WorldSpec spec;
  spec.models.push_back({test::kFullbodySkel, Eigen::Vector3d(1.0, 0.5, -2.0)});
  spec.timestep = 0.002;
  spec.gravity = Eigen::Vector3d(0, 0, -9.81);
  auto shifted = make_dart_engine(spec);
  auto plain = load_fullbody();
  EXPECT_DOUBLE_EQ(shifted->timestep(), 0.002);
  EXPECT_TRUE(shifted->gravity().isApprox(Eigen::Vector3d(0, 0, -9.81)));
  shifted->forward();
  plain->forward();
  // same q, whole content translated
  EXPECT_TRUE(shifted->com().isApprox(plain->com() + Eigen::Vector3d(1.0, 0.5, -2.0), 1e-12));
}

TEST(DartEngine, TwoCopiesGetPrefixedNames) {
  WorldSpec spec;
  spec.models.push_back({test::kFullbodySkel, Eigen::Vector3d::Zero()});
  spec.models.push_back({test::kFullbodySkel, Eigen::Vector3d(2, 0, 0)});
  auto e = make_dart_engine(spec);
  EXPECT_EQ(e->nv(), 74);
  EXPECT_EQ(e->nbody(), 40);
  EXPECT_NEAR(e->total_mass(), 2 * 47.9028, 1e-6);
  EXPECT_EQ(e->dof_index("j_shin_left"), 9);
  const int second =
      e->dof_index(e->body_name(20).substr(0, e->body_name(20).find('/')) + "/j_shin_left");
  EXPECT_EQ(second, 37 + 9);
  EXPECT_NE(e->body_name(20).find("/h_pelvis"), std::string::npos);
}

TEST(DartEngine, SolveMassMatchesDenseLdlt) {
  auto e = load_fullbody();
  e->set_positions(random_configuration(*e, 1));
  e->forward();
  Eigen::MatrixXd m(e->nv(), e->nv());
  e->mass_matrix(m);
  EXPECT_TRUE(m.isApprox(m.transpose(), 1e-12));
  const Eigen::VectorXd b = random_vector(e->nv(), 2);
  Eigen::VectorXd x = b;
  e->solve_mass(x);
  const Eigen::VectorXd dense = m.ldlt().solve(b);
  EXPECT_LT((x - dense).norm() / dense.norm(), 1e-9);
}

TEST(DartEngine, PointAndRotationJacobiansMatchFiniteDifferences) {
  auto e = load_fullbody();
  const Eigen::VectorXd q0 = random_configuration(*e, 3);
  const int n = e->nv();
  const double h = 1e-6;
  for (const char* name : {"h_pelvis", "h_toe_left", "h_hand_right", "h_head"}) {
    const int body = e->require_body(name);
    e->set_positions(q0);
    e->forward();
    const BodyPose pose0 = e->body_pose(body);
    // a point fixed to the body, off its origin
    const Eigen::Vector3d local(0.03, -0.05, 0.02);
    const Eigen::Vector3d point = pose0.pos + pose0.quat * local;
    Eigen::MatrixXd jp(3, n), jr(3, n);
    e->point_jacobian(body, point, jp, jr);

    Eigen::MatrixXd fd_pos(3, n), fd_rot(3, n);
    Eigen::VectorXd qp(n), qm(n);
    for (int i = 0; i < n; ++i) {
      const Eigen::VectorXd dir = Eigen::VectorXd::Unit(n, i);
      e->integrate_positions(q0, dir, h, qp);
      e->integrate_positions(q0, dir, -h, qm);
      e->set_positions(qp);
      e->forward();
      const BodyPose pp = e->body_pose(body);
      e->set_positions(qm);
      e->forward();
      const BodyPose pm = e->body_pose(body);
      fd_pos.col(i) = ((pp.pos + pp.quat * local) - (pm.pos + pm.quat * local)) / (2 * h);
      fd_rot.col(i) =
          world_rotation_between(pm.quat.toRotationMatrix(), pp.quat.toRotationMatrix()) / (2 * h);
    }
    EXPECT_LT((jp - fd_pos).cwiseAbs().maxCoeff(), 1e-6) << name;
    EXPECT_LT((jr - fd_rot).cwiseAbs().maxCoeff(), 1e-6) << name;
    // skipping one block leaves the other intact
    Eigen::MatrixXd jp_only(3, n), none(3, 0);
    e->set_positions(q0);
    e->forward();
    e->point_jacobian(body, point, jp_only, none);
    EXPECT_TRUE(jp_only.isApprox(jp, 1e-14)) << name;
  }
}

TEST(DartEngine, ComJacobianMatchesFiniteDifferences) {
  auto e = load_fullbody();
  const Eigen::VectorXd q0 = random_configuration(*e, 4);
  const int n = e->nv();
  e->set_positions(q0);
  e->forward();
  Eigen::MatrixXd j(3, n);
  e->com_jacobian(j);
  const double h = 1e-6;
  Eigen::MatrixXd fd(3, n);
  Eigen::VectorXd qp(n), qm(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::VectorXd dir = Eigen::VectorXd::Unit(n, i);
    e->integrate_positions(q0, dir, h, qp);
    e->integrate_positions(q0, dir, -h, qm);
    e->set_positions(qp);
    e->forward();
    const Eigen::Vector3d cp = e->com();
    e->set_positions(qm);
    e->forward();
    fd.col(i) = (cp - e->com()) / (2 * h);
  }
  EXPECT_LT((j - fd).cwiseAbs().maxCoeff(), 1e-6);

  // and J v is the COM velocity
  const Eigen::VectorXd v = random_vector(n, 5);
  e->set_positions(q0);
  e->set_velocities(v);
  e->forward();
  EXPECT_TRUE(e->com_velocity().isApprox(j * v, 1e-10));
}

TEST(DartEngine, FreeJointPositionAlgebraRoundTrips) {
  auto e = load_fullbody();
  const int n = e->nv();
  Eigen::VectorXd q0 = random_configuration(*e, 6);
  q0.head<3>() = Eigen::Vector3d(1.2, -0.7, 2.0);  // a large root rotation
  Eigen::VectorXd q_before(n);
  e->get_positions(q_before);

  // small steps: difference(q, q (+) v dt) == v dt
  const Eigen::VectorXd v = random_vector(n, 7);
  const double dt = 1e-3;
  Eigen::VectorXd q1(n), d(n);
  e->integrate_positions(q0, v, dt, q1);
  e->difference_positions(q0, q1, d);
  EXPECT_LT((d - v * dt).cwiseAbs().maxCoeff(), 1e-12);
  // the root moved on SE(3), not by plain addition
  EXPECT_GT((q1.head<6>() - (q0.head<6>() + v.head<6>() * dt)).norm(), 1e-6);

  // large displacements: q0 (+) (q2 (-) q0) == q2
  const Eigen::VectorXd q2 = random_configuration(*e, 8);
  Eigen::VectorXd back(n);
  e->difference_positions(q0, q2, d);
  e->integrate_positions(q0, d, 1.0, back);
  EXPECT_LT((back - q2).cwiseAbs().maxCoeff(), 1e-12);

  // both are pure: the engine's state is untouched
  Eigen::VectorXd q_after(n);
  e->get_positions(q_after);
  EXPECT_EQ(q_after, q_before);
}

TEST(DartEngine, FreeJointVelocityIsBodyFrameTwist) {
  auto e = load_fullbody();
  const int n = e->nv();
  e->set_positions(random_configuration(*e, 9));
  Eigen::VectorXd v = Eigen::VectorXd::Zero(n);
  v.head<6>() << 0.3, -0.2, 0.5, 1.0, 2.0, -0.5;
  e->set_velocities(v);
  e->forward();
  const int pelvis = e->require_body("h_pelvis");
  const Eigen::Matrix3d r = e->body_pose(pelvis).quat.toRotationMatrix();
  const Eigen::Matrix<double, 6, 1> twist = e->body_velocity(pelvis);
  EXPECT_TRUE(twist.head<3>().isApprox(r * v.head<3>(), 1e-12));
  EXPECT_TRUE(twist.tail<3>().isApprox(r * v.segment<3>(3), 1e-12));
}

TEST(DartEngine, SaveRestoreThenStepIsBitIdentical) {
  auto e = load_fullbody();
  const int n = e->nv();
  // fall into contact with the ground first, so the contact solver is exercised too
  for (int i = 0; i < 600; ++i) e->step();
  ASSERT_GT(e->num_contacts(), 0);

  EngineState saved;
  e->save_state(saved);
  const Eigen::VectorXd tau = random_vector(n, 10, 5.0);
  auto run = [&]() {
    std::vector<Eigen::VectorXd> trace;
    for (int i = 0; i < 20; ++i) {
      Eigen::VectorXd t = tau;
      t.head<6>().setZero();
      e->set_generalized_forces(t);
      e->apply_external_force(e->require_body("h_head"), Eigen::Vector3d(20, 0, 5),
                              e->body_com(e->require_body("h_head")));
      e->step();
      Eigen::VectorXd q(n), v(n);
      e->get_positions(q);
      e->get_velocities(v);
      trace.push_back(q);
      trace.push_back(v);
    }
    return trace;
  };
  const auto first = run();
  const double t_first = e->time();
  e->restore_state(saved);
  EXPECT_EQ(e->time(), saved.time);
  const auto second = run();
  EXPECT_EQ(e->time(), t_first);
  for (size_t i = 0; i < first.size(); ++i) ASSERT_EQ(first[i], second[i]) << "entry " << i;
}

// the synthetic walk's character on DART: capsules on a plane, which FCL collides
std::unique_ptr<Engine> load_capsule_character() {
  const BvhClip clip = read_bvh(test::source_dir() + "/models/synthetic_walk.bvh");
  WorldSpec spec;
  spec.models.push_back({write_temp("synthetic_walk.xml", make_bvh_character(clip, {}).mjcf)});
  return make_dart_engine(spec);
}

// steps with a torque pattern of its own; the positions, velocities and constraint forces
std::vector<Eigen::VectorXd> torqued_trace(Engine& e, int steps, unsigned seed) {
  const int n = e.nv();
  std::vector<Eigen::VectorXd> trace;
  Eigen::VectorXd q(n), v(n), f(n);
  for (int i = 0; i < steps; ++i) {
    Eigen::VectorXd tau = random_vector(n, seed + i, 20.0);
    tau.head<6>().setZero();
    e.set_generalized_forces(tau);
    e.step();
    e.get_positions(q);
    e.get_velocities(v);
    e.constraint_forces(f);
    trace.insert(trace.end(), {q, v, f});
  }
  return trace;
}

// the first entry where two traces differ in any bit; -1: none
int first_difference(const std::vector<Eigen::VectorXd>& a, const std::vector<Eigen::VectorXd>& b) {
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (a[i] != b[i]) {
      std::cerr << "entry " << i << ": largest difference " << (a[i] - b[i]).cwiseAbs().maxCoeff()
                << "\n";
      return static_cast<int>(i);
    }
  return a.size() == b.size() ? -1 : static_cast<int>(std::min(a.size(), b.size()));
}

// DART's broad phase (FCL's tree) orders contact pairs by its history: a restore must not let
// the steps before it, or another engine's, change a replay's last bits (a planner's rollouts
// then depended on the thread count)
TEST(DartEngine, RestoreReplaysBitExactlyWhateverRanBefore) {
  auto e = load_capsule_character();
  // tumble onto the ground, with several limbs in contact
  torqued_trace(*e, 300, 1);
  ASSERT_GT(e->num_contacts(), 1);
  EngineState saved;
  e->save_state(saved);
  Eigen::VectorXd f_saved(e->nv()), f_restored(e->nv());
  e->constraint_forces(f_saved);
  ASSERT_GT(f_saved.norm(), 0.0);
  const auto continued = torqued_trace(*e, 40, 1000);

  // another history on the same engine, then the saved state again
  torqued_trace(*e, 150, 2000);
  e->restore_state(saved);
  e->forward();
  e->constraint_forces(f_restored);
  EXPECT_EQ(f_restored, f_saved) << "the last step's constraint forces are state";
  const auto replayed = torqued_trace(*e, 40, 1000);

  // and on a fresh engine (a planner's other worker)
  auto fresh = load_capsule_character();
  fresh->restore_state(saved);
  fresh->forward();
  const auto elsewhere = torqued_trace(*fresh, 40, 1000);
  EXPECT_EQ(first_difference(replayed, continued), -1);
  EXPECT_EQ(first_difference(elsewhere, continued), -1);
}

TEST(DartEngine, BipedFallsAndRestsOnGround) {
  auto e = load_fullbody();
  e->forward();
  const double com0 = e->com().y();
  for (int i = 0; i < 300; ++i) e->step();
  EXPECT_TRUE(e->state_is_finite());
  // gravity is -y in this file: the limp biped falls
  EXPECT_LT(e->com().y(), com0 - 0.1);
  for (int i = 0; i < 2700; ++i) e->step();
  // ...and comes to rest on the ground box (top at y = -0.895), not through it
  EXPECT_GT(e->com().y(), -0.895);
  EXPECT_LT(e->com_velocity().norm(), 0.05);
  ASSERT_GT(e->num_contacts(), 0);

  // contacts: ground is body -1, normal from body1 to body2, force on body2.
  // At rest the contact forces on the biped carry its weight.
  Eigen::Vector3d on_biped = Eigen::Vector3d::Zero();
  for (int i = 0; i < e->num_contacts(); ++i) {
    const Contact c = e->contact(i);
    ASSERT_TRUE(c.body1 == -1 || c.body2 == -1) << "no self-collision in this file";
    const Eigen::Vector3d up_into_biped = c.body1 == -1 ? c.normal : Eigen::Vector3d(-c.normal);
    EXPECT_NEAR(up_into_biped.y(), 1.0, 1e-9);
    on_biped += c.body2 == -1 ? Eigen::Vector3d(-c.force) : c.force;
  }
  const double weight = e->total_mass() * 9.81;
  EXPECT_NEAR(on_biped.y(), weight, 0.1 * weight);
  EXPECT_TRUE(e->body_touches_ground(e->require_body("h_heel_left")) ||
              e->body_touches_ground(e->require_body("h_toe_left")));

  // constraint forces balance gravity in generalised coordinates at rest: the root's
  // vertical force equals the biped's weight
  Eigen::VectorXd f(e->nv()), c(e->nv());
  e->constraint_forces(f);
  e->forward();
  e->bias_forces(c);
  EXPECT_GT(f.norm(), 0.0);
  EXPECT_LT((f - c).norm(), 0.1 * c.norm());
}

TEST(DartEngine, ForwardFindsContactGeometryForASetState) {
  auto settled = load_fullbody();
  for (int i = 0; i < 1500; ++i) settled->step();
  EngineState resting;
  settled->save_state(resting);

  // a fresh engine put into the resting state sees the ground contacts after forward()
  auto e = load_fullbody();
  EXPECT_EQ(e->num_contacts(), 0);
  e->restore_state(resting);
  e->forward();
  ASSERT_GT(e->num_contacts(), 0);
  for (int i = 0; i < e->num_contacts(); ++i) EXPECT_EQ(e->contact(i).force.norm(), 0.0);
  const int heel = e->require_body("h_heel_left"), toe = e->require_body("h_toe_left");
  EXPECT_TRUE(e->body_touches_ground(heel) || e->body_touches_ground(toe));
  // a step then reports that step's contacts, with forces
  e->step();
  double total = 0;
  for (int i = 0; i < e->num_contacts(); ++i) total += e->contact(i).force.norm();
  EXPECT_GT(total, 0.0);
}

TEST(DartEngine, MjcfPendulumPeriodMatchesSmallAngleTheory) {
  const double angle0 = 0.05;
  WorldSpec spec;
  spec.models.push_back({write_temp("pendulum.xml", pendulum_mjcf(angle0))});
  auto e = make_dart_engine(spec);
  ASSERT_EQ(e->nv(), 1);
  EXPECT_EQ(e->joint(0).type, JointType::kHinge);
  EXPECT_EQ(e->dof_name(0), "swing");
  EXPECT_DOUBLE_EQ(e->timestep(), 0.0005);
  e->forward();
  // the bob hangs 1 m from the pivot, tilted by angle0
  EXPECT_NEAR(e->com().norm(), 1.0, 1e-9);
  EXPECT_NEAR(std::atan2(-e->com().x(), -e->com().z()), angle0, 1e-9);

  // time between the first and the third downward zero crossing of the angle rate
  const int swing = e->require_dof("swing");
  std::vector<double> crossings;
  double prev = e->dof_velocity(swing);
  while (e->time() < 10.0 && crossings.size() < 3) {
    e->step();
    const double v = e->dof_velocity(swing);
    if (prev > 0 && v <= 0) crossings.push_back(e->time());
    prev = v;
  }
  ASSERT_EQ(crossings.size(), 3u);
  const double period = (crossings[2] - crossings[0]) / 2;
  const double theory = 2 * M_PI * std::sqrt((1.0 + 1e-6) / 9.81);
  EXPECT_NEAR(period, theory, 0.02 * theory);
}

// a 3-link chain on hinges about different axes, with full inertials
constexpr const char* kChainMjcf = R"(<mujoco model="chain">
  <option timestep="0.001" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="link1" pos="0 0 1">
      <joint name="j1" type="hinge" axis="0 1 0"/>
      <inertial pos="0.1 0 -0.2" mass="2" diaginertia="0.03 0.04 0.01"/>
      <body name="link2" pos="0 0 -0.4">
        <joint name="j2" type="hinge" axis="1 0 0"/>
        <inertial pos="0 0.05 -0.15" mass="1.5" fullinertia="0.02 0.025 0.01 0.001 0 0.002"/>
        <body name="link3" pos="0 0 -0.3">
          <joint name="j3" type="hinge" axis="0 1 0"/>
          <inertial pos="0 0 -0.1" mass="0.5" quat="0.9238795 0 0.3826834 0"
                    diaginertia="0.004 0.005 0.001"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
)";

TEST(DartEngine, AgreesWithMujocoOnAnMjcfChain) {
  WorldSpec spec;
  spec.models.push_back({write_temp("chain.xml", kChainMjcf)});
  auto dart = make_dart_engine(spec);
  auto mujoco = make_mujoco_engine(spec);
  ASSERT_EQ(dart->nv(), 3);
  ASSERT_EQ(mujoco->nv(), 3);
  EXPECT_NEAR(dart->total_mass(), mujoco->total_mass(), 1e-12);
  EXPECT_TRUE(dart->gravity().isApprox(mujoco->gravity()));
  EXPECT_DOUBLE_EQ(dart->timestep(), mujoco->timestep());

  // same state, by dof name
  const Eigen::Vector3d q(0.4, -0.7, 1.1), v(0.5, 1.5, -2.0);
  for (Engine* e : {dart.get(), mujoco.get()}) {
    for (int i = 0; i < 3; ++i) {
      const std::string name = "j" + std::to_string(i + 1);
      e->set_dof_position(e->require_dof(name), q[i]);
    }
    Eigen::VectorXd vel(3);
    for (int i = 0; i < 3; ++i) vel[e->require_dof("j" + std::to_string(i + 1))] = v[i];
    e->set_velocities(vel);
    e->forward();
  }
  // express both in j1, j2, j3 order
  auto reorder = [](const Engine& e, const Eigen::MatrixXd& m) {
    Eigen::PermutationMatrix<3> p;
    for (int i = 0; i < 3; ++i) p.indices()[i] = e.require_dof("j" + std::to_string(i + 1));
    return Eigen::MatrixXd(p.transpose() * m * p);
  };
  Eigen::MatrixXd md(3, 3), mm(3, 3);
  dart->mass_matrix(md);
  mujoco->mass_matrix(mm);
  EXPECT_LT((reorder(*dart, md) - reorder(*mujoco, mm)).norm(), 1e-9 * mm.norm())
      << "dart\n"
      << md << "\nmujoco\n"
      << mm;
  Eigen::VectorXd cd(3), cm(3);
  dart->bias_forces(cd);
  mujoco->bias_forces(cm);
  Eigen::Vector3d cd_named, cm_named;
  for (int i = 0; i < 3; ++i) {
    cd_named[i] = cd[dart->require_dof("j" + std::to_string(i + 1))];
    cm_named[i] = cm[mujoco->require_dof("j" + std::to_string(i + 1))];
  }
  EXPECT_LT((cd_named - cm_named).norm(), 1e-9 * cm_named.norm())
      << cd_named.transpose() << " vs " << cm_named.transpose();
  EXPECT_TRUE(dart->com().isApprox(mujoco->com(), 1e-12));
  const int tip_d = dart->require_body("link3"), tip_m = mujoco->require_body("link3");
  EXPECT_TRUE(dart->body_pose(tip_d).pos.isApprox(mujoco->body_pose(tip_m).pos, 1e-12));
  EXPECT_TRUE(dart->body_com(tip_d).isApprox(mujoco->body_com(tip_m), 1e-12));
  EXPECT_TRUE(dart->body_velocity(tip_d).isApprox(mujoco->body_velocity(tip_m), 1e-12));
}

TEST(DartEngine, UrdfGetsFloatingRootAndOffset) {
  const std::string urdf = write_temp("two_link.urdf", R"(<robot name="two_link">
  <link name="base">
    <inertial><mass value="2"/><origin xyz="0 0 0"/>
      <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="arm">
    <inertial><mass value="1"/><origin xyz="0 0 -0.5"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="elbow" type="revolute">
    <parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="2.0" effort="10" velocity="5"/>
  </joint>
</robot>
)");
  WorldSpec spec;
  spec.models.push_back({urdf, Eigen::Vector3d(0, 0, 3)});
  auto e = make_dart_engine(spec);
  EXPECT_EQ(e->nv(), 7);
  EXPECT_EQ(e->nbody(), 2);
  EXPECT_NEAR(e->total_mass(), 3.0, 1e-12);
  const JointInfo& root = e->joint(e->dof_joint(0));
  EXPECT_EQ(root.type, JointType::kFree);
  const JointInfo& elbow = e->joint(e->require_joint("elbow"));
  EXPECT_EQ(elbow.type, JointType::kHinge);
  EXPECT_TRUE(elbow.has_limits);
  EXPECT_DOUBLE_EQ(elbow.lower, -1.5);
  EXPECT_DOUBLE_EQ(elbow.upper, 2.0);
  e->forward();
  EXPECT_TRUE(e->body_pose(e->require_body("base")).pos.isApprox(Eigen::Vector3d(0, 0, 3)));
  // no file gravity in URDF: DART's default
  EXPECT_TRUE(e->gravity().isApprox(Eigen::Vector3d(0, 0, -9.81)));
}

TEST(DartEngine, PerStepInputsAreConsumedOnce) {
  WorldSpec spec;
  spec.models.push_back({write_temp("pendulum_flat.xml", pendulum_mjcf(0.0))});
  spec.gravity = Eigen::Vector3d::Zero();
  auto e = make_dart_engine(spec);
  const double dt = e->timestep();
  const double inertia = 1.0 + 1e-6;  // about the pivot
  Eigen::VectorXd tau(1);
  tau << 2.0;
  e->set_generalized_forces(tau);
  e->step();
  EXPECT_NEAR(e->dof_velocity(0), 2.0 * dt / inertia, 1e-12);
  const double after_torque = e->dof_velocity(0);
  e->step();  // cleared: no further acceleration
  EXPECT_DOUBLE_EQ(e->dof_velocity(0), after_torque);

  // +x force at the bob (0, 0, -1): torque r x f about +y is -1 N m per N
  e->forward();
  e->apply_external_force(0, Eigen::Vector3d(3.0, 0, 0), e->body_com(0));
  e->step();
  EXPECT_NEAR(e->dof_velocity(0) - after_torque, -3.0 * dt / inertia, 1e-9);
  const double after_push = e->dof_velocity(0);
  e->step();
  EXPECT_DOUBLE_EQ(e->dof_velocity(0), after_push);

  // no actuators in DART models
  EXPECT_NO_THROW(e->set_controls(Eigen::VectorXd(0)));
  EXPECT_THROW(e->set_controls(Eigen::VectorXd::Zero(1)), std::invalid_argument);
}

TEST(DartEngine, VelocityCommandServosAndNanReleases) {
  WorldSpec spec;
  spec.models.push_back({write_temp("pendulum_servo.xml", pendulum_mjcf(0.3))});
  auto e = make_dart_engine(spec);
  e->set_dof_velocity_command(0, 1.5);
  for (int i = 0; i < 200; ++i) e->step();
  // held at the commanded rate against gravity
  EXPECT_NEAR(e->dof_velocity(0), 1.5, 1e-9);
  e->set_dof_velocity_command(0, std::nan(""));
  const double v0 = e->dof_velocity(0);
  for (int i = 0; i < 200; ++i) e->step();
  EXPECT_GT(std::abs(e->dof_velocity(0) - v0), 0.05);  // gravity acts again
}

TEST(DartEngine, BadInputsThrowInputErrorNamingTheFile) {
  auto expect_error_naming = [](const std::string& path, const std::string& mention) {
    WorldSpec spec;
    spec.models.push_back({path});
    try {
      make_dart_engine(spec);
      ADD_FAILURE() << "no error for " << path;
    } catch (const InputError& err) {
      EXPECT_NE(std::string(err.what()).find(mention), std::string::npos) << err.what();
    }
  };
  expect_error_naming("/nonexistent/robot.skel", "robot.skel");
  expect_error_naming("dart://sample/skel/no_such_model.skel", "no_such_model.skel");
  expect_error_naming(write_temp("broken.skel", "<skel version=\"1.0\"><world name=\"w\">\n"),
                      "broken.skel");
  // well-formedness errors carry a line: here that of the unclosed <world>
  expect_error_naming(
      write_temp("mismatched.skel", "<skel version=\"1.0\">\n<world name=\"w\">\n</skel>\n"),
      "mismatched.skel:2:");
  expect_error_naming(write_temp("empty.skel", "<skel version=\"1.0\"></skel>\n"), "empty.skel");
  expect_error_naming(write_temp("broken.xml", "<mujoco><worldbody><body>\n"), "broken.xml");
  expect_error_naming(write_temp("model.obj", "v 0 0 0\n"), "model.obj");
  EXPECT_THROW(make_dart_engine(WorldSpec{}), InputError);
}

// the message of the InputError make_dart_engine throws for one model file
std::string dart_load_error(const std::string& path) {
  WorldSpec spec;
  spec.models.push_back({path});
  try {
    make_dart_engine(spec);
  } catch (const InputError& err) {
    return err.what();
  }
  ADD_FAILURE() << "no error for " << path;
  return "";
}

// each of these aborted, crashed or loaded on DART before stance's checks ran first
TEST(DartEngine, ModelsDartWouldCrashOnAreRejectedWithFileAndLine) {
  std::string neg = write_temp("neg.skel", R"(<skel><world>
<skeleton name="s">
<body name="a">
<inertia><mass>-2</mass></inertia>
</body>
<joint type="free" name="j"><parent>world</parent><child>a</child></joint>
</skeleton></world></skel>
)");
  std::string message = dart_load_error(neg);
  EXPECT_NE(message.find("neg.skel:4: <mass> must be positive, found -2"), std::string::npos)
      << message;

  std::string mesh = write_temp("mesh.skel", R"(<skel><world>
<skeleton name="s">
<body name="a">
<visualization_shape><geometry><mesh/></geometry></visualization_shape>
</body>
<joint type="free" name="j"><parent>world</parent><child>a</child></joint>
</skeleton></world></skel>
)");
  message = dart_load_error(mesh);
  EXPECT_NE(message.find("mesh.skel:4: <mesh> is missing <file_name>"), std::string::npos)
      << message;

  // a body no joint makes a child: DART's SkelParser left it half made and crashed (fuzz_model)
  std::string loose = write_temp("loose.skel", R"(<skel><world>
<skeleton name="s">
<body name="a"><inertia><mass>1</mass></inertia></body>
<body name="b"><inertia><mass>1</mass></inertia></body>
<joint type="free" name="j"><parent>world</parent><child>a</child></joint>
</skeleton></world></skel>
)");
  message = dart_load_error(loose);
  EXPECT_NE(message.find("loose.skel:4: body 'b' is no joint's <child> in skeleton 's'"),
            std::string::npos)
      << message;

  // MJCF: MuJoCo's compiler sees it before DART's parser (whose SphereShape asserts)
  std::string sphere = write_temp("sphere.xml", R"(<mujoco>
<worldbody>
<body>
<freejoint/>
<geom type="sphere" size="-1"/>
</body>
</worldbody>
</mujoco>
)");
  message = dart_load_error(sphere);
  EXPECT_NE(message.find("sphere.xml:5: "), std::string::npos) << message;
  EXPECT_NE(message.find("size"), std::string::npos) << message;

  // vectors DART reads with a fixed size (its toVector3d asserts; MuJoCo reads what is there;
  // found by fuzz_model in a CI run)
  for (const auto& [attribute, expected] : std::vector<std::pair<std::string, std::string>>{
           {"axis=\"0 -10 \"", "axes.xml:5: <joint> axis: expected 3 numbers, got '0 -10 '"},
           // these two MuJoCo's compiler rejects first, at the same line
           {"axis=\"0 1 z\"", "axes.xml:5: XML Error: problem reading attribute 'axis'"},
           {"pos=\"0 0 0 1\"", "axes.xml:5: XML Error: attribute 'pos' has too much data"}}) {
    std::string axes = write_temp("axes.xml",
                                  "<mujoco>\n<worldbody>\n<body name=\"b\">\n"
                                  "<geom type=\"sphere\" size=\"0.1\"/>\n"
                                  "<joint name=\"j\" type=\"hinge\" " +
                                      attribute +
                                      "/>\n</body>\n</worldbody>\n"
                                      "</mujoco>\n");
    message = dart_load_error(axes);
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }

  // an rgba of three numbers and a line break, which MuJoCo reads and DART's toVector4d asserts
  // on (found by fuzz_model)
  std::string colour = write_temp("colour.xml",
                                  "<mujoco>\n<worldbody>\n<body name=\"b\">\n"
                                  "<joint name=\"j\" type=\"hinge\"/>\n"
                                  "<geom type=\"sphere\" size=\"0.1\" rgba=\"0.3 0.3 0.6 \n\"/>\n"
                                  "</body>\n</worldbody>\n</mujoco>\n");
  message = dart_load_error(colour);
  EXPECT_NE(message.find("colour.xml:5: <geom> rgba: expected 4 numbers"), std::string::npos)
      << message;

  // a body welded to its parent body (no joint): DART's reader dereferenced a null joint
  // (found by fuzz_model; MuJoCo's humanoid.xml has such a head)
  std::string welded = write_temp("welded.xml", R"(<mujoco>
<worldbody>
<body name="upper"><joint name="j" type="hinge"/><geom type="sphere" size="0.1"/>
<body name="fore" pos="0.4 0 0">
<geom type="sphere" size="0.1"/>
</body>
</body>
</worldbody>
</mujoco>
)");
  message = dart_load_error(welded);
  EXPECT_NE(message.find("welded.xml:4: <body name=\"fore\"> has no joint"), std::string::npos)
      << message;
}

// what MuJoCo's sample models use and DART 6.12's MJCF reader crashed on: unnamed joints (they
// get MuJoCo's names, so dofs match across engines), sites (left out on DART) and infinite
// planes (bounded on DART)
TEST(DartEngine, UnnamedJointsSitesAndInfinitePlanesLoad) {
  std::string file = write_temp("sample_like.xml", R"(<mujoco>
<worldbody>
<geom type="plane" size="0 0 0.1"/>
<site name="marker" pos="0 0 1"/>
<body name="a" pos="0 0 1"><freejoint/><geom type="sphere" size="0.1"/>
<site pos="0 0 0.1"/>
<body name="b" pos="0 0 -0.3"><joint type="hinge" axis="0 1 0"/>
<geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.05"/>
<body name="c" pos="0 0 -0.3"><joint name="elbow" type="hinge"/><geom type="sphere" size="0.05"/>
</body></body>
</body>
</worldbody>
</mujoco>
)");
  WorldSpec spec;
  spec.models.push_back({file});
  std::unique_ptr<Engine> dart = make_dart_engine(spec);
  std::unique_ptr<Engine> mujoco = make_engine("mujoco", spec);
  ASSERT_EQ(dart->nv(), mujoco->nv());
  // the same names (a free joint's six come in each engine's order: rotations first on DART)
  std::vector<std::string> dart_names = dart->dof_names(), mujoco_names = mujoco->dof_names();
  std::sort(dart_names.begin(), dart_names.end());
  std::sort(mujoco_names.begin(), mujoco_names.end());
  EXPECT_EQ(dart_names, mujoco_names);
  EXPECT_EQ(dart->dof_index("joint1"), mujoco->dof_index("joint1"));
  EXPECT_NEAR(dart->total_mass(), mujoco->total_mass(), 1e-9);
  // the plane holds the ball up on both engines
  for (int k = 0; k < 500; ++k) dart->step();
  EXPECT_GT(dart->body_pose(dart->body_index("a")).pos.z(), 0.05);
}

// a robot laid out as public model collections lay it out (tests/models/pitch_ankle_robot*.xml,
// our own numbers): a scene file that <include>s the robot, capsule feet and limbs (FCL) and a
// pelvis with no geom. DART 6.12 skipped the <include> (an empty world) and, in the next
// collide after the broad phase was rebuilt, crashed on the robot's stale collision records
TEST(DartEngine, PitchAnkleRobotSceneLoadsAsOnMujocoAndSteps) {
  WorldSpec spec;
  spec.models.push_back({test::source_dir() + "/tests/models/pitch_ankle_robot_scene.xml"});
  std::unique_ptr<Engine> dart = make_dart_engine(spec);
  std::unique_ptr<Engine> mujoco = make_engine("mujoco", spec);
  ASSERT_EQ(dart->nv(), mujoco->nv());
  EXPECT_EQ(dart->nbody(), mujoco->nbody());
  EXPECT_NEAR(dart->total_mass(), mujoco->total_mass(), 1e-9);
  std::vector<std::string> dart_names = dart->dof_names(), mujoco_names = mujoco->dof_names();
  std::sort(dart_names.begin(), dart_names.end());
  std::sort(mujoco_names.begin(), mujoco_names.end());
  EXPECT_EQ(dart_names, mujoco_names);
  // steps, a save and a restore, each rebuilding the broad phase, and the contact query (short:
  // DART's LCP on capsule soles costs about 60 ms a step once they touch)
  const int sole = dart->body_index("left_sole_link");
  ASSERT_GE(sole, 0);
  const double sole_z = dart->body_pose(sole).pos.z();
  EngineState saved;
  dart->forward();
  for (int k = 0; k < 10; ++k) dart->step();
  dart->save_state(saved);
  for (int k = 0; k < 10; ++k) dart->step();
  dart->restore_state(saved);
  dart->forward();
  for (int k = 0; k < 10; ++k) dart->step();
  EXPECT_NEAR(dart->body_pose(sole).pos.z(), sole_z, 0.01);  // the soles land on the floor
  EXPECT_TRUE(dart->state_is_finite());
}

// a mesh asset without a name is named after its file by MuJoCo; DART 6.12 asserted on the geom
// that uses it by that name. It loads on DART with the same bodies
TEST(DartEngine, UnnamedMeshAssetsLoadByTheirFileName) {
  const std::string dir =
      std::filesystem::path(write_temp("shell.obj",
                                       "v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nv 0 0 0.05\n"
                                       "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"))
          .parent_path()
          .string();
  WorldSpec spec;
  spec.models.push_back({write_temp("meshed.xml", fmt::format(R"(<mujoco>
<compiler meshdir="{}"/>
<asset><mesh file="dart_shell.obj"/></asset>
<worldbody><geom type="plane" size="1 1 0.1"/>
<body name="a" pos="0 0 1"><freejoint/><inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
<geom type="sphere" size="0.1"/><geom type="mesh" mesh="dart_shell" contype="0" conaffinity="0" mass="0"/></body>
</worldbody></mujoco>
)",
                                                              dir))});
  std::unique_ptr<Engine> dart = make_dart_engine(spec);
  std::unique_ptr<Engine> mujoco = make_engine("mujoco", spec);
  EXPECT_EQ(dart->nbody(), mujoco->nbody());
  EXPECT_NEAR(dart->total_mass(), mujoco->total_mass(), 1e-9);
}

// a carriage return between the numbers of a capsule's fromto: MuJoCo reads it as a separator,
// DART 6.12's parser read a zero length and its CapsuleShape asserted (found by fuzz_model); the
// DART path now reads it as the spaced file
TEST(DartEngine, WhitespaceInsideAttributesReadsAsSpaces) {
  auto arm = [](const std::string& name, const std::string& separator) {
    WorldSpec spec;
    spec.models.push_back(
        {write_temp(name,
                    "<mujoco><worldbody><body name=\"b\"><joint name=\"j\" type=\"hinge\"/>"
                    "<geom type=\"capsule\" fromto=\"0 0 0" +
                        separator +
                        "0.15 0 0\" size=\"0.03\" mass=\"0.5\"/></body></worldbody>"
                        "</mujoco>\n"),
         {}});
    return make_dart_engine(spec);
  };
  auto spaced = arm("spaced.xml", " ");
  auto returned = arm("returned.xml", "\t\r");
  ASSERT_EQ(returned->nv(), 1);
  EXPECT_EQ(returned->total_mass(), spaced->total_mass());
  spaced->forward();
  returned->forward();
  // the same capsule: 0.15 m long, not zero
  EXPECT_EQ(returned->body_com(0), spaced->body_com(0));
  EXPECT_EQ(returned->body_pose(0).pos, spaced->body_pose(0).pos);
}

// a form feed or a vertical tab between numbers, in any format that reaches DART: stance's checks
// and MuJoCo read them as the separators they are; DART 6.12's parsers split on spaces only and
// asserted in toVector3d / toIsometry3d (fuzz_model found the SDF axis after 409,978 executions).
// Each file now loads on DART as its spaced twin does.
TEST(DartEngine, EveryWhitespaceBetweenNumbersReadsAsASpaceInEveryFormat) {
  struct Case {
    const char* name;
    std::string text;  // with @ where the separator goes
  };
  const std::vector<Case> cases = {
      {"ws.skel",
       "<skel version=\"1.0\"><world name=\"w\"><physics><time_step>0.001</time_step>"
       "<gravity>0 -9.81 0</gravity></physics><skeleton name=\"s\"><body name=\"b\">"
       "<transformation>0 0.5 0@0 0 0</transformation><inertia><mass>2</mass>"
       "<offset>0 0 0</offset></inertia><collision_shape><geometry><box><size>0.1 0.1 0.1</size>"
       "</box></geometry></collision_shape></body><joint type=\"free\" name=\"j\">"
       "<parent>world</parent><child>b</child></joint></skeleton></world></skel>\n"},
      {"ws.xml",
       "<mujoco><worldbody><body name=\"b\" pos=\"0 0@1\"><freejoint/>"
       "<geom type=\"sphere\" size=\"0.1\" mass=\"2\"/></body></worldbody></mujoco>\n"},
      {"ws.sdf",
       "<sdf version=\"1.4\"><model name=\"m\"><link name=\"a\"><inertial><mass>2</mass>"
       "<inertia><ixx>0.1</ixx><ixy>0</ixy><ixz>0</ixz><iyy>0.1</iyy><iyz>0</iyz><izz>0.1</izz>"
       "</inertia></inertial><collision name=\"c\"><geometry><box><size>0.2 0.2 0.2</size>"
       "</box></geometry></collision></link><link name=\"b\"><pose>0 0 -0.5 0 0 0</pose>"
       "<collision name=\"c\"><geometry><sphere><radius>0.1</radius></sphere></geometry>"
       "</collision></link><joint name=\"j\" type=\"revolute\"><parent>a</parent>"
       "<child>b</child><pose>0 0 0.25 0 0 0</pose><axis><xyz>0 1@0</xyz></axis></joint>"
       "</model></sdf>\n"}};
  for (const Case& c : cases)
    for (const char* separator : {"\f", "\v", "\t\r\n"}) {
      auto load = [&](const std::string& sep) {
        std::string text = c.text;
        text.replace(text.find('@'), 1, sep);
        WorldSpec spec;
        spec.models.push_back({write_temp(c.name, text)});
        return make_dart_engine(spec);
      };
      SCOPED_TRACE(std::string(c.name) + " with separator code " +
                   std::to_string(static_cast<int>(separator[0])));
      std::unique_ptr<Engine> spaced = load(" ");
      std::unique_ptr<Engine> odd;
      ASSERT_NO_THROW(odd = load(separator));
      ASSERT_EQ(odd->nv(), spaced->nv());
      EXPECT_EQ(odd->total_mass(), spaced->total_mass());
      spaced->forward();
      odd->forward();
      for (int b = 0; b < spaced->nbody(); ++b)
        EXPECT_EQ(odd->body_pose(b).pos, spaced->body_pose(b).pos) << spaced->body_name(b);
    }
}

// a body far from the origin is finite but overflows FCL's broadphase, which segfaulted on the
// first collision (found by fuzz_model: a body at 1.3e217 m in an MJCF file): refused with the
// file and line; 1 km out still loads
TEST(DartEngine, MjcfNumbersBeyondAMillionAreRefusedWithTheLine) {
  auto far = [](const std::string& y) {
    return write_temp("far.xml",
                      "<mujoco>\n<worldbody>\n<body name=\"b\"><freejoint/>"
                      "<geom type=\"sphere\" size=\"0.1\"/>\n<body name=\"leg\" pos=\"0 " +
                          y +
                          " 0\"><joint name=\"j\" type=\"hinge\"/>"
                          "<geom type=\"capsule\" fromto=\"0 0 0 0 0 -0.4\" size=\"0.05\"/>"
                          "</body></body>\n</worldbody>\n</mujoco>\n");
  };
  const std::string message = dart_load_error(far("-1.3e217"));
  EXPECT_NE(message.find("far.xml:4: <body> pos: -1.3e217 is out of range"), std::string::npos)
      << message;
  WorldSpec spec;
  spec.models.push_back({far("1000")});
  std::unique_ptr<Engine> near;
  ASSERT_NO_THROW(near = make_dart_engine(spec));
  near->forward();
  EXPECT_NEAR(near->body_pose(near->require_body("leg")).pos.y(), 1000, 1e-9);
}

// the same bound in SKEL, URDF and SDF, whose readers run before DART's: a link 1.3e217 m away
// is refused with its file and line, one 1 km away loads where it is
TEST(DartEngine, SkelUrdfAndSdfLengthsBeyondAMillionAreRefusedWithTheLine) {
  struct Case {
    const char* name;
    std::string text;  // '@' is the far link's distance along y
    int line;          // of the far number
  };
  const std::vector<Case> cases = {
      {"far.skel",
       "<skel version=\"1.0\"><world name=\"w\"><skeleton name=\"s\">\n"
       "<body name=\"a\"><inertia><mass>2</mass></inertia></body>\n"
       "<body name=\"b\">\n<transformation>0 @ 0 0 0 0</transformation>\n"
       "<inertia><mass>1</mass></inertia></body>\n"
       "<joint type=\"free\" name=\"root\"><parent>world</parent><child>a</child></joint>\n"
       "<joint type=\"revolute\" name=\"j\"><parent>a</parent><child>b</child>"
       "<axis><xyz>1 0 0</xyz></axis></joint>\n</skeleton></world></skel>\n",
       4},
      {"far.urdf",
       "<robot name=\"r\">\n<link name=\"a\"><inertial><mass value=\"2\"/>"
       "<inertia ixx=\"0.1\" iyy=\"0.1\" izz=\"0.1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>"
       "</inertial></link>\n<link name=\"b\"><inertial><mass value=\"1\"/>"
       "<inertia ixx=\"0.1\" iyy=\"0.1\" izz=\"0.1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/>"
       "</inertial></link>\n<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/>"
       "<child link=\"b\"/>\n<origin xyz=\"0 @ 0\"/><axis xyz=\"1 0 0\"/>"
       "<limit lower=\"-1\" upper=\"1\" effort=\"10\" velocity=\"5\"/></joint>\n"
       "</robot>\n",
       5},
      {"far.sdf",
       "<sdf version=\"1.4\"><model name=\"m\">\n<link name=\"a\"><inertial><mass>2</mass>"
       "</inertial></link>\n<link name=\"b\">\n<pose>0 @ 0 0 0 0</pose></link>\n"
       "<joint name=\"j\" type=\"revolute\"><parent>a</parent><child>b</child>"
       "<axis><xyz>1 0 0</xyz></axis></joint>\n</model></sdf>\n",
       4}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    auto with = [&](const std::string& y) {
      std::string text = c.text;
      text.replace(text.find('@'), 1, y);
      return write_temp(c.name, text);
    };
    const std::string message = dart_load_error(with("-1.3e217"));
    EXPECT_NE(message.find(std::string(c.name) + ":" + std::to_string(c.line) + ":"),
              std::string::npos)
        << message;
    EXPECT_NE(message.find("is out of range (lengths are at most 1000000 m)"), std::string::npos)
        << message;
    WorldSpec spec;
    spec.models.push_back({with("1000")});
    std::unique_ptr<Engine> near;
    ASSERT_NO_THROW(near = make_dart_engine(spec));
    near->forward();
    EXPECT_NEAR(near->body_pose(near->require_body("b")).pos.y(), 1000, 1e-9);
  }
}

// dart-doc's soft-body and mesh worlds load as they did before the checks
TEST(DartEngine, DartDocSoftBodyMeshAndShapeWorldsLoad) {
  if (!std::filesystem::exists("/usr/share/doc/dart/data/skel/softBodies.skel"))
    GTEST_SKIP() << "dart-doc not installed";
  for (const char* file :
       {"softBodies.skel", "soft_cubes.skel", "mesh_collision.skel", "shapes.skel"}) {
    WorldSpec spec;
    spec.models.push_back({std::string("dart://sample/skel/") + file});
    std::unique_ptr<Engine> e;
    EXPECT_NO_THROW(e = make_dart_engine(spec)) << file;
    if (!e) continue;
    EXPECT_GT(e->nv(), 0) << file;
    // DART 6.12 asserts inside its own solver when soft contact blows up, or when FCL's mesh
    // contact yields a NaN normal (both seen on CI's CPU): only the world of boxes
    // (mesh_collision.skel, despite its name; shapes.skel holds the meshes) is stepped here,
    // on DART's own detector. The README records the limit.
    if (std::string(file) != "mesh_collision.skel") continue;
    e->step();
    Eigen::VectorXd q(e->nq());
    e->get_positions(q);
    EXPECT_TRUE(q.allFinite()) << file;
  }
}

}  // namespace
}  // namespace stance
