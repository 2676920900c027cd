#include "control/retarget.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <Eigen/Dense>

#include "core/error.h"
#include "engine/engine.h"
#include "math/rotations.h"

namespace stance {

namespace {

constexpr double kProbeAngle = 0.5;  // rad; rotations about one axis are probed exactly
constexpr int kMaxHinges = 6;        // per body

// one joint of a model body, with what probing found out about it
using JointSlot = RetargetJoint;

struct ModelBody {
  int parent = -1;
  std::vector<JointSlot> joints;
  Eigen::Quaterniond rest_world = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond rest_local = Eigen::Quaterniond::Identity();  // B: parent^T * body at rest
  Eigen::Vector3d rest_pos = Eigen::Vector3d::Zero();
  int mapped = -1;  // index into the map's entries
  int depth = 0;
};

// the rotation part of a ball or free joint in the engine's coordinates: MuJoCo stores a
// quaternion (w x y z; free: after the position), DART a rotation vector (free: before it)
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

template <class Q>
void set_joint_translation(const JointSlot& j, const Eigen::Vector3d& p, Q& q) {
  q.template segment<3>(j.qpos + (j.nq == 7 ? 0 : 3)) = p;
}

template <class Q>
Eigen::Vector3d frame_translation(const JointSlot& j, const Q& q) {
  return q.template segment<3>(j.qpos + (j.nq == 7 ? 0 : 3));
}

// the rotation of a body's hinge chain: the product of its hinges in joint order
Eigen::Quaterniond hinge_rotation(const std::vector<JointSlot>& joints, const double* angles) {
  Eigen::Quaterniond r = Eigen::Quaterniond::Identity();
  int k = 0;
  for (const JointSlot& j : joints)
    if (j.type == JointType::kHinge)
      r = r * Eigen::Quaterniond(Eigen::AngleAxisd(angles[k++], j.axis));
  return r;
}

// the hinge angles whose product is closest to `want` (Gauss-Newton from `angles`, then limits).
// With a bone direction `bone` (unit, body frame; zero: none), a chain too short to reach every
// rotation (fewer than three hinges) puts the bone on the wanted direction first and fits the
// twist only as well as it can: a two-hinge shoulder aims the upper arm rather than splitting
// the difference between aim and twist.
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

// a rotation probed about one axis: the rotation vector of before^T * after, per radian
Eigen::Vector3d probed_axis(const Eigen::Quaterniond& before, const Eigen::Quaterniond& after) {
  return quaternion_log((before.conjugate() * after).normalized()) / kProbeAngle;
}

// the model's bodies (parents, depths) and the joints on each
std::vector<ModelBody> read_model_tree(const Engine& probe) {
  std::vector<ModelBody> model(probe.nbody());
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

// positions q at rest, kinematics updated
void set_pose(Engine& probe, const Eigen::VectorXd& q) {
  probe.set_positions(q);
  probe.set_velocities(Eigen::VectorXd::Zero(probe.nv()));
  probe.forward();
}

// Fills the bodies' rest poses (in q0, the zero pose it writes), hinge axes and ball/free joint
// frames by setting one coordinate at a time and reading the body's rotation; returns the
// inverse of the free joint's translation map (coordinates -> world displacement).
Eigen::Matrix3d probe_kinematics(Engine& probe, std::vector<ModelBody>& model,
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

}  // namespace

RetargetedMotion::RetargetedMotion(const ReferenceMotion& reference, const JointMap& map,
                                   Engine& probe, double duration_s,
                                   const std::vector<int>& level_feet) {
  const MotionSkeleton& sk = reference.skeleton();
  const int nb = probe.nbody();
  nq_ = probe.nq();
  nv_ = probe.nv();
  frame_time_ = reference.frame_time_s();

  std::vector<ModelBody> model = read_model_tree(probe);

  // the map's entries, resolved
  std::vector<int> segment_body(sk.segment_count(), -1);
  for (size_t e = 0; e < map.joints.size(); ++e) {
    const JointMapEntry& entry = map.joints[e];
    auto where = [&](const std::string& msg) { return located(map.source, entry.line, msg); };
    int s = sk.find_segment(entry.segment);
    if (s < 0) {
      std::vector<std::string> names;
      for (const auto& seg : sk.segments) names.push_back(seg.name);
      if (std::find(sk.joint_names.begin(), sk.joint_names.end(), entry.segment) !=
          sk.joint_names.end())
        throw InputError(where(
            fmt::format("clip joint '{}' is no segment of its own (merged into its parent: zero "
                        "length, or a helper that is skipped); map one of: {}",
                        entry.segment, fmt::join(names, ", "))));
      throw InputError(where(fmt::format("the clip has no joint '{}'{}", entry.segment,
                                         did_you_mean(entry.segment, names))));
    }
    int b = probe.body_index(entry.body);
    if (b < 0)
      throw InputError(where(fmt::format("the model has no body '{}'{}", entry.body,
                                         did_you_mean(entry.body, probe.body_names()))));
    if (segment_body[s] >= 0)
      throw InputError(where(fmt::format("clip joint '{}' is mapped twice", entry.segment)));
    if (model[b].mapped >= 0)
      throw InputError(where(fmt::format("model body '{}' is mapped twice", entry.body)));
    segment_body[s] = b;
    model[b].mapped = static_cast<int>(e);
    bodies_.push_back({b, s, entry.segment + " -> " + entry.body});
  }
  const int root_body = segment_body[0];
  if (root_body < 0)
    throw InputError(located(
        map.source, 1,
        fmt::format("joints: map the clip's root '{}' onto a model body", sk.segments[0].name)));
  // the character's free joint: at the top of the root body's tree
  int free_body = root_body;
  while (model[free_body].parent >= 0) free_body = model[free_body].parent;
  const JointSlot* free_joint = nullptr;
  for (const JointSlot& j : model[free_body].joints)
    if (j.type == JointType::kFree) free_joint = &j;
  if (!free_joint)
    throw InputError(located(map.source, 1,
                             fmt::format("the model's body '{}' has no free joint: retargeting "
                                         "needs a floating base",
                                         probe.body_name(free_body))));
  std::vector<int> order;  // the character's bodies, parents first
  for (int b = 0; b < nb; ++b) {
    int top = b;
    while (model[top].parent >= 0) top = model[top].parent;
    if (top == free_body) order.push_back(b);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return model[a].depth < model[b].depth; });
  for (const RetargetBody& rb : bodies_)
    if (std::find(order.begin(), order.end(), rb.body) == order.end())
      throw InputError(located(map.source, map.joints[model[rb.body].mapped].line,
                               fmt::format("body '{}' is not part of the character under '{}'",
                                           probe.body_name(rb.body), probe.body_name(free_body))));

  // rest poses, hinge axes, joint frames and the root's translation, probed
  Eigen::VectorXd q0(nq_), qp(nq_);
  const Eigen::Matrix3d translation_inverse =
      probe_kinematics(probe, model, order, free_body, *free_joint, q0);
  auto pose_at = [&](const Eigen::VectorXd& q) { set_pose(probe, q); };

  // clip -> model world: the up axis, then a yaw and scale from the rest skeletons
  const Eigen::Quaterniond up_turn =
      map.model_up == 'y'
          ? Eigen::Quaterniond(Eigen::AngleAxisd(-std::numbers::pi / 2, Eigen::Vector3d::UnitX()))
          : Eigen::Quaterniond::Identity();
  const Eigen::Vector3d up = up_turn * Eigen::Vector3d::UnitZ();
  ReferencePose pose = reference.make_pose();
  for (auto& r : pose.rotations) r.setIdentity();
  pose.root_position.setZero();
  std::vector<Eigen::Vector3d> clip_pos(sk.segment_count());
  std::vector<Eigen::Quaterniond> clip_rot(sk.segment_count());
  reference.forward_kinematics(pose, clip_pos, clip_rot);
  const std::vector<Eigen::Vector3d> clip_rest = clip_pos;
  double cross = 0, dot = 0, clip_lo = 1e300, clip_hi = -1e300, model_lo = 1e300, model_hi = -1e300;
  for (const RetargetBody& rb : bodies_) {
    Eigen::Vector3d rs = clip_rest[rb.segment] - clip_rest[0];
    Eigen::Vector3d rm =
        up_turn.conjugate() * (model[rb.body].rest_pos - model[root_body].rest_pos);
    cross += rs.x() * rm.y() - rs.y() * rm.x();
    dot += rs.x() * rm.x() + rs.y() * rm.y();
    clip_lo = std::min(clip_lo, rs.z());
    clip_hi = std::max(clip_hi, rs.z());
    model_lo = std::min(model_lo, rm.z());
    model_hi = std::max(model_hi, rm.z());
  }
  yaw_ = map.yaw_deg ? *map.yaw_deg / kRadToDeg
                     : (cross == 0 && dot == 0 ? 0 : std::atan2(cross, dot));
  scale_ = map.scale ? *map.scale
                     : (clip_hi - clip_lo > 1e-6 && model_hi - model_lo > 1e-6
                            ? (model_hi - model_lo) / (clip_hi - clip_lo)
                            : 1.0);
  const Eigen::Quaterniond to_model =
      up_turn * Eigen::Quaterniond(Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()));

