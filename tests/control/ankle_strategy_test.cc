// Ankle strategy: the offset against a hand computation, the band rules and their torques on
// fullbody1's heel and toe dofs, and parameter checks.
#include "control/ankle_strategy.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> standing_biped() {
  LoadedScenario s = load_scenario(test::scenario_path("biped_stand.yaml"));
  auto e = make_scenario_engine(s.scenario, "mujoco");
  // some velocity so the derivative term is not zero
  Eigen::VectorXd v = Eigen::VectorXd::Zero(e->nv());
  v[e->require_dof("j_shin_left")] = 0.3;
  v[e->require_dof("j_thigh_left_z")] = -0.2;
  e->set_velocities(v);
  e->forward();
  return e;
}

ControlOutput run_once(const AnkleStrategyParams& p, const Engine& e, AnkleStrategy::State& s) {
  AnkleStrategy a(p, {}, e);
  AnkleStrategy::Model m;
  m.params = p;
  m.heel_body = e.require_body(p.heel_body);
  for (const auto& n : p.heel_dofs) m.heel_dofs.push_back(e.require_dof(n));
  for (const auto& n : p.toe_dofs) m.toe_dofs.push_back(e.require_dof(n));
  m.axis = p.forward_axis.normalized();
  ControlOutput out;
  out.resize(e.nv(), e.nu());
  AnkleStrategy::compute(m, s, e, out);
  return out;
}

TEST(AnkleStrategy, OffsetIsComMinusTheHeelPoint) {
  auto e = standing_biped();
  AnkleStrategyParams p;
  AnkleStrategy::Model m;
  m.params = p;
  m.heel_body = e->require_body("h_heel_left");
  m.axis = Eigen::Vector3d::UnitX();
  double offset = 0, rate = 0, heel = 0;
  AnkleStrategy::measure(m, *e, offset, rate, heel);
  BodyPose pose = e->body_pose(m.heel_body);
  Eigen::Vector3d point = pose.pos + pose.quat * Eigen::Vector3d(0.05, 0, 0);
  EXPECT_NEAR(heel, point.x(), 1e-12);
  EXPECT_NEAR(offset, e->com().x() - point.x(), 1e-12);
  // the rate against a finite difference of the offset
  const double h = 1e-6;
  Eigen::VectorXd q(e->nq()), v(e->nv()), q2(e->nq());
  e->get_positions(q);
  e->get_velocities(v);
  e->integrate_positions(q, v, h, q2);
  e->set_positions(q2);
  e->forward();
  double offset2 = 0, rate2 = 0, heel2 = 0;
  AnkleStrategy::measure(m, *e, offset2, rate2, heel2);
  EXPECT_NEAR(rate, (offset2 - offset) / h, 1e-4 * (1 + std::abs(rate)));
  EXPECT_GT(std::abs(rate), 1e-3);
}

