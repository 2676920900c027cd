// A clip rewritten the ways other exporters write the same motion (the tests that stance reads
// any sane BVH without a setting):
//  - Z-up: the skeleton written Z-up, or the Y-up skeleton turned onto Z-up by its root's
//    rotation in every frame;
//  - other joint names (Bandai Namco's Foot_L, 3ds Max's "Bip01 L Foot", DAZ's lFoot);
//  - a carrier ROOT above the old root, which gets position channels of its own (Bandai Namco's
//    joint_Root on the floor above a floating Hips);
//  - leading T-pose frames (cgspeed's CMU release begins with one).
#pragma once

#include <map>
#include <numbers>
#include <string>

#include "motion/bvh.h"

namespace stance::test {

// C: +90 deg about x, y -> z
inline Eigen::Quaterniond y_to_z() {
  return Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()));
}

// every offset, end site and root position turned by C, every local rotation conjugated by it
inline BvhClip written_z_up(BvhClip clip) {
  const Eigen::Quaterniond c = y_to_z();
  for (BvhJoint& j : clip.joints) {
    j.offset = c * j.offset;
    j.end_site_offset = c * j.end_site_offset;
  }
  for (Eigen::Quaterniond& q : clip.rotations) q = c * q * c.conjugate();
  for (Eigen::Vector3d& p : clip.positions) p = c * p;
  return clip;
}

// the skeleton as it is, the root's rotation and position turned by C in every frame
inline BvhClip root_turned_z_up(BvhClip clip) {
  const Eigen::Quaterniond c = y_to_z();
  const BvhJoint& root = clip.joints[0];
  for (int f = 0; f < clip.frame_count; ++f) {
    clip.rotation(f, 0) = c * clip.rotation(f, 0);
    if (root.position_slot >= 0)
      clip.positions[static_cast<size_t>(f) * clip.position_joint_count + root.position_slot] =
          c * clip.translation(f, 0);
  }
  return clip;
}

// the joints renamed (names not in `names` stay)
inline BvhClip renamed(BvhClip clip, const std::map<std::string, std::string>& names) {
  for (BvhJoint& j : clip.joints)
    if (auto it = names.find(j.name); it != names.end()) j.name = it->second;
  return clip;
}

// Bandai Namco's names for the synthetic walk's joints
inline const std::map<std::string, std::string>& bandai_names() {
  static const std::map<std::string, std::string> names = {
      {"LeftUpLeg", "UpperLeg_L"},   {"LeftLeg", "LowerLeg_L"},     {"LeftFoot", "Foot_L"},
      {"RightUpLeg", "UpperLeg_R"},  {"RightLeg", "LowerLeg_R"},    {"RightFoot", "Foot_R"},
      {"LeftArm", "UpperArm_L"},     {"LeftForeArm", "LowerArm_L"}, {"RightArm", "UpperArm_R"},
      {"RightForeArm", "LowerArm_R"}};
  return names;
}

