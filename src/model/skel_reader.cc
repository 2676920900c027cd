#include "model/skel_file.h"

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

using namespace mjcf;  // the MJCF writing helpers

using namespace skel_detail;

// ---------------------------------------------------------------------------------------------
// reading helpers: every error names file:line of the element

// the elements whose numbers are lengths (or a joint's initial state, which places bodies)
const std::set<std::string> kSkelLengths = {"transformation", "size",       "radius",
                                            "height",         "base_width", "base_depth",
                                            "offset",         "init_pos",   "init_vel"};

class SkelReader : public XmlReader {
 public:
  explicit SkelReader(std::string file) : XmlReader(std::move(file), kSkelLengths) {}

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

}  // namespace

namespace skel_detail {

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

}  // namespace skel_detail

}  // namespace stance
