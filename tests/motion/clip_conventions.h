// A clip rewritten the ways other exporters write the same motion (the tests that stance reads
// any sane BVH without a setting):
//  - Z-up: the skeleton written Z-up, or the Y-up skeleton turned onto Z-up by its root's
//    rotation in every frame;
//  - other joint names (Bandai Namco's Foot_L, 3ds Max's "Bip01 L Foot", DAZ's lFoot);
//  - a carrier ROOT above the old root, which gets position channels of its own (Bandai Namco's
//    joint_Root on the floor above a floating Hips);
//  - leading T-pose frames (cgspeed's CMU release begins with one);
//  - other units (every length scaled), a namespace prefix on every name (Mixamo's);
//  - a rest pose that is no standing pose (Bandai Namco's bones all lie along X), and a carrier
//    root on the ground under the hips that holds the clip's translation or none of it.
#pragma once

#include <functional>
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

// every name with `prefix` in front ("mixamorig:")
inline BvhClip prefixed(BvhClip clip, const std::string& prefix) {
  for (BvhJoint& j : clip.joints) j.name = prefix + j.name;
  return clip;
}

// every length (OFFSETs, End Sites, position channels) times `factor`: the clip in other units
inline BvhClip rescaled(BvhClip clip, double factor) {
  for (BvhJoint& j : clip.joints) {
    j.offset *= factor;
    j.end_site_offset *= factor;
  }
  for (Eigen::Vector3d& p : clip.positions) p *= factor;
  return clip;
}

// every joint's frame turned so that its bone (to its first child, else its End Site) lies along
// its +X and rolled about it by `roll_rad`, the rotations and translations turned to match: the
// rest pose lies along X, as Bandai Namco's does, and every frame poses every joint where the clip
// does
inline BvhClip with_bones_along_x(const BvhClip& in, double roll_rad = 0) {
  BvhClip out = in;
  const int n = in.joint_count();
  std::vector<Eigen::Quaterniond> turn(n, Eigen::Quaterniond::Identity());
  for (int j = n - 1; j >= 0; --j) {
    Eigen::Vector3d bone =
        in.joints[j].has_end_site ? in.joints[j].end_site_offset : Eigen::Vector3d::Zero();
    for (int c = n - 1; c > j; --c)
      if (in.joints[c].parent == j) bone = bvh_rest_translation(in, c);  // the first child
    if (bone.norm() > 0)
      turn[j] = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitX(), bone) *
                Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX());
  }
  auto parent_turn = [&](int j) {
    const int p = in.joints[j].parent;
    return p < 0 ? Eigen::Quaterniond::Identity() : turn[p];
  };
  for (int j = 0; j < n; ++j) {
    out.joints[j].offset = parent_turn(j).conjugate() * in.joints[j].offset;
    out.joints[j].end_site_offset = turn[j].conjugate() * in.joints[j].end_site_offset;
  }
  for (int f = 0; f < in.frame_count; ++f)
    for (int j = 0; j < n; ++j) {
      out.rotation(f, j) = parent_turn(j).conjugate() * in.rotation(f, j) * turn[j];
      if (in.joints[j].position_slot >= 0)
        out.positions[static_cast<size_t>(f) * in.position_joint_count +
                      in.joints[j].position_slot] =
            parent_turn(j).conjugate() * in.translation(f, j);
    }
  out.raw.resize(0, 0);
  return out;
}

// the carrier's translation and rotation at a frame, given the old root's translation there
using CarrierPose = std::function<void(int frame, const Eigen::Vector3d& root,
                                       Eigen::Vector3d& translation, Eigen::Quaterniond& rotation)>;

