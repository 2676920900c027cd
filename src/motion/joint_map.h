// The YAML joint-name map of retargeting (control/retarget.h): which clip segment drives which
// model body, the model's up axis, and the yaw, scale and height the clip is placed with.
// Parsed here, free of any engine.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace stance {

struct JointMapEntry {
  std::string segment;  // clip joint (a MotionSkeleton segment)
  std::string body;     // model body
  int line = 0;         // in the map file, for messages
};

struct JointMap {
  std::string source;  // file name, for messages
  std::vector<JointMapEntry> joints;
  char model_up = 'z';            // the model's up axis: 'z' (MuJoCo) or 'y' (DART .skel)
  std::optional<double> yaw_deg;  // clip -> model yaw about up; empty: aligned automatically
  std::optional<double> scale;    // model length per clip metre; empty: ratio of heights
  // added to the root along up; empty: found so that the model's lowest point touches the
  // floor in the first frame (the clip's ankles and the model's differ in height above the sole)
  std::optional<double> height_offset_m;
  bool align_bones = true;  // rest-pose correction A_s
};

// throws InputError naming the file and line
JointMap parse_joint_map(const YAML::Node& node, const std::string& source);
JointMap read_joint_map(const std::string& path);

}  // namespace stance
