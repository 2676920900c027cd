#include "control/retarget.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <Eigen/Dense>

#include "control/retarget_probe.h"
#include "core/error.h"
#include "engine/engine.h"
#include "math/rotations.h"
#include "motion/bvh_measure.h"

namespace stance {

// the constructor's working state: the probed model, the map resolved onto it, the clip's
// rest skeleton and the work vectors of the per-frame fit
struct RetargetedMotion::Build {
  Build(const ReferenceMotion& r, const JointMap& m, Engine& p)
      : reference(r), map(m), probe(p), sk(r.skeleton()) {}

  const ReferenceMotion& reference;
  const JointMap& map;
  Engine& probe;
  const MotionSkeleton& sk;
  std::vector<RetargetModelBody> model;
  std::vector<int> segment_body;  // per clip segment: its model body, or -1
  int root_body = -1;             // the clip root's body
  int free_body = -1;             // the character's floating body, at the top of its tree
  const JointSlot* free_joint = nullptr;
  std::vector<int> order;  // the character's bodies, parents first
  Eigen::VectorXd q0, qp;  // the zero pose; scratch
  Eigen::Matrix3d translation_inverse;
  ReferencePose pose;
  std::vector<Eigen::Vector3d> clip_pos, clip_rest;
  std::vector<Eigen::Quaterniond> clip_rot;
  // the first frame, posed, where the clip's rest pose does not stand (else empty)
  std::vector<Eigen::Vector3d> first_pos;
  std::vector<Eigen::Quaterniond> first_rot;
  Eigen::Quaterniond to_model = Eigen::Quaterniond::Identity();  // clip world -> model world
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Quaterniond> bone_fix;  // per mapped body
  std::vector<Eigen::Vector3d> bone;         // per engine body, in its frame (zero: none)
  // levelled feet: mapped indices, how planted per frame and foot, each sole's up (body frame)
  std::vector<int> flat;
  std::vector<double> planted;
  std::vector<Eigen::Vector3d> sole_up_local;
  // the per-frame fit: wanted and reached world rotations per engine body, the pose so far
  std::vector<Eigen::Quaterniond> want, actual;
  std::vector<double> angles = std::vector<double>(8);
  Eigen::VectorXd q;
  double fit_sum = 0;
  long fit_count = 0;

  void pose_at(const Eigen::VectorXd& x) { set_pose(probe, x); }
};

void RetargetedMotion::map_bodies(Build& b) {
  const MotionSkeleton& sk = b.sk;
  const JointMap& map = b.map;
  Engine& probe = b.probe;
  std::vector<RetargetModelBody>& model = b.model;
  // the map's entries, resolved
  b.segment_body.assign(sk.segment_count(), -1);
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
    int body = probe.body_index(entry.body);
    if (body < 0)
      throw InputError(where(fmt::format("the model has no body '{}'{}", entry.body,
                                         did_you_mean(entry.body, probe.body_names()))));
    if (b.segment_body[s] >= 0)
      throw InputError(where(fmt::format("clip joint '{}' is mapped twice", entry.segment)));
    if (model[body].mapped >= 0)
      throw InputError(where(fmt::format("model body '{}' is mapped twice", entry.body)));
    b.segment_body[s] = body;
    model[body].mapped = static_cast<int>(e);
    bodies_.push_back({body, s, entry.segment + " -> " + entry.body});
  }
  b.root_body = b.segment_body[0];
  if (b.root_body < 0)
    throw InputError(located(
        map.source, 1,
        fmt::format("joints: map the clip's root '{}' onto a model body", sk.segments[0].name)));
}

void RetargetedMotion::find_character(Build& b) {
  const JointMap& map = b.map;
  Engine& probe = b.probe;
  std::vector<RetargetModelBody>& model = b.model;
  // the character's free joint: at the top of the root body's tree
  b.free_body = b.root_body;
  while (model[b.free_body].parent >= 0) b.free_body = model[b.free_body].parent;
  for (const JointSlot& j : model[b.free_body].joints)
    if (j.type == JointType::kFree) b.free_joint = &j;
  if (!b.free_joint)
    throw InputError(located(map.source, 1,
                             fmt::format("the model's body '{}' has no free joint: retargeting "
                                         "needs a floating base",
                                         probe.body_name(b.free_body))));
  for (int body = 0; body < probe.nbody(); ++body) {
    int top = body;
    while (model[top].parent >= 0) top = model[top].parent;
    if (top == b.free_body) b.order.push_back(body);
  }
  std::stable_sort(b.order.begin(), b.order.end(),
                   [&](int x, int y) { return model[x].depth < model[y].depth; });
  for (const RetargetBody& rb : bodies_)
    if (std::find(b.order.begin(), b.order.end(), rb.body) == b.order.end())
      throw InputError(
          located(map.source, map.joints[model[rb.body].mapped].line,
                  fmt::format("body '{}' is not part of the character under '{}'",
                              probe.body_name(rb.body), probe.body_name(b.free_body))));
}

