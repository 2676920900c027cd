// The ground of URDF/SDF robots: whether a set of robots needs one, and its URDF text.
#include "model/robot_model.h"

#include <tinyxml2.h>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/model_format.h"
#include "model/mjcf_writing.h"
#include "model/robot_model_detail.h"
#include "model/xml_reader.h"

namespace stance {

bool robot_is_ground(const RobotModel& robot) {
  if (!robot.root_joint.empty()) return false;
  for (const RobotJoint& j : robot.joints)
    if (j.type != RobotJointType::kFixed) return false;
  return std::any_of(robot.links.begin(), robot.links.end(),
                     [](const RobotLink& l) { return !l.collisions.empty(); });
}

bool robots_need_ground(const std::vector<RobotModel>& robots) {
  const auto floats = [](const RobotModel& r) {
    return !r.root_joint.empty() ||
           std::any_of(r.joints.begin(), r.joints.end(),
                       [](const RobotJoint& j) { return j.type == RobotJointType::kFloating; });
  };
  return std::none_of(robots.begin(), robots.end(), robot_is_ground) &&
         std::any_of(robots.begin(), robots.end(), floats);
}

std::string ground_urdf_text() {
  return R"(<?xml version="1.0"?>
<!-- a Z-up ground for URDF/SDF robots (stance's models/ground.urdf): a 40 m x 40 m box whose
     top face is z = 0, welded to the world -->
<robot name="ground">
  <link name="world"/>
  <link name="ground">
    <inertial>
      <mass value="1"/>
      <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
    <collision>
      <origin xyz="0 0 -0.5"/>
      <geometry><box size="40 40 1"/></geometry>
    </collision>
    <visual>
      <origin xyz="0 0 -0.5"/>
      <geometry><box size="40 40 1"/></geometry>
    </visual>
  </link>
  <joint name="ground_weld" type="fixed">
    <parent link="world"/>
    <child link="ground"/>
  </joint>
</robot>
)";
}

}  // namespace stance
