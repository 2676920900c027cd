#include "control/standing_pose.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/error.h"

namespace stance {

namespace {

bool hangs_from(const Engine& engine, int body, int ancestor) {
  for (int b = engine.body_parent(body); b >= 0; b = engine.body_parent(b))
    if (b == ancestor) return true;
  return false;
}

// the two lowest body origins along up of which neither hangs from the other
std::array<int, 2> lowest_two_bodies(const Engine& engine, const Eigen::Vector3d& up) {
  std::vector<int> order(engine.nbody());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return engine.body_pose(a).pos.dot(up) < engine.body_pose(b).pos.dot(up);
  });
  for (size_t i = 1; i < order.size(); ++i)
    if (!hangs_from(engine, order[i], order[0]) && !hangs_from(engine, order[0], order[i]))
      return {order[0], order[i]};
  throw InputError("stand_pose auto: the model has no two feet (bodies on separate branches)");
}

std::array<int, 2> feet_of(const Engine& engine, const StandingPoseOptions& options,
                           const Eigen::Vector3d& up) {
  if (options.feet.empty()) return lowest_two_bodies(engine, up);
  if (options.feet.size() != 2)
    throw InputError(
        fmt::format("stand_pose auto: expected 2 feet, found {}", options.feet.size()));
  return {engine.require_body(options.feet[0]), engine.require_body(options.feet[1])};
}

// the leg's hinges turning about `axis` (within 45 degrees), between the foot and the body both
// feet hang from (a spine's hinges above it are not the leg's), nearest the foot first
std::vector<int> hinges_of_leg(const Engine& engine, int foot, int other_foot,
                               const Eigen::Vector3d& axis) {
  Eigen::MatrixXd jac_rot = Eigen::MatrixXd::Zero(3, engine.nv()), jac_none(3, 0);
  engine.point_jacobian(foot, engine.body_pose(foot).pos, jac_none, jac_rot);
  std::vector<int> hinges;
  for (int b = foot; b >= 0 && !hangs_from(engine, other_foot, b); b = engine.body_parent(b))
    for (int j = 0; j < engine.njoint(); ++j) {
      const JointInfo& info = engine.joint(j);
      if (info.body != b || info.type != JointType::kHinge) continue;
      const Eigen::Vector3d a = jac_rot.col(info.dof_adr);
      if (a.norm() > 0 && std::abs(a.normalized().dot(axis)) >= std::sqrt(0.5))
        hinges.push_back(info.dof_adr);
    }
  return hinges;
}

// +1 when the dof turns its child about +axis, -1 about -axis
double turn_sign(const Engine& engine, int foot, int dof, const Eigen::Vector3d& axis) {
  Eigen::MatrixXd jac_rot = Eigen::MatrixXd::Zero(3, engine.nv()), jac_none(3, 0);
  engine.point_jacobian(foot, engine.body_pose(foot).pos, jac_none, jac_rot);
  return jac_rot.col(dof).dot(axis) > 0 ? 1.0 : -1.0;
}

// the root of a monotonic f on [-limit, limit] by bisection; 0 when f(0) is within tolerance
struct Bisection {
  bool found = true;
  double x = 0, f_lo = 0, f_hi = 0;
};
template <class F>
Bisection bisect(const F& f, double limit, double tolerance) {
  Bisection b;
  double fx = f(0);
  if (std::abs(fx) <= tolerance) return b;
  double lo = -limit, hi = limit;
  b.f_lo = f(lo);
  b.f_hi = f(hi);
  if ((b.f_lo > 0) == (b.f_hi > 0)) {
    b.found = false;
    return b;
  }
  const bool rising = b.f_hi > b.f_lo;
  for (int i = 0; i < 100 && std::abs(fx) > tolerance; ++i) {
    b.x = 0.5 * (lo + hi);
    fx = f(b.x);
    ((fx < 0) == rising ? lo : hi) = b.x;
  }
  return b;
}