// a new ROOT `name` that carries the old root, which must have position channels: the carrier
// moves (half the root's path, and a rocking turn) and the old root's channels are what is
// left, so that every joint's world pose is the clip's
inline BvhClip with_carrier_root(const BvhClip& in, const std::string& name) {
  BvhClip out = in;
  BvhJoint carrier;
  carrier.name = name;
  carrier.channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition,
                      BvhChannel::kZrotation, BvhChannel::kXrotation, BvhChannel::kYrotation};
  carrier.order = RotationOrder::kZXY;
  carrier.rotation_channel_count = 3;
  carrier.has_position = true;
  out.joints.insert(out.joints.begin(), carrier);
  int column = 0, slots = 0;
  for (size_t j = 0; j < out.joints.size(); ++j) {
    BvhJoint& joint = out.joints[j];
    if (j > 0) joint.parent += 1;
    joint.first_column = column;
    column += static_cast<int>(joint.channels.size());
    joint.position_slot = joint.has_position ? slots++ : -1;
  }
  out.channel_count = column;
  out.position_joint_count = slots;
  out.raw.resize(0, 0);
  const size_t nj = out.joints.size();
  out.rotations.assign(nj * in.frame_count, Eigen::Quaterniond::Identity());
  out.positions.assign(static_cast<size_t>(slots) * in.frame_count, Eigen::Vector3d::Zero());
  for (int f = 0; f < in.frame_count; ++f) {
    const Eigen::Vector3d t = in.translation(f, 0);
    const Eigen::Vector3d carried = 0.5 * t;
    const Eigen::Quaterniond turn(
        Eigen::AngleAxisd(0.3 * std::sin(0.1 * f), Eigen::Vector3d(0.2, 1, 0.1).normalized()));
    out.rotation(f, 0) = turn;
    out.positions[static_cast<size_t>(f) * slots] = carried;
    out.rotation(f, 1) = turn.conjugate() * in.rotation(f, 0);
    out.positions[static_cast<size_t>(f) * slots + 1] = turn.conjugate() * (t - carried);
    for (size_t j = 1; j < in.joints.size(); ++j) {
      out.rotation(f, static_cast<int>(j) + 1) = in.rotation(f, static_cast<int>(j));
      if (in.joints[j].position_slot >= 0)
        out.positions[static_cast<size_t>(f) * slots + in.joints[j].position_slot + 1] =
            in.translation(f, static_cast<int>(j));
    }
  }
  out.joints[1].offset = out.translation(0, 1);
  return out;
}

// every joint keyed with position channels that carry its bone, and the hierarchy's OFFSETs
// scaled by `offset_scale` (0: all zero), as exporters that key every joint may write them
inline BvhClip with_bones_in_position_channels(const BvhClip& in, double offset_scale) {
  BvhClip out = in;
  int column = 0, slots = 0;
  for (BvhJoint& joint : out.joints) {
    if (!joint.has_position) {
      joint.channels.insert(joint.channels.begin(), {BvhChannel::kXposition, BvhChannel::kYposition,
                                                     BvhChannel::kZposition});
      joint.has_position = true;
    }
    joint.first_column = column;
    column += static_cast<int>(joint.channels.size());
    joint.position_slot = slots++;
  }
  out.channel_count = column;
  out.position_joint_count = slots;
  out.raw.resize(0, 0);
  out.positions.assign(static_cast<size_t>(slots) * in.frame_count, Eigen::Vector3d::Zero());
  for (int f = 0; f < in.frame_count; ++f)
    for (size_t j = 0; j < out.joints.size(); ++j)
      out.positions[static_cast<size_t>(f) * slots + j] = in.translation(f, static_cast<int>(j));
  for (size_t j = 1; j < out.joints.size(); ++j) out.joints[j].offset *= offset_scale;
  return out;
}

// `count` T-pose frames put before the synthetic walk or run, its root at `root` (file units):
// every rotation the identity but the upper arms', raised sideways from hanging down
inline BvhClip with_leading_t_pose(const BvhClip& in, int count, const Eigen::Vector3d& root) {
  BvhClip out = in;
  const size_t nj = in.joints.size(), slots = in.position_joint_count;
  out.frame_count = in.frame_count + count;
  out.raw.resize(0, 0);
  std::vector<Eigen::Quaterniond> t_pose(nj * count, Eigen::Quaterniond::Identity());
  std::vector<Eigen::Vector3d> rest(slots * count);
  for (int f = 0; f < count; ++f)
    for (size_t j = 0; j < nj; ++j) {
      const std::string& name = in.joints[j].name;
      if (name == "LeftArm" || name == "RightArm")
        t_pose[f * nj + j] = Eigen::AngleAxisd((name == "LeftArm" ? 1 : -1) * std::numbers::pi / 2,
                                               Eigen::Vector3d::UnitZ());
      if (in.joints[j].position_slot >= 0)
        rest[f * slots + in.joints[j].position_slot] = j == 0 ? root : in.joints[j].offset;
    }
  out.rotations.insert(out.rotations.begin(), t_pose.begin(), t_pose.end());
  out.positions.insert(out.positions.begin(), rest.begin(), rest.end());
  return out;
}

}  // namespace stance::test
