// BVH clips: the body's root, the rest pose, the file's units, up axis and first motion frame,
// and the summary of `stance bvh info`. Reading is in bvh_parse.cc, writing in bvh_write.cc.
#include "motion/bvh.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <fmt/format.h>

#include "motion/bvh_measure.h"

namespace stance {

namespace {

struct UnitGuess {
  double scale_to_meters;
  std::string units;
};

}  // namespace

Eigen::Vector3d bvh_rest_translation(const BvhClip& clip, int joint) {
  const BvhJoint& j = clip.joints[joint];
  if (j.position_slot < 0 || clip.frame_count == 0) return j.offset;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int f = 0; f < clip.frame_count; ++f) sum += clip.translation(f, joint);
  return sum / clip.frame_count;
}

int bvh_body_root(const BvhClip& clip) {
  int body_root = 0;
  for (;;) {
    int children = 0, child = -1;
    for (int j = body_root + 1; j < clip.joint_count(); ++j)
      if (clip.joints[j].parent == body_root) {
        ++children;
        child = j;
      }
    if (children != 1 || !clip.joints[child].has_position) return body_root;
    body_root = child;
  }
}

namespace {

// the lowest drop of a leaf (end site or childless joint) below the body's root
// (bvh_body_root) along -y and -z, in the first frame's pose or at rest
Eigen::Vector2d leaf_drop(const BvhClip& clip, bool posed) {
  const size_t n = clip.joints.size();
  std::vector<Eigen::Vector3d> pos(n, Eigen::Vector3d::Zero());
  std::vector<Eigen::Quaterniond> rot(n, Eigen::Quaterniond::Identity());
  std::vector<bool> has_child(n, false), in_first_tree(n, false);
  Eigen::Vector2d drop = Eigen::Vector2d::Zero();
  for (size_t j = 0; j < n; ++j) {
    const BvhJoint& joint = clip.joints[j];
    const int p = joint.parent;
    const Eigen::Quaterniond local = posed && clip.frame_count > 0
                                         ? clip.rotation(0, static_cast<int>(j))
                                         : Eigen::Quaterniond::Identity();
    if (p < 0) {
      in_first_tree[j] = j == 0;
      rot[j] = local;
    } else {
      in_first_tree[j] = in_first_tree[p];
      has_child[p] = true;
      const int ji = static_cast<int>(j);
      pos[j] = pos[p] + rot[p] * (posed && clip.frame_count > 0 ? clip.translation(0, ji)
                                                                : bvh_rest_translation(clip, ji));
      rot[j] = rot[p] * local;
    }
  }
  const size_t body_root = static_cast<size_t>(bvh_body_root(clip));
  for (size_t j = 0; j < n; ++j) {
    if (!in_first_tree[j]) continue;
    const BvhJoint& joint = clip.joints[j];
    auto lower = [&](const Eigen::Vector3d& q) {
      drop.x() = std::max(drop.x(), pos[body_root].y() - q.y());
      drop.y() = std::max(drop.y(), pos[body_root].z() - q.z());
    };
    if (joint.has_end_site) lower(pos[j] + rot[j] * joint.end_site_offset);
    if (!has_child[j]) lower(pos[j]);
  }
  return drop;
}

UnitGuess guess_units(const BvhClip& clip) {
  if (clip.joints.empty()) return {1.0, "unknown"};
  // the legs: the longest drop below the root, at rest or, where the rest pose does not stand,
  // in the posed frames (bvh_measure.h)
  const double leg = bvh_leg_drop(clip);
  if (!(leg > 0.0)) return {1.0, "unknown"};

  struct Unit {
    double scale;
    const char* name;
  };
  static constexpr Unit kUnits[] = {{1.0, "meters"},        {0.01, "centimeters"},
                                    {0.001, "millimeters"}, {0.0254, "inches"},
                                    {0.3048, "feet"},       {0.056444, "cmu"}};
  constexpr double kTypicalLegM = 0.9;
  const Unit* best = nullptr;
  double best_err = INFINITY;
  for (const Unit& u : kUnits) {
    double leg_m = leg * u.scale;
    if (leg_m < 0.45 || leg_m > 1.5) continue;
    double err = std::abs(std::log(leg_m / kTypicalLegM));
    if (err < best_err) {
      best_err = err;
      best = &u;
    }
  }
  if (best) return {best->scale, best->name};
  return {kTypicalLegM / leg, "unknown"};
}

}  // namespace

char detect_bvh_up_axis(const BvhClip& clip, bool posed) {
  if (clip.joints.empty()) return 'y';
  const Eigen::Vector2d drop = leaf_drop(clip, posed);
  return drop.y() > drop.x() ? 'z' : 'y';
}

double detect_bvh_scale_to_meters(const BvhClip& clip) {
  return guess_units(clip).scale_to_meters;
}

