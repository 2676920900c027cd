#include "control/mocap_weak_ankles.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "control/mocap_retarget_tracker.h"

namespace stance {

WeakAnkleLegs find_weak_ankle_legs(const Engine& engine, const std::vector<RetargetBody>& bodies,
                                   int root, const int foot[2]) {
  WeakAnkleLegs legs;
  const double weak_below = kWeakAnkleTorquePerKg * engine.total_mass();
  for (int side = 0; side < 2; ++side) {
    // the ankle: the joints of the bodies from the foot up to the shin (a hinge chain's links)
    double strongest = 0;
    bool ankle = true;
    const int root_body = bodies[root].body, shin_body = bodies[foot[side]].parent;
    for (int b = bodies[foot[side]].body; b >= 0 && b != root_body; b = engine.body_parent(b)) {
      if (b == shin_body) ankle = false;
      for (int j = 0; j < engine.njoint(); ++j) {
        const JointInfo& info = engine.joint(j);
        if (info.body != b || info.type == JointType::kFree) continue;
        for (int d = info.dof_adr; d < info.dof_adr + info.nv; ++d)
          if (ankle)
            strongest = std::max(strongest, info.force_limit);
          else
            legs.leg_dofs[side].push_back(d);
      }
    }
    if (strongest > 0 && strongest < weak_below) legs.weak = true;
  }
  return legs;
}

void lift_foot(const Engine& engine, int foot_body, const std::vector<int>& leg_dofs,
               const Eigen::Vector3d& up, double lift, Eigen::MatrixXd& jac, Eigen::VectorXd& dv,
               Eigen::VectorXd& q_ref) {
  Eigen::MatrixXd none(3, 0);
  engine.point_jacobian(foot_body, engine.body_pose(foot_body).pos, jac, none);
  // dq = J^T (J J^T + lambda I)^-1 (lift up), over the leg's dofs only
  Eigen::Matrix3d a = 1e-4 * Eigen::Matrix3d::Identity();
  for (int d : leg_dofs) {
    const Eigen::Vector3d column = jac.col(d);  // fixed size: the outer product allocates none
    a += column * column.transpose();
  }
  const Eigen::Vector3d w = a.ldlt().solve(lift * up);
  dv.setZero();
  for (int d : leg_dofs) dv[d] = jac.col(d).dot(w);
  engine.integrate_positions(q_ref, dv, 1.0, q_ref);
}

void MocapRetargetTracker::lift_swing_foot(State& s, const Engine& engine, int swing,
                                           const BodyPose& root) const {
  // the flat stance foot leaves the root lower than the clip's (which rises onto its toes): the
  // swing foot at the clip's joint angles would be as much lower
  const double lift =
      std::clamp(s.up.dot(s.bal_pos[root_mapped_] - root.pos), 0.0, kWeakSwingMaxLift);
  if (lift <= 0) return;
  lift_foot(engine, motion_->bodies()[foot_[swing]].body, weak_legs_.leg_dofs[swing], s.up, lift,
            s.jac_b, s.scratch, s.q_ref);
}

}  // namespace stance
