#include "control/simbicon.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <set>

#include "core/atomic_file.h"
#include "core/error.h"

namespace stance {

double pitch_about_minus_y(const Eigen::Quaterniond& q) {
  // the body x axis in the world: (cos a, ., sin a) for a rotation a about -y
  const Eigen::Matrix3d r = q.toRotationMatrix();
  return std::atan2(r(2, 0), r(0, 0));
}

double hinge_sign(const Eigen::Vector3d& axis_world, const Eigen::Vector3d& right,
                  const std::string& dof_name) {
  const double n = axis_world.norm();
  const double c = n > 0 ? axis_world.dot(right) / n : 0.0;
  if (std::abs(c) < std::sqrt(0.5))
    throw InputError(fmt::format(
        "simbicon skeleton: dof '{}' turns about ({:.3g} {:.3g} {:.3g}) in the world, not about "
        "the character's lateral axis ({:.3g} {:.3g} {:.3g}) (0 0 0: the dof is not between the "
        "root and the foot); name the leg's pitch hinge, or set skeleton.up and skeleton.forward",
        dof_name, axis_world.x(), axis_world.y(), axis_world.z(), -right.x(), -right.y(),
        -right.z()));
  return c > 0 ? 1.0 : -1.0;
}

SimbiconGaitStats simbicon_gait_stats(const std::vector<SimbiconStep>& steps, int skip) {
  SimbiconGaitStats s;
  double sum_l = 0, sum_l2 = 0, sum_d = 0, sum_d2 = 0, sum_w = 0;
  std::array<double, 2> side_l{}, side_d{};
  std::array<int, 2> side_n{};
  for (size_t i = std::max(0, skip); i < steps.size(); ++i) {
    const SimbiconStep& st = steps[i];
    ++s.steps;
    sum_l += st.length_m;
    sum_l2 += st.length_m * st.length_m;
    sum_d += st.duration_s;
    sum_d2 += st.duration_s * st.duration_s;
    sum_w += st.width_m;
    side_l[st.foot] += st.length_m;
    side_d[st.foot] += st.duration_s;
    ++side_n[st.foot];
  }
  if (s.steps == 0) return s;
  const double n = s.steps;
  s.step_length_mean = sum_l / n;
  s.step_duration_mean = sum_d / n;
  s.step_width_mean = sum_w / n;
  s.step_length_std =
      std::sqrt(std::max(0.0, sum_l2 / n - s.step_length_mean * s.step_length_mean));
  s.step_duration_std =
      std::sqrt(std::max(0.0, sum_d2 / n - s.step_duration_mean * s.step_duration_mean));
  if (side_n[0] > 0 && side_n[1] > 0) {
    const double l0 = side_l[0] / side_n[0], l1 = side_l[1] / side_n[1];
    const double d0 = side_d[0] / side_n[0], d1 = side_d[1] / side_n[1];
    if (std::abs(s.step_length_mean) > 1e-9)
      s.length_asymmetry = std::abs(l0 - l1) / std::abs(s.step_length_mean);
    if (s.step_duration_mean > 1e-9)
      s.duration_asymmetry = std::abs(d0 - d1) / s.step_duration_mean;
  }
  return s;
}

namespace {

void check_half_cycle(const std::vector<SimbiconStateTargets>& states, const char* name,
                      bool required) {
  if (states.empty() && !required) return;
  if (states.size() != 2)
    throw InputError(
        fmt::format("simbicon gait.{}: expected 2 states (timed, then contact), "
                    "found {}",
                    name, states.size()));
}

void check_gains(const std::vector<SimbiconGains>& gains, const char* name) {
  if (gains.size() > 1)
    throw InputError(
        fmt::format("simbicon gait.{}: expected at most 1 entry, found {}", name, gains.size()));
}

double clamp_torque(double tau, double limit) {
  return std::clamp(tau, -limit, limit);
}

// PD on one hinge towards target (rad, in the dof's own sign)
double joint_servo(const Engine& engine, int dof, double target, const SimbiconJointGain& gain) {
  const double tau =
      gain.kp * (target - engine.dof_position(dof)) - gain.damping() * engine.dof_velocity(dof);
  return clamp_torque(tau, gain.max_torque);
}

// knees and ankles: relative servos towards the gait's angle times the hinge's sign
void add_leg_servos(const Simbicon::Model& m, int fsm, const SimbiconStateTargets& tg,
                    const SimbiconGains& gn, double dc_ankle, const Engine& engine,
                    ControlOutput& out) {
  auto servo = [&](int dof, double sign, double target, const SimbiconJointGain& gain) {
    return joint_servo(engine, dof, sign * target, gain);
  };
  const int stance = fsm < 2 ? Simbicon::kRight : Simbicon::kLeft, swing = 1 - stance;
  out.tau[m.knee[swing]] += servo(m.knee[swing], m.knee_sign[swing], tg.swing_knee, gn.swing_knee);
  out.tau[m.knee[stance]] +=
      servo(m.knee[stance], m.knee_sign[stance], tg.stance_knee, gn.stance_knee);
  out.tau[m.ankle[swing]] +=
      servo(m.ankle[swing], m.ankle_sign[swing], tg.swing_ankle, gn.swing_ankle);
  out.tau[m.ankle[stance]] +=
      servo(m.ankle[stance], m.ankle_sign[stance], tg.stance_ankle + dc_ankle, gn.stance_ankle);
}

// a left/right pair of optional dofs: both named, or neither (-1, -1)
std::array<int, 2> optional_dof_pair(const Engine& engine, const std::string& right,
                                     const std::string& left, const char* key) {
  if (right.empty() != left.empty())
    throw InputError(
        fmt::format("simbicon skeleton: right_{0} is {1} but left_{0} is {2}; name "
                    "both or neither",
                    key, right.empty() ? "empty" : "'" + right + "'",
                    left.empty() ? "empty" : "'" + left + "'"));
  if (right.empty()) return {-1, -1};
  return {engine.require_dof(right), engine.require_dof(left)};
}

// 3D dofs: the hip rolls make a biped spatial; hip yaw and ankle roll are optional in 3D (robots
// with one-axis ankles, or hips without yaw)
void resolve_spatial_dofs(const SimbiconSkeleton& k, const Engine& engine, Simbicon::Model& m) {
  m.hip_roll = optional_dof_pair(engine, k.right_hip_roll, k.left_hip_roll, "hip_roll");
  m.hip_yaw = optional_dof_pair(engine, k.right_hip_yaw, k.left_hip_yaw, "hip_yaw");
  m.ankle_roll = optional_dof_pair(engine, k.right_ankle_roll, k.left_ankle_roll, "ankle_roll");
  m.spatial = m.hip_roll[0] >= 0;
  if (!m.spatial && (m.hip_yaw[0] >= 0 || m.ankle_roll[0] >= 0))
    throw InputError(
        "simbicon skeleton: hip yaw or ankle roll named without left/right_hip_roll; a 3D biped "
        "needs the hip rolls (hip yaw and ankle roll are optional), a planar one none of them");
}

// one line at load naming what a 3D controller turned off for the model; once per message per
// process (a planner and a sweep build the controller many times)
void note_turned_off_features(const Simbicon::Model& m, const ControllerContext& ctx) {
  if (!m.spatial || ctx.rollout) return;
  std::vector<std::string> off;
  if (m.ankle_roll[0] < 0)
    off.push_back(
        "ankle roll servos (no ankle roll: coronal balance by the swing hip's roll "
        "and foot placement)");
  if (m.hip_yaw[0] < 0)
    off.push_back(m.params.path_gain > 0 ? "heading hold and path_gain (no hip yaw)"
                                         : "heading hold (no hip yaw)");
  if (off.empty()) return;
  const std::string line = fmt::format("note: {}: {}: simbicon: turned off for this model: {}",
                                       ctx.source.file, ctx.path, fmt::join(off, "; "));
  static std::mutex mutex;
  static std::set<std::string> printed;
  std::lock_guard<std::mutex> lock(mutex);
  if (printed.insert(line).second) std::cerr << line << "\n";
}

// which feet touch the ground: one pass over the contacts
std::array<bool, 2> feet_on_ground(const Simbicon::Model& m, const Engine& engine) {
  std::array<bool, 2> on_ground{false, false};
  for (int i = 0, n = engine.num_contacts(); i < n; ++i) {
    const Contact c = engine.contact(i);
    const int other = c.body1 < 0 ? c.body2 : (c.body2 < 0 ? c.body1 : -2);
    for (int side : {Simbicon::kRight, Simbicon::kLeft})
      if (other == m.foot[side]) on_ground[side] = true;
  }
  return on_ground;
}

// FSM: timed states end on the clock, contact states when the swing foot lands
void advance_fsm(const Simbicon::Model& m, SimbiconState& s, const Engine& engine,
                 const std::array<bool, 2>& on_ground) {
  const double t = engine.time();
  const SimbiconStateTargets& cur = m.targets[s.fsm];
  const int swing = s.fsm < 2 ? Simbicon::kLeft : Simbicon::kRight;
  const double in_state = t - s.state_start_s;
  bool done = in_state >= cur.duration_s;
  if (cur.ends_on_contact && in_state >= cur.min_duration_s && on_ground[swing]) done = true;
  if (done) {
    s.state_time_sum[s.fsm] += in_state;
    ++s.state_count[s.fsm];
    if (cur.ends_on_contact) {
      // a strike: the swing foot becomes the stance foot
      const Eigen::Vector3d foot = engine.body_pose(m.foot[swing]).pos;
      const double ankle_x = (m.heading * Eigen::Vector3d::UnitX()).dot(foot);
      const double ankle_y = (m.heading * Eigen::Vector3d::UnitY()).dot(foot);
      if (s.steps.size() < static_cast<size_t>(m.params.max_recorded_steps))
        s.steps.push_back({t, swing, ankle_x, ankle_x - s.last_stance_ankle_x, t - s.last_strike_s,
                           m.spatial ? std::abs(ankle_y - s.last_stance_ankle_y) : 0.0});
      s.last_stance_ankle_x = ankle_x;
      s.last_stance_ankle_y = ankle_y;
      s.last_strike_s = t;
    }
    s.fsm = (s.fsm + 1) % 4;
    s.state_start_s = t;
  }
}

}  // namespace

Simbicon::Simbicon(const SimbiconParams& params, const ControllerContext& ctx,
                   const Engine& engine) {
  Model& m = model_;
  m.params = params;
  const SimbiconGait& g = params.gait;
  check_half_cycle(g.states, "states", true);
  check_half_cycle(g.right_stance, "right_stance", false);
  check_half_cycle(g.left_stance, "left_stance", false);
  check_gains(g.right_stance_gains, "right_stance_gains");
  check_gains(g.left_stance_gains, "left_stance_gains");
  if (params.balance_point != "hip" && params.balance_point != "com")
    throw InputError(fmt::format("simbicon balance_point: expected hip or com, found '{}'",
                                 params.balance_point));
  m.use_com = params.balance_point == "com";

  // per FSM state: states 0, 1 right stance; 2, 3 left stance
  for (int s = 0; s < 4; ++s) {
    const auto& side_states = s < 2 ? g.right_stance : g.left_stance;
    m.targets[s] = side_states.empty() ? g.states[s % 2] : side_states[s % 2];
    const auto& side_gains = s < 2 ? g.right_stance_gains : g.left_stance_gains;
    m.gains[s] = side_gains.empty() ? g.gains : side_gains[0];
  }

  const SimbiconSkeleton& k = params.skeleton;
  m.torso = engine.require_body(k.torso);
  m.thigh = {engine.require_body(k.right_thigh), engine.require_body(k.left_thigh)};
  m.foot = {engine.require_body(k.right_foot), engine.require_body(k.left_foot)};
  m.hip = {engine.require_dof(k.right_hip), engine.require_dof(k.left_hip)};
  m.knee = {engine.require_dof(k.right_knee), engine.require_dof(k.left_knee)};
  m.ankle = {engine.require_dof(k.right_ankle), engine.require_dof(k.left_ankle)};
  resolve_spatial_dofs(k, engine, m);
  for (int dof : {m.hip[0], m.hip[1], m.knee[0], m.knee[1], m.ankle[0], m.ankle[1]}) {
    const JointInfo& j = engine.joint(engine.dof_joint(dof));
    if (j.type != JointType::kHinge)
      throw InputError(
          fmt::format("simbicon skeleton: dof '{}' must be a hinge", engine.dof_name(dof)));
  }

  // the character frame: up (default minus gravity), forward made normal to it, left = up x fwd
  Eigen::Vector3d up = k.up;
  if (up.squaredNorm() == 0) {
    const Eigen::Vector3d g = engine.gravity();
    if (g.squaredNorm() == 0)
      throw InputError("simbicon skeleton.up: zero gravity; give the character's up axis");
    up = -g.normalized();
  } else {
    up.normalize();
  }
  Eigen::Vector3d fwd = k.forward - k.forward.dot(up) * up;
  if (fwd.norm() < 1e-6 * std::max(1.0, k.forward.norm()))
    throw InputError(
        fmt::format("simbicon skeleton.forward: ({} {} {}) is zero or along the up axis ({} {} {})",
                    k.forward.x(), k.forward.y(), k.forward.z(), up.x(), up.y(), up.z()));
  fwd.normalize();
  m.up = up;
  Eigen::Matrix3d frame;
  frame << fwd, up.cross(fwd), up;
  m.frame_quat = Eigen::Quaterniond(frame);
  m.heading = m.frame_quat * Eigen::AngleAxisd(params.heading_rad, Eigen::Vector3d::UnitZ());

  // hinge signs: each pitch dof's axis in the world at the loaded pose, read from the foot's
  // rotational Jacobian (its column at a hinge dof is the hinge's world axis)
  const Eigen::Vector3d right = -(m.heading * Eigen::Vector3d::UnitY());
  Eigen::MatrixXd jac_rot = Eigen::MatrixXd::Zero(3, engine.nv()), jac_none(3, 0);
  for (int side : {kRight, kLeft}) {
    engine.point_jacobian(m.foot[side], engine.body_pose(m.foot[side]).pos, jac_none, jac_rot);
    auto sign = [&](int dof) { return hinge_sign(jac_rot.col(dof), right, engine.dof_name(dof)); };
    m.hip_sign[side] = sign(m.hip[side]);
    m.knee_sign[side] = sign(m.knee[side]);
    m.ankle_sign[side] = sign(m.ankle[side]);
  }
  if (!k.spine_roll.empty()) {
    if (!m.spatial)
      throw InputError("simbicon skeleton.spine_roll: only for a 3D biped (name the hip rolls)");
    m.spine_roll = engine.require_dof(k.spine_roll);
    const JointInfo& j = engine.joint(engine.dof_joint(m.spine_roll));
    engine.point_jacobian(j.body, engine.body_pose(j.body).pos, jac_none, jac_rot);
    const Eigen::Vector3d axis = jac_rot.col(m.spine_roll).normalized();
    const Eigen::Vector3d forward = m.heading * Eigen::Vector3d::UnitX();
    if (j.type != JointType::kHinge || std::abs(axis.dot(forward)) < std::sqrt(0.5))
      throw InputError(fmt::format(
          "simbicon skeleton.spine_roll: dof '{}' is not a hinge about the character's forward "
          "axis",
          k.spine_roll));
    // the lean turns the upper body about forward relative to the torso: the hinge's angle when
    // the upper body is its child, minus it when the torso is on the child's side
    bool torso_is_child = false;
    for (int b = m.torso; b >= 0 && !torso_is_child; b = engine.body_parent(b))
      torso_is_child = b == j.body;
    m.spine_sign = (axis.dot(forward) > 0 ? 1.0 : -1.0) * (torso_is_child ? -1.0 : 1.0);
  }
  note_turned_off_features(m, ctx);
}

void Simbicon::reset_state(State& s, const Engine& engine) const {
  s.jac_rot.setZero(3, engine.nv());
  s.jac_none.resize(3, 0);
  s.steps.reserve(model_.params.max_recorded_steps);
  s.fsm = model_.params.initial_state;
  s.state_start_s = engine.time();
  s.swing_hip_target = 0;
  s.d = s.v = 0;
  const Eigen::Vector3d p = model_.use_com
                                ? engine.com()
                                : Eigen::Vector3d(0.5 * (engine.body_pose(model_.thigh[0]).pos +
                                                         engine.body_pose(model_.thigh[1]).pos));
  const double x = (model_.heading * Eigen::Vector3d::UnitX()).dot(p);
  s.lateral_start = s.lateral_last = (model_.heading * Eigen::Vector3d::UnitY()).dot(p);
  s.start_x = s.last_x = x;
  s.start_time = s.last_time = engine.time();
  s.last_strike_s = engine.time();
  const int stance = s.fsm < 2 ? kRight : kLeft;
  const Eigen::Vector3d stance_ankle = engine.body_pose(model_.foot[stance]).pos;
  s.last_stance_ankle_x = (model_.heading * Eigen::Vector3d::UnitX()).dot(stance_ankle);
  s.last_stance_ankle_y = (model_.heading * Eigen::Vector3d::UnitY()).dot(stance_ankle);
  s.flight_time_s = 0;
  s.steps.clear();
  s.state_time_sum.fill(0);
  s.state_count.fill(0);
}

void Simbicon::compute_with(State& s, const Engine& engine, const double* correction,
                            ControlOutput& out) const {
  const Model& m = model_;
  const double t = engine.time();
  const std::array<bool, 2> on_ground = feet_on_ground(m, engine);
  advance_fsm(m, s, engine, on_ground);

  if (!on_ground[kRight] && !on_ground[kLeft]) s.flight_time_s += engine.timestep();

  const SimbiconStateTargets& tg = m.targets[s.fsm];
  const SimbiconGains& gn = m.gains[s.fsm];
  const int stance = s.fsm < 2 ? kRight : kLeft;
  const int swing = 1 - stance;

  // balance feedback inputs: hip (or COM) relative to the stance ankle, along the heading
  const Eigen::Vector3d fwd = m.heading * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d left = m.heading * Eigen::Vector3d::UnitY();
  // a body's orientation goal in the world from its rotation in the gait's frame: heading *
  // goal * frame^-1 (body frames are parallel to the world at rest)
  const Eigen::Quaterniond rest = m.frame_quat.conjugate();
  const Eigen::Vector3d ankle = engine.body_pose(m.foot[stance]).pos;
  Eigen::Vector3d point, velocity;
  if (m.use_com) {
    point = engine.com();
    velocity = engine.com_velocity();
  } else {
    // the hip centre: midway between the thigh frames (at the hip joints)
    point = 0.5 * (engine.body_pose(m.thigh[0]).pos + engine.body_pose(m.thigh[1]).pos);
    velocity = 0.5 * (engine.body_velocity(m.thigh[0]).tail<3>() +
                      engine.body_velocity(m.thigh[1]).tail<3>());
  }
  s.d = fwd.dot(point - ankle);
  s.v = fwd.dot(velocity);
  s.last_x = fwd.dot(point);
  s.lateral_last = left.dot(point);
  s.last_time = t;
  // the planner's correction (correction_dims): offsets of the swing thigh, torso and stance
  // ankle targets, and in 3D of the swing thigh's and the torso's roll
  const double* c = correction;
  const double dc_swing = c ? c[0] : 0.0, dc_torso = c ? c[1] : 0.0, dc_ankle = c ? c[2] : 0.0;
  s.swing_hip_target = tg.swing_hip + tg.cd * s.d + tg.cv * s.v + dc_swing;

  if (m.spatial) {
    // 3D: world-frame orientation servos; outward is +y for the left swing leg
    const double outward = swing == kLeft ? 1.0 : -1.0;
    const double d_lat = left.dot(point - ankle), v_lat = left.dot(velocity);
    const double roll_target = outward * tg.swing_hip_roll + tg.cd_lateral * d_lat +
                               tg.cv_lateral * v_lat + (c ? c[3] : 0.0);
    const Eigen::Vector3d minus_y = -Eigen::Vector3d::UnitY(), unit_x = Eigen::Vector3d::UnitX();
    // heading policy: the heading turns by +path_gain per metre of lateral offset from the
    // start line. Measured, not derived: this sign brings the walker back to the line (the
    // coronal feedback re-centres the feet faster than the turned heading moves the body);
    // the opposite sign drifts off (tests/control/simbicon_test.cc, docs/simbicon.md)
    // without hip yaw nothing turns the walker: no steering
    const double path_gain = m.hip_yaw[0] >= 0 ? m.params.path_gain : 0.0;
    const double steer = std::clamp(path_gain * (s.lateral_last - s.lateral_start),
                                    -m.params.max_steer_rad, m.params.max_steer_rad);
    const Eigen::Quaterniond heading = Eigen::AngleAxisd(steer, m.up) * m.heading;
    const Eigen::Quaterniond torso_goal =
        heading * Eigen::AngleAxisd(outward * tg.torso_roll + (c ? c[4] : 0.0), unit_x) *
        Eigen::AngleAxisd(tg.torso + dc_torso, minus_y) * rest;
    const Eigen::Quaterniond thigh_goal = heading * Eigen::AngleAxisd(roll_target, unit_x) *
                                          Eigen::AngleAxisd(s.swing_hip_target, minus_y) * rest;
    auto orientation_servo = [&](int body, const Eigen::Quaterniond& goal,
                                 const SimbiconJointGain& gain) {
      const Eigen::AngleAxisd err(goal * engine.body_pose(body).quat.conjugate());
      Eigen::Vector3d tau = gain.kp * err.angle() * err.axis() -
                            gain.damping() * engine.body_velocity(body).head<3>();
      for (int i = 0; i < 3; ++i) tau[i] = clamp_torque(tau[i], gain.max_torque);
      // without hip yaw the heading is not held: a torque about up would leak into the roll and
      // pitch hinges through their tilt
      if (m.hip_yaw[0] < 0) tau -= m.up.dot(tau) * m.up;
      return tau;
    };
    const Eigen::Vector3d tau_torso = orientation_servo(m.torso, torso_goal, gn.torso);
    const Eigen::Vector3d tau_swing = orientation_servo(m.thigh[swing], thigh_goal, gn.swing_hip);
    Eigen::Vector3d tau_stance = -tau_torso - tau_swing;
    for (int i = 0; i < 3; ++i)
      tau_stance[i] = clamp_torque(tau_stance[i], gn.stance_hip_max_torque);
    // a torque pair (thigh +tau, torso -tau) is the hip dofs' forces a_i . tau, where a_i are
    // the hip axes in the world: the thigh's rotational Jacobian columns at those dofs
    auto to_hip = [&](int side, const Eigen::Vector3d& tau) {
      const int thigh = m.thigh[side];
      engine.point_jacobian(thigh, engine.body_pose(thigh).pos, s.jac_none, s.jac_rot);
      for (int dof : {m.hip_roll[side], m.hip[side], m.hip_yaw[side]})
        if (dof >= 0) out.tau[dof] += s.jac_rot.col(dof).dot(tau);
    };
    to_hip(swing, tau_swing);
    to_hip(stance, tau_stance);
    if (m.ankle_roll[0] >= 0) {
      out.tau[m.ankle_roll[swing]] += joint_servo(engine, m.ankle_roll[swing], 0.0, gn.swing_ankle);
      out.tau[m.ankle_roll[stance]] +=
          joint_servo(engine, m.ankle_roll[stance], 0.0, gn.stance_ankle);
    }
    if (m.spine_roll >= 0) {
      // leaning towards the stance leg is a turn about +forward for the right leg
      const double lean = (stance == kRight ? 1.0 : -1.0) * tg.spine_roll;
      out.tau[m.spine_roll] += joint_servo(engine, m.spine_roll, m.spine_sign * lean, gn.spine);
    }
    add_leg_servos(m, s.fsm, tg, gn, dc_ankle, engine, out);
    return;
  }

  // world-frame servos: torso and swing thigh, pitch about the gait frame's -y (the angular
  // velocity about -left is -left . w)
  const Eigen::Quaterniond to_gait = m.heading.conjugate();
  const double torso_angle =
      pitch_about_minus_y(to_gait * engine.body_pose(m.torso).quat * m.frame_quat);
  const double torso_rate = -left.dot(engine.body_velocity(m.torso).head<3>());
  const double thigh_angle =
      pitch_about_minus_y(to_gait * engine.body_pose(m.thigh[swing]).quat * m.frame_quat);
  const double thigh_rate = -left.dot(engine.body_velocity(m.thigh[swing]).head<3>());
  const double tau_torso =
      gn.torso.kp * (tg.torso + dc_torso - torso_angle) - gn.torso.damping() * torso_rate;
  const double tau_swing_hip = clamp_torque(
      gn.swing_hip.kp * (s.swing_hip_target - thigh_angle) - gn.swing_hip.damping() * thigh_rate,
      gn.swing_hip.max_torque);
  // the stance hip holds the torso: the torso feels -tau_swing_hip - tau_stance_hip
  const double tau_stance_hip = clamp_torque(
      -clamp_torque(tau_torso, gn.torso.max_torque) - tau_swing_hip, gn.stance_hip_max_torque);

  out.tau[m.hip[swing]] += m.hip_sign[swing] * tau_swing_hip;
  out.tau[m.hip[stance]] += m.hip_sign[stance] * tau_stance_hip;
  add_leg_servos(m, s.fsm, tg, gn, dc_ankle, engine, out);
}

void Simbicon::correction_dims(std::vector<CorrectionDim>& dims) const {
  for (const char* name : {"swing_hip_pitch", "torso_pitch", "stance_ankle_pitch"})
    dims.push_back({name, 0.1, "rad"});
  if (model_.spatial)
    for (const char* name : {"swing_hip_roll", "torso_roll"}) dims.push_back({name, 0.1, "rad"});
}

void Simbicon::signal_names(std::vector<std::string>& names) const {
  names.insert(names.end(),
               {"simbicon_state", "simbicon_swing_hip_target", "simbicon_d", "simbicon_v"});
}

void Simbicon::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.insert(values.end(), {double(s.fsm), s.swing_hip_target, s.d, s.v});
}