  // rest-pose correction: a body with one mapped child bone turns onto the clip's bone
  const int nmapped = static_cast<int>(bodies_.size());
  std::vector<Eigen::Quaterniond> bone_fix(nmapped, Eigen::Quaterniond::Identity());
  std::vector<int> mapped_of_segment(sk.segment_count(), -1);
  for (int i = 0; i < nmapped; ++i) mapped_of_segment[bodies_[i].segment] = i;
  std::vector<std::vector<int>> mapped_children(nmapped);
  for (int i = 0; i < nmapped; ++i)
    for (int a = sk.segments[bodies_[i].segment].parent; a >= 0; a = sk.segments[a].parent)
      if (mapped_of_segment[a] >= 0) {
        mapped_children[mapped_of_segment[a]].push_back(i);
        break;
      }
  // each mapped body's bone towards its one mapped child, in its own frame (the hinge fit aims it)
  std::vector<Eigen::Vector3d> bone(nb, Eigen::Vector3d::Zero());
  for (int i = 0; i < nmapped; ++i) {
    if (mapped_children[i].size() != 1) continue;
    const int b = bodies_[i].body;
    Eigen::Vector3d d = model[bodies_[mapped_children[i][0]].body].rest_pos - model[b].rest_pos;
    if (d.norm() > 1e-6) bone[b] = model[b].rest_world.conjugate() * d.normalized();
  }
  if (map.align_bones) {
    for (int i = 0; i < nmapped; ++i) {
      const RetargetBody& rb = bodies_[i];
      if (rb.segment == 0) continue;
      // the bone: towards the one mapped child (leaves keep their rest offset: a one-hinge
      // elbow cannot take a forearm turned onto the clip's)
      Eigen::Vector3d bone_clip = Eigen::Vector3d::Zero(), bone_model = Eigen::Vector3d::Zero();
      if (mapped_children[i].size() == 1) {
        const RetargetBody& child = bodies_[mapped_children[i][0]];
        bone_clip = clip_rest[child.segment] - clip_rest[rb.segment];
        bone_model = model[child.body].rest_pos - model[rb.body].rest_pos;
      }
      bone_model = to_model.conjugate() * bone_model;
      if (bone_clip.norm() > 1e-6 && bone_model.norm() > 1e-6)
        bone_fix[i] = Eigen::Quaterniond::FromTwoVectors(bone_model, bone_clip);
    }
  }

