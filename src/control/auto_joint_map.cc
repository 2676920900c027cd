#include "control/auto_joint_map.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "control/mocap_clip.h"
#include "core/error.h"
#include "engine/world_spec.h"
#include "motion/bvh.h"
#include "motion/bvh_measure.h"
#include "motion/reference_motion.h"

namespace stance {

namespace {

// a tree of bodies (or clip segments) at rest: world origins, up along `up`
struct RestTree {
  std::vector<std::string> names;
  std::vector<int> parent;  // -1: a root
  std::vector<Eigen::Vector3d> pos;
  std::vector<std::vector<int>> children;
  std::vector<bool> member;  // of the tree stance reads (the model's largest)
  std::vector<double> mass;  // kg; 1 for a clip's segments
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double joint_tolerance_m = 0;  // origins closer than this are one joint

  int size() const { return static_cast<int>(names.size()); }
  double height(int b) const { return pos[b].dot(up); }
  int depth(int b) const {
    int d = 0;
    for (; parent[b] >= 0; b = parent[b]) ++d;
    return d;
  }
  bool under(int b, int top) const {  // b is top or below it
    for (; b >= 0; b = parent[b])
      if (b == top) return true;
    return false;
  }
  int common_ancestor(int a, int b) const {
    for (; a >= 0; a = parent[a])
      if (under(b, a)) return a;
    return -1;
  }
  // the bodies below `top` down to `bottom` (inclusive), top to bottom
  std::vector<int> chain(int top, int bottom) const {
    std::vector<int> up_chain;
    for (int b = bottom; b >= 0 && b != top; b = parent[b]) up_chain.push_back(b);
    return {up_chain.rbegin(), up_chain.rend()};
  }
  // the leaves, but light branches (under 2% of the mass from the leaf up to where the tree
  // branches): sensor and camera frames welded onto a robot
  std::vector<int> leaves() const {
    double total = 0;
    for (int b = 0; b < size(); ++b)
      if (member[b]) total += mass[b];
    std::vector<int> out;
    for (int b = 0; b < size(); ++b) {
      if (!member[b] || !children[b].empty()) continue;
      double branch = 0;
      for (int a = b; a >= 0; a = parent[a]) {
        branch += mass[a];
        if (parent[a] >= 0 && children[parent[a]].size() > 1) break;
      }
      if (branch >= 0.02 * total) out.push_back(b);
    }
    return out;
  }
};

void finish_tree(RestTree& t) {
  t.children.assign(t.size(), {});
  for (int b = 0; b < t.size(); ++b)
    if (t.parent[b] >= 0) t.children[t.parent[b]].push_back(b);
  double lo = 1e300, hi = -1e300;
  for (int b = 0; b < t.size(); ++b)
    if (t.member[b]) {
      lo = std::min(lo, t.height(b));
      hi = std::max(hi, t.height(b));
    }
  t.joint_tolerance_m = std::max(1e-4, 0.03 * (hi - lo));
}

// the clip's tree at rest, or posed (`posed`: each segment's position, not empty)
RestTree tree_of_clip(const MotionSkeleton& sk, const std::vector<Eigen::Vector3d>& posed) {
  RestTree t;
  for (int k = 0; k < sk.segment_count(); ++k) {
    const MotionSegment& s = sk.segments[k];
    t.names.push_back(s.name);
    t.parent.push_back(s.parent);
    if (!posed.empty())
      t.pos.push_back(posed[k] - posed[0]);
    else
      t.pos.push_back(s.parent >= 0 ? Eigen::Vector3d(t.pos[s.parent] + s.offset)
                                    : Eigen::Vector3d::Zero().eval());
  }
  t.member.assign(t.size(), true);
  t.mass.assign(t.size(), 1.0);
  finish_tree(t);
  return t;
}

// the model's bodies as posed now; members: the tree with the most bodies
RestTree tree_of_model(const Engine& e) {
  RestTree t;
  for (int b = 0; b < e.nbody(); ++b) {
    t.names.push_back(e.body_name(b));
    t.parent.push_back(e.body_parent(b));
    t.pos.push_back(e.body_pose(b).pos);
    t.mass.push_back(e.body_mass(b));
  }
  const Eigen::Vector3d g = e.gravity();
  if (std::abs(g.y()) > std::abs(g.z())) t.up = Eigen::Vector3d::UnitY();
  std::vector<int> root(t.size()), count(t.size(), 0);
  for (int b = 0; b < t.size(); ++b) {
    int r = b;
    while (t.parent[r] >= 0) r = t.parent[r];
    root[b] = r;
    ++count[r];
  }
  const int main_root =
      static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
  t.member.resize(t.size());
  for (int b = 0; b < t.size(); ++b) t.member[b] = root[b] == main_root;
  finish_tree(t);
  return t;
}

// consecutive bodies of a chain whose origins coincide: one joint each (a hinge chain)
std::vector<std::vector<int>> joints_of(const RestTree& t, const std::vector<int>& chain) {
  std::vector<std::vector<int>> out;
  for (int b : chain) {
    if (!out.empty() && (t.pos[b] - t.pos[out.back().front()]).norm() < t.joint_tolerance_m)
      out.back().push_back(b);
    else
      out.push_back({b});
  }
  return out;
}

// the side the names give, from `b` up to the nearest branching body: -1 left, +1 right, 0
int side_by_name(const RestTree& t, int b) {
  for (; b >= 0; b = t.parent[b]) {
    if (int side = side_of_joint_name(t.names[b])) return side;
    if (t.parent[b] >= 0 && t.children[t.parent[b]].size() > 1) break;
  }
  return 0;
}

// the parts a role finder fills in: indices into the tree, -1 when not found
struct Roles {
  int pelvis = -1, chest = -1, head = -1;
  std::vector<int> spine;                                        // pelvis to chest, exclusive
  std::array<int, 2> thigh{-1, -1}, shin{-1, -1}, foot{-1, -1};  // left, right
  std::array<int, 2> upper_arm{-1, -1}, lower_arm{-1, -1};
};

double leg_length(const RestTree& t, const Roles& r) {
  double sum = 0;
  for (int s = 0; s < 2; ++s)
    sum += (t.pos[r.thigh[s]] - t.pos[r.shin[s]]).norm() +
           (t.pos[r.shin[s]] - t.pos[r.foot[s]]).norm();
  return sum / 2;
}

std::string body_list(const RestTree& t) {
  std::string out;
  for (int b = 0; b < t.size(); ++b)
    if (t.member[b]) out += (out.empty() ? "" : ", ") + t.names[b];
  return out;
}

std::string lowered(const std::string& name) {
  std::string low;
  for (char c : name) low += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return low;
}

bool elbow_named(const std::string& name) {
  return lowered(name).find("elbow") != std::string::npos;
}

bool girdle_named(const std::string& name) {
  // clavicle, scapula, collar; "LeftShoulder" and "Shoulder_L" (Bandai Namco's: a collar), not
  // "left_shoulder_pitch_link"
  const std::string low = lowered(name);
  for (const char* part : {"clav", "scap", "collar"})
    if (low.find(part) != std::string::npos) return true;
  const std::string tail = "shoulder";
  for (const char* side : {"", "_l", "_r", ".l", ".r", " l", " r"}) {
    const std::string end = tail + side;
    if (low.size() >= end.size() && low.compare(low.size() - end.size(), end.size(), end) == 0)
      return true;
  }
  return false;
}

// the model's legs: the lowest leaf, and the lowest leaf whose chain parts from it high up
void find_model_legs(const RestTree& t, Roles& r) {
  std::vector<int> leaves = t.leaves();
  std::stable_sort(leaves.begin(), leaves.end(),
                   [&](int a, int b) { return t.height(a) < t.height(b) - 1e-9; });
  if (leaves.size() < 2) return;
  double lo = 1e300, hi = -1e300;
  for (int b = 0; b < t.size(); ++b)
    if (t.member[b]) lo = std::min(lo, t.height(b)), hi = std::max(hi, t.height(b));
  const int first = leaves[0];
  int second = -1, split = -1;
  for (size_t i = 1; i < leaves.size() && second < 0; ++i) {
    const int c = t.common_ancestor(first, leaves[i]);
    if (c >= 0 && t.height(c) >= lo + 0.3 * (hi - lo)) second = leaves[i], split = c;
  }
  if (second < 0) return;
  // sides by name, else by the rest pose (the model faces +x: left is up x forward)
  int side_first = side_by_name(t, first);
  const int side_second = side_by_name(t, second);
  if (side_first == 0 || side_first == side_second) {
    Eigen::Vector3d left = t.up.cross(Eigen::Vector3d::UnitX());
    side_first = (t.pos[first] - t.pos[second]).dot(left) > 0 ? -1 : 1;
  }
  r.pelvis = split;
  for (int leaf : {first, second}) {
    const int s = (leaf == first) == (side_first < 0) ? 0 : 1;
    const auto joints = joints_of(t, t.chain(split, leaf));
    const double top = t.height(joints.front().front()), bottom = t.height(leaf);
    size_t ankle = 0;
    while (ankle < joints.size() &&
           t.height(joints[ankle].front()) > bottom + 0.15 * (top - bottom))
      ++ankle;
    if (ankle < 2 || ankle >= joints.size()) continue;
    r.foot[s] = joints[ankle].back();
    r.shin[s] = joints[ankle - 1].back();
    r.thigh[s] = joints[ankle - 2].back();
  }
}

void find_clip_legs(const MotionSkeleton& sk, const RestTree& t, Roles& r) {
  int hip[2], foot[2];
  find_mocap_legs(sk, {}, hip, foot);
  r.pelvis = 0;
  for (int s = 0; s < 2; ++s) {
    if (hip[s] < 0 || foot[s] < 0 || foot[s] == hip[s] || !t.under(foot[s], hip[s])) continue;
    r.thigh[s] = hip[s];
    r.foot[s] = foot[s];
    if (t.parent[foot[s]] != hip[s]) r.shin[s] = t.parent[foot[s]];
  }
}

// the arms, the chest and the head, once the legs are known; `model` picks the head as the
// first joint above the chest (a robot's sensors sit beyond it), a clip's as its top segment
void find_upper_body(const RestTree& t, Roles& r, bool model) {
  auto in_leg = [&](int b) {
    for (int s = 0; s < 2; ++s)
      if (t.under(b, r.thigh[s])) return true;
    return false;
  };
  // the lateral axis, from the right foot to the left
  Eigen::Vector3d lateral = t.pos[r.foot[0]] - t.pos[r.foot[1]];
  lateral -= t.up * t.up.dot(lateral);
  if (lateral.norm() > 1e-9) lateral.normalize();
  std::vector<int> rest;
  for (int b : t.leaves())
    if (!in_leg(b)) rest.push_back(b);
  std::array<int, 2> hand{-1, -1};
  for (int s = 0; s < 2; ++s) {
    const int want = s == 0 ? -1 : 1;
    double best = 0;
    for (bool by_name : {true, false}) {
      for (int b : rest) {
        const int named = side_by_name(t, b);
        const double out = t.pos[b].dot(lateral) * (s == 0 ? 1 : -1);
        const bool fits = by_name ? named == want : named == 0 && out > t.joint_tolerance_m;
        if (fits && (hand[s] < 0 || out > best)) hand[s] = b, best = out;
      }
      if (hand[s] >= 0) break;
    }
  }
  if (hand[0] < 0 || hand[1] < 0 || hand[0] == hand[1]) return;
  const int chest = t.common_ancestor(hand[0], hand[1]);
  if (chest < 0 || in_leg(chest) || chest == hand[0] || chest == hand[1]) return;
  r.chest = chest;
  std::array<int, 2> arm_top{-1, -1};
  for (int s = 0; s < 2; ++s) {
    auto joints = joints_of(t, t.chain(chest, hand[s]));
    arm_top[s] = joints.front().front();
    // a first joint at the chest's origin, or a shoulder girdle, is no upper arm
    while (joints.size() > 2 &&
           ((t.pos[joints[0].front()] - t.pos[chest]).norm() < t.joint_tolerance_m ||
            std::all_of(joints[0].begin(), joints[0].end(),
                        [&](int b) { return girdle_named(t.names[b]); })))
      joints.erase(joints.begin());
    // a robot's shoulder may be three hinges apart, one of them a twist halfway down the upper
    // arm (pitch, roll, yaw links): where a body is named an elbow, the upper arm is the joint
    // above it
    const auto elbow = std::find_if(joints.begin() + 1, joints.end(), [&](const auto& joint) {
      return std::any_of(joint.begin(), joint.end(),
                         [&](int b) { return elbow_named(t.names[b]); });
    });
    if (elbow != joints.end()) joints.erase(joints.begin(), elbow - 1);
    r.upper_arm[s] = joints[0].back();
    if (joints.size() > 1) r.lower_arm[s] = joints[1].back();
  }
  // the head: the highest other leaf above the chest
  int top = -1;
  for (int b : rest)
    if (t.under(b, chest) && b != chest && !t.under(b, arm_top[0]) && !t.under(b, arm_top[1]) &&
        t.height(b) > t.height(chest) && (top < 0 || t.height(b) > t.height(top)))
      top = b;
  if (top >= 0) {
    const auto joints = joints_of(t, t.chain(chest, top));
    r.head = model ? joints.front().back() : top;
  }
  // the spine: between the pelvis and the chest, one body per joint (the deepest, which every
  // hinge of the joint moves)
  const int meet = t.common_ancestor(r.pelvis, chest);
  std::vector<int> path;
  for (int b = t.parent[r.pelvis]; b >= 0 && t.under(b, meet) && b != meet; b = t.parent[b])
    path.push_back(b);
  if (meet != r.pelvis && meet != chest) path.push_back(meet);
  for (int b : t.chain(meet, chest))
    if (b != chest) path.push_back(b);
  for (const auto& joint : joints_of(t, path))
    r.spine.push_back(*std::max_element(joint.begin(), joint.end(),
                                        [&](int a, int b) { return t.depth(a) < t.depth(b); }));
}

// index i of k picks spread over n (k <= n): ends kept, the middle for one
int spread(int i, int n, int k) {
  if (k == 1) return (n - 1) / 2;
  return static_cast<int>(std::lround(double(i) * (n - 1) / (k - 1)));
}

// the segments posed in the clip's first frame where its rest pose does not stand (it spans
// less than 2/3 of that frame's height, as retarget.cc judges it: Bandai Namco's lies along X)
std::vector<Eigen::Vector3d> first_frame_if_lying(const BvhClip& clip, const MotionSkeleton& sk) {
  if (clip.frame_count < 1) return {};
  const ReferenceMotion reference(clip, sk, ReferenceOptions{});
  ReferencePose pose = reference.make_pose();
  std::vector<Eigen::Vector3d> rest, posed;
  std::vector<Eigen::Quaterniond> turned;
  for (auto& r : pose.rotations) r.setIdentity();
  pose.root_position.setZero();
  reference.forward_kinematics(pose, rest, turned);
  reference.frame_pose(0, pose);
  reference.forward_kinematics(pose, posed, turned);
  auto span = [](const std::vector<Eigen::Vector3d>& p) {
    double lo = 1e300, hi = -1e300;
    for (const Eigen::Vector3d& x : p) lo = std::min(lo, x.z()), hi = std::max(hi, x.z());
    return hi - lo;
  };
  return rest_span_stands(span(rest), span(posed)) ? std::vector<Eigen::Vector3d>{} : posed;
}

}  // namespace

AutoJointMap find_joint_map(const MotionSkeleton& clip, const std::string& clip_name,
                            const Engine& model, const std::string& model_name,
                            const std::vector<Eigen::Vector3d>& posed) {
  const RestTree ct = tree_of_clip(clip, posed), mt = tree_of_model(model);
  Roles cr, mr;
  find_clip_legs(clip, ct, cr);
  find_model_legs(mt, mr);
  auto legs_complete = [](const Roles& r) {
    for (int s = 0; s < 2; ++s)
      if (r.thigh[s] < 0 || r.shin[s] < 0 || r.foot[s] < 0) return false;
    return true;
  };
  if (!legs_complete(mr))
    throw InputError(fmt::format(
        "{}: found no two legs (each a chain from the pelvis through a knee to a foot, the "
        "lowest body) among its bodies: {}; give a joint map with --map",
        model_name, body_list(mt)));
  if (!legs_complete(cr))
    throw InputError(fmt::format(
        "{}: found no two legs (thigh, knee, foot) among its joints: {}; give a joint map with "
        "--map",
        clip_name, body_list(ct)));
  find_upper_body(ct, cr, false);
  find_upper_body(mt, mr, true);

  AutoJointMap out;
  out.map.source = model_name + " (found automatically)";
  out.map.model_up = mt.up.y() > 0.5 ? 'y' : 'z';
  out.clip_leg_length_m = leg_length(ct, cr);
  out.model_leg_length_m = leg_length(mt, mr);
  out.map.scale = out.model_leg_length_m / out.clip_leg_length_m;
  std::set<int> used_segments, used_bodies;
  auto add = [&](const std::string& role, int segment, int body) {
    JointMapRole r{role, segment >= 0 ? ct.names[segment] : "", body >= 0 ? mt.names[body] : ""};
    if (r.matched() && used_segments.insert(segment).second && used_bodies.insert(body).second)
      out.map.joints.push_back({r.segment, r.body, 0});
    out.roles.push_back(r);
  };
  add("pelvis", cr.pelvis, mr.pelvis);
  const int nc = static_cast<int>(cr.spine.size()), nm = static_cast<int>(mr.spine.size());
  const int k = std::min(nc, nm);
  for (int i = 0; i < k; ++i)
    add(k == 1 ? "spine" : fmt::format("spine {}", i + 1), cr.spine[spread(i, nc, k)],
        mr.spine[spread(i, nm, k)]);
  if (nc != nm && (nc == 0 || nm == 0)) add("spine", nc ? cr.spine[0] : -1, nm ? mr.spine[0] : -1);
  add("chest", cr.chest, mr.chest);
  add("head", cr.head, mr.head);
  for (int s = 0; s < 2; ++s) {
    const std::string side = s == 0 ? "left " : "right ";
    add(side + "thigh", cr.thigh[s], mr.thigh[s]);
    add(side + "shin", cr.shin[s], mr.shin[s]);
    add(side + "foot", cr.foot[s], mr.foot[s]);
  }
  for (int s = 0; s < 2; ++s) {
    const std::string side = s == 0 ? "left " : "right ";
    add(side + "upper arm", cr.upper_arm[s], mr.upper_arm[s]);
    add(side + "lower arm", cr.lower_arm[s], mr.lower_arm[s]);
  }
  return out;
}

AutoJointMap find_joint_map_of_files(const std::string& bvh_path, const std::string& model_path,
                                     const std::string& engine, double scale_to_meters) {
  MotionSkeletonOptions options;
  options.scale_to_meters = scale_to_meters;
  const BvhClip clip = read_bvh(bvh_path);
  const MotionSkeleton skeleton = make_motion_skeleton(clip, options);
  WorldSpec spec;
  spec.models.push_back({model_path});
  std::unique_ptr<Engine> model = make_engine(engine, spec);
  model->forward();
  return find_joint_map(skeleton, bvh_path, *model, model_path,
                        first_frame_if_lying(clip, skeleton));
}

std::string joint_map_report(const AutoJointMap& found) {
  std::string out = fmt::format(
      "joint map: {} of {} roles matched; scale {:.4g} (leg {:.3g} m on the model, {:.3g} m in "
      "the clip)\n",
      found.map.joints.size(), found.roles.size(), *found.map.scale, found.model_leg_length_m,
      found.clip_leg_length_m);
  for (const JointMapRole& r : found.roles) {
    if (r.matched())
      out += fmt::format("  {:<16} {} -> {}\n", r.role, r.segment, r.body);
    else
      out += fmt::format("  {:<16} not matched: {}\n", r.role,
                         r.segment.empty() && r.body.empty() ? "in neither"
                         : r.segment.empty() ? "not in the clip (model: " + r.body + ")"
                                             : "not in the model (clip: " + r.segment + ")");
  }
  return out;
}

std::string joint_map_yaml(const AutoJointMap& found, const std::string& clip_name,
                           const std::string& model_name) {
  auto quoted = [](const std::string& s) {
    YAML::Emitter e;
    e << YAML::DoubleQuoted << s;
    return std::string(e.c_str());
  };
  std::string out = fmt::format(
      "# Joint map found by `stance bvh track` from the model's tree and names: the clip\n"
      "# {}\n# onto the model {}.\n"
      "# Keys are clip joints, values model bodies. Edit it and pass it back with --map.\n",
      clip_name, model_name);
  out += fmt::format("model_up: {}\nyaw_deg: auto\n", found.map.model_up);
  out +=
      fmt::format("scale: {:.6g}    # leg length: {:.4g} m on the model / {:.4g} m in the clip\n",
                  *found.map.scale, found.model_leg_length_m, found.clip_leg_length_m);
  out += "height_offset: auto\njoints:\n";
  for (const JointMapEntry& j : found.map.joints) {
    std::string role;
    for (const JointMapRole& r : found.roles)
      if (r.segment == j.segment && r.body == j.body) role = r.role;
    out += fmt::format("  {}: {}    # {}\n", quoted(j.segment), quoted(j.body), role);
  }
  for (const JointMapRole& r : found.roles)
    if (!r.matched())
      out += fmt::format("  # {}: not matched (clip: {}, model: {})\n", r.role,
                         r.segment.empty() ? "none" : r.segment, r.body.empty() ? "none" : r.body);
  return out;
}

}  // namespace stance
