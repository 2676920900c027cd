// The torque laws shared by the motion-capture trackers (mocap_tracker on a bvh2mjcf character,
// mocap_retarget on any model): deadbeat inverse dynamics for the kinematic root mode, and stable
// PD (Tan et al. 2011) towards a pose with target velocities, solved by the engine's shifted
// mass solve (no dense mass matrix). Work vectors are sized once; the calls allocate nothing.
#pragma once

#include <Eigen/Core>

namespace stance {

class Engine;

struct PoseTrackingWork {
  Eigen::VectorXd q_pred, err, p, d, c, f, rhs, shift;
  Eigen::MatrixXd m;  // the deadbeat law's mass matrix
  void resize(int nq, int nv);
};

// tau += the torques that bring q to q_ref in one step (root included):
//   tau = M ((q_ref (-) q) / dt - v) / dt + c
// Contact forces are not fed back: from the last step they alternate with the new ones.
void add_deadbeat_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                          const Eigen::VectorXd& q_ref, PoseTrackingWork& w, Eigen::VectorXd& tau);

// tau += stable PD towards (q_ref, v_ref) with per-dof gains kp, kd (dim nv), given the
// torques already in tau (they enter the solve for the next velocity):
//   p = -Kp (q + v dt (-) q_ref), d = -Kd (v - v_ref),
//   (M + Kd dt) a = p + d - c + f + tau,  tau_spd = p + d - Kd dt a.
// max_torque > 0 clamps every dof outside [skip_begin, skip_end) (the free root).
void add_stable_pd_torques(const Engine& engine, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                           const Eigen::VectorXd& q_ref, const Eigen::VectorXd& v_ref,
                           const Eigen::VectorXd& kp, const Eigen::VectorXd& kd, double max_torque,
                           int skip_begin, int skip_end, PoseTrackingWork& w, Eigen::VectorXd& tau);

}  // namespace stance
