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

// the leg's pitch hinges, between the foot and the body both feet hang from (a spine's hinges
// above it are not the leg's), nearest the foot first
std::vector<int> pitch_hinges_of_leg(const Engine& engine, int foot, int other_foot,
                                     const Eigen::Vector3d& left) {
  Eigen::MatrixXd jac_rot = Eigen::MatrixXd::Zero(3, engine.nv()), jac_none(3, 0);
  engine.point_jacobian(foot, engine.body_pose(foot).pos, jac_none, jac_rot);
  std::vector<int> hinges;
  for (int b = foot; b >= 0 && !hangs_from(engine, other_foot, b); b = engine.body_parent(b))
    for (int j = 0; j < engine.njoint(); ++j) {
      const JointInfo& info = engine.joint(j);
      if (info.body != b || info.type != JointType::kHinge) continue;
      const Eigen::Vector3d axis = jac_rot.col(info.dof_adr);
      if (axis.norm() > 0 && std::abs(axis.normalized().dot(left)) >= std::sqrt(0.5))
        hinges.push_back(info.dof_adr);
    }
  return hinges;
}

// +1 when the dof turns its child about +left, -1 about -left
double turn_sign(const Engine& engine, int foot, int dof, const Eigen::Vector3d& left) {
  Eigen::MatrixXd jac_rot = Eigen::MatrixXd::Zero(3, engine.nv()), jac_none(3, 0);
  engine.point_jacobian(foot, engine.body_pose(foot).pos, jac_none, jac_rot);
  return jac_rot.col(dof).dot(left) > 0 ? 1.0 : -1.0;
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

double standing_com_offset(Engine& engine, const StandingPose& pose, const Eigen::Vector3d& forward,
                           const Eigen::VectorXd& q0, double lean_rad) {
  // the thighs turn forward about left by the lean, the feet back by it: flat and level
  Eigen::VectorXd q = q0;
  for (int side = 0; side < 2; ++side) {
    q[engine.joint(engine.dof_joint(pose.hip[side])).qpos_adr] += pose.hip_sign[side] * lean_rad;
    q[engine.joint(engine.dof_joint(pose.ankle[side])).qpos_adr] -=
        pose.ankle_sign[side] * lean_rad;
  }
  engine.set_positions(q);
  engine.forward();
  const Eigen::Vector3d fwd = character_frame(engine, forward).forward;
  const Eigen::Vector3d centre = 0.5 * (engine.body_com(engine.require_body(pose.feet[0])) +
                                        engine.body_com(engine.require_body(pose.feet[1])));
  return fwd.dot(engine.com() - centre);
}

StandingPose find_standing_pose(Engine& engine, const StandingPoseOptions& options) {
  engine.forward();
  const Frame frame = character_frame(engine, options.forward);
  StandingPose pose;
  const std::array<int, 2> feet = feet_of(engine, options, frame.up);
  for (int side = 0; side < 2; ++side) {
    const int foot = feet[side];
    pose.feet[side] = engine.body_name(foot);
    const std::vector<int> hinges = pitch_hinges_of_leg(engine, foot, feet[1 - side], frame.left);
    if (hinges.size() < 2)
      throw InputError(fmt::format(
          "stand_pose auto: foot '{}' hangs from {} pitch hinge(s) (about the lateral axis); "
          "a hip and an ankle are needed",
          pose.feet[side], hinges.size()));
    pose.ankle[side] = hinges.front();
    pose.hip[side] = hinges.back();
    pose.ankle_sign[side] = turn_sign(engine, foot, pose.ankle[side], frame.left);
    pose.hip_sign[side] = turn_sign(engine, foot, pose.hip[side], frame.left);
  }

  // bisection on the lean: the COM moves forward as the legs lean forward
  Eigen::VectorXd q0(engine.nq());
  engine.get_positions(q0);
  auto offset = [&](double lean) {
    return standing_com_offset(engine, pose, options.forward, q0, lean);
  };
  pose.offset_before_m = offset(0);
  double lo = -options.max_lean_rad, hi = options.max_lean_rad;
  double f_lo = offset(lo), f_hi = offset(hi);
  if (f_lo > 0 || f_hi < 0)
    throw InputError(fmt::format(
        "stand_pose auto: no leg lean within +-{:.3g} rad puts the COM over the feet ('{}', "
        "'{}'): the COM is {:.3g} to {:.3g} m ahead of their centre",
        options.max_lean_rad, pose.feet[0], pose.feet[1], f_lo, f_hi));
  double lean = 0, f = pose.offset_before_m;
  for (int i = 0; i < 100 && std::abs(f) > options.tolerance_m; ++i) {
    lean = 0.5 * (lo + hi);
    f = offset(lean);
    (f < 0 ? lo : hi) = lean;
  }
  pose.lean_rad = lean;
  pose.offset_m = offset(lean);  // leaves the engine in the pose
  return pose;
}

std::string describe_standing_pose(const StandingPose& pose, const Engine& engine) {
  return fmt::format(
      "stand_pose auto: legs leaned {:+.4f} rad (hips {} {}, ankles {} {} back by it), feet '{}' "
      "'{}': COM {:+.4f} m ahead of the feet's centre before, {:.1e} m after",
      pose.lean_rad, engine.dof_name(pose.hip[0]), engine.dof_name(pose.hip[1]),
      engine.dof_name(pose.ankle[0]), engine.dof_name(pose.ankle[1]), pose.feet[0], pose.feet[1],
      pose.offset_before_m, pose.offset_m);
}

}  // namespace stance
