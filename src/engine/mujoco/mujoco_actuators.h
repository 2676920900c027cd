// What a MuJoCo model's actuators mean to stance, whose controllers drive the joints by torque:
// each joint's torque limit (docs/robots.md, "Torque limits"), and servos made torque motors. A
// servo (biastype affine on a joint: <position>, <velocity>, a <general> servo) pulls its joint
// to its control; stance's controllers leave the controls at 0 and drive the joints through
// generalised forces, so a servo would pull every joint to zero against them.
#pragma once

#include <mujoco/mujoco.h>

#include <string>
#include <vector>

#include "engine/backend_world.h"

namespace stance {

// each servo of `m` becomes a motor of unit gain (its gear kept), its control a torque within its
// forcerange (unbounded without one), and the keyframes' controls and activations for it (its
// targets) are zeroed; motors and other actuators are left untouched. Returns how many changed.
int servos_as_torque_motors(mjModel* m);

// the note for the user, naming `source`; empty when servos is 0
std::string servo_note(const std::string& source, int servos);

// the largest |torque| actuator i puts on its joint, infinite when the file bounds it not
double actuator_joint_limit(const mjModel* m, int i);

// per joint index: the sum of its actuators' limits; infinite when one of them is unbounded
std::vector<double> joint_force_limits(const mjModel* m);

// the joints' limits, each the tighter of the actuators' and the model's own by joint name
std::vector<double> joint_force_limits(const mjModel* m, const BackendModel& model);

// a joint's limit tighter than its one actuator's own bounds that actuator's force as well
void bound_lone_motors(mjModel* m, const std::vector<double>& joint_limits);

}  // namespace stance