// the clip's first frame, posed (b.first_pos, b.first_rot), where its rest pose does not stand:
// its mapped bodies span less than 2/3 of the first frame's height, as bvh_measure.h judges the
// legs. Left empty where it stands.
void RetargetedMotion::find_lying_rest(Build& b) const {
  auto height_span = [&](const std::vector<Eigen::Vector3d>& p) {
    double lo = 1e300, hi = -1e300;
    for (const RetargetBody& rb : bodies_) {
      lo = std::min(lo, p[rb.segment].z());
      hi = std::max(hi, p[rb.segment].z());
    }
    return hi - lo;
  };
  ReferencePose first = b.reference.make_pose();
  b.reference.frame_pose(0, first);
  std::vector<Eigen::Vector3d> posed;
  std::vector<Eigen::Quaterniond> turned;
  b.reference.forward_kinematics(first, posed, turned);
  if (rest_span_stands(height_span(b.clip_rest), height_span(posed))) return;
  b.first_pos = std::move(posed);
  b.first_rot = std::move(turned);
}

namespace {

// per point: whether it lies in the lowest quarter of their height span (where feet stand)
std::vector<bool> in_lowest_quarter(const std::vector<Eigen::Vector3d>& points) {
  double lowest = 1e300, highest = -1e300;
  for (const Eigen::Vector3d& p : points) {
    lowest = std::min(lowest, p.z());
    highest = std::max(highest, p.z());
  }
  std::vector<bool> low(points.size());
  for (size_t k = 0; k < points.size(); ++k)
    low[k] = points[k].z() - lowest <= 0.25 * (highest - lowest);
  return low;
}

// the model's leg length over the clip's where both legs are mapped (0 where not): each leg the
// thigh to the shin to the foot, the foot a mapped body with no mapped body below it in the
// lowest quarter of the clip's `posed` height, its two mapped ancestors the shin and the thigh.
// Bone lengths do not change with the pose, as a height span does (a lean, a crouch, the head
// a map puts on the model's head centre).
double leg_length_ratio(const MotionSkeleton& sk, const std::vector<RetargetBody>& bodies,
                        const std::vector<Eigen::Vector3d>& posed,
                        const std::vector<RetargetModelBody>& model) {
  const int n = static_cast<int>(bodies.size());
  std::vector<int> mapped_of_segment(sk.segment_count(), -1), parent(n, -1);
  for (int i = 0; i < n; ++i) mapped_of_segment[bodies[i].segment] = i;
  std::vector<bool> has_child(n, false);
  for (int i = 0; i < n; ++i)
    for (int a = sk.segments[bodies[i].segment].parent; a >= 0 && parent[i] < 0;
         a = sk.segments[a].parent)
      if (mapped_of_segment[a] >= 0) has_child[parent[i] = mapped_of_segment[a]] = true;
  const std::vector<bool> low = in_lowest_quarter(posed);
  double clip_leg = 0, model_leg = 0;
  int legs = 0;
  for (int foot = 0; foot < n; ++foot) {
    if (has_child[foot] || !low[bodies[foot].segment]) continue;
    const int shin = parent[foot], thigh = shin >= 0 ? parent[shin] : -1;
    if (thigh < 0) continue;
    for (auto [from, to] : {std::pair{thigh, shin}, std::pair{shin, foot}}) {
      clip_leg += (posed[bodies[to].segment] - posed[bodies[from].segment]).norm();
      model_leg += (model[bodies[to].body].rest_pos - model[bodies[from].body].rest_pos).norm();
    }
    ++legs;
  }
  return legs == 2 && clip_leg > 1e-6 ? model_leg / clip_leg : 0.0;
}

}  // namespace

