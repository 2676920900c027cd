#include "model/skel_to_mjcf.h"

#include <tinyxml2.h>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/model_format.h"
#include "core/timestep.h"
#include "model/mjcf_writing.h"
#include "model/model_path.h"
#include "model/xml_reader.h"

namespace stance {

namespace {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::Vector4d;
using tinyxml2::XMLElement;

using mjcf::kCollisionBits;
using mjcf::kInf;
using mjcf::kMaxMujocoBodyDepth;
using mjcf::num;
using mjcf::quat_text;
using mjcf::set_pose;
using mjcf::vec;

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

// ---------------------------------------------------------------------------------------------
// reading helpers: every error names file:line of the element

class SkelReader : public XmlReader {
 public:
  using XmlReader::XmlReader;

  std::string text(const XMLElement* el) const {
    const char* t = el->GetText();
    return t != nullptr ? std::string(t) : std::string();
  }

  // an element whose numbers are lengths (or a joint's initial state, which places bodies)
  static bool is_length(const XMLElement* el) {
    static const std::set<std::string> kLengths = {"transformation", "size",       "radius",
                                                   "height",         "base_width", "base_depth",
                                                   "offset",         "init_pos",   "init_vel"};
    return kLengths.count(el->Name()) > 0;
  }

  // all whitespace-separated numbers of the element's text; `count` < 0 accepts any count
  std::vector<double> numbers(const XMLElement* el, int count) const {
    return parse_numbers(el, text(el), fmt::format("<{}>", el->Name()), count, is_length(el),
                         "is not a number");
  }

  double number(const XMLElement* el) const { return numbers(el, 1)[0]; }

  // DART asserts on sizes, masses and counts that are not positive
  double positive(const XMLElement* el) const {
    double v = number(el);
    if (!(v > 0)) fail(el, fmt::format("<{}> must be positive, found {}", el->Name(), text(el)));
    return v;
  }

  Vector3d positive_vector3(const XMLElement* el) const {
    Vector3d v = vector3(el);
    if (!(v.array() > 0).all()) {
      fail(el,
           fmt::format("<{}>: every number must be positive, found '{}'", el->Name(), text(el)));
    }
    return v;
  }

  // `count` whole numbers in [low, high] (DART reads these as unsigned or int)
  void integers(const XMLElement* el, int count, int low, int high) const {
    for (double v : numbers(el, count)) {
      if (v != std::floor(v) || v < low || v > high) {
        fail(el, fmt::format("<{}>: expected whole numbers in [{}, {}], found '{}'", el->Name(),
                             low, high, text(el)));
      }
    }
  }

  Vector3d vector3(const XMLElement* el) const {
    std::vector<double> v = numbers(el, 3);
    return Vector3d(v[0], v[1], v[2]);
  }

  bool boolean(const XMLElement* el) const {
    std::string t = text(el);
    std::string trimmed;
    for (char c : t) {
      if (!std::isspace(static_cast<unsigned char>(c)))
        trimmed += static_cast<char>(std::tolower(c));
    }
    if (trimmed == "true" || trimmed == "1") return true;
    if (trimmed == "false" || trimmed == "0") return false;
    fail(el, fmt::format("<{}>: expected true/false/1/0, found '{}'", el->Name(), t));
  }