void Simbicon::markers(const ControllerState& state, const Engine& engine,
                       std::vector<Marker>& out) const {
  const State& s = cast(state);
  const Model& m = model_;
  const int stance = s.fsm < 2 ? kRight : kLeft;
  const Eigen::Vector3d lateral = m.heading * Eigen::Vector3d::UnitY();
  // planar models: rings in the sagittal plane, beside the body on the side the viewer's
  // camera starts on (-y), where the torso does not hide them; 3D: flat, wide enough to
  // encircle the foot and the pelvis
  const Eigen::Vector3d side =
      m.spatial ? Eigen::Vector3d::Zero() : Eigen::Vector3d(-0.2 * lateral);
  const Eigen::Vector3d normal = m.spatial ? Eigen::Vector3d::Zero() : lateral;
  const Eigen::Vector3d ankle = engine.body_pose(m.foot[stance]).pos;
  const Eigen::Vector3d hip =
      0.5 * (engine.body_pose(m.thigh[0]).pos + engine.body_pose(m.thigh[1]).pos);
  const Eigen::Vector3d point = m.use_com ? engine.com() : hip;
  Marker ring;
  ring.shape = Marker::Shape::kCircle;
  ring.pos = ankle + side;
  ring.normal = normal;
  ring.radius = m.spatial ? 0.14 : 0.08;
  ring.rgba = {0.1f, 0.9f, 0.2f, 1};
  ring.label = stance == kRight ? "stance ankle (R)" : "stance ankle (L)";
  out.push_back(ring);
  ring.pos = point + side;
  ring.radius = m.spatial ? 0.22 : 0.08;
  ring.rgba = {0.2f, 0.6f, 1.0f, 1};
  ring.label = m.use_com ? "COM" : "hip";
  out.push_back(ring);
  // d: from the stance ankle to the balance point
  Marker d;
  d.shape = Marker::Shape::kLine;
  d.pos = ankle + side;
  d.end = point + side;
  d.radius = 0.006;
  d.rgba = {0.9f, 0.9f, 0.9f, 0.8f};
  out.push_back(d);
  // the swing thigh's target after feedback: theta from vertical about -y, turned to the
  // heading; labelled at its head
  const double th = s.swing_hip_target;
  Marker target;
  target.shape = Marker::Shape::kArrow;
  target.pos = hip + side;
  target.end = target.pos + 0.4 * (m.heading * Eigen::Vector3d(std::sin(th), 0, -std::cos(th)));
  target.radius = 0.015;
  target.rgba = {1.0f, 0.3f, 0.8f, 1};
  out.push_back(target);
  Marker head;
  head.pos = target.end;
  head.radius = 0.012;
  head.rgba = target.rgba;
  head.label = "swing target";
  out.push_back(head);
}

