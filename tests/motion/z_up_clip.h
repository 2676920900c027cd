// A Y-up clip made Z-up, the two ways files come: the skeleton written Z-up, or the Y-up
// skeleton turned onto Z-up by its root's rotation in every frame (the up-axis tests).
#pragma once

#include <numbers>

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

}  // namespace stance::test
