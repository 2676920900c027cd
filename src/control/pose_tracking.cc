#include "control/pose_tracking.h"

#include <algorithm>

#include "engine/engine.h"

namespace stance {

void StablePdWork::resize(int nv) {
  for (Eigen::VectorXd* x : {&p, &d, &c, &f, &rhs, &shift}) x->setZero(nv);
}

void stable_pd_torque(const Engine& engine, const Eigen::VectorXd& kp, const Eigen::VectorXd& kd,
                      const Eigen::VectorXd& err, const Eigen::VectorXd& v_err,
                      const Eigen::VectorXd* tau_other, bool constraint_forces, StablePdWork& w,
                      Eigen::VectorXd& spd) {
  const double dt = engine.timestep();
  w.p.noalias() = -kp.cwiseProduct(err);
  w.d.noalias() = -kd.cwiseProduct(v_err);
  engine.bias_forces(w.c);
  w.rhs = w.p + w.d - w.c;
  if (constraint_forces) {
    engine.constraint_forces(w.f);
    w.rhs += w.f;
  }
  if (tau_other) w.rhs += *tau_other;
  w.shift = kd * dt;
  engine.solve_mass_shifted(w.shift, w.rhs);  // rhs now holds the next velocity's change rate
  spd = w.p + w.d;
  spd.noalias() -= w.shift.cwiseProduct(w.rhs);
}

void PoseTrackingWork::resize(int nq, int nv) {
  q_pred.setZero(nq);
  for (Eigen::VectorXd* x : {&err, &v_err, &spd}) x->setZero(nv);
  solve.resize(nv);
  m.setZero(nv, nv);
}

void add_deadbeat_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                          const Eigen::VectorXd& q_ref, PoseTrackingWork& w, Eigen::VectorXd& tau) {
  const double dt = engine.timestep();
  engine.mass_matrix(w.m);
  engine.bias_forces(w.solve.c);
  engine.difference_positions(q, q_ref, w.err);
  w.v_err = (w.err / dt - v) / dt;
  tau.noalias() += w.m * w.v_err;
  tau += w.solve.c;
}

void add_stable_pd_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                           const Eigen::VectorXd& q_ref, const Eigen::VectorXd& v_ref,
                           const Eigen::VectorXd& kp, const Eigen::VectorXd& kd, double max_torque,
                           int skip_begin, int skip_end, PoseTrackingWork& w,
                           Eigen::VectorXd& tau) {
  engine.integrate_positions(q, v, engine.timestep(), w.q_pred);
  engine.difference_positions(q_ref, w.q_pred, w.err);
  w.v_err = v - v_ref;
  stable_pd_torque(engine, kp, kd, w.err, w.v_err, &tau, true, w.solve, w.spd);
  if (max_torque > 0)
    for (int i = 0; i < w.spd.size(); ++i)
      if (i < skip_begin || i >= skip_end) w.spd[i] = std::clamp(w.spd[i], -max_torque, max_torque);
  tau += w.spd;
}

}  // namespace stance