// a new ROOT `name` with 6 channels that carries the old root, which must have position
// channels: the carrier is posed by `pose` and the old root's channels are what is left, so that
// every joint's world pose is the clip's
inline BvhClip with_carrier_root(const BvhClip& in, const std::string& name,
                                 const CarrierPose& pose) {
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
    Eigen::Vector3d carried = Eigen::Vector3d::Zero();
    Eigen::Quaterniond turn = Eigen::Quaterniond::Identity();
    pose(f, t, carried, turn);
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

// the carrier moves (half the root's path, and a rocking turn)
inline BvhClip with_carrier_root(const BvhClip& in, const std::string& name) {
  return with_carrier_root(in, name,
                           [](int f, const Eigen::Vector3d& root, Eigen::Vector3d& translation,
                              Eigen::Quaterniond& rotation) {
                             translation = 0.5 * root;
                             rotation =
                                 Eigen::AngleAxisd(0.3 * std::sin(0.1 * f),
                                                   Eigen::Vector3d(0.2, 1, 0.1).normalized());
                           });
}

// Bandai Namco's carrier: on the ground under the root (Y up), holding the clip's horizontal
// translation, or, `holds_translation` false, standing still at the origin
inline BvhClip with_ground_carrier_root(const BvhClip& in, const std::string& name,
                                        bool holds_translation) {
  return with_carrier_root(in, name,
                           [holds_translation](int, const Eigen::Vector3d& root,
                                               Eigen::Vector3d& translation, Eigen::Quaterniond&) {
                             translation = Eigen::Vector3d(root.x(), 0, root.z());
                             if (!holds_translation) translation.setZero();
                           });
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

// every End Site of a joint named in `names` becomes a joint of that name (3 rotation channels,
// still, with an End Site of zero length), as LaFAN1's toes, hands and head are
inline BvhClip with_end_sites_as_joints(const BvhClip& in,
                                        const std::map<std::string, std::string>& names) {
  BvhClip out = in;
  out.joints.clear();
  std::vector<int> from;  // per new joint: its joint in `in`, or -1
  std::vector<int> index(in.joints.size());
  for (size_t j = 0; j < in.joints.size(); ++j) {
    BvhJoint joint = in.joints[j];
    if (joint.parent >= 0) joint.parent = index[joint.parent];
    index[j] = static_cast<int>(out.joints.size());
    const auto it = joint.has_end_site ? names.find(joint.name) : names.end();
    BvhJoint leaf;
    if (it != names.end()) {  // a joint with an End Site has no children: its leaf comes next
      leaf.name = it->second;
      leaf.parent = index[j];
      leaf.offset = joint.end_site_offset;
      leaf.channels = {BvhChannel::kZrotation, BvhChannel::kXrotation, BvhChannel::kYrotation};
      leaf.order = RotationOrder::kZXY;
      leaf.rotation_channel_count = 3;
      leaf.has_end_site = true;
      joint.has_end_site = false;
    }
    out.joints.push_back(joint);
    from.push_back(static_cast<int>(j));
    if (it != names.end()) {
      out.joints.push_back(leaf);
      from.push_back(-1);
    }
  }
  int column = 0;
  for (BvhJoint& joint : out.joints) {
    joint.first_column = column;
    column += static_cast<int>(joint.channels.size());
  }
  out.channel_count = column;
  out.raw.resize(0, 0);
  out.rotations.assign(out.joints.size() * in.frame_count, Eigen::Quaterniond::Identity());
  for (int f = 0; f < in.frame_count; ++f)
    for (size_t j = 0; j < out.joints.size(); ++j)
      if (from[j] >= 0) out.rotation(f, static_cast<int>(j)) = in.rotation(f, from[j]);
  return out;
}

// every joint's rotation channels listed Z, Y, X (the root's after its positions), the frames
// unchanged
inline BvhClip with_zyx_channels(BvhClip clip) {
  for (BvhJoint& joint : clip.joints) {
    std::vector<BvhChannel> channels;
    if (joint.has_position)
      channels = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
    for (BvhChannel c : {BvhChannel::kZrotation, BvhChannel::kYrotation, BvhChannel::kXrotation})
      channels.push_back(c);
    joint.channels = channels;
    joint.order = RotationOrder::kZYX;
  }
  clip.raw.resize(0, 0);
  return clip;
}

// every `step`-th frame (60 Hz -> 30 Hz at 2)
inline BvhClip every_nth_frame(const BvhClip& in, int step) {
  BvhClip out = in;
  out.frame_count = (in.frame_count + step - 1) / step;
  out.frame_time_s = in.frame_time_s * step;
  out.raw.resize(0, 0);
  out.rotations.clear();
  out.positions.clear();
  for (int f = 0; f < in.frame_count; f += step) {
    for (int j = 0; j < in.joint_count(); ++j) out.rotations.push_back(in.rotation(f, j));
    for (int k = 0; k < in.position_joint_count; ++k)
      out.positions.push_back(in.positions[static_cast<size_t>(f) * in.position_joint_count + k]);
  }
  return out;
}

// the synthetic walk or run as Ubisoft LaForge's LaFAN1 writes its clips: 30 Hz, centimetres,
// Y up; rotations Z, Y, X, positions on the root only, whose OFFSET is where it starts; the rest
// pose lies along X (every bone on its joint's +X, the hips across Z); the toes, hands and head
// are joints of their own whose End Sites have zero length; LaFAN1's joint names
inline BvhClip lafan1_like(const BvhClip& walk) {
  BvhClip clip = renamed(with_end_sites_as_joints(walk, {{"LeftFoot", "LeftToe"},
                                                         {"RightFoot", "RightToe"},
                                                         {"LeftForeArm", "LeftHand"},
                                                         {"RightForeArm", "RightHand"},
                                                         {"Head", "HeadEnd"}}),
                         {{"Head", "Neck"}, {"Chest", "Spine1"}});
  clip = renamed(clip, {{"HeadEnd", "Head"}});
  clip = with_zyx_channels(every_nth_frame(with_bones_along_x(clip), 2));
  clip.joints[0].offset = clip.translation(0, 0);
  return clip;
}

}  // namespace stance::test