struct Frame {
  Eigen::Vector3d up, forward, left;
};

Frame character_frame(const Engine& engine, const Eigen::Vector3d& forward_hint) {
  const Eigen::Vector3d g = engine.gravity();
  if (g.squaredNorm() == 0) throw InputError("stand_pose auto: zero gravity has no standing");
  Frame f;
  f.up = -g.normalized();
  f.forward = forward_hint - forward_hint.dot(f.up) * f.up;
  if (f.forward.norm() < 1e-6) throw InputError("stand_pose auto: forward is along gravity");
  f.forward.normalize();
  f.left = f.up.cross(f.forward);
  return f;
}

}  // namespace

Eigen::Vector2d standing_com_offsets(Engine& engine, const StandingPose& pose,
                                     const Eigen::Vector3d& forward, const Eigen::VectorXd& q0,
                                     double lean_rad, double roll_rad) {
  // the thighs turn forward about left by the lean, the feet back by it: flat and level; the
  // same about forward by the roll
  Eigen::VectorXd q = q0;
  auto turn = [&](int dof, double angle) {
    q[engine.joint(engine.dof_joint(dof)).qpos_adr] += angle;
  };
  for (int side = 0; side < 2; ++side) {
    turn(pose.hip[side], pose.hip_sign[side] * lean_rad);
    turn(pose.ankle[side], -pose.ankle_sign[side] * lean_rad);
    if (!pose.roll_searched) continue;
    turn(pose.hip_roll[side], pose.hip_roll_sign[side] * roll_rad);
    turn(pose.ankle_roll[side], -pose.ankle_roll_sign[side] * roll_rad);
  }
  engine.set_positions(q);
  engine.forward();
  const Frame frame = character_frame(engine, forward);
  const Eigen::Vector3d centre = 0.5 * (engine.body_com(engine.require_body(pose.feet[0])) +
                                        engine.body_com(engine.require_body(pose.feet[1])));
  const Eigen::Vector3d com = engine.com() - centre;
  return {frame.forward.dot(com), frame.left.dot(com)};
}

double standing_com_offset(Engine& engine, const StandingPose& pose, const Eigen::Vector3d& forward,
                           const Eigen::VectorXd& q0, double lean_rad) {
  return standing_com_offsets(engine, pose, forward, q0, lean_rad, 0)[0];
}

namespace {

// the hips and ankles of both legs, in pitch and (where each leg has two) in roll
void find_leg_hinges(const Engine& engine, const std::array<int, 2>& feet, const Frame& frame,
                     StandingPose& pose) {
  pose.roll_searched = true;
  for (int side = 0; side < 2; ++side) {
    const int foot = feet[side];
    pose.feet[side] = engine.body_name(foot);
    const std::vector<int> hinges = hinges_of_leg(engine, foot, feet[1 - side], frame.left);
    if (hinges.size() < 2)
      throw InputError(fmt::format(
          "stand_pose auto: foot '{}' hangs from {} pitch hinge(s) (about the lateral axis); "
          "a hip and an ankle are needed",
          pose.feet[side], hinges.size()));
    pose.ankle[side] = hinges.front();
    pose.hip[side] = hinges.back();
    pose.ankle_sign[side] = turn_sign(engine, foot, pose.ankle[side], frame.left);
    pose.hip_sign[side] = turn_sign(engine, foot, pose.hip[side], frame.left);
    const std::vector<int> rolls = hinges_of_leg(engine, foot, feet[1 - side], frame.forward);
    if (rolls.size() < 2) {
      pose.roll_searched = false;
      continue;
    }
    pose.ankle_roll[side] = rolls.front();
    pose.hip_roll[side] = rolls.back();
    pose.ankle_roll_sign[side] = turn_sign(engine, foot, rolls.front(), frame.forward);
    pose.hip_roll_sign[side] = turn_sign(engine, foot, rolls.back(), frame.forward);
  }
}

}  // namespace