TEST(AnkleStrategy, BandsSetTheHeelAndToeTorques) {
  auto e = standing_biped();
  AnkleStrategyParams p;
  AnkleStrategy::State s0;
  run_once(p, *e, s0);
  // a forward band around the current offset, the backward band away from it
  p.forward = {s0.offset - 0.01, s0.offset + 0.01, 200, 100, 10};
  p.backward = {s0.offset - 0.3, s0.offset - 0.2, 2000, 100, 100};
  AnkleStrategy::State s;
  ControlOutput out = run_once(p, *e, s);
  EXPECT_EQ(s.band, 1);
  const double heel = -p.forward.k1 * s.offset - p.forward.kd * s.rate;
  const double toe = -p.forward.k2 * s.offset - p.forward.kd * s.rate;
  for (const auto& n : p.heel_dofs) EXPECT_NEAR(out.tau[e->require_dof(n)], heel, 1e-12);
  for (const auto& n : p.toe_dofs) EXPECT_NEAR(out.tau[e->require_dof(n)], toe, 1e-12);
  EXPECT_NE(heel, 0);
  EXPECT_NEAR(out.tau.cwiseAbs().sum(), 2 * std::abs(heel) + 2 * std::abs(toe), 1e-9);

  // the same offset inside a backward band (the heel point moved forward) uses its gains
  AnkleStrategyParams back = p;
  back.forward = {0.5, 0.6, 1, 1, 1};
  back.backward = {s.offset - 0.01, s.offset + 0.01, 2000, 100, 100};
  AnkleStrategy::State s2;
  out = run_once(back, *e, s2);
  EXPECT_EQ(s2.band, -1);
  EXPECT_NEAR(out.tau[e->require_dof("j_heel_right_1")], -2000 * s2.offset - 100 * s2.rate, 1e-9);

  // outside both bands, or disabled: nothing
  AnkleStrategyParams none = p;
  none.forward = {0.5, 0.6, 1, 1, 1};
  AnkleStrategy::State s3;
  EXPECT_EQ(run_once(none, *e, s3).tau.norm(), 0);
  EXPECT_EQ(s3.band, 0);
  AnkleStrategyParams off = p;
  off.enabled = false;
  AnkleStrategy::State s4;
  EXPECT_EQ(run_once(off, *e, s4).tau.norm(), 0);
  EXPECT_EQ(s4.band, 1);  // still measured and logged
}

TEST(AnkleStrategy, CaptureTermTorquesTheHeelsOnTheCapturePoint) {
  auto e = standing_biped();
  AnkleStrategyParams p;
  p.forward = {0.5, 0.6, 1, 1, 1};  // both seed bands out of the way
  p.backward = {-0.6, -0.5, 1, 1, 1};
  AnkleStrategy::State s0;
  EXPECT_EQ(run_once(p, *e, s0).tau.norm(), 0);  // gain 0: the seed, nothing

  // the capture point by hand: offset + rate / sqrt(g / h), h the COM's height over the point
  p.capture = {300, 0.0, 0.2, 1000};
  AnkleStrategy::State s;
  run_once(p, *e, s);
  BodyPose heel = e->body_pose(e->require_body("h_heel_left"));
  Eigen::Vector3d point = heel.pos + heel.quat * Eigen::Vector3d(0.05, 0, 0);
  const double h = e->com().y() - point.y();
  EXPECT_NEAR(s.capture_point, s.offset + s.rate / std::sqrt(e->gravity().norm() / h), 1e-12);

  // a band just ahead of it: the heels get gain * distance, the toes nothing
  p.capture.lower = s.capture_point + 0.01;
  p.capture.upper = s.capture_point + 0.5;
  AnkleStrategy::State s2;
  ControlOutput out = run_once(p, *e, s2);
  for (const auto& n : p.heel_dofs) EXPECT_NEAR(out.tau[e->require_dof(n)], 300 * 0.01, 1e-9);
  for (const auto& n : p.toe_dofs) EXPECT_EQ(out.tau[e->require_dof(n)], 0);
  // clamped, and with the opposite sign ahead of the band
  EXPECT_EQ(AnkleStrategy::capture_torque({300, -0.01, 0.2, 8}, -0.5), 8);
  EXPECT_EQ(AnkleStrategy::capture_torque({300, -0.01, 0.2, 8}, 0.1), 0);
  EXPECT_NEAR(AnkleStrategy::capture_torque({300, -0.01, 0.2, 8}, 0.21), -3, 1e-12);
  // disabled: nothing, though still measured
  p.enabled = false;
  AnkleStrategy::State s3;
  EXPECT_EQ(run_once(p, *e, s3).tau.norm(), 0);
  EXPECT_NE(s3.capture_point, 0);
}