  to_model_ = to_model;
  up_ = up;
  bone_fix_ = bone_fix;
  for (const RetargetBody& rb : bodies_) {
    rest_world_.push_back(model[rb.body].rest_world);
    rest_local_.push_back(model[rb.body].rest_local);
    joints_.push_back(model[rb.body].joints);
    bone_.push_back(bone[rb.body]);
    int hinges = 0;
    for (const JointSlot& j : model[rb.body].joints) hinges += j.type == JointType::kHinge;
    if (hinges > kMaxHinges)
      throw InputError(fmt::format("retarget: body '{}' has {} hinges (at most {})",
                                   probe.body_name(rb.body), hinges, kMaxHinges));
  }

  // the table: one pose per clip frame over the run (at least one pass)
  int frames = reference.frame_count();
  if (reference.loops() && duration_s > 0) {
    if (duration_s > 3600)
      throw InputError("retarget: runs longer than an hour are not tabulated; shorten duration");
    frames = std::max(frames, static_cast<int>(std::ceil(duration_s / frame_time_)) + 2);
  }
  frames_ = std::max(frames, 2);
  q_.resize(static_cast<size_t>(frames_) * nq_);
  local_.resize(static_cast<size_t>(frames_) * nmapped);
  world_.resize(static_cast<size_t>(frames_) * nmapped);
  position_.resize(static_cast<size_t>(frames_) * nmapped);
  std::vector<Eigen::Quaterniond> want(nb), actual(nb);
  body_fit_error_.assign(nmapped, 0.0);
  body_aim_error_.assign(nmapped, 0.0);
  std::vector<double> angles(8);
  Eigen::VectorXd q = q0;
  double fit_sum = 0;
  long fit_count = 0;
  // planted feet: per frame and levelled body, how planted the clip has it (1 within 2 cm of
  // its planted height and below 0.3 m/s; 0 from 5 cm above it or 0.8 m/s), on the model's scale
  std::vector<int> flat;  // mapped indices
  for (int i = 0; i < nmapped; ++i)
    if (std::find(level_feet.begin(), level_feet.end(), bodies_[i].segment) != level_feet.end())
      flat.push_back(i);
  std::vector<double> planted(static_cast<size_t>(frames_) * flat.size(), 0.0);
  // each levelled body's sole up, in its own frame: its up at the model's rest
  std::vector<Eigen::Vector3d> sole_up_local(flat.size());
  for (size_t k = 0; k < flat.size(); ++k)
    sole_up_local[k] = model[bodies_[flat[k]].body].rest_world.conjugate() * up;
  if (!flat.empty()) {
    std::vector<Eigen::Vector3d> seen(static_cast<size_t>(frames_) * flat.size());
    std::vector<Eigen::Quaterniond> seen_rot(seen.size());
    for (int f = 0; f < frames_; ++f) {
      reference.sample(f * frame_time_, pose);
      reference.forward_kinematics(pose, clip_pos, clip_rot);
      for (size_t k = 0; k < flat.size(); ++k) {
        const RetargetBody& rb = bodies_[flat[k]];
        seen[f * flat.size() + k] = scale_ * clip_pos[rb.segment];
        seen_rot[f * flat.size() + k] = to_model * clip_rot[rb.segment] * bone_fix[flat[k]] *
                                        to_model.conjugate() * model[rb.body].rest_world;
      }
    }
    // a body's planted height: the 20th percentile of its heights (a walk stands more than a
    // fifth of the time; the lowest frame alone is a capture's noise or a crouch)
    std::vector<double> lowest(flat.size()), heights(frames_);
    for (size_t k = 0; k < flat.size(); ++k) {
      for (int f = 0; f < frames_; ++f) heights[f] = seen[f * flat.size() + k].z();
      std::nth_element(heights.begin(), heights.begin() + frames_ / 5, heights.end());
      lowest[k] = heights[frames_ / 5];
    }
    for (int f = 0; f < frames_; ++f)
      for (size_t k = 0; k < flat.size(); ++k) {
        const int g = f + 1 < frames_ ? f + 1 : f - 1;
        const Eigen::Vector3d d = seen[g * flat.size() + k] - seen[f * flat.size() + k];
        const double speed = std::hypot(d.x(), d.y()) / frame_time_;
        const double rise = seen[f * flat.size() + k].z() - lowest[k];
        planted[f * flat.size() + k] =
            std::clamp((0.05 - rise) / 0.03, 0.0, 1.0) * std::clamp((0.8 - speed) / 0.5, 0.0, 1.0);
      }
    // where the model's rest pose does not stand (a character built from a clip whose rest pose
    // lies along X, as Bandai Namco's), the rest up is no sole's: the world's up as the planted
    // body sees it, on the mean, is, where that is more than 45 deg from the rest up. A standing
    // rest pose's feet (pitched at most some 30 deg while they stand) keep their rest up.
    for (size_t k = 0; k < flat.size(); ++k) {
      Eigen::Vector3d seen_up = Eigen::Vector3d::Zero();
      for (int f = 0; f < frames_; ++f)
        seen_up += planted[f * flat.size() + k] * (seen_rot[f * flat.size() + k].conjugate() * up);
      if (seen_up.norm() > 1e-9 &&
          seen_up.normalized().dot(sole_up_local[k]) < std::cos(std::numbers::pi / 4))
        sole_up_local[k] = seen_up.normalized();
    }
  }
  for (int f = 0; f < frames_; ++f) {
    reference.sample(f * frame_time_, pose);
    reference.forward_kinematics(pose, clip_pos, clip_rot);
    for (int i = 0; i < nmapped; ++i) {
      const RetargetBody& rb = bodies_[i];
      want[rb.body] = to_model * clip_rot[rb.segment] * bone_fix[i] * to_model.conjugate() *
                      model[rb.body].rest_world;
    }
    // a planted foot turned level: its up at the model's rest onto the world's up
    for (size_t k = 0; k < flat.size(); ++k) {
      const double w = planted[f * flat.size() + k];
      if (w <= 0) continue;
      const int b = bodies_[flat[k]].body;
      const Eigen::Vector3d sole_up = want[b] * sole_up_local[k];
      const Eigen::Quaterniond level = Eigen::Quaterniond::FromTwoVectors(sole_up, up) * want[b];
      want[b] = want[b].slerp(w, level).normalized();
    }
    for (int b : order) {
      const ModelBody& mb = model[b];
      const Eigen::Quaterniond parent =
          mb.parent >= 0 ? actual[mb.parent] : Eigen::Quaterniond::Identity();
      const Eigen::Quaterniond base = parent * mb.rest_local;
      Eigen::Quaterniond target = base;  // unmapped: joints at zero
      if (mb.mapped >= 0) {
        target = want[b];
      } else if (b == free_body) {
        // an unmapped floating body follows the mapped body nearest below it, rigidly
        for (int i = 0; i < nmapped; ++i) {
          int a = bodies_[i].body;
          while (a >= 0 && a != b) a = model[a].parent;
          if (a == b) {
            target = want[bodies_[i].body] * model[bodies_[i].body].rest_world.conjugate() *
                     mb.rest_world;
            break;
          }
        }
      }
      const Eigen::Quaterniond local_want = (base.conjugate() * target).normalized();
      Eigen::Quaterniond local = Eigen::Quaterniond::Identity();
      int hinges = 0;
      for (const JointSlot& j : mb.joints) hinges += j.type == JointType::kHinge;
      if (hinges > 0) {
        if (static_cast<int>(angles.size()) < hinges) angles.resize(hinges);
        int k = 0;
        for (const JointSlot& j : mb.joints)
          if (j.type == JointType::kHinge) angles[k++] = f > 0 ? q[j.qpos] : 0.0;
        if (mb.mapped >= 0) solve_hinges(mb.joints, local_want, bone[b], angles.data(), hinges);
        k = 0;
        for (const JointSlot& j : mb.joints)
          if (j.type == JointType::kHinge) q[j.qpos] = angles[k++];
        local = hinge_rotation(mb.joints, angles.data());
      }
      for (const JointSlot& j : mb.joints)
        if (j.type == JointType::kBall || j.type == JointType::kFree) {
          Eigen::Matrix3d t = j.frame;
          Eigen::Quaterniond joint_q(t.transpose() * local_want.toRotationMatrix() * t);
          set_joint_rotation(j, joint_q.normalized(), q);
          local = local_want;
        }
      actual[b] = (base * local).normalized();
      if (mb.mapped >= 0) {
        double e = geodesic_angle(actual[b], want[b]) * kRadToDeg;
        body_fit_error_[mb.mapped] += e / frames_;
        if (bone[b].squaredNorm() > 0) {
          const Eigen::Vector3d got = actual[b] * bone[b], wanted = want[b] * bone[b];
          body_aim_error_[mb.mapped] +=
              std::atan2(got.cross(wanted).norm(), got.dot(wanted)) * kRadToDeg / frames_;
        }
        fit_sum += e;
        ++fit_count;
        fit_error_max_ = std::max(fit_error_max_, e);
      }
    }
    // the root: put the clip root's body where the scaled clip root is
    set_joint_translation(*free_joint, Eigen::Vector3d::Zero(), q);
    pose_at(q);
    const Eigen::Vector3d at = probe.body_pose(root_body).pos;
    const Eigen::Vector3d goal =
        to_model * (scale_ * pose.root_position) + up * map.height_offset_m.value_or(0.0);
    set_joint_translation(*free_joint, translation_inverse * (goal - at), q);
    Eigen::Map<Eigen::VectorXd>(q_.data() + static_cast<size_t>(f) * nq_, nq_) = q;
    for (int i = 0; i < nmapped; ++i) {
      const int b = bodies_[i].body;
      const int p = model[b].parent;
      local_[static_cast<size_t>(f) * nmapped + i] =
          p >= 0 ? (actual[p].conjugate() * actual[b]).normalized() : actual[b];
      world_[static_cast<size_t>(f) * nmapped + i] = actual[b];
      position_[static_cast<size_t>(f) * nmapped + i] = probe.body_pose(b).pos + (goal - at);
    }
  }
  fit_error_mean_ = fit_count ? fit_sum / fit_count : 0;

