#include "engine/mujoco/mujoco_actuators.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

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

// the largest |torque| actuator i puts on its joint, infinite when the file bounds it not: its
// forcerange when forcelimited, and for a motor (fixed gain, no bias) gain x its ctrlrange's reach
double actuator_joint_limit(const mjModel* m, int i) {
  double force = std::numeric_limits<double>::infinity();
  if (m->actuator_forcelimited[i])
    force = std::max(std::abs(m->actuator_forcerange[2 * i]),
                     std::abs(m->actuator_forcerange[2 * i + 1]));
  const bool motor =
      m->actuator_biastype[i] == mjBIAS_NONE && m->actuator_gaintype[i] == mjGAIN_FIXED;
  if (motor && m->actuator_ctrllimited[i]) {
    const double reach = std::max(std::abs(m->actuator_ctrlrange[2 * i]),
                                  std::abs(m->actuator_ctrlrange[2 * i + 1]));
    force = std::min(force, std::abs(m->actuator_gainprm[mjNGAIN * i]) * reach);
  }
  return std::abs(m->actuator_gear[6 * i]) * force;
}

// per joint index: the sum of its actuators' limits; infinite when one of them is unbounded
std::vector<double> joint_force_limits(const mjModel* m) {
  std::vector<double> limits(m->njnt, std::numeric_limits<double>::infinity());
  std::vector<int> bounded(m->njnt, 0), driven(m->njnt, 0);
  std::vector<double> sum(m->njnt, 0.0);
  for (int i = 0; i < m->nu; ++i) {
    if (m->actuator_trntype[i] != mjTRN_JOINT) continue;
    const int j = m->actuator_trnid[2 * i];
    const double limit = actuator_joint_limit(m, i);
    ++driven[j];
    if (std::isfinite(limit)) {
      ++bounded[j];
      sum[j] += limit;
    }
  }
  for (int j = 0; j < m->njnt; ++j)
    if (driven[j] > 0 && bounded[j] == driven[j]) limits[j] = sum[j];
  return limits;
}

// the joints' limits, each the tighter of the actuators' and the model's own by joint name
std::vector<double> joint_force_limits(const mjModel* m, const BackendModel& model) {
  std::vector<double> limits = joint_force_limits(m);
  for (const auto& [name, limit] : model.effort_limits) {
    const int j = mj_name2id(m, mjOBJ_JOINT, name.c_str());
    if (j >= 0) limits[j] = std::min(limits[j], limit);
  }
  return limits;
}

// a joint's limit tighter than its one actuator's own (a newer MuJoCo's actuatorfrcrange) bounds
// that motor's force as well, as MuJoCo 3 bounds it: controls (LQR's) are held to it. With the
// controls at 0 (torque-driven runs) nothing changes.
void bound_lone_motors(mjModel* m, const std::vector<double>& joint_limits) {
  std::vector<int> actuators(m->njnt, 0);
  for (int i = 0; i < m->nu; ++i)
    if (m->actuator_trntype[i] == mjTRN_JOINT) ++actuators[m->actuator_trnid[2 * i]];
  for (int i = 0; i < m->nu; ++i) {
    const int j = m->actuator_trnid[2 * i];
    const double gear = std::abs(m->actuator_gear[6 * i]);
    if (m->actuator_trntype[i] != mjTRN_JOINT || actuators[j] != 1 || gear == 0) continue;
    if (!(joint_limits[j] < actuator_joint_limit(m, i))) continue;
    const double force = joint_limits[j] / gear;
    double* range = m->actuator_forcerange + 2 * i;
    const bool limited = m->actuator_forcelimited[i];
    range[0] = limited ? std::max(range[0], -force) : -force;
    range[1] = limited ? std::min(range[1], force) : force;
    m->actuator_forcelimited[i] = 1;
  }
}

}  // namespace stance