void RetargetedMotion::fit_rest_skeletons(Build& b) {
  const JointMap& map = b.map;
  const std::vector<RetargetModelBody>& model = b.model;
  // clip -> model world: the up axis, then a yaw and scale from the rest skeletons
  const Eigen::Quaterniond up_turn =
      map.model_up == 'y'
          ? Eigen::Quaterniond(Eigen::AngleAxisd(-std::numbers::pi / 2, Eigen::Vector3d::UnitX()))
          : Eigen::Quaterniond::Identity();
  b.up = up_turn * Eigen::Vector3d::UnitZ();
  b.pose = b.reference.make_pose();
  for (auto& r : b.pose.rotations) r.setIdentity();
  b.pose.root_position.setZero();
  b.clip_pos.resize(b.sk.segment_count());
  b.clip_rot.resize(b.sk.segment_count());
  b.reference.forward_kinematics(b.pose, b.clip_pos, b.clip_rot);
  b.clip_rest = b.clip_pos;
  const std::vector<Eigen::Vector3d>& clip_rest = b.clip_rest;
  // a rest pose that does not stand (Bandai Namco's bones lie along X) tells no height and no
  // facing: the yaw and scale then come from the first frame's pose
  find_lying_rest(b);
  const std::vector<Eigen::Vector3d>& clip_posed = b.first_pos;
  const std::vector<Eigen::Vector3d>& fitted = clip_posed.empty() ? clip_rest : clip_posed;
  double cross = 0, dot = 0, clip_lo = 1e300, clip_hi = -1e300, model_lo = 1e300, model_hi = -1e300;
  for (const RetargetBody& rb : bodies_) {
    Eigen::Vector3d rs = fitted[rb.segment] - fitted[0];
    Eigen::Vector3d rm =
        up_turn.conjugate() * (model[rb.body].rest_pos - model[b.root_body].rest_pos);
    // posed, only the bodies on the root (the hips across it): the limbs below swing
    const bool on_root = b.sk.segments[rb.segment].parent == 0;
    if (clip_posed.empty() || on_root) {
      cross += rs.x() * rm.y() - rs.y() * rm.x();
      dot += rs.x() * rm.x() + rs.y() * rm.y();
    }
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
  // posed, the legs measure the scale where both are mapped
  const double legs =
      map.scale || clip_posed.empty() ? 0.0 : leg_length_ratio(b.sk, bodies_, clip_posed, model);
  if (legs > 0) scale_ = legs;
  b.to_model = up_turn * Eigen::Quaterniond(Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()));
}

void RetargetedMotion::fix_bones(Build& b) {
  const MotionSkeleton& sk = b.sk;
  const std::vector<RetargetModelBody>& model = b.model;
  const std::vector<Eigen::Vector3d>& clip_rest = b.clip_rest;
  // rest-pose correction: a body with one mapped child bone turns onto the clip's bone
  const int nmapped = static_cast<int>(bodies_.size());
  b.bone_fix.assign(nmapped, Eigen::Quaterniond::Identity());
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
  b.bone.assign(b.probe.nbody(), Eigen::Vector3d::Zero());
  for (int i = 0; i < nmapped; ++i) {
    if (mapped_children[i].size() != 1) continue;
    const int body = bodies_[i].body;
    Eigen::Vector3d d = model[bodies_[mapped_children[i][0]].body].rest_pos - model[body].rest_pos;
    if (d.norm() > 1e-6) b.bone[body] = model[body].rest_world.conjugate() * d.normalized();
  }
  if (!b.map.align_bones) return;  // the clip's own character: its rest pose is the clip's
  if (!b.first_rot.empty()) return fix_bones_from_first_frame(b, mapped_children);
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
    bone_model = b.to_model.conjugate() * bone_model;
    if (bone_clip.norm() > 1e-6 && bone_model.norm() > 1e-6)
      b.bone_fix[i] = Eigen::Quaterniond::FromTwoVectors(bone_model, bone_clip);
  }
}

namespace {

// the rotation that turns the unit directions `from` onto `to` best (least squares; Kabsch's),
// or the one turning the single direction when they all lie along one line
Eigen::Quaterniond best_fit_turn(const std::vector<Eigen::Vector3d>& from,
                                 const std::vector<Eigen::Vector3d>& to) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < from.size(); ++k) h += to[k] * from[k].transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  if (s(0) < 1e-9) return Eigen::Quaterniond::Identity();
  if (s(1) < 1e-6 * s(0))
    return Eigen::Quaterniond::FromTwoVectors(svd.matrixV().col(0), svd.matrixU().col(0));
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return Eigen::Quaterniond(svd.matrixU() * d * svd.matrixV().transpose()).normalized();
}