void Simbicon::add_metrics(const ControllerState& state, nlohmann::json& metrics) const {
  const State& s = cast(state);
  const double elapsed = s.last_time - s.start_time;
  const double distance = s.last_x - s.start_x;
  metrics["distance_m"] = distance;
  metrics["mean_speed_mps"] = elapsed > 0 ? distance / elapsed : 0.0;
  // sideways drift per metre forward (3D; 0 for a planar model)
  metrics["lateral_drift_m"] = s.lateral_last - s.lateral_start;
  metrics["drift_per_10m"] =
      std::abs(distance) > 1e-9
          ? 10.0 * std::abs(s.lateral_last - s.lateral_start) / std::abs(distance)
          : 0.0;
  metrics["flight_fraction"] = elapsed > 0 ? s.flight_time_s / elapsed : 0.0;
  // the first two steps are the start-up from standing
  const SimbiconGaitStats g = simbicon_gait_stats(s.steps, 2);
  metrics["step_count"] = static_cast<int>(s.steps.size());
  metrics["step_length_mean_m"] = g.step_length_mean;
  metrics["step_length_std_m"] = g.step_length_std;
  metrics["step_duration_mean_s"] = g.step_duration_mean;
  metrics["step_duration_std_s"] = g.step_duration_std;
  metrics["step_width_mean_m"] = g.step_width_mean;
  metrics["step_length_asymmetry"] = g.length_asymmetry;
  metrics["step_duration_asymmetry"] = g.duration_asymmetry;
  nlohmann::json per_state = nlohmann::json::array();
  for (int i = 0; i < 4; ++i) {
    per_state.push_back(
        {{"state", i},
         {"count", s.state_count[i]},
         {"mean_duration_s", s.state_count[i] ? s.state_time_sum[i] / s.state_count[i] : 0.0}});
  }
  metrics["simbicon_states"] = per_state;
}

void Simbicon::write_outputs(const ControllerState& state, const std::string& out_dir) const {
  const State& s = cast(state);
  AtomicFile file(std::filesystem::path(out_dir) / "steps.csv");
  std::ostream& f = file.stream();
  f << "time,foot,ankle_x,length_m,duration_s,width_m\n";
  for (const SimbiconStep& st : s.steps)
    f << fmt::format("{:.6f},{},{:.6f},{:.6f},{:.6f},{:.6f}\n", st.time_s,
                     st.foot == kRight ? "right" : "left", st.ankle_x, st.length_m, st.duration_s,
                     st.width_m);
  file.commit();
}

}  // namespace stance
