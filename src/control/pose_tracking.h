// The torque laws of tracking: stable PD (Tan et al. 2011), the one SPD solve shared by the
// `stable_pd` controller and the motion-capture tracker, by the engine's shifted mass solve (no
// dense mass matrix); and deadbeat inverse dynamics for the tracker's kinematic root mode. Work
// vectors are sized once; the calls allocate nothing.
#pragma once

#include <Eigen/Core>

namespace stance {

class Engine;

// the SPD solve's work, dim nv
struct StablePdWork {
  Eigen::VectorXd p, d, c, f, rhs, shift;
  void resize(int nv);
};

// the stable PD torque for a predicted position error err = (q + v dt) (-) q_ref and a velocity
// error v_err = v - v_ref (dim nv each), with the other torques of the same step tau_other
// (null: none; they enter the solve for the next velocity):
//   p = -Kp err,  d = -Kd v_err,
//   (M + Kd dt) a = p + d - c + f + tau_other,  spd = p + d - Kd dt a
// with c the bias forces and f the last step's constraint forces (when constraint_forces).
// (M + Kd dt)^-1 is the engine's: MuJoCo's sparse tree factor, DART's articulated-body pass.
// Writes spd (dim nv); spd may not alias err or v_err.
void stable_pd_torque(const Engine& engine, const Eigen::VectorXd& kp, const Eigen::VectorXd& kd,
                      const Eigen::VectorXd& err, const Eigen::VectorXd& v_err,
                      const Eigen::VectorXd* tau_other, bool constraint_forces, StablePdWork& w,
                      Eigen::VectorXd& spd);

struct PoseTrackingWork {
  Eigen::VectorXd q_pred, err, v_err, spd;
  StablePdWork solve;
  Eigen::MatrixXd m;  // the deadbeat law's mass matrix
  void resize(int nq, int nv);
};

// tau += the torques that bring q to q_ref in one step (root included):
//   tau = M ((q_ref (-) q) / dt - v) / dt + c
// Contact forces are not fed back: from the last step they alternate with the new ones.
void add_deadbeat_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                          const Eigen::VectorXd& q_ref, PoseTrackingWork& w, Eigen::VectorXd& tau);

// tau += stable PD towards (q_ref, v_ref) with per-dof gains kp, kd (dim nv), given the
// torques already in tau (stable_pd_torque with err = (q + v dt) (-) q_ref, v_err = v - v_ref,
// tau_other = tau and the constraint forces). max_torque > 0 clamps every dof outside
// [skip_begin, skip_end) (the free root).
void add_stable_pd_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                           const Eigen::VectorXd& q_ref, const Eigen::VectorXd& v_ref,
                           const Eigen::VectorXd& kp, const Eigen::VectorXd& kd, double max_torque,
                           int skip_begin, int skip_end, PoseTrackingWork& w, Eigen::VectorXd& tau);

}  // namespace stance