// a segment's bone towards the mean of its bones' ends (its child joints, mapped or not, and its
// End Sites), posed by its clip-world rotation `posed` (unit; zero where it has none)
Eigen::Vector3d end_clip_bone(const MotionSegment& segment, const Eigen::Quaterniond& posed) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& end : segment.bone_ends) sum += end;
  return sum.norm() < 1e-6 ? Eigen::Vector3d::Zero() : (posed * sum).normalized();
}

}  // namespace

// A rest pose that does not stand (Bandai Namco's bones lie along X, each rolled its own way)
// is no pose to turn the model's bones onto. The turns then come from the first frame, G_i, each
// the clip-world rotation of a model body from its rest there: the root's is the best fit of its
// mapped children's directions (the hips and the spine) onto the clip's, so the pelvis stands
// and faces the heading; each body below follows its mapped parent, swung onto the clip's bone
// (its twist the parent's, as a standing rest pose has it). An end body (no mapped body below
// it: forearm, head) bends against its parent from the model's rest as the clip's bends from
// straight, which its rest pose is: the swing from the parent's bone onto its own (towards its
// unmapped joints or End Sites); a foot, whose rest is no straight line, follows its shin.
// A_i = W_i(0)^T G_i.
void RetargetedMotion::fix_bones_from_first_frame(Build& b,
                                                  const std::vector<std::vector<int>>& children) {
  const int nmapped = static_cast<int>(bodies_.size());
  auto model_dir = [&](int from, int to) {  // clip world, at the model's rest
    const Eigen::Vector3d d =
        b.model[bodies_[to].body].rest_pos - b.model[bodies_[from].body].rest_pos;
    return (b.to_model.conjugate() * d).normalized();
  };
  auto clip_dir = [&](int from, int to) {
    return (b.first_pos[bodies_[to].segment] - b.first_pos[bodies_[from].segment]).normalized();
  };
  // mapped bodies, parents first (by their segments' depth in the clip)
  std::vector<int> parent(nmapped, -1), depth(nmapped, 0), order(nmapped);
  for (int i = 0; i < nmapped; ++i)
    for (int c : children[i]) parent[c] = i;
  for (int i = 0; i < nmapped; ++i)
    for (int p = parent[i]; p >= 0; p = parent[p]) ++depth[i];
  for (int i = 0; i < nmapped; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return depth[x] < depth[y]; });
  std::vector<Eigen::Quaterniond> turn(nmapped, Eigen::Quaterniond::Identity());
  const std::vector<bool> feet = in_lowest_quarter(b.first_pos);
  for (int i : order) {
    const bool has_bone = children[i].size() == 1;
    if (parent[i] < 0) {
      std::vector<Eigen::Vector3d> from, to;
      for (int c : children[i]) {
        from.push_back(model_dir(i, c));
        to.push_back(clip_dir(i, c));
      }
      turn[i] = from.empty() ? b.first_rot[bodies_[i].segment] : best_fit_turn(from, to);
    } else {
      turn[i] = turn[parent[i]];
      if (has_bone) {
        const Eigen::Vector3d bone = turn[i] * model_dir(i, children[i][0]);
        turn[i] = Eigen::Quaterniond::FromTwoVectors(bone, clip_dir(i, children[i][0])) * turn[i];
      } else if (children[i].empty() && !feet[bodies_[i].segment]) {
        // an end body (forearm, head) bends against its parent from the model's rest as the
        // clip's bends from straight (its rest pose's bend): its bone, towards its unmapped
        // joints or End Sites, against its parent's. Not a foot: straight is no foot's rest
        const int s = bodies_[i].segment;
        const Eigen::Vector3d clip_bone = end_clip_bone(b.sk.segments[s], b.first_rot[s]);
        const Eigen::Vector3d parent_bone = b.first_pos[s] - b.first_pos[b.sk.segments[s].parent];
        if (clip_bone.norm() > 0 && parent_bone.norm() > 1e-6)
          turn[i] = Eigen::Quaterniond::FromTwoVectors(parent_bone, clip_bone) * turn[i];
      }
    }
    b.bone_fix[i] = (b.first_rot[bodies_[i].segment].conjugate() * turn[i]).normalized();
  }
}