std::string detect_bvh_units(const BvhClip& clip) {
  return guess_units(clip).units;
}

int detect_bvh_first_motion_frame(const BvhClip& clip) {
  const int frames = clip.frame_count;
  if (frames < 8) return 0;
  const double scale = detect_bvh_scale_to_meters(clip);
  // per step from frame f to f + 1: the largest turn of a joint and the largest move of a joint
  // with position channels
  std::vector<double> turn(frames - 1, 0.0), move(frames - 1, 0.0);
  for (int f = 0; f + 1 < frames; ++f)
    for (int j = 0; j < clip.joint_count(); ++j) {
      turn[f] = std::max(turn[f], geodesic_angle(clip.rotation(f, j), clip.rotation(f + 1, j)));
      if (clip.joints[j].position_slot >= 0)
        move[f] =
            std::max(move[f], scale * (clip.translation(f + 1, j) - clip.translation(f, j)).norm());
    }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  // a jump: ten times a typical step, and at least 30 deg or 0.25 m
  const double turn_jump = std::max(30 * std::numbers::pi / 180, 10 * median(turn));
  const double move_jump = std::max(0.25, 10 * median(move));
  // after the last jump among the first three steps
  int first = 0;
  for (int f = 0; f < std::min(3, frames - 2); ++f)
    if (turn[f] > turn_jump || move[f] > move_jump) first = f + 1;
  return first;
}

nlohmann::json bvh_info_json(const BvhClip& clip) {
  UnitGuess units = guess_units(clip);
  nlohmann::json orders = nlohmann::json::object();
  int end_sites = 0;
  for (const BvhJoint& j : clip.joints) {
    if (j.has_end_site) ++end_sites;
    if (j.rotation_channel_count > 0) orders[j.name] = rotation_order_name(j.order);
  }
  return {
      {"file", clip.source},
      {"frames", clip.frame_count},
      {"frame_time", clip.frame_time_s},
      {"joints", clip.joint_count()},
      {"end_sites", end_sites},
      {"channels", clip.channel_count},
      {"duration_s", clip.frame_count * clip.frame_time_s},
      {"rotation_orders", orders},
      {"units", units.units},
      {"scale_to_meters", units.scale_to_meters},
      {"up_axis", std::string(1, detect_bvh_up_axis(clip))},
      {"first_motion_frame", detect_bvh_first_motion_frame(clip)},
      {"character", bvh_measures_json(clip)},
  };
}

std::string bvh_info_text(const BvhClip& clip) {
  UnitGuess units = guess_units(clip);
  int end_sites = 0;
  std::map<std::string_view, int> order_counts;
  for (const BvhJoint& j : clip.joints) {
    if (j.has_end_site) ++end_sites;
    if (j.rotation_channel_count > 0) ++order_counts[rotation_order_name(j.order)];
  }
  std::string out;
  out += fmt::format("file:        {}\n", clip.source);
  out += fmt::format("frames:      {}\n", clip.frame_count);
  out +=
      fmt::format("frame time:  {} s ({:.4g} fps)\n", clip.frame_time_s, 1.0 / clip.frame_time_s);
  out += fmt::format("duration:    {:.4g} s\n", clip.frame_count * clip.frame_time_s);
  out += fmt::format("joints:      {} (+{} End Sites)\n", clip.joint_count(), end_sites);
  out += fmt::format("channels:    {} per frame\n", clip.channel_count);
  out +=
      fmt::format("units:       {} ({:.6g} m per file unit)\n", units.units, units.scale_to_meters);
  out += fmt::format("up axis:     {}\n", detect_bvh_up_axis(clip));
  if (int first = detect_bvh_first_motion_frame(clip); first > 0)
    out += fmt::format(
        "motion from: frame {} (the frames before jump to it: a T-pose or rest pose)\n", first);
  out += bvh_measures_text(clip);
  std::string orders;
  for (const auto& [name, count] : order_counts) {
    orders += fmt::format("{}{} x{}", orders.empty() ? "" : ", ", name, count);
  }
  out += fmt::format("rotations:   {}\n", orders.empty() ? "none" : orders);
  out += "joint tree (order, channels):\n";
  std::vector<int> depth(clip.joints.size(), 0);
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    const BvhJoint& joint = clip.joints[j];
    if (joint.parent >= 0) depth[j] = depth[joint.parent] + 1;
    std::string order = joint.rotation_channel_count > 0
                            ? std::string(rotation_order_name(joint.order))
                            : std::string("-");
    out += fmt::format("  {}{}  {}  {}{}{}\n", std::string(2 * depth[j], ' '), joint.name, order,
                       joint.channels.size(), joint.has_position ? " +position" : "",
                       joint.has_end_site ? "  [End Site]" : "");
  }
  return out;
}

}  // namespace stance
