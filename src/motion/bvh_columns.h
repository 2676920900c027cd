// Private to src/motion/bvh*.cc: where each joint's channels sit in a motion row, shared by
// the reader (bvh_parse.cc) and the writer (bvh_write.cc).
#pragma once

#include <array>
#include <vector>

#include "motion/bvh.h"

namespace stance::bvh_detail {

// per joint: motion-row column of each rotation angle (listed order) and position axis, or -1
struct JointColumns {
  std::array<int, 3> rotation{-1, -1, -1};
  std::array<int, 3> position{-1, -1, -1};
};

std::vector<JointColumns> joint_columns(const BvhClip& clip);

}  // namespace stance::bvh_detail
