// The tracker's gains per dof (mocap_retarget): set by dof or joint name, and in free mode on a
// robot's motors each dof's kp capped at what its torque limit allows, and optionally the legs'
// kp raised towards the body's gravity stiffness.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace stance {

class Engine;

// gains[dof] = value for a dof named `name`, or for every dof of a joint so named; InputError
// naming `what` (the parameter) for an unknown name
void set_gain_by_name(const Engine& engine, Eigen::VectorXd& gains, const std::string& name,
                      double value, const char* what);

// a weak dof's PD reaches its limit no sooner than at limit_gain_error rad (a clamped stable PD
// loses the damping its implicit step counts on, and chatters): kp is capped at limit /
// limit_gain_error, kd by the same factor; a stiffer kp on it would only saturate sooner, a
// softer one is kept
void cap_gains_at_limits(const Engine& engine, double limit_gain_error, Eigen::VectorXd& kp,
                         Eigen::VectorXd& kd);

// the dofs of the joints on `leg_bodies` get at least `floor` kp (kd in ratio), under the cap
// above when limit_gain_error > 0
void raise_gains_to_floor(const Engine& engine, const std::vector<int>& leg_bodies, double floor,
                          double limit_gain_error, Eigen::VectorXd& kp, Eigen::VectorXd& kd);

}  // namespace stance
