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
#include <iterator>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/model_format.h"
#include "model/mjcf_lock.h"
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

namespace {
using tinyxml2::XMLElement;

bool named(const XMLElement* e, const char* name) {
  return std::strcmp(e->Name(), name) == 0;
}

bool is_free_joint(const XMLElement* e) {
  const char* type = e->Attribute("type");
  return named(e, "freejoint") || (named(e, "joint") && type && std::strcmp(type, "free") == 0);
}

bool has_joint_child(const XMLElement* body) {
  for (const XMLElement* e = body->FirstChildElement(); e; e = e->NextSiblingElement())
    if (named(e, "joint") || named(e, "freejoint")) return true;
  return false;
}

// a geom that collides unless both its contype and conaffinity are 0
bool collides(const XMLElement* geom) {
  const char* type = geom->Attribute("contype");
  const char* affinity = geom->Attribute("conaffinity");
  const auto zero = [](const char* v) { return v != nullptr && std::atoi(v) == 0; };
  return !(zero(type) && zero(affinity));
}

// the geoms of `e` and of its bodies welded to it, while nothing between them moves
bool has_static_colliding_geom(const XMLElement* e) {
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (named(c, "geom") && collides(c)) return true;
    if (named(c, "body") && !has_joint_child(c) && has_static_colliding_geom(c)) return true;
  }
  return false;
}

void collect_ground_facts(const XMLElement* e, MjcfGroundFacts& facts) {
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    if (is_free_joint(c)) facts.floats = true;
    if (named(c, "worldbody") && has_static_colliding_geom(c)) facts.has_floor = true;
    collect_ground_facts(c, facts);
  }
}
}  // namespace

MjcfGroundFacts mjcf_ground_facts(const std::string& path) {
  const auto text_of = [](const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  MjcfGroundFacts facts;
  for (const std::string& file : mjcf_include_paths(path, text_of)) {
    const std::string text = text_of(file);
    tinyxml2::XMLDocument doc;
    if (doc.Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS) continue;
    if (doc.RootElement() != nullptr) collect_ground_facts(doc.RootElement(), facts);
  }
  return facts;
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
