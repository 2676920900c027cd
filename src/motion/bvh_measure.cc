#include "motion/bvh_measure.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "motion/reference_motion.h"

namespace stance {
namespace {

constexpr int kMaxMeasuredFrames = 64;
constexpr double kSpeedWindowS = 0.25;

// the points of one pose, file axes and units: every joint, and per joint its leaf point (its
// end site, or itself when it has no child), for the joints at and below the body root
struct PosePoints {
  std::vector<Eigen::Vector3d> joint;
  std::vector<Eigen::Vector3d> end;
};

struct Tree {
  int body_root = 0;
  std::vector<bool> in_body, leaf;  // per joint, for the legs
  // per joint, for the height and the heading: in the body and no helper (a name the skeleton
  // skips, as MASS's _RIGMESH joints; their subtrees too); its end site counts unless it is
  // longer than half the legs (MASS's right hand has a 1.6 m one)
  std::vector<bool> counted, end_counted, counted_leaf;
};

Tree body_tree(const BvhClip& clip) {
  const int n = clip.joint_count();
  Tree t;
  t.body_root = bvh_body_root(clip);
  t.in_body.assign(n, false);
  std::vector<bool> has_child(n, false);
  for (int j = 0; j < n; ++j) {
    const int p = clip.joints[j].parent;
    if (p >= 0) has_child[p] = true;
    t.in_body[j] = j == t.body_root || (p >= 0 && t.in_body[p]);
  }
  t.leaf.assign(n, false);
  for (int j = 0; j < n; ++j)
    t.leaf[j] = t.in_body[j] && (clip.joints[j].has_end_site || !has_child[j]);
  return t;
}

// the counted joints of `t`, given the legs' drop (file units)
void count_joints(const BvhClip& clip, double leg_drop, Tree& t) {
  const int n = clip.joint_count();
  const MotionSkeletonOptions skeleton_defaults;
  t.counted.assign(n, false);
  t.end_counted.assign(n, false);
  t.counted_leaf.assign(n, false);
  std::vector<bool> counted_child(n, false);
  for (int j = 0; j < n; ++j) {
    const BvhJoint& joint = clip.joints[j];
    const int p = joint.parent;
    bool helper = false;
    for (const std::string& pattern : skeleton_defaults.skip_name_patterns)
      helper = helper || joint.name.find(pattern) != std::string::npos;
    t.counted[j] = t.in_body[j] && !helper && (j == t.body_root || (p >= 0 && t.counted[p]));
    t.end_counted[j] =
        t.counted[j] && joint.has_end_site && joint.end_site_offset.norm() <= 0.5 * leg_drop;
    if (t.counted[j] && p >= 0) counted_child[p] = true;
  }
  for (int j = 0; j < n; ++j)
    t.counted_leaf[j] = t.counted[j] && (t.end_counted[j] || !counted_child[j]);
}

// the pose at `frame`, or the rest pose (every rotation the identity, rest translations) when
// frame < 0
void pose_points(const BvhClip& clip, int frame, PosePoints& out) {
  const int n = clip.joint_count();
  out.joint.assign(n, Eigen::Vector3d::Zero());
  out.end.assign(n, Eigen::Vector3d::Zero());
  std::vector<Eigen::Quaterniond> rot(n, Eigen::Quaterniond::Identity());
  const bool posed = frame >= 0 && frame < clip.frame_count;
  for (int j = 0; j < n; ++j) {
    const int p = clip.joints[j].parent;
    const Eigen::Quaterniond local =
        posed ? clip.rotation(frame, j) : Eigen::Quaterniond::Identity();
    const Eigen::Vector3d t = posed ? clip.translation(frame, j) : bvh_rest_translation(clip, j);
    out.joint[j] = p < 0 ? t : Eigen::Vector3d(out.joint[p] + rot[p] * t);
    rot[j] = p < 0 ? local : rot[p] * local;
    out.end[j] = clip.joints[j].has_end_site
                     ? Eigen::Vector3d(out.joint[j] + rot[j] * clip.joints[j].end_site_offset)
                     : out.joint[j];
  }
}

int axis_index(char up) {
  return up == 'z' ? 2 : 1;
}

// the lowest leaf's drop below the body root along `axis`
double drop_along(const Tree& t, const PosePoints& p, int axis) {
  double drop = 0;
  for (size_t j = 0; j < p.joint.size(); ++j)
    if (t.leaf[j]) drop = std::max(drop, p.joint[t.body_root][axis] - p.end[j][axis]);
  return drop;
}

// the span of the counted joints and end sites along `axis`
double extent_along(const Tree& t, const PosePoints& p, int axis) {
  double lo = INFINITY, hi = -INFINITY;
  for (size_t j = 0; j < p.joint.size(); ++j) {
    if (!t.counted[j]) continue;
    const double z = p.joint[j][axis], e = t.end_counted[j] ? p.end[j][axis] : z;
    lo = std::min({lo, z, e});
    hi = std::max({hi, z, e});
  }
  return hi > lo ? hi - lo : 0.0;
}

// up to kMaxMeasuredFrames frames spread evenly over the clip, the first and last included
std::vector<int> measured_frames(const BvhClip& clip) {
  std::vector<int> frames;
  const int count = std::min(clip.frame_count, kMaxMeasuredFrames);
  for (int i = 0; i < count; ++i)
    frames.push_back(count == 1
                         ? 0
                         : static_cast<int>(std::lround(static_cast<double>(i) *
                                                        (clip.frame_count - 1) / (count - 1))));
  return frames;
}

// the rest pose's drop (along y or z, whichever is larger: the rest up axis) and the posed
// frames' largest (along the world's up axis)
struct LegDrops {
  double rest = 0, posed = 0;
  bool rest_stands() const { return rest_span_stands(rest, posed); }
};

LegDrops leg_drops(const BvhClip& clip, const Tree& t) {
  LegDrops d;
  PosePoints p;
  pose_points(clip, -1, p);
  d.rest = std::max(drop_along(t, p, 1), drop_along(t, p, 2));
  const int up = axis_index(detect_bvh_up_axis(clip, true));
  for (int f : measured_frames(clip)) {
    pose_points(clip, f, p);
    d.posed = std::max(d.posed, drop_along(t, p, up));
  }
  return d;
}

Eigen::Vector3d horizontal(Eigen::Vector3d v, char up) {
  v[axis_index(up)] = 0;
  return v;
}

// the chain of joints from the body root down to `j`
std::vector<int> chain_to(const BvhClip& clip, const Tree& t, int j) {
  std::vector<int> chain;
  for (; j >= 0 && t.in_body[j]; j = clip.joints[j].parent) chain.push_back(j);
  std::reverse(chain.begin(), chain.end());
  return chain;
}

// where the character faces at `frame`, horizontal: across the line between its thighs (the
// first joints apart from where the chains to its two lowest feet part), towards where its toes
// point (the lowest quarter's leaves, each from the point above it). Only the toes where there is
// one foot; zero when nothing tells.
Eigen::Vector3d facing_direction(const BvhClip& clip, const Tree& t, int frame, char up) {
  PosePoints p;
  pose_points(clip, frame, p);
  const int a = axis_index(up);
  const double span = extent_along(t, p, a);
  const double tiny = 1e-6 * span;
  auto leaf_point = [&](int j) { return t.end_counted[j] ? p.end[j] : p.joint[j]; };
  double lo = INFINITY;
  for (int j = 0; j < clip.joint_count(); ++j)
    if (t.counted_leaf[j]) lo = std::min(lo, leaf_point(j)[a]);
  std::vector<int> feet;
  Eigen::Vector3d toes = Eigen::Vector3d::Zero();
  for (int j = 0; j < clip.joint_count(); ++j) {
    if (!t.counted_leaf[j] || leaf_point(j)[a] > lo + 0.25 * span) continue;
    feet.push_back(j);
    int k = j;
    Eigen::Vector3d from = p.joint[j];
    while ((leaf_point(j) - from).norm() <= tiny && clip.joints[k].parent >= 0) {
      k = clip.joints[k].parent;
      from = p.joint[k];
    }
    toes += horizontal(leaf_point(j) - from, up);
  }
  if (feet.empty()) return Eigen::Vector3d::Zero();
  // the lowest foot, and the low leaf whose chain parts from it highest up
  std::sort(feet.begin(), feet.end(),
            [&](int x, int y) { return leaf_point(x)[a] < leaf_point(y)[a]; });
  const std::vector<int> first = chain_to(clip, t, feet[0]);
  std::vector<int> second;
  size_t split = first.size();
  for (size_t i = 1; i < feet.size(); ++i) {
    std::vector<int> c = chain_to(clip, t, feet[i]);
    size_t common = 0;
    while (common < c.size() && common < first.size() && c[common] == first[common]) ++common;
    if (common < split) {
      split = common;
      second = c;
    }
  }
  Eigen::Vector3d facing = toes;
  if (!second.empty() && split > 0) {
    // each thigh: the first joint below the split that is away from it
    auto thigh = [&](const std::vector<int>& c) {
      for (size_t i = split; i < c.size(); ++i)
        if ((p.joint[c[i]] - p.joint[c[split - 1]]).norm() > tiny) return p.joint[c[i]];
      return p.joint[c.back()];
    };
    Eigen::Vector3d across = Eigen::Vector3d::Zero();
    across[a] = 1;
    across = across.cross(horizontal(thigh(first) - thigh(second), up));
    if (across.norm() > tiny) facing = across.dot(toes) < 0 ? -across : across;
  }
  return facing.norm() > tiny ? Eigen::Vector3d(facing.normalized()) : Eigen::Vector3d::Zero();
}

// the body root's position at each frame (file axes and units)
std::vector<Eigen::Vector3d> body_root_path(const BvhClip& clip, int body_root) {
  std::vector<int> chain;
  for (int j = body_root; j >= 0; j = clip.joints[j].parent) chain.push_back(j);
  std::reverse(chain.begin(), chain.end());
  std::vector<Eigen::Vector3d> path(clip.frame_count);
  for (int f = 0; f < clip.frame_count; ++f) {
    Eigen::Vector3d pos = Eigen::Vector3d::Zero();
    Eigen::Quaterniond rot = Eigen::Quaterniond::Identity();
    for (int j : chain) {
      pos += rot * clip.translation(f, j);
      rot = rot * clip.rotation(f, j);
    }
    path[f] = pos;
  }
  return path;
}

}  // namespace

double bvh_leg_drop(const BvhClip& clip) {
  if (clip.joints.empty()) return 0;
  const LegDrops d = leg_drops(clip, body_tree(clip));
  return d.rest_stands() ? d.rest : d.posed;
}

BvhCharacterMeasures measure_bvh_character(const BvhClip& clip, double scale_to_meters) {
  BvhCharacterMeasures m;
  if (clip.joints.empty()) return m;
  const double s = scale_to_meters > 0 ? scale_to_meters : detect_bvh_scale_to_meters(clip);
  m.scale_to_meters = s;
  m.up_axis = detect_bvh_up_axis(clip, true);
  Tree t = body_tree(clip);
  const LegDrops d = leg_drops(clip, t);
  m.rest_pose_stands = d.rest_stands();
  const double leg = d.rest_stands() ? d.rest : d.posed;
  m.leg_m = s * leg;
  count_joints(clip, leg, t);

  // the standing height: the largest span over the poses measured
  PosePoints p;
  double span = 0;
  if (m.rest_pose_stands) {
    pose_points(clip, -1, p);
    span = extent_along(t, p, axis_index(detect_bvh_up_axis(clip, false)));
  }
  for (int f : measured_frames(clip)) {
    pose_points(clip, f, p);
    span = std::max(span, extent_along(t, p, axis_index(m.up_axis)));
  }
  m.standing_height_m = s * span;
  if (clip.frame_count == 0) return m;

  // speed over windows of about 0.25 s, from the first motion frame
  const int first = detect_bvh_first_motion_frame(clip);
  const std::vector<Eigen::Vector3d> path = body_root_path(clip, t.body_root);
  const int last = clip.frame_count - 1;
  const int window = std::min(
      last - first, std::max(1, static_cast<int>(std::lround(kSpeedWindowS / clip.frame_time_s))));
  if (window >= 1 && clip.frame_time_s > 0) {
    double sum = 0;
    int count = 0;
    for (int f = first; f + window <= last; ++f, ++count) {
      const double v = s * horizontal(path[f + window] - path[f], m.up_axis).norm() /
                       (window * clip.frame_time_s);
      sum += v;
      m.peak_speed_mps = std::max(m.peak_speed_mps, v);
    }
    m.mean_speed_mps = count ? sum / count : 0.0;
  }
  m.travel = horizontal(path[last] - path[first], m.up_axis);
  m.facing = facing_direction(clip, t, first, m.up_axis);
  return m;
}

double bvh_heading_deg(const Eigen::Vector3d& d, char up_axis) {
  const double x = up_axis == 'z' ? d.x() : d.z(), y = up_axis == 'z' ? d.y() : d.x();
  if (x == 0 && y == 0) return NAN;
  return std::atan2(y, x) * 180 / std::numbers::pi;
}

std::vector<std::string> bvh_character_warnings(const BvhClip& clip,
                                                const BvhCharacterMeasures& m) {
  std::vector<std::string> out;
  const double h = m.standing_height_m;
  if (h > 0 && (h < kMinPersonHeightM || h > kMaxPersonHeightM))
    out.push_back(fmt::format(
        "{}: the character stands {:.3g} m tall (legs {:.3g} m) at {:.6g} m per file unit, "
        "not a person's {}-{} m; if the units are wrong, set scale_to_meters (metres per file "
        "unit; {:.4g} makes it 1.7 m tall; bvh track and bvh2mjcf: --scale-to-meters)",
        clip.source, h, m.leg_m, m.scale_to_meters, kMinPersonHeightM, kMaxPersonHeightM,
        m.scale_to_meters * 1.7 / h));
  if (m.peak_speed_mps > kMaxPersonSpeedMps)
    out.push_back(fmt::format(
        "{}: the root moves at up to {:.3g} m/s (mean {:.3g} m/s) at {:.6g} m per file unit, "
        "faster than a person's {} m/s; if the units are wrong, set scale_to_meters (metres per "
        "file unit; bvh track and bvh2mjcf: --scale-to-meters)",
        clip.source, m.peak_speed_mps, m.mean_speed_mps, m.scale_to_meters, kMaxPersonSpeedMps));
  return out;
}

namespace {
// "about +Y from +Z": how bvh_heading_deg measures
std::string heading_reference(char up_axis) {
  return up_axis == 'z' ? "about +Z from +X" : "about +Y from +Z";
}
nlohmann::json heading_json(const Eigen::Vector3d& d, char up_axis) {
  const double deg = bvh_heading_deg(d, up_axis);
  return std::isnan(deg) ? nlohmann::json(nullptr) : nlohmann::json(deg);
}
std::string heading_text(const Eigen::Vector3d& d, char up_axis) {
  const double deg = bvh_heading_deg(d, up_axis);
  return std::isnan(deg) ? std::string("-") : fmt::format("{:.1f} deg", deg);
}
}  // namespace

nlohmann::json bvh_measures_json(const BvhClip& clip) {
  const BvhCharacterMeasures m = measure_bvh_character(clip);
  return {{"standing_height_m", m.standing_height_m},
          {"leg_m", m.leg_m},
          {"rest_pose_stands", m.rest_pose_stands},
          {"mean_speed_mps", m.mean_speed_mps},
          {"peak_speed_mps", m.peak_speed_mps},
          {"facing_deg", heading_json(m.facing, m.up_axis)},
          {"travel_deg", heading_json(m.travel, m.up_axis)},
          {"heading_axes", heading_reference(m.up_axis)},
          {"warnings", bvh_character_warnings(clip, m)}};
}

std::string bvh_measures_text(const BvhClip& clip) {
  const BvhCharacterMeasures m = measure_bvh_character(clip);
  std::string out;
  out += fmt::format("height:      {:.3g} m standing, legs {:.3g} m ({})\n", m.standing_height_m,
                     m.leg_m,
                     m.rest_pose_stands ? "the rest pose and the frames"
                                        : "the frames; the rest pose does not stand");
  out += fmt::format("speed:       {:.3g} m/s mean, {:.3g} m/s at most (the root, over 0.25 s)\n",
                     m.mean_speed_mps, m.peak_speed_mps);
  out += fmt::format("heading:     facing {}, travelling {} ({}, file axes)\n",
                     heading_text(m.facing, m.up_axis), heading_text(m.travel, m.up_axis),
                     heading_reference(m.up_axis));
  for (const std::string& w : bvh_character_warnings(clip, m)) out += "warning:     " + w + "\n";
  return out;
}

}  // namespace stance
