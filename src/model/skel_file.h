// SKEL files as stance reads them, for the MJCF translation (skel_to_mjcf.cc): the parsed
// content, checked as DART's SkelParser would need it. Not for other code.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "model/mjcf_writing.h"
#include "model/skel_to_mjcf.h"

namespace stance::skel_detail {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector4d;
using mjcf::kInf;

// ---------------------------------------------------------------------------------------------
// parsed SKEL content

// every shape DART's SkelParser reads; the MuJoCo translation rejects cone, pyramid,
// multi_sphere and mesh
enum class ShapeKind {
  kSphere,
  kBox,
  kEllipsoid,
  kCylinder,
  kCapsule,
  kPlane,
  kCone,
  kPyramid,
  kMultiSphere,
  kMesh
};

struct Shape {
  ShapeKind kind = ShapeKind::kBox;
  std::string tag;                           // the geometry element's name, for messages
  int line = 0;                              // of the geometry element
  bool collision = false;                    // collision_shape (else visualization_shape)
  bool collidable = true;                    // <collidable> of a collision shape
  Isometry3d pose = Isometry3d::Identity();  // relative to the body
  Vector3d size = Vector3d::Zero();          // box size, ellipsoid diameters
  double radius = 0;
  double height = 0;
  Vector3d normal = Vector3d::UnitZ();  // plane
  double offset = 0;                    // plane
  std::optional<Vector4d> rgba;
};

struct Body {
  std::string name;
  int line = 0;
  Isometry3d world = Isometry3d::Identity();  // at q = 0, offset and skeleton frame included
  double mass = 1;                            // DART's Inertia defaults
  Vector3d com = Vector3d::Zero();
  Matrix3d moment = Matrix3d::Identity();
  bool has_inertia = false;
  bool has_moment = false;
  bool gravity = true;
  int soft_line = 0;          // of <soft_shape>: a DART soft body (not translated to MuJoCo)
  std::vector<Shape> shapes;  // visualization shapes first, as DART creates them
};

struct Dof {
  std::string name;
  double lower = -kInf;
  double upper = kInf;
  double damping = 0;
  double friction = 0;
  double stiffness = 0;
  double rest = 0;
};

struct Joint {
  std::string name;
  std::string type;
  std::string parent;  // "" for the world
  std::string child;
  int line = 0;
  Isometry3d child_to_joint = Isometry3d::Identity();  // T_CJ
  std::vector<Vector3d> axes;                          // per rotational/translational dof
  std::vector<Dof> dofs;
  Eigen::VectorXd init_pos;
  Eigen::VectorXd init_vel;
};

struct Skeleton {
  std::string name;
  std::string file;
  int line = 0;
  bool mobile = true;
  std::vector<Body> bodies;
  std::vector<Joint> joints;
};

struct SkelFile {
  std::string path;
  std::optional<double> timestep;
  std::optional<Vector3d> gravity;
  std::vector<Skeleton> skeletons;
};

// reads and checks one SKEL file (its path resolved, its skeletons moved by input.offset);
// throws InputError "<file>:<line>: ..." on bad input
SkelFile read_skel_file(const SkelInput& input);

}  // namespace stance::skel_detail
