// The tracker's balance layer on legs with weak ankles (docs/robots.md, "Within the robot's
// motors"): an ankle whose strongest dof is under 1 N m per kg of the model cannot lift the heel
// under the body's weight, so the stance foot stays flat where the clip rises onto its toes, the
// pelvis rides lower than the clip's, and a swing foot at the clip's joint angles scuffs. There
// the swing leg is servoed while the clip swings it (a scuffing foot is no second stance foot)
// and its hip and knee lift the foot by as much as the root rides below the clip's.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "control/retarget.h"
#include "engine/engine.h"

namespace stance {

// N m per kg of the model: an ankle whose strongest dof is limited below this is weak. Lifting
// the heel under the body takes m g times the toe's lever, about 1.5 N m/kg on a 15 cm foot:
// humanoid.xml's 0.49 and a Unitree H1's 0.78 N m/kg cannot, and both hold the looped walks more
// often with the rules (docs/robots.md); Atlas's 4.7 can
inline constexpr double kWeakAnkleTorquePerKg = 1.0;

struct WeakAnkleLegs {
  bool weak = false;
  std::vector<int> leg_dofs[2];  // per side: the dofs between the root body and the ankle
};

// the legs of the mapped feet bodies[foot[side]] below the mapped root bodies[root]. The ankle
// is the joints of the bodies from the foot up to its mapped parent, the shin (a hinge chain's
// links included); the leg's dofs are those from the shin up to the root's body. Weak when on
// either side the ankle's strongest dof is limited below kWeakAnkleTorquePerKg x the model's
// mass; a model without limits is never weak.
WeakAnkleLegs find_weak_ankle_legs(const Engine& engine, const std::vector<RetargetBody>& bodies,
                                   int root, const int foot[2]);

// adds to q_ref the leg dofs' move (damped least squares on the foot origin's Jacobian) that
// raises the foot origin by `lift` along `up` and keeps it in place horizontally; jac is 3 x nv
// and dv nv scratch. Allocates nothing.
void lift_foot(const Engine& engine, int foot_body, const std::vector<int>& leg_dofs,
               const Eigen::Vector3d& up, double lift, Eigen::MatrixXd& jac, Eigen::VectorXd& dv,
               Eigen::VectorXd& q_ref);

}  // namespace stance