void RetargetedMotion::keep_rest(Build& b, double duration_s) {
  to_model_ = b.to_model;
  up_ = b.up;
  bone_fix_ = b.bone_fix;
  for (const RetargetBody& rb : bodies_) {
    const RetargetModelBody& mb = b.model[rb.body];
    rest_world_.push_back(mb.rest_world);
    rest_local_.push_back(mb.rest_local);
    joints_.push_back(mb.joints);
    bone_.push_back(b.bone[rb.body]);
    int hinges = 0;
    for (const JointSlot& j : mb.joints) hinges += j.type == JointType::kHinge;
    if (hinges > kMaxHinges)
      throw InputError(fmt::format("retarget: body '{}' has {} hinges (at most {})",
                                   b.probe.body_name(rb.body), hinges, kMaxHinges));
  }

  // the table: one pose per clip frame over the run (at least one pass)
  int frames = b.reference.frame_count();
  if (b.reference.loops() && duration_s > 0) {
    if (duration_s > 3600)
      throw InputError("retarget: runs longer than an hour are not tabulated; shorten duration");
    frames = std::max(frames, static_cast<int>(std::ceil(duration_s / frame_time_)) + 2);
  }
  frames_ = std::max(frames, 2);
  const size_t nmapped = bodies_.size();
  q_.resize(static_cast<size_t>(frames_) * nq_);
  local_.resize(static_cast<size_t>(frames_) * nmapped);
  world_.resize(static_cast<size_t>(frames_) * nmapped);
  position_.resize(static_cast<size_t>(frames_) * nmapped);
  b.want.resize(b.probe.nbody());
  b.actual.resize(b.probe.nbody());
  body_fit_error_.assign(nmapped, 0.0);
  body_aim_error_.assign(nmapped, 0.0);
  b.q = b.q0;
}