  // ground: shift the whole table along up until the first frame's lowest point just touches
  // the floor (bisection on contacts with static geometry after one step from rest). A model
  // with no floor within 8 m keeps the clip's height.
  height_offset_ = map.height_offset_m.value_or(0.0);
  if (!map.height_offset_m) {
    auto shifted = [&](double shift, Eigen::VectorXd& out) {
      out = frame(0);
      set_joint_translation(
          *free_joint, frame_translation(*free_joint, out) + translation_inverse * (shift * up),
          out);
    };
    auto touches = [&](double shift) {
      shifted(shift, qp);
      pose_at(qp);
      probe.step();
      for (int i = 0; i < probe.num_contacts(); ++i) {
        Contact c = probe.contact(i);
        if (c.body1 < 0 || c.body2 < 0) return true;
      }
      return false;
    };
    double lo = -0.25, hi = 0.25;  // m: touching at lo, clear at hi (widened as needed)
    while (!touches(lo) && lo > -8) lo *= 2;
    while (touches(hi) && hi < 8) hi *= 2;
    if (touches(lo) && !touches(hi)) {
      for (int i = 0; i < 40; ++i) {
        double mid = 0.5 * (lo + hi);
        (touches(mid) ? lo : hi) = mid;
      }
      height_offset_ = hi;
      for (int f = 0; f < frames_; ++f) {
        Eigen::Map<Eigen::VectorXd> qf(q_.data() + static_cast<size_t>(f) * nq_, nq_);
        set_joint_translation(
            *free_joint, frame_translation(*free_joint, qf) + translation_inverse * (hi * up), qf);
        for (int i = 0; i < nmapped; ++i)
          position_[static_cast<size_t>(f) * nmapped + i] += hi * up;
      }
    }
  }

  // velocities: central differences in the engine's own tangent space
  v_.resize(static_cast<size_t>(frames_) * nv_);
  Eigen::VectorXd dv(nv_);
  for (int f = 0; f < frames_; ++f) {
    int a = std::max(f - 1, 0), b = std::min(f + 1, frames_ - 1);
    probe.difference_positions(frame(a), frame(b), dv);
    Eigen::Map<Eigen::VectorXd>(v_.data() + static_cast<size_t>(f) * nv_, nv_) =
        dv / ((b - a) * frame_time_);
  }
  // ends of the character: mapped bodies with no mapped body below them
  for (int i = 0; i < nmapped; ++i) {
    bool leaf = true;
    for (int k = 0; k < nmapped; ++k)
      for (int a = model[bodies_[k].body].parent; a >= 0 && k != i; a = model[a].parent)
        if (a == bodies_[i].body) leaf = false;
    if (leaf) end_bodies_.push_back(i);
  }
  probe.set_positions(frame(0));
  probe.forward();
}

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
