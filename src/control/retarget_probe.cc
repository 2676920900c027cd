#include "control/retarget_probe.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "math/rotations.h"

namespace stance {

namespace {

constexpr double kProbeAngle = 0.5;  // rad; rotations about one axis are probed exactly

// a rotation probed about one axis: the rotation vector of before^T * after, per radian
Eigen::Vector3d probed_axis(const Eigen::Quaterniond& before, const Eigen::Quaterniond& after) {
  return quaternion_log((before.conjugate() * after).normalized()) / kProbeAngle;
}

}  // namespace

void set_joint_rotation(const JointSlot& j, const Eigen::Quaterniond& r, Eigen::VectorXd& q) {
  if (j.nq == 4 || j.nq == 7) {
    int a = j.qpos + (j.nq == 7 ? 3 : 0);
    // the sign nearest the previous value keeps the table continuous
    const double s = r.w() * q[a] + r.x() * q[a + 1] + r.y() * q[a + 2] + r.z() * q[a + 3];
    if (s < 0) {
      q[a] = -r.w();
      q[a + 1] = -r.x();
      q[a + 2] = -r.y();
      q[a + 3] = -r.z();
      return;
    }
    q[a] = r.w();
    q[a + 1] = r.x();
    q[a + 2] = r.y();
    q[a + 3] = r.z();
  } else {
    q.segment<3>(j.qpos) = quaternion_log(r);
  }
}

Eigen::Quaterniond hinge_rotation(const std::vector<JointSlot>& joints, const double* angles) {
  Eigen::Quaterniond r = Eigen::Quaterniond::Identity();
  int k = 0;
  for (const JointSlot& j : joints)
    if (j.type == JointType::kHinge)
      r = r * Eigen::Quaterniond(Eigen::AngleAxisd(angles[k++], j.axis));
  return r;
}

void solve_hinges(const std::vector<JointSlot>& joints, const Eigen::Quaterniond& want,
                  const Eigen::Vector3d& bone, double* angles, int n) {
  const bool aim = n < 3 && bone.squaredNorm() > 0;
  const double twist_weight = aim ? 0.1 : 1.0;
  const Eigen::Vector3d bone_want = want * bone;
  auto residual = [&](Eigen::Matrix<double, 6, 1>& r) {
    const Eigen::Quaterniond q = hinge_rotation(joints, angles);
    r.head<3>() = twist_weight * quaternion_log(want.conjugate() * q);
    r.tail<3>() = aim ? Eigen::Vector3d(q * bone - bone_want) : Eigen::Vector3d::Zero();
  };
  // fixed capacity: the solve also runs inside controllers, which must not allocate
  Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxHinges> jac(6, n);
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxHinges, 1> step(n);
  Eigen::Matrix<double, 6, 1> r, rh;
  for (int iter = 0; iter < 30; ++iter) {
    residual(r);
    if (r.norm() < 1e-12) break;
    const double h = 1e-7;
    for (int k = 0; k < n; ++k) {
      angles[k] += h;
      residual(rh);
      jac.col(k) = (rh - r) / h;
      angles[k] -= h;
    }
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxHinges, kMaxHinges> jtj =
        jac.transpose() * jac;
    jtj.diagonal().array() += 1e-9;
    step = jtj.ldlt().solve(jac.transpose() * r);
    double max_step = step.cwiseAbs().maxCoeff();
    if (max_step > 0.5) step *= 0.5 / max_step;  // stay in the basin across the wrap
    for (int k = 0; k < n; ++k) angles[k] -= step[k];
    if (max_step < 1e-12) break;
  }
  int k = 0;
  for (const JointSlot& j : joints) {
    if (j.type != JointType::kHinge) continue;
    if (j.limited && j.lower < j.upper) angles[k] = std::clamp(angles[k], j.lower, j.upper);
    ++k;
  }
}

std::vector<RetargetModelBody> read_model_tree(const Engine& probe) {
  std::vector<RetargetModelBody> model(probe.nbody());
  for (int b = 0; b < probe.nbody(); ++b) model[b].parent = probe.body_parent(b);
  for (int j = 0; j < probe.njoint(); ++j) {
    const JointInfo& info = probe.joint(j);
    if (info.body < 0) continue;
    JointSlot slot;
    slot.type = info.type;
    slot.qpos = info.qpos_adr;
    slot.nq = info.nq;
    slot.limited = info.has_limits;
    slot.lower = info.lower;
    slot.upper = info.upper;
    model[info.body].joints.push_back(slot);
  }
  for (int b = 0; b < probe.nbody(); ++b)
    for (int a = model[b].parent; a >= 0; a = model[a].parent) ++model[b].depth;
  return model;
}

void set_pose(Engine& probe, const Eigen::VectorXd& q) {
  probe.set_positions(q);
  probe.set_velocities(Eigen::VectorXd::Zero(probe.nv()));
  probe.forward();
}

Eigen::Matrix3d probe_kinematics(Engine& probe, std::vector<RetargetModelBody>& model,
                                 const std::vector<int>& order, int free_body,
                                 const JointSlot& free_joint, Eigen::VectorXd& q0) {
  // the zero pose: hinges and slides 0, balls and the free joint at identity, root at origin
  probe.get_positions(q0);
  for (int b : order)
    for (const JointSlot& j : model[b].joints) {
      if (j.type == JointType::kHinge || j.type == JointType::kSlide) q0[j.qpos] = 0;
      if (j.type == JointType::kBall || j.type == JointType::kFree)
        set_joint_rotation(j, Eigen::Quaterniond::Identity(), q0);
      if (j.type == JointType::kFree) set_joint_translation(j, Eigen::Vector3d::Zero(), q0);
    }
  auto pose_at = [&](const Eigen::VectorXd& q) { set_pose(probe, q); };
  pose_at(q0);
  for (int b : order) {
    BodyPose p = probe.body_pose(b);
    model[b].rest_world = p.quat;
    model[b].rest_pos = p.pos;
  }
  for (int b : order) {
    Eigen::Quaterniond parent =
        model[b].parent >= 0 ? model[model[b].parent].rest_world : Eigen::Quaterniond::Identity();
    model[b].rest_local = (parent.conjugate() * model[b].rest_world).normalized();
  }
  // probe hinge axes and ball/free frames, one coordinate at a time from the zero pose
  Eigen::VectorXd qp(q0.size());
  for (int b : order)
    for (JointSlot& j : model[b].joints) {
      if (j.type == JointType::kHinge) {
        qp = q0;
        qp[j.qpos] = kProbeAngle;
        pose_at(qp);
        j.axis = probed_axis(model[b].rest_world, probe.body_pose(b).quat);
        if (std::abs(j.axis.norm() - 1) > 1e-6)
          throw InputError(fmt::format("retarget: cannot probe the axis of a hinge of body '{}'",
                                       probe.body_name(b)));
        j.axis.normalize();
      } else if (j.type == JointType::kBall || j.type == JointType::kFree) {
        for (int c = 0; c < 3; ++c) {
          qp = q0;
          set_joint_rotation(
              j, Eigen::Quaterniond(Eigen::AngleAxisd(kProbeAngle, Eigen::Vector3d::Unit(c))), qp);
          pose_at(qp);
          j.frame.col(c) = probed_axis(model[b].rest_world, probe.body_pose(b).quat);
        }
        if ((j.frame.transpose() * j.frame - Eigen::Matrix3d::Identity()).norm() > 1e-6)
          throw InputError(fmt::format("retarget: cannot probe the frame of the joint of body '{}'",
                                       probe.body_name(b)));
      }
    }
  // the free joint's translation: linear in its coordinates
  Eigen::Matrix3d translation_map;
  for (int c = 0; c < 3; ++c) {
    qp = q0;
    set_joint_translation(free_joint, Eigen::Vector3d::Unit(c), qp);
    pose_at(qp);
    translation_map.col(c) = probe.body_pose(free_body).pos - model[free_body].rest_pos;
  }
  if (std::abs(translation_map.determinant()) < 1e-9)
    throw InputError("retarget: the free joint's translation could not be probed");
  return translation_map.inverse();
}

void fold_hinge_chains(std::vector<RetargetModelBody>& model, const std::vector<int>& order,
                       int free_body) {
  std::vector<int> children(model.size(), 0);
  for (int b : order)
    if (model[b].parent >= 0) ++children[model[b].parent];
  auto hinges_of = [&](int b) {
    int n = 0;
    for (const JointSlot& j : model[b].joints) n += j.type == JointType::kHinge ? 1 : 100;
    return n;  // a ball, slide or free joint: never folded
  };
  for (int b : order) {
    if (model[b].mapped < 0 || b == free_body) continue;
    int hinges = hinges_of(b);
    RetargetModelBody& mb = model[b];
    for (int p = mb.parent; p >= 0 && p != free_body && model[p].mapped < 0 && children[p] == 1 &&
                            hinges < 3 && hinges + hinges_of(p) <= kMaxHinges;
         p = mb.parent) {
      std::vector<JointSlot> folded = model[p].joints;
      for (JointSlot& j : folded)
        j.axis = (mb.rest_world.conjugate() * model[p].rest_world * j.axis).normalized();
      hinges += hinges_of(p);
      mb.joints.insert(mb.joints.begin(), folded.begin(), folded.end());
      mb.rest_local = (model[p].rest_local * mb.rest_local).normalized();
      mb.parent = model[p].parent;
      model[p].joints.clear();
    }
  }
}

}  // namespace stance
