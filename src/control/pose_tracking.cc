#include "control/pose_tracking.h"

#include <algorithm>

#include "engine/engine.h"

namespace stance {

void PoseTrackingWork::resize(int nq, int nv) {
  q_pred.setZero(nq);
  for (Eigen::VectorXd* x : {&err, &p, &d, &c, &f, &rhs, &shift}) x->setZero(nv);
  m.setZero(nv, nv);
}

void add_deadbeat_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                          const Eigen::VectorXd& q_ref, PoseTrackingWork& w, Eigen::VectorXd& tau) {
  const double dt = engine.timestep();
  engine.mass_matrix(w.m);
  engine.bias_forces(w.c);
  engine.difference_positions(q, q_ref, w.err);
  w.rhs = (w.err / dt - v) / dt;
  tau.noalias() += w.m * w.rhs;
  tau += w.c;
}

void add_stable_pd_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                           const Eigen::VectorXd& q_ref, const Eigen::VectorXd& v_ref,
                           const Eigen::VectorXd& kp, const Eigen::VectorXd& kd, double max_torque,
                           int skip_begin, int skip_end, PoseTrackingWork& w,
                           Eigen::VectorXd& tau) {
  const double dt = engine.timestep();
  engine.bias_forces(w.c);
  engine.constraint_forces(w.f);
  engine.integrate_positions(q, v, dt, w.q_pred);
  engine.difference_positions(q_ref, w.q_pred, w.err);
  w.p = -kp.cwiseProduct(w.err);
  w.d = -kd.cwiseProduct(v - v_ref);
  // (M + Kd dt)^-1 by the engine: MuJoCo's sparse tree factor, DART's articulated-body pass
  w.shift = kd * dt;
  w.rhs = w.p + w.d - w.c + w.f + tau;
  engine.solve_mass_shifted(w.shift, w.rhs);
  Eigen::VectorXd& spd = w.err;  // reuse: the SPD torque
  spd = w.p + w.d - (kd * dt).cwiseProduct(w.rhs);
  if (max_torque > 0)
    for (int i = 0; i < spd.size(); ++i)
      if (i < skip_begin || i >= skip_end) spd[i] = std::clamp(spd[i], -max_torque, max_torque);
  tau += spd;
}

}  // namespace stance
