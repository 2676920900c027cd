#include "engine/mujoco/mujoco_servos.h"

#include <fmt/format.h>

namespace stance {

namespace {

// a servo: an actuator on a joint whose force depends on the joint's position or velocity
// (biastype affine: <position>, <velocity>, a <general> servo). At ctrl 0 it pulls its joint
// towards zero, against the torques of stance's controllers.
bool is_joint_servo(const mjModel* m, int i) {
  return m->actuator_trntype[i] == mjTRN_JOINT && m->actuator_biastype[i] == mjBIAS_AFFINE;
}

}  // namespace

// stance's controllers drive joints by torque: each servo becomes a motor of unit gain, its
// control a torque within its forcerange (unbounded without one; the joint's actuatorfrcrange
// then bounds it), and the keyframes' controls and activations for it (targets) are zeroed.
// Returns how many actuators it changed; motors are left untouched.
int servos_as_torque_motors(mjModel* m) {
  int count = 0;
  const int first_act = m->nu - m->na;  // 2.2.2: the activations of the last na actuators
  for (int i = 0; i < m->nu; ++i) {
    if (!is_joint_servo(m, i)) continue;
    ++count;
    m->actuator_gaintype[i] = mjGAIN_FIXED;
    m->actuator_biastype[i] = mjBIAS_NONE;
    for (int k = 0; k < mjNGAIN; ++k) m->actuator_gainprm[mjNGAIN * i + k] = k == 0 ? 1 : 0;
    for (int k = 0; k < mjNBIAS; ++k) m->actuator_biasprm[mjNBIAS * i + k] = 0;
    m->actuator_ctrllimited[i] = m->actuator_forcelimited[i];
    for (int k = 0; k < 2; ++k)
      m->actuator_ctrlrange[2 * i + k] = m->actuator_forcerange[2 * i + k];
    for (int key = 0; key < m->nkey; ++key) {
      m->key_ctrl[m->nu * key + i] = 0;
      if (i >= first_act) m->key_act[m->na * key + i - first_act] = 0;
    }
  }
  return count;
}

std::string servo_note(const std::string& source, int servos) {
  if (servos == 0) return "";
  return fmt::format(
      "{}: {} position/velocity servo actuator{} (force from the joint's position or velocity: "
      "kp, kv) made torque motors within {} forcerange: stance's controllers drive the joints "
      "by torque, and a servo at ctrl 0 would pull each joint to zero",
      source, servos, servos == 1 ? "" : "s", servos == 1 ? "its" : "their");
}

}  // namespace stance