  // "x y z roll pitch yaw" -> T with R = Rx(roll) Ry(pitch) Rz(yaw) (DART's toIsometry3d)
  Isometry3d transform(const XMLElement* el) const {
    std::vector<double> v = numbers(el, 6);
    Isometry3d t = Isometry3d::Identity();
    t.linear() =
        (Eigen::AngleAxisd(v[3], Vector3d::UnitX()) * Eigen::AngleAxisd(v[4], Vector3d::UnitY()) *
         Eigen::AngleAxisd(v[5], Vector3d::UnitZ()))
            .toRotationMatrix();
    t.translation() = Vector3d(v[0], v[1], v[2]);
    return t;
  }
};

// a shape as DART's readShape reads it (the first known geometry wins, in DART's order)
Shape read_shape(const SkelReader& r, const XMLElement* el, bool collision) {
  Shape s;
  s.collision = collision;
  if (const XMLElement* t = el->FirstChildElement("transformation")) s.pose = r.transform(t);
  const XMLElement* geometry = r.need(el, "geometry");
  const XMLElement* g = nullptr;
  for (const char* tag : {"sphere", "box", "ellipsoid", "cylinder", "capsule", "cone", "pyramid",
                          "plane", "multi_sphere", "mesh"}) {
    if ((g = geometry->FirstChildElement(tag)) != nullptr) break;
  }
  if (g == nullptr) {
    const XMLElement* first = geometry->FirstChildElement();
    if (first == nullptr) r.fail(geometry, "<geometry> is empty");
    r.fail(first, fmt::format("unknown shape <{}> (DART reads sphere, box, ellipsoid, cylinder, "
                              "capsule, cone, pyramid, plane, multi_sphere, mesh)",
                              first->Name()));
  }
  s.tag = g->Name();
  s.line = g->GetLineNum();
  if (s.tag == "sphere") {
    s.kind = ShapeKind::kSphere;
    s.radius = r.positive(r.need(g, "radius"));
  } else if (s.tag == "box" || s.tag == "ellipsoid") {
    s.kind = s.tag == "box" ? ShapeKind::kBox : ShapeKind::kEllipsoid;
    s.size = r.positive_vector3(r.need(g, "size"));
  } else if (s.tag == "cylinder" || s.tag == "capsule" || s.tag == "cone") {
    s.kind = s.tag == "cylinder"  ? ShapeKind::kCylinder
             : s.tag == "capsule" ? ShapeKind::kCapsule
                                  : ShapeKind::kCone;
    s.radius = r.positive(r.need(g, "radius"));
    s.height = r.positive(r.need(g, "height"));
  } else if (s.tag == "pyramid") {
    s.kind = ShapeKind::kPyramid;
    r.positive(r.need(g, "base_width"));
    r.positive(r.need(g, "base_depth"));
    s.height = r.positive(r.need(g, "height"));
  } else if (s.tag == "plane") {
    s.kind = ShapeKind::kPlane;
    s.normal = r.vector3(r.need(g, "normal"));
    if (s.normal.norm() == 0) r.fail(g, "<plane>: the normal is zero");
    if (const XMLElement* o = g->FirstChildElement("offset")) {
      s.offset = r.number(o);
    } else if (const XMLElement* p = g->FirstChildElement("point")) {
      // DART's PlaneShape(normal, point): offset = normal . point, normal normalized first
      s.offset = s.normal.normalized().dot(r.vector3(p));
    }
  } else if (s.tag == "multi_sphere") {
    s.kind = ShapeKind::kMultiSphere;
    const XMLElement* sphere = r.need(g, "sphere");
    for (; sphere != nullptr; sphere = sphere->NextSiblingElement("sphere")) {
      r.positive(r.need(sphere, "radius"));
      r.vector3(r.need(sphere, "position"));
    }
  } else {
    s.kind = ShapeKind::kMesh;
    const XMLElement* file = r.need(g, "file_name");
    std::string name = r.text(file);
    name.erase(0, name.find_first_not_of(" \t\r\n"));
    name.erase(name.find_last_not_of(" \t\r\n") + 1);
    if (name.empty()) r.fail(file, "<mesh>: <file_name> is empty");
    r.vector3(r.need(g, "scale"));
    // DART resolves the name against the .skel file; a missing file leaves it a null shape
    if (name.find("://") == std::string::npos) {
      namespace fs = std::filesystem;
      fs::path mesh = fs::path(r.file()).parent_path() / name;
      std::error_code ec;
      if (!fs::is_regular_file(mesh, ec)) {
        r.fail(file, fmt::format("<mesh>: no such file '{}'", mesh.string()));
      }
    }
  }
  if (!collision) {
    if (const XMLElement* c = el->FirstChildElement("color")) {
      std::vector<double> v = r.numbers(c, -1);
      if (v.size() == 3) s.rgba = Vector4d(v[0], v[1], v[2], 1.0);
      if (v.size() == 4) s.rgba = Vector4d(v[0], v[1], v[2], v[3]);
      // DART ignores colors of other sizes with a warning; so do we
    }
  } else if (const XMLElement* c = el->FirstChildElement("collidable")) {
    s.collidable = r.number(c) != 0;
  }
  return s;
}

// <soft_shape> as DART's readSoftBodyNode reads it: counts are bounded, as DART allocates
// the point masses they ask for
void check_soft_shape(const SkelReader& r, const XMLElement* el) {
  r.positive(r.need(el, "total_mass"));
  if (const XMLElement* t = el->FirstChildElement("transformation")) r.transform(t);
  const XMLElement* geometry = r.need(el, "geometry");
  if (const XMLElement* g = geometry->FirstChildElement("sphere")) {
    r.positive(r.need(g, "radius"));
    r.integers(r.need(g, "num_slices"), 1, 2, 100);
    r.integers(r.need(g, "num_stacks"), 1, 2, 100);
  } else if (const XMLElement* g = geometry->FirstChildElement("box")) {
    r.positive_vector3(r.need(g, "size"));
    r.integers(r.need(g, "frags"), 3, 2, 100);
  } else if (const XMLElement* g = geometry->FirstChildElement("ellipsoid")) {
    r.positive_vector3(r.need(g, "size"));
    r.integers(r.need(g, "num_slices"), 1, 2, 100);
    r.integers(r.need(g, "num_stacks"), 1, 2, 100);
  } else if (const XMLElement* g = geometry->FirstChildElement("cylinder")) {
    r.positive(r.need(g, "radius"));
    r.positive(r.need(g, "height"));
    r.integers(r.need(g, "num_slices"), 1, 2, 100);
    r.integers(r.need(g, "num_stacks"), 1, 2, 100);
    r.integers(r.need(g, "num_rings"), 1, 2, 100);
  } else {
    const XMLElement* first = geometry->FirstChildElement();
    r.fail(first != nullptr ? first : geometry,
           "<soft_shape> needs a sphere, box, ellipsoid or cylinder geometry");
  }
  for (const char* tag : {"kv", "ke", "damp"}) {
    if (const XMLElement* e = el->FirstChildElement(tag)) {
      if (r.number(e) < 0) r.fail(e, fmt::format("<{}> must not be negative", tag));
    }
  }
}

// the moment DART's Shape::computeInertia(mass) gives, about the shape's own origin
Matrix3d shape_inertia(const Shape& s, double mass) {
  Matrix3d i = Matrix3d::Zero();
  switch (s.kind) {
    case ShapeKind::kSphere:
      i.diagonal().setConstant(0.4 * mass * s.radius * s.radius);
      break;
    case ShapeKind::kBox: {
      Vector3d q = s.size.cwiseProduct(s.size);
      i.diagonal() = mass / 12.0 * Vector3d(q.y() + q.z(), q.x() + q.z(), q.x() + q.y());
      break;
    }
    case ShapeKind::kEllipsoid: {
      Vector3d q = s.size.cwiseProduct(s.size);  // squared diameters
      i.diagonal() = mass / 20.0 * Vector3d(q.y() + q.z(), q.x() + q.z(), q.x() + q.y());
      break;
    }
    case ShapeKind::kCylinder: {
      double r2 = s.radius * s.radius;
      double h2 = s.height * s.height;
      double ixx = mass * (3.0 * r2 + h2) / 12.0;
      i.diagonal() = Vector3d(ixx, ixx, 0.5 * mass * r2);
      break;
    }
    case ShapeKind::kCapsule: {
      // DART 6.12 CapsuleShape::computeInertia: hemispheres counted as h^2/4 + 3hr/8 + 2r^2/5
      double r = s.radius;
      double h = s.height;
      double v_cyl = M_PI * r * r * h;
      double v_sph = 4.0 / 3.0 * M_PI * r * r * r;
      double density = mass / (v_cyl + v_sph);
      double m_cyl = density * v_cyl;
      double m_sph = density * v_sph;
      double ixx = m_cyl * (h * h / 12.0 + r * r / 4.0) +
                   m_sph * (h * h / 4.0 + 3.0 / 8.0 * h * r + 2.0 / 5.0 * r * r);
      double izz = m_cyl * (r * r / 2.0) + m_sph * (2.0 / 5.0 * r * r);
      i.diagonal() = Vector3d(ixx, ixx, izz);
      break;
    }
    case ShapeKind::kPlane:
      break;  // DART's PlaneShape::computeInertia is zero
    case ShapeKind::kCone:
    case ShapeKind::kPyramid:
    case ShapeKind::kMultiSphere:
    case ShapeKind::kMesh:
      break;  // not translated (emit_geoms rejects them)
  }
  return i;
}

Body read_body(const SkelReader& r, const XMLElement* el, const Isometry3d& skeleton_frame) {
  Body b;
  b.name = r.attribute(el, "name");
  b.line = el->GetLineNum();
  if (const XMLElement* soft = el->FirstChildElement("soft_shape")) {
    check_soft_shape(r, soft);
    b.soft_line = soft->GetLineNum();
  }
  for (const XMLElement* m = el->FirstChildElement("marker"); m != nullptr;
       m = m->NextSiblingElement("marker")) {
    r.attribute(m, "name");
    if (const XMLElement* o = m->FirstChildElement("offset")) r.vector3(o);
  }
  if (const XMLElement* g = el->FirstChildElement("gravity")) b.gravity = r.boolean(g);
  b.world = skeleton_frame;
  if (const XMLElement* t = el->FirstChildElement("transformation")) {
    b.world = skeleton_frame * r.transform(t);
  }
  if (const XMLElement* in = el->FirstChildElement("inertia")) {
    b.has_inertia = true;
    b.mass = r.positive(r.need(in, "mass"));
    if (const XMLElement* m = in->FirstChildElement("moment_of_inertia")) {
      b.has_moment = true;
      double ixx = r.number(r.need(m, "ixx"));
      double iyy = r.number(r.need(m, "iyy"));
      double izz = r.number(r.need(m, "izz"));
      double ixy = r.number(r.need(m, "ixy"));
      double ixz = r.number(r.need(m, "ixz"));
      double iyz = r.number(r.need(m, "iyz"));
      b.moment << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
      if (!(ixx > 0 && iyy > 0 && izz > 0)) {
        r.fail(m, fmt::format("body '{}': <moment_of_inertia> needs ixx, iyy and izz > 0", b.name));
      }
    }
    if (const XMLElement* o = in->FirstChildElement("offset")) b.com = r.vector3(o);
  }
  for (const XMLElement* s = el->FirstChildElement("visualization_shape"); s != nullptr;
       s = s->NextSiblingElement("visualization_shape")) {
    b.shapes.push_back(read_shape(r, s, false));
  }
  for (const XMLElement* s = el->FirstChildElement("collision_shape"); s != nullptr;
       s = s->NextSiblingElement("collision_shape")) {
    b.shapes.push_back(read_shape(r, s, true));
  }
  // DART: without <moment_of_inertia>, the first shape's inertia for the body mass
  if (b.has_inertia && !b.has_moment && !b.shapes.empty()) {
    b.moment = shape_inertia(b.shapes.front(), b.mass);
  }
  return b;
}

// <axis>/<axis2>/<axis3>: damping, dynamics and limits of dof i (DART's readJointDynamicsAndLimit)
void read_axis_dynamics(const SkelReader& r, const XMLElement* joint_el, Joint& j) {
  for (size_t i = 0; i < j.dofs.size(); ++i) {
    std::string tag = i == 0 ? "axis" : "axis" + std::to_string(i + 1);
    const XMLElement* axis = joint_el->FirstChildElement(tag.c_str());
    if (axis == nullptr) continue;
    Dof& d = j.dofs[i];
    if (const XMLElement* e = axis->FirstChildElement("damping")) d.damping = r.number(e);
    if (const XMLElement* dyn = axis->FirstChildElement("dynamics")) {
      if (const XMLElement* e = dyn->FirstChildElement("damping")) d.damping = r.number(e);
      if (const XMLElement* e = dyn->FirstChildElement("friction")) d.friction = r.number(e);
      if (const XMLElement* e = dyn->FirstChildElement("spring_rest_position"))
        d.rest = r.number(e);
      if (const XMLElement* e = dyn->FirstChildElement("spring_stiffness")) {
        d.stiffness = r.number(e);
      }
    }
    if (const XMLElement* lim = axis->FirstChildElement("limit")) {
      if (const XMLElement* e = lim->FirstChildElement("lower")) d.lower = r.number(e);
      if (const XMLElement* e = lim->FirstChildElement("upper")) d.upper = r.number(e);
    }
  }
}

double dof_attribute(const SkelReader& r, const XMLElement* el, const char* name, double fallback) {
  double v = fallback;
  if (el->QueryDoubleAttribute(name, &v) == tinyxml2::XML_WRONG_ATTRIBUTE_TYPE) {
    r.fail(el, fmt::format("<{}>: attribute '{}' is not a number", el->Name(), name));
  }
  return v;
}

// <dof local_index=.. name=..> elements (DART's readAllDegreesOfFreedom)
void read_dof_elements(const SkelReader& r, const XMLElement* joint_el, Joint& j) {
  const int n = static_cast<int>(j.dofs.size());
  for (const XMLElement* el = joint_el->FirstChildElement("dof"); el != nullptr;
       el = el->NextSiblingElement("dof")) {
    int index = -1;
    if (el->QueryIntAttribute("local_index", &index) == tinyxml2::XML_WRONG_ATTRIBUTE_TYPE) {
      r.fail(el, "<dof>: local_index is not an integer");
    }
    if (index == -1 && n == 1) index = 0;
    if (index < 0 || index >= n) {
      r.fail(el, fmt::format("joint '{}' has {} dofs; <dof> needs local_index in [0, {})", j.name,
                             n, n));
    }
    Dof& d = j.dofs[index];
    if (const char* name = el->Attribute("name")) d.name = name;
    if (const XMLElement* p = el->FirstChildElement("position")) {
      d.lower = dof_attribute(r, p, "lower", d.lower);
      d.upper = dof_attribute(r, p, "upper", d.upper);
      if (j.init_pos.size() == n)
        j.init_pos[index] = dof_attribute(r, p, "initial", j.init_pos[index]);
    }
    if (const XMLElement* v = el->FirstChildElement("velocity")) {
      if (j.init_vel.size() == n)
        j.init_vel[index] = dof_attribute(r, v, "initial", j.init_vel[index]);
    }
    if (const XMLElement* e = el->FirstChildElement("damping")) d.damping = r.number(e);
    if (const XMLElement* e = el->FirstChildElement("friction")) d.friction = r.number(e);
    if (const XMLElement* e = el->FirstChildElement("spring_rest_position")) d.rest = r.number(e);
    if (const XMLElement* e = el->FirstChildElement("spring_stiffness")) d.stiffness = r.number(e);
  }
}

Vector3d read_axis_xyz(const SkelReader& r, const XMLElement* joint_el, const char* tag,
                       const std::string& joint_name) {
  const XMLElement* axis = joint_el->FirstChildElement(tag);
  if (axis == nullptr) {
    r.fail(joint_el, fmt::format("joint '{}' is missing <{}><xyz>", joint_name, tag));
  }
  Vector3d a = r.vector3(r.need(axis, "xyz"));
  if (a.norm() == 0) r.fail(axis, fmt::format("joint '{}': <{}> is zero", joint_name, tag));
  return a.normalized();
}

Joint read_joint(const SkelReader& r, const XMLElement* el) {
  Joint j;
  j.name = r.attribute(el, "name");
  j.type = r.attribute(el, "type");
  j.line = el->GetLineNum();
  std::vector<std::string> suffixes;  // DART's default dof names: joint name + suffix
  if (j.type == "revolute" || j.type == "prismatic") {
    j.axes.push_back(read_axis_xyz(r, el, "axis", j.name));
    suffixes = {""};
  } else if (j.type == "universal") {
    j.axes.push_back(read_axis_xyz(r, el, "axis", j.name));
    j.axes.push_back(read_axis_xyz(r, el, "axis2", j.name));
    suffixes = {"_1", "_2"};
  } else if (j.type == "euler") {
    const XMLElement* order = r.need(el, "axis_order");
    std::string o = r.text(order);
    o.erase(0, o.find_first_not_of(" \t\r\n"));
    o.erase(o.find_last_not_of(" \t\r\n") + 1);
    if (o != "xyz" && o != "zyx") {
      r.fail(order, fmt::format("euler joint '{}': axis_order '{}' is not supported by DART's "
                                "SkelParser (use xyz or zyx)",
                                j.name, o));
    }
    for (char c : o) {
      j.axes.push_back(c == 'x'   ? Vector3d::UnitX()
                       : c == 'y' ? Vector3d::UnitY()
                                  : Vector3d::UnitZ());
      suffixes.push_back(std::string("_") + c);
    }
  } else if (j.type == "ball") {
    suffixes = {"_x", "_y", "_z"};
  } else if (j.type == "translational") {
    j.axes = {Vector3d::UnitX(), Vector3d::UnitY(), Vector3d::UnitZ()};
    suffixes = {"_x", "_y", "_z"};
  } else if (j.type == "free") {
    suffixes = {"_rot_x", "_rot_y", "_rot_z", "_pos_x", "_pos_y", "_pos_z"};
  } else if (j.type == "planar") {
    // DART only: the MuJoCo translation rejects it
    if (const XMLElement* plane = el->FirstChildElement("plane")) {
      std::string type = r.attribute(plane, "type");
      if (type == "arbitrary") {
        r.vector3(r.need(r.need(plane, "translation_axis1"), "xyz"));
        r.vector3(r.need(r.need(plane, "translation_axis2"), "xyz"));
      } else if (type != "xy" && type != "yz" && type != "zx") {
        r.fail(plane, fmt::format("planar joint '{}': plane type '{}' is not one of xy, yz, zx, "
                                  "arbitrary",
                                  j.name, type));
      }
    }
    suffixes = {"_1", "_2", "_3"};
  } else if (j.type == "weld") {
  } else {
    r.fail(el, fmt::format("joint '{}': unsupported joint type '{}' (supported: weld, revolute, "
                           "prismatic, universal, euler, ball, translational, planar, free)",
                           j.name, j.type));
  }
  const int n = static_cast<int>(suffixes.size());
  j.dofs.resize(n);
  for (int i = 0; i < n; ++i) j.dofs[i].name = j.name + suffixes[i];
  j.init_pos = Eigen::VectorXd::Zero(n);
  j.init_vel = Eigen::VectorXd::Zero(n);

  // DART reads <axis>.. dynamics and limits for revolute/prismatic/universal/euler/translational
  if (j.type != "ball" && j.type != "free" && j.type != "weld") read_axis_dynamics(r, el, j);
  if (n > 0) {
    if (const XMLElement* p = el->FirstChildElement("init_pos")) {
      std::vector<double> v = r.numbers(p, n);
      j.init_pos = Eigen::Map<Eigen::VectorXd>(v.data(), n);
    }
    if (const XMLElement* p = el->FirstChildElement("init_vel")) {
      std::vector<double> v = r.numbers(p, n);
      j.init_vel = Eigen::Map<Eigen::VectorXd>(v.data(), n);
    }
    read_dof_elements(r, el, j);
  }

  const XMLElement* parent = r.need(el, "parent");
  j.parent = r.text(parent);
  const XMLElement* child = r.need(el, "child");
  j.child = r.text(child);
  if (const XMLElement* t = el->FirstChildElement("transformation")) {
    j.child_to_joint = r.transform(t);
  }
  return j;
}

// fails on a joint cycle, which DART's assembly loop would follow for ever; linear in the bodies
void check_no_cycle(const SkelReader& r, const Skeleton& s) {
  std::map<std::string, std::string> parent_of;  // child body -> parent body ("" = world)
  for (const Joint& j : s.joints) parent_of[j.child] = j.parent;
  enum { kUnseen, kOnPath, kDone };
  std::map<std::string, int> state;
  for (const Body& b : s.bodies) {
    std::vector<std::string> path;
    for (std::string body = b.name;;) {
      int& st = state[body];
      if (st == kDone) break;
      if (st == kOnPath) {
        throw InputError(
            located(r.file(), b.line, fmt::format("body '{}' is in a joint cycle", b.name)));
      }
      st = kOnPath;
      path.push_back(body);
      auto it = parent_of.find(body);
      if (it == parent_of.end() || it->second.empty()) break;
      body = it->second;
    }
    for (const std::string& body : path) state[body] = kDone;
  }
}

Skeleton read_skeleton(const SkelReader& r, const XMLElement* el, const Vector3d& offset,
                       size_t& bodies_in_file) {
  Skeleton s;
  s.name = r.attribute(el, "name");
  s.file = r.file();
  s.line = el->GetLineNum();
  Isometry3d frame = Isometry3d::Identity();
  frame.translation() = offset;
  if (const XMLElement* t = el->FirstChildElement("transformation")) frame = frame * r.transform(t);
  if (const XMLElement* m = el->FirstChildElement("mobile")) s.mobile = r.boolean(m);

  std::set<std::string> body_names;
  for (const XMLElement* b = el->FirstChildElement("body"); b != nullptr;
       b = b->NextSiblingElement("body")) {
    if (++bodies_in_file > kMaxSkelBodies) {
      r.fail(b, fmt::format("more than {} bodies in one file (a limit that keeps loading time "
                            "and memory bounded)",
                            kMaxSkelBodies));
    }
    Body body = read_body(r, b, frame);
    if (!body_names.insert(body.name).second) {
      r.fail(b, fmt::format("skeleton '{}' has two bodies named '{}'", s.name, body.name));
    }
    s.bodies.push_back(std::move(body));
  }
  std::set<std::string> children;
  for (const XMLElement* e = el->FirstChildElement("joint"); e != nullptr;
       e = e->NextSiblingElement("joint")) {
    Joint j = read_joint(r, e);
    // DART: "world" means no parent unless a body is called "world"
    if (j.parent == "world" && body_names.count("world") == 0) j.parent.clear();
    if (!j.parent.empty() && body_names.count(j.parent) == 0) {
      r.fail(e->FirstChildElement("parent"),
             fmt::format("joint '{}': parent body '{}' does not exist in skeleton '{}'{}", j.name,
                         j.parent, s.name,
                         did_you_mean(j.parent, {body_names.begin(), body_names.end()})));
    }
    if (body_names.count(j.child) == 0) {
      r.fail(e->FirstChildElement("child"),
             fmt::format("joint '{}': child body '{}' does not exist in skeleton '{}'{}", j.name,
                         j.child, s.name,
                         did_you_mean(j.child, {body_names.begin(), body_names.end()})));
    }
    if (!children.insert(j.child).second) {
      r.fail(e, fmt::format("joint '{}': body '{}' already has a parent joint", j.name, j.child));
    }
    s.joints.push_back(std::move(j));
  }
  // DART's SkelParser starts assembling at the first joint, which must exist
  if (s.joints.empty()) r.fail(el, fmt::format("skeleton '{}' has no joint", s.name));
  check_no_cycle(r, s);
  return s;
}

SkelFile read_skel_file(const SkelInput& input) {
  const std::string path = resolve_model_path(input.path);
  SkelReader r(path);
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLError err = doc.LoadFile(path.c_str());
  if (err != tinyxml2::XML_SUCCESS) {
    // ErrorStr() is "Error=NAME ErrorID=.. Line number=N[: detail]"; keep NAME and detail
    std::string detail = doc.ErrorStr() != nullptr ? doc.ErrorStr() : "";
    size_t colon = detail.find(": ", detail.find("Line number="));
    detail = colon != std::string::npos ? detail.substr(colon + 2) : "";
    throw InputError(located(path, doc.ErrorLineNum(),
                             fmt::format("malformed XML ({}){}{}", doc.ErrorName(),
                                         detail.empty() ? "" : ": ", detail)));
  }
  const XMLElement* skel = doc.FirstChildElement("skel");
  if (skel == nullptr) {
    throw InputError(located(path, doc.RootElement() ? doc.RootElement()->GetLineNum() : 0,
                             "expected <skel> as the root element"));
  }
  const XMLElement* world = r.need(skel, "world");
  SkelFile f;
  f.path = path;
  if (const XMLElement* physics = world->FirstChildElement("physics")) {
    if (const XMLElement* t = physics->FirstChildElement("time_step")) {
      f.timestep = r.number(t);
      const std::string problem = timestep_problem(*f.timestep);
      if (!problem.empty()) r.fail(t, "<time_step>: " + problem);
    }
    if (const XMLElement* g = physics->FirstChildElement("gravity")) f.gravity = r.vector3(g);
  }
  size_t bodies_in_file = 0;
  for (const XMLElement* s = world->FirstChildElement("skeleton"); s != nullptr;
       s = s->NextSiblingElement("skeleton")) {
    f.skeletons.push_back(read_skeleton(r, s, input.offset, bodies_in_file));
  }
  return f;
}

// ---------------------------------------------------------------------------------------------
// kinematics shared with DART

Matrix3d exp_rotation(const Vector3d& w) {
  double angle = w.norm();
  if (angle == 0) return Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

// J(q): the joint's motion in its own frame
Isometry3d joint_motion(const Joint& j, const Eigen::VectorXd& q) {
  Isometry3d m = Isometry3d::Identity();
  if (j.type == "revolute" || j.type == "universal" || j.type == "euler") {
    for (size_t i = 0; i < j.axes.size(); ++i) {
      m.linear() = m.linear() * Eigen::AngleAxisd(q[i], j.axes[i]).toRotationMatrix();
    }
  } else if (j.type == "prismatic" || j.type == "translational") {
    for (size_t i = 0; i < j.axes.size(); ++i) m.translation() += q[i] * j.axes[i];
  } else if (j.type == "ball") {
    m.linear() = exp_rotation(q.head<3>());
  } else if (j.type == "free") {
    m.linear() = exp_rotation(q.head<3>());
    m.translation() = q.tail<3>();
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// MJCF writing

class MjcfWriter {
 public:
  MjcfWriter() {
    doc_.InsertEndChild(doc_.NewComment(
        " generated by stance from DART .skel; semantics follow DART 6.12's SkelParser:\n"
        "     joint ranges are emitted but limited=\"false\" (DART does not enforce position\n"
        "     limits by default); masses and inertias come only from <inertial>, geoms have\n"
        "     mass 0; bodies of one skeleton never collide with each other (DART's\n"
        "     self-collision is off by default); friction is MuJoCo's default 1 = DART's\n"
        "     default (DART 6.12 does not read <friction_coeff>); keyframe \"init\" holds the\n"
        "     state DART starts in (<init_pos>/<init_vel>) "));
    root_ = doc_.NewElement("mujoco");
    doc_.InsertEndChild(root_);
    XMLElement* compiler = add(root_, "compiler");
    compiler->SetAttribute("angle", "radian");
    compiler->SetAttribute("inertiafromgeom", "false");
    option_ = add(root_, "option");
    worldbody_ = add(root_, "worldbody");
  }

  XMLElement* add(XMLElement* parent, const char* name) {
    XMLElement* el = doc_.NewElement(name);
    parent->InsertEndChild(el);
    return el;
  }

  tinyxml2::XMLDocument doc_;
  XMLElement* root_ = nullptr;
  XMLElement* option_ = nullptr;
  XMLElement* worldbody_ = nullptr;
  std::vector<double> key_qpos_;
  std::vector<double> key_qvel_;
  std::set<std::string> body_names_;
  std::set<std::string> joint_names_;
  int next_collision_bit_ = 0;  // the next mobile skeleton's contype bit
};

class SkeletonEmitter {
 public:
  SkeletonEmitter(MjcfWriter& w, const Skeleton& s) : w_(w), s_(s) {
    for (size_t i = 0; i < s.bodies.size(); ++i) body_index_[s.bodies[i].name] = i;
    for (size_t i = 0; i < s.joints.size(); ++i) {
      joint_of_child_[s.joints[i].child] = i;
      if (!s.joints[i].parent.empty()) child_joints_[s.joints[i].parent].push_back(i);
    }
  }

  void emit() {
    // roots: children of world joints, and bodies that parent a joint but are nobody's child
    // (DART gives those a free joint named "root")
    std::vector<std::string> roots;
    for (const Body& b : s_.bodies) {
      auto it = joint_of_child_.find(b.name);
      if (it != joint_of_child_.end()) {
        if (s_.joints[it->second].parent.empty()) roots.push_back(b.name);
      } else if (child_joints_.count(b.name) != 0) {
        roots.push_back(b.name);
      } else {
        fail(b.line, fmt::format("body '{}' is not connected to any joint", b.name));
      }
    }
    choose_collision_mask();
    // depth first, children in file order, on a stack of its own: the file sets the depth
    // (the reader has rejected joint cycles, so every body is reached once)
    struct Pending {
      std::string body;
      XMLElement* parent_el;         // null = top level
      Isometry3d parent_init_world;  // DART's initial pose of the parent, for immobile ones
      int depth;                     // of the body element: 1 at the top level
    };
    std::vector<Pending> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) {
      stack.push_back({*it, nullptr, Isometry3d::Identity(), 1});
    }
    while (!stack.empty()) {
      Pending p = std::move(stack.back());
      stack.pop_back();
      if (p.depth > kMaxMujocoBodyDepth) {
        fail(body(p.body).line,
             fmt::format("body '{}' is nested {} bodies deep: MuJoCo reads at most {} (DART loads "
                         "it: --engine dart)",
                         p.body, p.depth, kMaxMujocoBodyDepth));
      }
      Isometry3d world_init;
      XMLElement* el = emit_body(p.body, p.parent_el, p.parent_init_world, world_init);
      auto cit = child_joints_.find(p.body);
      if (cit == child_joints_.end()) continue;
      for (auto ji = cit->second.rbegin(); ji != cit->second.rend(); ++ji) {
        stack.push_back({s_.joints[*ji].child, s_.mobile ? el : nullptr, world_init,
                         s_.mobile ? p.depth + 1 : 1});
      }
    }
  }

 private:
  [[noreturn]] void fail(int line, const std::string& message) const {
    throw InputError(located(s_.file, line, message));
  }

  const Body& body(const std::string& name) const { return s_.bodies[body_index_.at(name)]; }

  // DART never collides a skeleton with itself: a mobile skeleton with two or more colliding
  // bodies gets a contype bit of its own and collides with every bit but it (linear in the
  // bodies, where an <exclude> per body pair was quadratic)
  void choose_collision_mask() {
    if (!s_.mobile) return;
    int colliding = 0;
    for (const Body& b : s_.bodies) {
      bool collides = false;
      for (const Shape& sh : b.shapes) collides = collides || (sh.collision && sh.collidable);
      colliding += collides ? 1 : 0;
    }
    if (colliding < 2) return;
    if (w_.next_collision_bit_ >= kCollisionBits) {
      fail(s_.line, fmt::format("more than {} mobile skeletons with colliding bodies: the MuJoCo "
                                "translation keeps one contype bit per skeleton",
                                kCollisionBits));
    }
    const int bit = 1 << w_.next_collision_bit_++;
    contype_ = bit;
    conaffinity_ = static_cast<int>((1u << kCollisionBits) - 1u) & ~bit;
  }

  // emits one body under parent_el (null = top level); world_init: its initial world pose
  XMLElement* emit_body(const std::string& name, XMLElement* parent_el,
                        const Isometry3d& parent_init_world, Isometry3d& world_init) {
    const Body& b = body(name);
    if (b.soft_line != 0) {
      fail(b.soft_line, fmt::format("body '{}': soft bodies are not supported by the MuJoCo "
                                    "translation (DART loads them: --engine dart)",
                                    b.name));
    }
    auto jit = joint_of_child_.find(name);
    const Joint* j = jit != joint_of_child_.end() ? &s_.joints[jit->second] : nullptr;
    const Isometry3d parent_world0 =
        (j != nullptr && !j->parent.empty()) ? body(j->parent).world : Isometry3d::Identity();
    // DART: T_parent_child(q) = T_P^-1 T_C T_CJ J(q) T_CJ^-1
    const Isometry3d rel0 = parent_world0.inverse() * b.world;
    Isometry3d motion = Isometry3d::Identity();
    if (j != nullptr) {
      motion = j->child_to_joint * joint_motion(*j, j->init_pos) * j->child_to_joint.inverse();
    }
    // a body that parents joints but has none: DART's implicit free joint "root"
    const bool implicit_root = j == nullptr;
    world_init = parent_init_world * rel0 * motion;

    if (!w_.body_names_.insert(name).second) {
      fail(b.line, fmt::format("body name '{}' is used twice (MuJoCo body names must be unique "
                               "across all skeletons and files)",
                               name));
    }
    XMLElement* el = w_.add(parent_el != nullptr ? parent_el : w_.worldbody_, "body");
    el->SetAttribute("name", name.c_str());
    if (!s_.mobile) {
      set_pose(el, world_init);  // static, directly under <worldbody>
    } else {
      set_pose(el, parent_el != nullptr ? rel0 : b.world);
      if (implicit_root) {
        add_joint_name("root", b.line);
        XMLElement* fj = w_.add(el, "freejoint");
        fj->SetAttribute("name", "root");
        append_free_key(b.world, Eigen::VectorXd::Zero(6), Eigen::VectorXd::Zero(6));
      } else {
        emit_joint(el, *j, b);
      }
      if (!b.gravity) {
        fail(b.line, fmt::format("body '{}': <gravity>false</gravity> is not supported by the "
                                 "MuJoCo translation",
                                 name));
      }
    }
    emit_inertial(el, b);
    emit_geoms(el, b);
    return el;
  }

  void add_joint_name(const std::string& name, int line) {
    if (!w_.joint_names_.insert(name).second) {
      fail(line, fmt::format("joint name '{}' is used twice (MuJoCo joint names must be unique "
                             "across all skeletons and files)",
                             name));
    }
  }

  void append_free_key(const Isometry3d& frame0, const Eigen::VectorXd& q,
                       const Eigen::VectorXd& v) {
    // MuJoCo free qpos: world position + quaternion; qvel: world linear, body angular
    Isometry3d pose = frame0;
    pose.linear() = frame0.linear() * exp_rotation(q.head<3>());
    pose.translation() = frame0.translation() + frame0.linear() * q.tail<3>();
    Eigen::Quaterniond quat(pose.linear());
    quat.normalize();
    Vector3d p = pose.translation();
    w_.key_qpos_.insert(w_.key_qpos_.end(),
                        {p.x(), p.y(), p.z(), quat.w(), quat.x(), quat.y(), quat.z()});
    Vector3d lin = pose.linear() * v.tail<3>();
    w_.key_qvel_.insert(w_.key_qvel_.end(), {lin.x(), lin.y(), lin.z(), v[0], v[1], v[2]});
  }

  static double uniform(const std::vector<Dof>& dofs, double Dof::*field, bool& ok) {
    ok = true;
    for (const Dof& d : dofs) ok = ok && d.*field == dofs.front().*field;
    return dofs.front().*field;
  }

  void set_dof_dynamics(XMLElement* el, const Dof& d) {
    if (d.damping != 0) el->SetAttribute("damping", num(d.damping).c_str());
    if (d.friction != 0) el->SetAttribute("frictionloss", num(d.friction).c_str());
    if (d.stiffness != 0) {
      el->SetAttribute("stiffness", num(d.stiffness).c_str());
      el->SetAttribute("springref", num(d.rest).c_str());
    }
    if (std::isfinite(d.lower) || std::isfinite(d.upper)) {
      // DART reads limits but does not enforce them by default (mIsPositionLimitEnforced)
      el->SetAttribute("limited", "false");
      el->SetAttribute("range", fmt::format("{} {}", num(std::isfinite(d.lower) ? d.lower : -1e10),
                                            num(std::isfinite(d.upper) ? d.upper : 1e10))
                                    .c_str());
    }
  }

  void emit_joint(XMLElement* body_el, const Joint& j, const Body& b) {
    const Isometry3d& t_cj = j.child_to_joint;
    const Vector3d anchor = t_cj.translation();
    if (j.type == "weld") return;
    if (j.type == "planar") {
      fail(j.line, fmt::format("joint '{}': planar joints are not supported by the MuJoCo "
                               "translation (DART loads them: --engine dart)",
                               j.name));
    }
    if (j.type == "free") {
      if (!j.parent.empty()) {
        fail(j.line, fmt::format("free joint '{}' has parent body '{}': MuJoCo allows free joints "
                                 "only for children of the world",
                                 j.name, j.parent));
      }
      if (!t_cj.matrix().isIdentity(0.0)) {
        fail(j.line, fmt::format("free joint '{}': a non-identity joint <transformation> is not "
                                 "supported (MuJoCo's free joint moves the body frame itself)",
                                 j.name));
      }
      bool ok = true;
      double damping = uniform(j.dofs, &Dof::damping, ok);
      if (!ok) fail(j.line, fmt::format("free joint '{}': per-dof damping differs", j.name));
      add_joint_name(j.name, j.line);
      if (damping == 0) {
        w_.add(body_el, "freejoint")->SetAttribute("name", j.name.c_str());
      } else {
        XMLElement* el = w_.add(body_el, "joint");
        el->SetAttribute("name", j.name.c_str());
        el->SetAttribute("type", "free");
        el->SetAttribute("damping", num(damping).c_str());
      }
      append_free_key(b.world, j.init_pos, j.init_vel);
      return;
    }
    if (j.type == "ball") {
      bool ok = true;
      double damping = uniform(j.dofs, &Dof::damping, ok);
      if (!ok) fail(j.line, fmt::format("ball joint '{}': per-dof damping differs", j.name));
      for (const Dof& d : j.dofs) {
        if (d.stiffness != 0 || d.friction != 0) {
          fail(j.line,
               fmt::format("ball joint '{}': springs and friction are not supported", j.name));
        }
      }
      add_joint_name(j.name, j.line);
      XMLElement* el = w_.add(body_el, "joint");
      el->SetAttribute("name", j.name.c_str());
      el->SetAttribute("type", "ball");
      el->SetAttribute("pos", vec(anchor).c_str());
      if (damping != 0) el->SetAttribute("damping", num(damping).c_str());
      // MuJoCo's ball rotates the body frame: Q = R_CJ exp(q) R_CJ^T
      const Matrix3d r_cj = t_cj.linear();
      Eigen::Quaterniond quat(Matrix3d(r_cj * exp_rotation(j.init_pos) * r_cj.transpose()));
      quat.normalize();
      w_.key_qpos_.insert(w_.key_qpos_.end(), {quat.w(), quat.x(), quat.y(), quat.z()});
      Vector3d w = r_cj * j.init_vel.head<3>();
      w_.key_qvel_.insert(w_.key_qvel_.end(), {w.x(), w.y(), w.z()});
      return;
    }
    // one hinge or slide per dof, composed in dof order like DART's R1 R2 R3
    const bool slide = j.type == "prismatic" || j.type == "translational";
    for (size_t i = 0; i < j.dofs.size(); ++i) {
      const Dof& d = j.dofs[i];
      add_joint_name(d.name, j.line);
      XMLElement* el = w_.add(body_el, "joint");
      el->SetAttribute("name", d.name.c_str());
      el->SetAttribute("type", slide ? "slide" : "hinge");
      if (!slide) el->SetAttribute("pos", vec(anchor).c_str());
      el->SetAttribute("axis", vec(t_cj.linear() * j.axes[i]).c_str());
      set_dof_dynamics(el, d);
      w_.key_qpos_.push_back(j.init_pos[i]);
      w_.key_qvel_.push_back(j.init_vel[i]);
    }
  }

  void emit_inertial(XMLElement* body_el, const Body& b) {
    XMLElement* el = w_.add(body_el, "inertial");
    el->SetAttribute("pos", vec(b.com).c_str());
    el->SetAttribute("mass", num(b.mass).c_str());
    const Matrix3d& i = b.moment;
    el->SetAttribute("fullinertia",
                     fmt::format("{} {} {} {} {} {}", num(i(0, 0)), num(i(1, 1)), num(i(2, 2)),
                                 num(i(0, 1)), num(i(0, 2)), num(i(1, 2)))
                         .c_str());
  }

  void emit_geoms(XMLElement* body_el, const Body& b) {
    int n_visual = 0;
    int n_collision = 0;
    for (const Shape& s : b.shapes) {
      if (s.kind == ShapeKind::kCone || s.kind == ShapeKind::kPyramid ||
          s.kind == ShapeKind::kMultiSphere || s.kind == ShapeKind::kMesh) {
        fail(s.line, fmt::format("body '{}': shape <{}> is not supported by the MuJoCo "
                                 "translation (supported: sphere, box, ellipsoid, cylinder, "
                                 "capsule, plane; DART loads it: --engine dart)",
                                 b.name, s.tag));
      }
      XMLElement* el = w_.add(body_el, "geom");
      int& counter = s.collision ? n_collision : n_visual;
      el->SetAttribute(
          "name",
          fmt::format("{}/{}{}", b.name, s.collision ? "collision" : "visual", counter++).c_str());
      Isometry3d pose = s.pose;
      switch (s.kind) {
        case ShapeKind::kSphere:
          el->SetAttribute("type", "sphere");
          el->SetAttribute("size", num(s.radius).c_str());
          break;
        case ShapeKind::kBox:
          el->SetAttribute("type", "box");
          el->SetAttribute("size", vec(0.5 * s.size).c_str());
          break;
        case ShapeKind::kEllipsoid:
          el->SetAttribute("type", "ellipsoid");
          el->SetAttribute("size", vec(0.5 * s.size).c_str());  // DART: diameters
          break;
        case ShapeKind::kCylinder:
          el->SetAttribute("type", "cylinder");
          el->SetAttribute("size",
                           fmt::format("{} {}", num(s.radius), num(0.5 * s.height)).c_str());
          break;
        case ShapeKind::kCapsule:
          el->SetAttribute("type", "capsule");  // DART: height of the cylindrical part
          el->SetAttribute("size",
                           fmt::format("{} {}", num(s.radius), num(0.5 * s.height)).c_str());
          break;
        case ShapeKind::kPlane: {
          // DART plane {x : n.x = offset} -> MuJoCo plane: local z = n, origin at offset * n
          el->SetAttribute("type", "plane");
          el->SetAttribute("size", "0 0 1");
          Vector3d n = s.normal.normalized();
          Isometry3d local = Isometry3d::Identity();
          local.linear() =
              Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitZ(), n).toRotationMatrix();
          local.translation() = s.offset * n;
          pose = pose * local;
          break;
        }
        case ShapeKind::kCone:
        case ShapeKind::kPyramid:
        case ShapeKind::kMultiSphere:
        case ShapeKind::kMesh:
          break;  // rejected above
      }
      set_pose(el, pose);
      el->SetAttribute("mass", "0");
      if (s.collision) {
        el->SetAttribute("contype", s.collidable ? contype_ : 0);
        el->SetAttribute("conaffinity", s.collidable ? conaffinity_ : 0);
        el->SetAttribute("group", 3);
        el->SetAttribute("rgba", "0.5 0.5 0.5 0.3");
      } else {
        el->SetAttribute("contype", 0);
        el->SetAttribute("conaffinity", 0);
        el->SetAttribute("group", 1);
        if (s.rgba) {
          const Vector4d& c = *s.rgba;
          el->SetAttribute(
              "rgba",
              fmt::format("{} {} {} {}", num(c[0]), num(c[1]), num(c[2]), num(c[3])).c_str());
        }
      }
    }
  }

  MjcfWriter& w_;
  const Skeleton& s_;
  std::map<std::string, size_t> body_index_;
  std::map<std::string, size_t> joint_of_child_;
  std::map<std::string, std::vector<size_t>> child_joints_;
  int contype_ = 1;  // of this skeleton's colliding geoms (choose_collision_mask)
  int conaffinity_ = 1;
};

std::string join_numbers(const std::vector<double>& v) {
  std::string out;
  for (size_t i = 0; i < v.size(); ++i) {
    if (i > 0) out += ' ';
    out += num(v[i]);
  }
  return out;
}

}  // namespace

void check_skel_for_dart(const std::string& path) {
  const SkelFile file = read_skel_file(SkelInput{path});
  // DART's SkelParser builds each body from the joint that makes it a child; a body without one
  // is left half made and DART then aborts or crashes (found by fuzz_model). The MuJoCo
  // translation takes such a body as a root of its own.
  for (const Skeleton& s : file.skeletons) {
    std::set<std::string> children;
    for (const Joint& j : s.joints) children.insert(j.child);
    for (const Body& b : s.bodies)
      if (children.count(b.name) == 0)
        throw InputError(located(
            file.path, b.line,
            fmt::format("body '{}' is no joint's <child> in skeleton '{}' (DART needs a joint "
                        "for every body; a weld joint fixes it to its parent)",
                        b.name, s.name)));
  }
}

SkelTranslation skel_to_mjcf(const std::vector<SkelInput>& files) {
  if (files.empty()) throw InputError("skel_to_mjcf: no .skel files given");
  std::vector<SkelFile> parsed;
  parsed.reserve(files.size());
  for (const SkelInput& f : files) parsed.push_back(read_skel_file(f));

  SkelTranslation out;
  // physics: DART's World defaults unless a file sets them; files must agree
  std::optional<std::pair<double, std::string>> timestep;
  std::optional<std::pair<Vector3d, std::string>> gravity;
  for (const SkelFile& f : parsed) {
    if (f.timestep) {
      if (timestep && timestep->first != *f.timestep) {
        throw InputError(fmt::format("{}: time_step {} differs from {} in {}", f.path,
                                     num(*f.timestep), num(timestep->first), timestep->second));
      }
      timestep = std::make_pair(*f.timestep, f.path);
    }
    if (f.gravity) {
      if (gravity && gravity->first != *f.gravity) {
        throw InputError(
            fmt::format("{}: gravity differs from the one in {}", f.path, gravity->second));
      }
      gravity = std::make_pair(*f.gravity, f.path);
    }
  }
  if (timestep) out.timestep = timestep->first;
  if (gravity) out.gravity = gravity->first;

  MjcfWriter w;
  w.root_->SetAttribute("model", std::filesystem::path(parsed.front().path).stem().c_str());
  w.option_->SetAttribute("timestep", num(out.timestep).c_str());
  w.option_->SetAttribute("gravity", vec(out.gravity).c_str());
  for (const SkelFile& f : parsed) {
    for (const Skeleton& s : f.skeletons) {
      if (!s.mobile) out.immobile_skeletons.push_back(s.name);
      SkeletonEmitter(w, s).emit();
    }
  }
  if (!w.key_qpos_.empty()) {
    XMLElement* key = w.add(w.add(w.root_, "keyframe"), "key");
    key->SetAttribute("name", "init");
    key->SetAttribute("qpos", join_numbers(w.key_qpos_).c_str());
    key->SetAttribute("qvel", join_numbers(w.key_qvel_).c_str());
  }
  tinyxml2::XMLPrinter printer;
  w.doc_.Print(&printer);
  out.mjcf = printer.CStr();
  return out;
}

void write_mjcf_file(const std::string& skel_path, const std::string& out_path) {
  SkelTranslation t = skel_to_mjcf({SkelInput{skel_path}});
  write_file_atomically(out_path, t.mjcf);
}

}  // namespace stance
