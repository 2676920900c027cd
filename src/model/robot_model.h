// Robots that users bring, as URDF or SDF files: one reader per format into one description,
// checked before any engine sees the file, then either translated to MJCF for MuJoCo or patched
// for DART's own parsers (DartLoader, SdfParser), so that both engines see the same bodies,
// joints, masses and contact shapes.
//
// Conventions, those of DART 6.12 (checked by tests/engine/robot_cross_engine_test.cc):
//  - the root link gets a free joint ("rootJoint" for URDF, "root" for SDF) unless the model is
//    fixed (RobotOptions::fixed_base, SDF <static>) or hangs from a URDF link named "world".
//  - links and joints keep their names; fixed joints keep their child link as a body of its own
//    (no fusion).
//  - a link without <inertial> weighs 1 kg with a unit moment of inertia about its origin, as
//    DART gives it; both engines get that.
//  - position limits are read but not enforced (DART's parsers leave enforcement off); effort
//    limits are the joint's force limit (engine.h: JointInfo::force_limit).
//  - joint damping and Coulomb friction are kept; links never collide with links of the same
//    model (DART's self-collision check is off by default).
//  - mesh_collision "box" (the default) replaces every collision mesh by the box that bounds its
//    vertices (after <scale>), on both engines: DART then uses its own deterministic detector.
//  - package://NAME/rest is looked up as DIR/NAME/rest in each folder of RobotOptions::
//    package_path, then of STANCE_PACKAGE_PATH (colon-separated).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/model_format.h"

namespace stance {

struct RobotOptions {
  bool fixed_base = false;                // weld the root link to the world
  std::vector<std::string> package_path;  // folders searched for package://
  std::string mesh_collision = "box";     // "box": bounding boxes; "mesh": the meshes
  // joints welded at their zero position, as fixed joints, on both engines (a robot made from
  // another: Atlas with one-axis ankles)
  std::vector<std::string> lock_joints;
};

struct RobotGeometry {
  enum class Kind { kBox, kSphere, kCylinder, kMesh };
  Kind kind = Kind::kBox;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // box: full extents; sphere: (r); cyl: (r, len)
  std::string mesh;                                // resolved path of a mesh
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  // in the link frame
  int line = 0;
};

struct RobotLink {
  std::string name;
  int line = 0;
  double mass = 1;                                        // kg; DART's default without <inertial>
  Eigen::Vector3d com = Eigen::Vector3d::Zero();          // link frame
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();  // about the COM, link axes
  std::vector<RobotGeometry> visuals, collisions;
};

enum class RobotJointType { kFixed, kRevolute, kContinuous, kPrismatic, kFloating, kBall };

struct RobotJoint {
  std::string name;
  RobotJointType type = RobotJointType::kFixed;
  std::string parent, child;
  int line = 0;
  // the child link's frame in the parent link's frame at q = 0
  Eigen::Isometry3d parent_to_child = Eigen::Isometry3d::Identity();
  // the joint frame in the child link's frame (URDF: identity; SDF: the joint's <pose>)
  Eigen::Isometry3d child_to_joint = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // unit, in the joint frame
  bool has_limits = false;
  double lower = 0, upper = 0;                              // rad or m
  double effort = std::numeric_limits<double>::infinity();  // N m or N
  double damping = 0, friction = 0;
};

struct RobotModel {
  std::string file;  // as shown in messages
  std::string name;
  ModelFormat format = ModelFormat::kUrdf;
  std::vector<RobotLink> links;
  std::vector<RobotJoint> joints;
  std::string root;        // the root link ("world" when it hangs from the world)
  std::string root_joint;  // the implicit root joint's name; empty when fixed
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // SDF <model><pose>
  int dropped_visual_meshes = 0;  // visual meshes MuJoCo cannot read (e.g. .dae)
};

// the most links one file may hold, a bound on load time and memory
constexpr size_t kMaxRobotLinks = 1000;

// Reads and checks a URDF (.urdf) or SDF (.sdf, one <model>) file: well-formed XML, required
// elements and attributes, numbers (counts, finite), masses >= 0, physical inertias, known joint
// types, unit-able axes, one tree (no unknown links, no link with two parents, no cycle), mesh
// files that exist (package:// resolved), and joints that move inertia: a floating base whose
// links all weigh 0, or a joint whose links below have no inertia along its dofs (with the
// joints below them free), is refused at the joint's (or root link's) line, as DART aborts on
// both; massless links welded to mass or carrying mass below them pass. Throws InputError
// "file:line: message".
RobotModel read_robot(const std::string& shown_name, const std::string& path,
                      const RobotOptions& options);

// the file's text as DART should parse it: package:// resolved to absolute paths, and with
// mesh_collision "box" every collision mesh replaced by its bounding box. The file must have
// passed read_robot.
std::string robot_text_for_dart(const std::string& shown_name, const std::string& path,
                                const RobotOptions& options);

// true when the robot can serve as a floor: nothing of it moves (welded whole to the world, as
// models/ground.urdf is; DART makes such a skeleton immobile) and it has a collision shape
bool robot_is_ground(const RobotModel& robot);

// true when a world of these robots has no floor but a floating base that falls through at once
bool robots_need_ground(const std::vector<RobotModel>& robots);

// what an MJCF model (with the files it includes) brings toward a floor: a free joint, and a
// colliding geom that never moves (in <worldbody>, or in a body welded to it)
struct MjcfGroundFacts {
  bool floats = false;
  bool has_floor = false;
};
MjcfGroundFacts mjcf_ground_facts(const std::string& path);

// the text of a Z-up ground for URDF/SDF robots, that of models/ground.urdf: a 40 m x 40 m box
// whose top face is z = 0, welded to the world
std::string ground_urdf_text();

struct RobotInput {
  std::string shown_name;
  std::string path;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  RobotOptions options;
};

struct RobotTranslation {
  std::string mjcf;  // the whole MJCF document
  // one line per file whose visual meshes MuJoCo cannot read and were dropped
  std::vector<std::string> warnings;
  // where each body (a link) is written: its file as shown and line, for MuJoCo's messages
  std::map<std::string, std::pair<std::string, int>> body_lines;
};

// Composes URDF/SDF files into one MuJoCo world, each a tree of bodies under <worldbody>, with a
// motor per actuated joint whose ctrlrange is the effort limit (gear 1), DART's default time
// step (1 ms) and gravity (0 0 -9.81). Throws InputError for what read_robot rejects and for
// what MuJoCo cannot represent.
RobotTranslation robots_to_mjcf(const std::vector<RobotInput>& robots);

// the box bounding a mesh's vertices (STL, binary or ASCII, or OBJ), times `scale`
Eigen::AlignedBox3d mesh_bounds(const std::string& shown_name, int line, const std::string& path,
                                const Eigen::Vector3d& scale);

}  // namespace stance