void RetargetedMotion::find_planted_feet(Build& b, const std::vector<int>& level_feet) {
  const int nmapped = static_cast<int>(bodies_.size());
  // planted feet: per frame and levelled body, how planted the clip has it (1 within 2 cm of
  // its planted height and below 0.3 m/s; 0 from 5 cm above it or 0.8 m/s), on the model's scale
  std::vector<int>& flat = b.flat;  // mapped indices
  for (int i = 0; i < nmapped; ++i)
    if (std::find(level_feet.begin(), level_feet.end(), bodies_[i].segment) != level_feet.end())
      flat.push_back(i);
  std::vector<double>& planted = b.planted;
  planted.assign(static_cast<size_t>(frames_) * flat.size(), 0.0);
  // each levelled body's sole up, in its own frame: its up at the model's rest
  b.sole_up_local.resize(flat.size());
  for (size_t k = 0; k < flat.size(); ++k)
    b.sole_up_local[k] = b.model[bodies_[flat[k]].body].rest_world.conjugate() * b.up;
  if (flat.empty()) return;
  std::vector<Eigen::Vector3d> seen(static_cast<size_t>(frames_) * flat.size());
  std::vector<Eigen::Quaterniond> seen_rot(seen.size());
  for (int f = 0; f < frames_; ++f) {
    b.reference.sample(f * frame_time_, b.pose);
    b.reference.forward_kinematics(b.pose, b.clip_pos, b.clip_rot);
    for (size_t k = 0; k < flat.size(); ++k) {
      const RetargetBody& rb = bodies_[flat[k]];
      seen[f * flat.size() + k] = scale_ * b.clip_pos[rb.segment];
      seen_rot[f * flat.size() + k] = b.to_model * b.clip_rot[rb.segment] * b.bone_fix[flat[k]] *
                                      b.to_model.conjugate() * b.model[rb.body].rest_world;
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
      seen_up += planted[f * flat.size() + k] * (seen_rot[f * flat.size() + k].conjugate() * b.up);
    if (seen_up.norm() > 1e-9 &&
        seen_up.normalized().dot(b.sole_up_local[k]) < std::cos(std::numbers::pi / 4))
      b.sole_up_local[k] = seen_up.normalized();
  }
}

void RetargetedMotion::solve_body(Build& b, int body, int f) {
  const RetargetModelBody& mb = b.model[body];
  const int nmapped = static_cast<int>(bodies_.size());
  const Eigen::Quaterniond parent =
      mb.parent >= 0 ? b.actual[mb.parent] : Eigen::Quaterniond::Identity();
  const Eigen::Quaterniond base = parent * mb.rest_local;
  Eigen::Quaterniond target = base;  // unmapped: joints at zero
  if (mb.mapped >= 0) {
    target = b.want[body];
  } else if (body == b.free_body) {
    // an unmapped floating body follows the mapped body nearest below it, rigidly
    for (int i = 0; i < nmapped; ++i) {
      int a = bodies_[i].body;
      while (a >= 0 && a != body) a = b.model[a].parent;
      if (a == body) {
        target = b.want[bodies_[i].body] * b.model[bodies_[i].body].rest_world.conjugate() *
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
    std::vector<double>& angles = b.angles;
    if (static_cast<int>(angles.size()) < hinges) angles.resize(hinges);
    int k = 0;
    for (const JointSlot& j : mb.joints)
      if (j.type == JointType::kHinge) angles[k++] = f > 0 ? b.q[j.qpos] : 0.0;
    if (mb.mapped >= 0) solve_hinges(mb.joints, local_want, b.bone[body], angles.data(), hinges);
    k = 0;
    for (const JointSlot& j : mb.joints)
      if (j.type == JointType::kHinge) b.q[j.qpos] = angles[k++];
    local = hinge_rotation(mb.joints, angles.data());
  }
  for (const JointSlot& j : mb.joints)
    if (j.type == JointType::kBall || j.type == JointType::kFree) {
      Eigen::Matrix3d t = j.frame;
      Eigen::Quaterniond joint_q(t.transpose() * local_want.toRotationMatrix() * t);
      set_joint_rotation(j, joint_q.normalized(), b.q);
      local = local_want;
    }
  b.actual[body] = (base * local).normalized();
  if (mb.mapped < 0) return;
  const Eigen::Quaterniond& actual = b.actual[body];
  const Eigen::Quaterniond& want = b.want[body];
  double e = geodesic_angle(actual, want) * kRadToDeg;
  body_fit_error_[mb.mapped] += e / frames_;
  if (b.bone[body].squaredNorm() > 0) {
    const Eigen::Vector3d got = actual * b.bone[body], wanted = want * b.bone[body];
    body_aim_error_[mb.mapped] +=
        std::atan2(got.cross(wanted).norm(), got.dot(wanted)) * kRadToDeg / frames_;
  }
  b.fit_sum += e;
  ++b.fit_count;
  fit_error_max_ = std::max(fit_error_max_, e);
}

void RetargetedMotion::fit_frame(Build& b, int f) {
  const int nmapped = static_cast<int>(bodies_.size());
  const std::vector<int>& flat = b.flat;
  b.reference.sample(f * frame_time_, b.pose);
  b.reference.forward_kinematics(b.pose, b.clip_pos, b.clip_rot);
  for (int i = 0; i < nmapped; ++i) {
    const RetargetBody& rb = bodies_[i];
    b.want[rb.body] = b.to_model * b.clip_rot[rb.segment] * b.bone_fix[i] * b.to_model.conjugate() *
                      b.model[rb.body].rest_world;
  }
  // a planted foot turned level: its up at the model's rest onto the world's up
  for (size_t k = 0; k < flat.size(); ++k) {
    const double w = b.planted[f * flat.size() + k];
    if (w <= 0) continue;
    const int body = bodies_[flat[k]].body;
    const Eigen::Vector3d sole_up = b.want[body] * b.sole_up_local[k];
    const Eigen::Quaterniond level =
        Eigen::Quaterniond::FromTwoVectors(sole_up, b.up) * b.want[body];
    b.want[body] = b.want[body].slerp(w, level).normalized();
  }
  for (int body : b.order) solve_body(b, body, f);
  // the root: put the clip root's body where the scaled clip root is
  set_joint_translation(*b.free_joint, Eigen::Vector3d::Zero(), b.q);
  b.pose_at(b.q);
  const Eigen::Vector3d at = b.probe.body_pose(b.root_body).pos;
  const Eigen::Vector3d goal =
      b.to_model * (scale_ * b.pose.root_position) + b.up * b.map.height_offset_m.value_or(0.0);
  set_joint_translation(*b.free_joint, b.translation_inverse * (goal - at), b.q);
  Eigen::Map<Eigen::VectorXd>(q_.data() + static_cast<size_t>(f) * nq_, nq_) = b.q;
  for (int i = 0; i < nmapped; ++i) {
    const int body = bodies_[i].body;
    const int p = b.model[body].parent;
    local_[static_cast<size_t>(f) * nmapped + i] =
        p >= 0 ? (b.actual[p].conjugate() * b.actual[body]).normalized() : b.actual[body];
    world_[static_cast<size_t>(f) * nmapped + i] = b.actual[body];
    position_[static_cast<size_t>(f) * nmapped + i] = b.probe.body_pose(body).pos + (goal - at);
  }
}

void RetargetedMotion::put_on_ground(Build& b) {
  // ground: shift the whole table along up until the first frame's lowest point just touches
  // the floor (bisection on contacts with static geometry after one step from rest). A model
  // with no floor within 8 m keeps the clip's height.
  height_offset_ = b.map.height_offset_m.value_or(0.0);
  if (b.map.height_offset_m) return;
  const JointSlot& free_joint = *b.free_joint;
  const Eigen::Vector3d up = b.up;
  Engine& probe = b.probe;
  auto shifted = [&](double shift, Eigen::VectorXd& out) {
    out = frame(0);
    set_joint_translation(
        free_joint, frame_translation(free_joint, out) + b.translation_inverse * (shift * up), out);
  };
  auto touches = [&](double shift) {
    shifted(shift, b.qp);
    b.pose_at(b.qp);
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
  if (!touches(lo) || touches(hi)) return;
  for (int i = 0; i < 40; ++i) {
    double mid = 0.5 * (lo + hi);
    (touches(mid) ? lo : hi) = mid;
  }
  height_offset_ = hi;
  const int nmapped = static_cast<int>(bodies_.size());
  for (int f = 0; f < frames_; ++f) {
    Eigen::Map<Eigen::VectorXd> qf(q_.data() + static_cast<size_t>(f) * nq_, nq_);
    set_joint_translation(
        free_joint, frame_translation(free_joint, qf) + b.translation_inverse * (hi * up), qf);
    for (int i = 0; i < nmapped; ++i) position_[static_cast<size_t>(f) * nmapped + i] += hi * up;
  }
}

void RetargetedMotion::finish(Build& b) {
  Engine& probe = b.probe;
  // velocities: central differences in the engine's own tangent space
  v_.resize(static_cast<size_t>(frames_) * nv_);
  Eigen::VectorXd dv(nv_);
  for (int f = 0; f < frames_; ++f) {
    int a = std::max(f - 1, 0), c = std::min(f + 1, frames_ - 1);
    probe.difference_positions(frame(a), frame(c), dv);
    Eigen::Map<Eigen::VectorXd>(v_.data() + static_cast<size_t>(f) * nv_, nv_) =
        dv / ((c - a) * frame_time_);
  }
  // ends of the character: mapped bodies with no mapped body below them
  const int nmapped = static_cast<int>(bodies_.size());
  for (int i = 0; i < nmapped; ++i) {
    bool leaf = true;
    for (int k = 0; k < nmapped; ++k)
      for (int a = b.model[bodies_[k].body].parent; a >= 0 && k != i; a = b.model[a].parent)
        if (a == bodies_[i].body) leaf = false;
    if (leaf) end_bodies_.push_back(i);
  }
  probe.set_positions(frame(0));
  probe.forward();
}

RetargetedMotion::RetargetedMotion(const ReferenceMotion& reference, const JointMap& map,
                                   Engine& probe, double duration_s,
                                   const std::vector<int>& level_feet) {
  nq_ = probe.nq();
  nv_ = probe.nv();
  frame_time_ = reference.frame_time_s();
  Build b(reference, map, probe);
  b.model = read_model_tree(probe);
  map_bodies(b);
  find_character(b);
  // rest poses, hinge axes, joint frames and the root's translation, probed
  b.q0.resize(nq_);
  b.qp.resize(nq_);
  b.translation_inverse =
      probe_kinematics(probe, b.model, b.order, b.free_body, *b.free_joint, b.q0);
  fold_hinge_chains(b.model, b.order, b.free_body);
  for (RetargetBody& rb : bodies_) rb.parent = b.model[rb.body].parent;
  fit_rest_skeletons(b);
  fix_bones(b);
  keep_rest(b, duration_s);
  find_planted_feet(b, level_feet);
  for (int f = 0; f < frames_; ++f) fit_frame(b, f);
  fit_error_mean_ = b.fit_count ? b.fit_sum / b.fit_count : 0;
  put_on_ground(b);
  finish(b);
}

}  // namespace stance
