// Servo actuators on a model that stance drives by torque. A servo (biastype affine on a joint:
// <position>, <velocity>, a <general> servo) pulls its joint to its control; stance's controllers
// leave the controls at 0 and drive the joints through generalised forces, so a servo would pull
// every joint to zero against them. MuJoCo only.
#pragma once

#include <mujoco/mujoco.h>

#include <string>

namespace stance {

// each servo of `m` becomes a motor of unit gain (its gear kept), its control a torque within its
// forcerange (unbounded without one), and the keyframes' controls and activations for it (its
// targets) are zeroed; motors and other actuators are left untouched. Returns how many changed.
int servos_as_torque_motors(mjModel* m);

// the note for the user, naming `source`; empty when servos is 0
std::string servo_note(const std::string& source, int servos);

}  // namespace stance
