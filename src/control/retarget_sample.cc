#include "control/retarget.h"

#include <algorithm>

#include "control/retarget_probe.h"
#include "math/rotations.h"

namespace stance {

Eigen::Quaterniond RetargetedMotion::clip_world_rotation(
    int i, const Eigen::Quaterniond& body_world) const {
  // inverts R_b = M W_s A_s M^T R_b(rest)
  return (to_model_.conjugate() * body_world * rest_world_[i].conjugate() * to_model_ *
          bone_fix_[i].conjugate())
      .normalized();
}

Eigen::Vector3d RetargetedMotion::clip_root_position(const Eigen::Vector3d& body_position) const {
  return to_model_.conjugate() * (body_position - height_offset_ * up_) / scale_;
}

void RetargetedMotion::sample_world(double t, std::vector<Eigen::Quaterniond>& world) const {
  int f;
  double alpha;
  locate(t, f, alpha);
  const size_t n = bodies_.size();
  for (size_t i = 0; i < n; ++i) {
    size_t a = static_cast<size_t>(f) * n + i;
    world[i] = slerp(world_[a], world_[a + n], alpha);
  }
}

void RetargetedMotion::set_body_local(int i, const Eigen::Quaterniond& local,
                                      Eigen::VectorXd& q) const {
  const std::vector<JointSlot>& joints = joints_[i];
  double angles[kMaxHinges];
  int n = 0;
  for (const JointSlot& j : joints)
    if (j.type == JointType::kHinge) angles[n++] = q[j.qpos];  // warm start: q's own values
  if (n > 0) {
    solve_hinges(joints, local, bone_[i], angles, n);
    n = 0;
    for (const JointSlot& j : joints)
      if (j.type == JointType::kHinge) q[j.qpos] = angles[n++];
  }
  for (const JointSlot& j : joints)
    if (j.type == JointType::kBall)
      set_joint_rotation(
          j, Eigen::Quaterniond(j.frame.transpose() * local.toRotationMatrix() * j.frame), q);
}

void RetargetedMotion::locate(double t, int& f, double& alpha) const {
  double x = std::max(t, 0.0) / frame_time_;
  f = std::min(static_cast<int>(x), frames_ - 2);
  alpha = std::clamp(x - f, 0.0, 1.0);
}

void RetargetedMotion::sample(const Engine& engine, double t, Eigen::Ref<Eigen::VectorXd> q,
                              Eigen::Ref<Eigen::VectorXd> v,
                              Eigen::Ref<Eigen::VectorXd> scratch) const {
  int f;
  double alpha;
  locate(t, f, alpha);
  engine.difference_positions(frame(f), frame(f + 1), scratch);
  engine.integrate_positions(frame(f), scratch, alpha, q);
  Eigen::Map<const Eigen::VectorXd> v0(v_.data() + static_cast<size_t>(f) * nv_, nv_);
  Eigen::Map<const Eigen::VectorXd> v1(v_.data() + static_cast<size_t>(f + 1) * nv_, nv_);
  v = (1 - alpha) * v0 + alpha * v1;
}

BodyPose RetargetedMotion::sample_body_pose(double t, int i) const {
  int f;
  double alpha;
  locate(t, f, alpha);
  const size_t a = static_cast<size_t>(f) * bodies_.size() + i, b = a + bodies_.size();
  BodyPose out;
  out.pos = (1 - alpha) * position_[a] + alpha * position_[b];
  out.quat = slerp(world_[a], world_[b], alpha);
  return out;
}

Eigen::Vector3d RetargetedMotion::sample_body_acceleration(double t, int i) const {
  auto position = [&](double at) {  // sample_body_pose's position without its slerp
    int f;
    double alpha;
    locate(at, f, alpha);
    const size_t a = static_cast<size_t>(f) * bodies_.size() + i, b = a + bodies_.size();
    return Eigen::Vector3d((1 - alpha) * position_[a] + alpha * position_[b]);
  };
  const double h = 0.03;
  return (position(t + h) - 2 * position(t) + position(t - h)) / (h * h);
}

Eigen::Quaterniond RetargetedMotion::sample_body_local(double t, int i) const {
  int f;
  double alpha;
  locate(t, f, alpha);
  const size_t a = static_cast<size_t>(f) * bodies_.size() + i;
  return slerp(local_[a], local_[a + bodies_.size()], alpha);
}

void RetargetedMotion::sample_bodies(double t, std::vector<Eigen::Quaterniond>& local,
                                     std::vector<Eigen::Vector3d>& position) const {
  int f;
  double alpha;
  locate(t, f, alpha);
  const size_t n = bodies_.size();
  for (size_t i = 0; i < n; ++i) {
    size_t a = static_cast<size_t>(f) * n + i, b = a + n;
    local[i] = slerp(local_[a], local_[b], alpha);
    position[i] = (1 - alpha) * position_[a] + alpha * position_[b];
  }
}

}  // namespace stance