TEST(AnkleStrategy, TipLeverClampsAndRampScalesTheBandTorques) {
  auto e = standing_biped();
  AnkleStrategyParams p;
  AnkleStrategy::State s0;
  run_once(p, *e, s0);
  p.forward = {s0.offset - 0.01, s0.offset + 0.01, 2000, 1000, 100};
  AnkleStrategy::State s;
  ControlOutput free = run_once(p, *e, s);
  const int heel = e->require_dof("j_heel_left_1"), toe = e->require_dof("j_toe_right");

  // clamp: each foot carries half the weight, the limit is that weight times the lever
  AnkleStrategyParams clamped = p;
  clamped.forward.tip_lever = 0.002;
  clamped.supported_mass = 40;
  AnkleStrategy clamp_ctrl(clamped, {}, *e);
  AnkleStrategy::Model m;
  m.params = clamped;
  m.heel_body = e->require_body(clamped.heel_body);
  for (const auto& n : clamped.heel_dofs) m.heel_dofs.push_back(e->require_dof(n));
  for (const auto& n : clamped.toe_dofs) m.toe_dofs.push_back(e->require_dof(n));
  m.axis = Eigen::Vector3d::UnitX();
  m.foot_weight = 40 * e->gravity().norm() / 2;
  ControlOutput out;
  out.resize(e->nv(), e->nu());
  AnkleStrategy::State sc;
  AnkleStrategy::compute(m, sc, *e, out);
  const double limit = 40 * e->gravity().norm() / 2 * 0.002;
  ASSERT_GT(std::abs(free.tau[heel]), limit);
  EXPECT_NEAR(std::abs(out.tau[heel]), limit, 1e-12);
  EXPECT_EQ(std::signbit(out.tau[heel]), std::signbit(free.tau[heel]));
  EXPECT_LE(std::abs(out.tau[toe]), limit + 1e-12);

  // ramp: 1 cm into a band ramped over 4 cm gives a quarter of the torque
  AnkleStrategyParams ramped = p;
  ramped.forward.lower = s.offset - 0.01;
  ramped.forward.upper = s.offset + 0.5;
  ramped.forward.ramp = 0.04;
  AnkleStrategy::State sr;
  ControlOutput r = run_once(ramped, *e, sr);
  EXPECT_NEAR(r.tau[heel], 0.25 * free.tau[heel], 1e-9 * std::abs(free.tau[heel]));
  EXPECT_NEAR(r.tau[toe], 0.25 * free.tau[toe], 1e-9 * std::abs(free.tau[toe]));
}

TEST(AnkleStrategy, PerStepDerivativeIsTheOffsetChange) {
  auto e = standing_biped();
  AnkleStrategyParams p;
  p.derivative = "per_step";
  AnkleStrategy a(p, {}, *e);
  auto state = a.make_state(*e);
  ControlOutput out;
  out.resize(e->nv(), e->nu());
  a.compute(*state, *e, out);
  std::vector<double> first;
  a.signals(*state, first);
  EXPECT_EQ(first[1], 0.0);  // no previous offset yet
  e->step();
  e->forward();
  out.clear();
  a.compute(*state, *e, out);
  std::vector<double> second;
  a.signals(*state, second);
  EXPECT_NEAR(second[1], second[0] - first[0], 1e-15);
}

TEST(AnkleStrategy, RejectsBadParameters) {
  auto e = standing_biped();
  AnkleStrategyParams p;
  p.forward_axis = Eigen::Vector3d::Zero();
  EXPECT_THROW(AnkleStrategy(p, {}, *e), InputError);
  p = {};
  p.backward.lower = 0;
  p.backward.upper = -0.1;
  EXPECT_THROW(AnkleStrategy(p, {}, *e), InputError);
  p = {};
  p.derivative = "sometimes";
  EXPECT_THROW(AnkleStrategy(p, {}, *e), InputError);
  p = {};
  p.capture.lower = 0.3;
  EXPECT_THROW(AnkleStrategy(p, {}, *e), InputError);
  p = {};
  p.heel_dofs = {"j_heel_middle"};
  EXPECT_ANY_THROW(AnkleStrategy(p, {}, *e));
}

}  // namespace
}  // namespace stance