StandingPose find_standing_pose(Engine& engine, const StandingPoseOptions& options) {
  engine.forward();
  const Frame frame = character_frame(engine, options.forward);
  StandingPose pose;
  const std::array<int, 2> feet = feet_of(engine, options, frame.up);
  find_leg_hinges(engine, feet, frame, pose);

  // bisection on the lean (the COM moves forward as the legs lean forward), then, where the legs
  // roll, on the sideways lean and the lean in turn until both offsets are within tolerance
  Eigen::VectorXd q0(engine.nq());
  engine.get_positions(q0);
  auto offsets = [&](double lean, double roll) {
    return standing_com_offsets(engine, pose, options.forward, q0, lean, roll);
  };
  const Eigen::Vector2d before = offsets(0, 0);
  pose.offset_before_m = before[0];
  pose.lateral_before_m = before[1];
  const double limit = options.max_lean_rad, tol = options.tolerance_m;
  for (int round = 0; round < 20; ++round) {
    const Bisection lean =
        bisect([&](double x) { return offsets(x, pose.roll_rad)[0]; }, limit, tol);
    if (!lean.found)
      throw InputError(fmt::format(
          "stand_pose auto: no leg lean within +-{:.3g} rad puts the COM over the feet ('{}', "
          "'{}'): the COM is {:.3g} to {:.3g} m ahead of their centre",
          limit, pose.feet[0], pose.feet[1], lean.f_lo, lean.f_hi));
    pose.lean_rad = lean.x;
    if (!pose.roll_searched) break;
    const Bisection roll =
        bisect([&](double x) { return offsets(pose.lean_rad, x)[1]; }, limit, tol);
    if (!roll.found)
      throw InputError(fmt::format(
          "stand_pose auto: no sideways lean within +-{:.3g} rad puts the COM over the feet ('{}', "
          "'{}'): the COM is {:.3g} to {:.3g} m left of their centre",
          limit, pose.feet[0], pose.feet[1], roll.f_lo, roll.f_hi));
    const bool settled = roll.x == pose.roll_rad;
    pose.roll_rad = roll.x;
    if (settled || std::abs(offsets(pose.lean_rad, pose.roll_rad)[0]) <= tol) break;
  }
  const Eigen::Vector2d after = offsets(pose.lean_rad, pose.roll_rad);  // leaves the engine there
  pose.offset_m = after[0];
  pose.lateral_m = after[1];
  return pose;
}

std::string describe_standing_pose(const StandingPose& pose, const Engine& engine) {
  std::string sideways;
  if (pose.roll_searched && pose.roll_rad != 0)
    sideways = fmt::format(
        "; sideways {:+.4f} rad (hip rolls {} {}, ankle rolls {} {} back by it): COM {:+.4f} m "
        "left of the feet's centre before, {:.1e} m after",
        pose.roll_rad, engine.dof_name(pose.hip_roll[0]), engine.dof_name(pose.hip_roll[1]),
        engine.dof_name(pose.ankle_roll[0]), engine.dof_name(pose.ankle_roll[1]),
        pose.lateral_before_m, pose.lateral_m);
  else if (!pose.roll_searched)
    sideways = fmt::format(
        "; not leaned sideways (no roll hinge at a hip and an ankle of each leg): COM {:+.4f} m "
        "left of the feet's centre",
        pose.lateral_m);
  const std::string sagittal = fmt::format(
      "stand_pose auto: legs leaned {:+.4f} rad (hips {} {}, ankles {} {} back by it), feet '{}' "
      "'{}': COM {:+.4f} m ahead of the feet's centre before, {:.1e} m after",
      pose.lean_rad, engine.dof_name(pose.hip[0]), engine.dof_name(pose.hip[1]),
      engine.dof_name(pose.ankle[0]), engine.dof_name(pose.ankle[1]), pose.feet[0], pose.feet[1],
      pose.offset_before_m, pose.offset_m);
  return sagittal + sideways;
}

}  // namespace stance
