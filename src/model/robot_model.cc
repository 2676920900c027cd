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

namespace {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using tinyxml2::XMLElement;

using namespace mjcf;  // the MJCF writing helpers
using namespace robot_detail;

// ---------------------------------------------------------------------------------------------
// reading helpers: every error names file:line of the element

// the elements whose numbers are lengths (URDF origin and shapes, SDF pose and shapes)
const std::set<std::string> kRobotLengths = {"origin", "box",  "sphere", "cylinder", "mesh",
                                             "pose",   "size", "radius", "length",   "scale"};

class RobotReader : public XmlReader {
 public:
  explicit RobotReader(std::string file) : XmlReader(std::move(file), kRobotLengths) {}

  // whitespace-separated finite numbers; `count` < 0 accepts any count
  std::vector<double> numbers(const XMLElement* el, const std::string& t, const std::string& what,
                              int count) const {
    return parse_numbers(el, t, what, count, is_length(el), "is not a finite number");
  }

  // an attribute's numbers; `fallback` when absent
  std::vector<double> attribute_numbers(const XMLElement* el, const char* name, int count,
                                        std::vector<double> fallback) const {
    const char* a = el->Attribute(name);
    if (a == nullptr) return fallback;
    return numbers(el, a, fmt::format("<{}> {}", el->Name(), name), count);
  }
  double attribute_number(const XMLElement* el, const char* name, double fallback) const {
    return attribute_numbers(el, name, 1, {fallback})[0];
  }
  // an element's text as numbers
  std::vector<double> text_numbers(const XMLElement* el, int count) const {
    return numbers(el, trimmed_text(el), fmt::format("<{}>", el->Name()), count);
  }
  double child_number(const XMLElement* parent, const char* name, double fallback) const {
    const XMLElement* el = parent->FirstChildElement(name);
    return el != nullptr ? text_numbers(el, 1)[0] : fallback;
  }

  bool boolean(const XMLElement* el) const {
    const std::string t = trimmed_text(el);
    if (t == "true" || t == "1") return true;
    if (t == "false" || t == "0") return false;
    fail(el, fmt::format("<{}>: expected true/false/1/0, found '{}'", el->Name(), t));
  }
};

// R = Rz(yaw) Ry(pitch) Rx(roll): URDF's rpy and SDF's pose (fixed axes x, y, z)
Matrix3d rpy_rotation(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Vector3d::UnitX()))
      .toRotationMatrix();
}

Isometry3d make_pose(const std::vector<double>& xyz, const std::vector<double>& rpy) {
  Isometry3d t = Isometry3d::Identity();
  t.translation() = Vector3d(xyz[0], xyz[1], xyz[2]);
  t.linear() = rpy_rotation(rpy[0], rpy[1], rpy[2]);
  return t;
}

// URDF <origin xyz rpy>; identity when absent
Isometry3d urdf_origin(const RobotReader& r, const XMLElement* parent) {
  const XMLElement* o = parent->FirstChildElement("origin");
  if (o == nullptr) return Isometry3d::Identity();
  return make_pose(r.attribute_numbers(o, "xyz", 3, {0, 0, 0}),
                   r.attribute_numbers(o, "rpy", 3, {0, 0, 0}));
}

// SDF <pose>x y z r p y</pose>; identity when absent
Isometry3d sdf_pose(const RobotReader& r, const XMLElement* parent) {
  const XMLElement* p = parent->FirstChildElement("pose");
  if (p == nullptr) return Isometry3d::Identity();
  for (const char* a : {"frame", "relative_to"}) {
    const char* v = p->Attribute(a);
    if (v != nullptr && *v != '\0')
      r.fail(p, fmt::format("<pose {}='{}'>: poses relative to other frames are not supported "
                            "(stance reads SDF 1.4-1.6 poses: links in the model frame, joints "
                            "in the child link frame)",
                            a, v));
  }
  const std::vector<double> v = r.text_numbers(p, 6);
  return make_pose({v[0], v[1], v[2]}, {v[3], v[4], v[5]});
}

// a symmetric inertia that a body can have: finite, eigenvalues >= 0, triangle inequality
void check_inertia(const RobotReader& r, const XMLElement* el, const std::string& link,
                   const Matrix3d& inertia) {
  Eigen::SelfAdjointEigenSolver<Matrix3d> eig(inertia);
  const Vector3d e = eig.eigenvalues();
  const double tol = 1e-9 * std::max(1.0, e.cwiseAbs().maxCoeff());
  const bool ok = e.minCoeff() >= -tol && e[0] + e[1] >= e[2] - tol;
  if (!ok)
    r.fail(el, fmt::format("link '{}': the inertia is not a body's (principal moments {:.6g} "
                           "{:.6g} {:.6g} must be >= 0, and any two add up to at least the third)",
                           link, e[0], e[1], e[2]));
}

// ---------------------------------------------------------------------------------------------
// mesh files

// a mesh reference (relative to the model file, absolute, file://, package:// or model://) as
// an absolute path to an existing file
std::string resolve_mesh(const RobotReader& r, const XMLElement* el, const std::string& model_path,
                         const std::string& reference, const RobotOptions& options) {
  namespace fs = std::filesystem;
  std::string path;
  const size_t scheme = reference.find("://");
  if (scheme == std::string::npos) {
    path = fs::path(reference).is_absolute()
               ? reference
               : (fs::path(model_path).parent_path() / reference).string();
  } else {
    const std::string kind = reference.substr(0, scheme);
    const std::string rest = reference.substr(scheme + 3);
    if (kind == "file") {
      path = rest;
    } else if (kind == "package" || kind == "model") {
      const std::vector<std::string> folders = package_folders(options);
      for (const std::string& dir : folders) {
        const fs::path candidate = fs::path(dir) / rest;
        std::error_code ec;
        if (fs::is_regular_file(candidate, ec)) {
          path = candidate.string();
          break;
        }
      }
      if (path.empty())
        r.fail(el, fmt::format("mesh '{}': not found in the package path ({}; set the model's "
                               "package_path or STANCE_PACKAGE_PATH to folders holding '{}')",
                               reference,
                               folders.empty() ? std::string("empty")
                                               : fmt::format("{}", fmt::join(folders, ":")),
                               rest.substr(0, rest.find('/'))));
    } else {
      r.fail(el, fmt::format("mesh '{}': unsupported URI scheme '{}://' (expected a path, "
                             "file://, package:// or model://)",
                             reference, kind));
    }
  }
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))
    r.fail(el, fmt::format("mesh '{}': no such file ({})", reference, path));
  return fs::absolute(path).lexically_normal().string();
}

// ---------------------------------------------------------------------------------------------
// URDF

RobotGeometry read_urdf_geometry(const RobotReader& r, const XMLElement* el,
                                 const std::string& model_path, const RobotOptions& options) {
  RobotGeometry g;
  g.line = el->GetLineNum();
  g.origin = urdf_origin(r, el);
  const XMLElement* geometry = r.need(el, "geometry");
  const XMLElement* shape = geometry->FirstChildElement();
  if (shape == nullptr) r.fail(geometry, "<geometry> holds no shape");
  const std::string kind = shape->Name();
  if (kind == "box") {
    const std::vector<double> s = r.attribute_numbers(shape, "size", 3, {});
    if (s.empty()) r.fail(shape, "<box> is missing the attribute 'size'");
    g.kind = RobotGeometry::Kind::kBox;
    g.size = Vector3d(s[0], s[1], s[2]);
  } else if (kind == "sphere") {
    g.kind = RobotGeometry::Kind::kSphere;
    g.size.x() = r.attribute_number(shape, "radius", 0);
  } else if (kind == "cylinder") {
    g.kind = RobotGeometry::Kind::kCylinder;
    g.size.x() = r.attribute_number(shape, "radius", 0);
    g.size.y() = r.attribute_number(shape, "length", 0);
  } else if (kind == "mesh") {
    g.kind = RobotGeometry::Kind::kMesh;
    g.mesh = resolve_mesh(r, shape, model_path, r.attribute(shape, "filename"), options);
    const std::vector<double> s = r.attribute_numbers(shape, "scale", 3, {1, 1, 1});
    g.scale = Vector3d(s[0], s[1], s[2]);
    if (!(g.scale.array() > 0).all())
      r.fail(shape, fmt::format("<mesh> scale: every number must be positive, found '{}'",
                                shape->Attribute("scale")));
    return g;
  } else {
    r.fail(shape,
           fmt::format("unknown geometry <{}> (expected box, sphere, cylinder or mesh)", kind));
  }
  const int n = g.kind == RobotGeometry::Kind::kBox      ? 3
                : g.kind == RobotGeometry::Kind::kSphere ? 1
                                                         : 2;
  for (int i = 0; i < n; ++i)
    if (!(g.size[i] > 0)) r.fail(shape, fmt::format("<{}>: sizes must be positive", kind));
  return g;
}

RobotLink read_urdf_link(const RobotReader& r, const XMLElement* el, const std::string& model_path,
                         const RobotOptions& options) {
  RobotLink link;
  link.name = r.attribute(el, "name");
  link.line = el->GetLineNum();
  if (const XMLElement* in = el->FirstChildElement("inertial")) {
    const Isometry3d origin = urdf_origin(r, in);
    const XMLElement* mass = r.need(in, "mass");
    r.attribute(mass, "value");
    link.mass = r.attribute_number(mass, "value", 0);
    if (!(link.mass >= 0)) r.fail(mass, fmt::format("link '{}': mass must be >= 0", link.name));
    const XMLElement* i = r.need(in, "inertia");
    double v[6];
    const char* names[6] = {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"};
    for (int k = 0; k < 6; ++k) {
      if (i->Attribute(names[k]) == nullptr)
        r.fail(i, fmt::format("<inertia> is missing the attribute '{}'", names[k]));
      v[k] = r.attribute_number(i, names[k], 0);
    }
    Matrix3d moment;
    moment << v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5];
    check_inertia(r, i, link.name, moment);
    link.com = origin.translation();
    link.inertia = origin.linear() * moment * origin.linear().transpose();
  }
  for (const XMLElement* c = el->FirstChildElement("collision"); c;
       c = c->NextSiblingElement("collision"))
    link.collisions.push_back(read_urdf_geometry(r, c, model_path, options));
  for (const XMLElement* c = el->FirstChildElement("visual"); c;
       c = c->NextSiblingElement("visual"))
    link.visuals.push_back(read_urdf_geometry(r, c, model_path, options));
  return link;
}

Vector3d unit_axis(const RobotReader& r, const XMLElement* el, const std::vector<double>& xyz) {
  const Vector3d axis(xyz[0], xyz[1], xyz[2]);
  if (!(axis.norm() > 1e-12)) r.fail(el, "the joint axis must not be zero");
  return axis.normalized();
}

// a joint element's name, line and type, the type one of `types` (in the order the message
// lists them); the start every format's joint reader shares
using JointTypeNames = std::vector<std::pair<const char*, RobotJointType>>;
RobotJoint read_joint_head(const RobotReader& r, const XMLElement* el,
                           const JointTypeNames& types) {
  RobotJoint j;
  j.name = r.attribute(el, "name");
  j.line = el->GetLineNum();
  const std::string type = r.attribute(el, "type");
  std::string supported;
  for (const auto& [name, value] : types) {
    if (type == name) {
      j.type = value;
      return j;
    }
    supported += supported.empty() ? name : std::string(", ") + name;
  }
  r.fail(el, fmt::format("joint '{}': unsupported joint type '{}' (supported: {})", j.name, type,
                         supported));
}

RobotJoint read_urdf_joint(const RobotReader& r, const XMLElement* el) {
  RobotJoint j = read_joint_head(r, el,
                                 {{"fixed", RobotJointType::kFixed},
                                  {"revolute", RobotJointType::kRevolute},
                                  {"continuous", RobotJointType::kContinuous},
                                  {"prismatic", RobotJointType::kPrismatic},
                                  {"floating", RobotJointType::kFloating}});
  const std::string type = r.attribute(el, "type");
  j.parent = r.attribute(r.need(el, "parent"), "link");
  j.child = r.attribute(r.need(el, "child"), "link");
  j.parent_to_child = urdf_origin(r, el);
  // an <axis> without xyz: URDF requires it, and DART's reader takes it as zero (then aborts)
  if (const XMLElement* axis = el->FirstChildElement("axis")) {
    if (axis->Attribute("xyz") == nullptr)
      r.fail(axis, fmt::format("joint '{}': <axis> needs its xyz", j.name));
    j.axis = unit_axis(r, axis, r.attribute_numbers(axis, "xyz", 3, {1, 0, 0}));
  }
  const XMLElement* limit = el->FirstChildElement("limit");
  const bool needs_limit =
      j.type == RobotJointType::kRevolute || j.type == RobotJointType::kPrismatic;
  if (needs_limit && limit == nullptr)
    r.fail(el, fmt::format("joint '{}': a {} joint needs <limit>", j.name, type));
  if (limit != nullptr && j.type != RobotJointType::kFixed && j.type != RobotJointType::kFloating) {
    for (const char* a : {"effort", "velocity"})
      if (limit->Attribute(a) == nullptr)
        r.fail(limit, fmt::format("<limit> is missing the attribute '{}'", a));
    j.effort = r.attribute_number(limit, "effort", kInf);
    if (!(j.effort >= 0)) r.fail(limit, "<limit> effort must be >= 0");
    if (j.type != RobotJointType::kContinuous) {
      j.lower = r.attribute_number(limit, "lower", 0);
      j.upper = r.attribute_number(limit, "upper", 0);
      j.has_limits = true;
      if (j.lower > j.upper)
        r.fail(limit, fmt::format("<limit>: lower {} is above upper {}", j.lower, j.upper));
    }
  }
  if (const XMLElement* d = el->FirstChildElement("dynamics")) {
    j.damping = r.attribute_number(d, "damping", 0);
    j.friction = r.attribute_number(d, "friction", 0);
    if (j.damping < 0 || j.friction < 0) r.fail(d, "<dynamics> damping and friction must be >= 0");
  }
  return j;
}

// ---------------------------------------------------------------------------------------------
// SDF

RobotGeometry read_sdf_geometry(const RobotReader& r, const XMLElement* el,
                                const std::string& model_path, const RobotOptions& options) {
  RobotGeometry g;
  g.line = el->GetLineNum();
  g.origin = sdf_pose(r, el);
  const XMLElement* geometry = r.need(el, "geometry");
  const XMLElement* shape = geometry->FirstChildElement();
  if (shape == nullptr) r.fail(geometry, "<geometry> holds no shape");
  const std::string kind = shape->Name();
  if (kind == "box") {
    const std::vector<double> s = r.text_numbers(r.need(shape, "size"), 3);
    g.kind = RobotGeometry::Kind::kBox;
    g.size = Vector3d(s[0], s[1], s[2]);
  } else if (kind == "sphere") {
    g.kind = RobotGeometry::Kind::kSphere;
    g.size.x() = r.text_numbers(r.need(shape, "radius"), 1)[0];
  } else if (kind == "cylinder") {
    g.kind = RobotGeometry::Kind::kCylinder;
    g.size.x() = r.text_numbers(r.need(shape, "radius"), 1)[0];
    g.size.y() = r.text_numbers(r.need(shape, "length"), 1)[0];
  } else if (kind == "mesh") {
    g.kind = RobotGeometry::Kind::kMesh;
    const XMLElement* uri = r.need(shape, "uri");
    g.mesh = resolve_mesh(r, uri, model_path, r.trimmed_text(uri), options);
    if (const XMLElement* s = shape->FirstChildElement("scale")) {
      const std::vector<double> v = r.text_numbers(s, 3);
      g.scale = Vector3d(v[0], v[1], v[2]);
      if (!(g.scale.array() > 0).all()) r.fail(s, "<scale>: every number must be positive");
    }
    return g;
  } else {
    r.fail(shape, fmt::format("unsupported geometry <{}> (supported: box, sphere, cylinder, "
                              "mesh)",
                              kind));
  }
  const int n = g.kind == RobotGeometry::Kind::kBox      ? 3
                : g.kind == RobotGeometry::Kind::kSphere ? 1
                                                         : 2;
  for (int i = 0; i < n; ++i)
    if (!(g.size[i] > 0)) r.fail(shape, fmt::format("<{}>: sizes must be positive", kind));
  return g;
}

// an SDF link; `world` receives the link's pose in the model frame
RobotLink read_sdf_link(const RobotReader& r, const XMLElement* el, const std::string& model_path,
                        const RobotOptions& options, Isometry3d& in_model) {
  RobotLink link;
  link.name = r.attribute(el, "name");
  link.line = el->GetLineNum();
  in_model = sdf_pose(r, el);
  if (const XMLElement* in = el->FirstChildElement("inertial")) {
    const Isometry3d pose = sdf_pose(r, in);
    link.mass = r.child_number(in, "mass", 1);
    if (!(link.mass >= 0))
      r.fail(in->FirstChildElement("mass"), fmt::format("link '{}': mass must be >= 0", link.name));
    Matrix3d moment = Matrix3d::Identity();
    if (const XMLElement* i = in->FirstChildElement("inertia")) {
      double v[6];
      const char* names[6] = {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"};
      for (int k = 0; k < 6; ++k) v[k] = r.text_numbers(r.need(i, names[k]), 1)[0];
      moment << v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5];
      check_inertia(r, i, link.name, moment);
    }
    if (!pose.linear().isIdentity(1e-12))
      r.fail(in->FirstChildElement("pose"),
             fmt::format("link '{}': a rotated <inertial> pose is not supported (DART 6.12 "
                         "ignores the rotation): rotate the inertia itself",
                         link.name));
    link.com = pose.translation();
    link.inertia = moment;
  }
  for (const XMLElement* c = el->FirstChildElement("collision"); c;
       c = c->NextSiblingElement("collision"))
    link.collisions.push_back(read_sdf_geometry(r, c, model_path, options));
  for (const XMLElement* c = el->FirstChildElement("visual"); c;
       c = c->NextSiblingElement("visual"))
    link.visuals.push_back(read_sdf_geometry(r, c, model_path, options));
  return link;
}

RobotJoint read_sdf_joint(const RobotReader& r, const XMLElement* el) {
  RobotJoint j = read_joint_head(r, el,
                                 {{"fixed", RobotJointType::kFixed},
                                  {"revolute", RobotJointType::kRevolute},
                                  {"prismatic", RobotJointType::kPrismatic},
                                  {"ball", RobotJointType::kBall}});
  j.parent = r.trimmed_text(r.need(el, "parent"));
  j.child = r.trimmed_text(r.need(el, "child"));
  j.child_to_joint = sdf_pose(r, el);
  if (j.type == RobotJointType::kRevolute || j.type == RobotJointType::kPrismatic) {
    const XMLElement* axis = r.need(el, "axis");
    j.axis = unit_axis(r, axis, r.text_numbers(r.need(axis, "xyz"), 3));
    if (const XMLElement* u = axis->FirstChildElement("use_parent_model_frame"); u && r.boolean(u))
      r.fail(u, fmt::format("joint '{}': use_parent_model_frame is not supported: give the axis "
                            "in the joint frame",
                            j.name));
    if (const XMLElement* limit = axis->FirstChildElement("limit")) {
      j.lower = r.child_number(limit, "lower", -1e16);
      j.upper = r.child_number(limit, "upper", 1e16);
      j.has_limits = j.lower > -1e16 || j.upper < 1e16;
      if (!j.has_limits) j.lower = j.upper = 0;
      const double effort = r.child_number(limit, "effort", -1);
      j.effort = effort < 0 ? kInf : effort;  // SDF: -1 means no limit
      if (j.lower > j.upper)
        r.fail(limit, fmt::format("<limit>: lower {} is above upper {}", j.lower, j.upper));
    }
    if (const XMLElement* d = axis->FirstChildElement("dynamics")) {
      j.damping = r.child_number(d, "damping", 0);
      j.friction = r.child_number(d, "friction", 0);
      if (j.damping < 0 || j.friction < 0)
        r.fail(d, "<dynamics> damping and friction must be >= 0");
    }
  }
  return j;
}

// ---------------------------------------------------------------------------------------------
// the tree

// one root, every joint's links known, no link with two parents; sets the root
void check_tree(const RobotReader& r, const XMLElement* root_el, RobotModel& m,
                const std::map<std::string, int>& link_lines) {
  std::vector<std::string> names;
  for (const auto& [name, line] : link_lines) names.push_back(name);
  std::map<std::string, const RobotJoint*> parent_joint;
  for (const RobotJoint& j : m.joints) {
    for (const std::string* end : {&j.parent, &j.child}) {
      if (*end == "world" && end == &j.parent) continue;
      if (link_lines.count(*end) == 0)
        throw InputError(located(m.file, j.line,
                                 fmt::format("joint '{}': unknown link '{}'{}", j.name, *end,
                                             did_you_mean(*end, names))));
    }
    if (j.parent == j.child)
      throw InputError(located(
          m.file, j.line, fmt::format("joint '{}': link '{}' is its own parent", j.name, j.child)));
    auto [it, fresh] = parent_joint.emplace(j.child, &j);
    if (!fresh)
      throw InputError(located(m.file, j.line,
                               fmt::format("link '{}' has two parent joints, '{}' (line {}) and "
                                           "'{}'",
                                           j.child, it->second->name, it->second->line, j.name)));
  }
  std::vector<std::string> roots;
  for (const RobotLink& l : m.links)
    if (parent_joint.count(l.name) == 0) roots.push_back(l.name);
  bool world_joints = false;
  for (const RobotJoint& j : m.joints) world_joints = world_joints || j.parent == "world";
  if (world_joints) {
    // SDF: joints to "world"; URDF: a link named "world" (its only parentless link)
    roots.erase(std::remove(roots.begin(), roots.end(), "world"), roots.end());
    if (!roots.empty())
      throw InputError(located(
          m.file, link_lines.at(roots.front()),
          fmt::format("link '{}' is not connected to the tree below 'world'", roots.front())));
    m.root = "world";
  } else if (roots.size() != 1) {
    if (roots.empty()) r.fail(root_el, "the joints form a cycle: no link is the root");
    throw InputError(located(m.file, link_lines.at(roots[1]),
                             fmt::format("links '{}' and '{}' both have no parent joint: a model "
                                         "is one tree",
                                         roots[0], roots[1])));
  } else {
    m.root = roots.front();
  }
  // every link reachable from the root (a cycle leaves links unreachable)
  std::map<std::string, std::vector<const RobotJoint*>> children;
  for (const RobotJoint& j : m.joints) children[j.parent].push_back(&j);
  std::set<std::string> seen{m.root};
  std::vector<std::string> stack{m.root};
  while (!stack.empty()) {
    const std::string l = stack.back();
    stack.pop_back();
    for (const RobotJoint* j : children[l])
      if (seen.insert(j->child).second) stack.push_back(j->child);
  }
  for (const RobotLink& l : m.links)
    if (seen.count(l.name) == 0)
      throw InputError(
          located(m.file, l.line, fmt::format("link '{}' is on a cycle of joints", l.name)));
}

void load_document(const std::string& shown_name, const std::string& path,
                   tinyxml2::XMLDocument& doc) {
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS)
    throw InputError(located(shown_name, doc.ErrorLineNum(),
                             std::string("malformed XML (") +
                                 tinyxml2::XMLDocument::ErrorIDToName(doc.ErrorID()) + ")"));
  // a file of only a declaration or comments parses, but has no element (found by fuzz_model)
  if (doc.RootElement() == nullptr)
    throw InputError(located(shown_name, 1, "no XML element in the file"));
}

void add_link(const RobotReader& r, const XMLElement* el, RobotModel& m,
              std::map<std::string, int>& link_lines, RobotLink link) {
  if (m.links.size() >= kMaxRobotLinks)
    r.fail(el, fmt::format("more than {} links", kMaxRobotLinks));
  auto [it, fresh] = link_lines.emplace(link.name, link.line);
  if (!fresh)
    r.fail(el,
           fmt::format("link name '{}' is used twice (first at line {})", link.name, it->second));
  m.links.push_back(std::move(link));
}

void check_joint_names(const RobotModel& m) {
  std::map<std::string, int> lines;
  for (const RobotJoint& j : m.joints) {
    auto [it, fresh] = lines.emplace(j.name, j.line);
    if (!fresh)
      throw InputError(located(
          m.file, j.line,
          fmt::format("joint name '{}' is used twice (first at line {})", j.name, it->second)));
  }
}

RobotModel read_urdf(const std::string& shown_name, const std::string& path,
                     const RobotOptions& options, const tinyxml2::XMLDocument& doc) {
  RobotReader r(shown_name);
  const XMLElement* robot = doc.RootElement();
  if (std::strcmp(robot->Name(), "robot") != 0)
    r.fail(robot, fmt::format("expected a <robot> root element, found <{}>", robot->Name()));
  RobotModel m;
  m.file = shown_name;
  m.format = ModelFormat::kUrdf;
  m.name = robot->Attribute("name") != nullptr ? robot->Attribute("name") : "";
  std::map<std::string, int> link_lines;
  for (const XMLElement* el = robot->FirstChildElement("link"); el;
       el = el->NextSiblingElement("link"))
    add_link(r, el, m, link_lines, read_urdf_link(r, el, path, options));
  if (m.links.empty()) r.fail(robot, "<robot> has no <link>");
  for (const XMLElement* el = robot->FirstChildElement("joint"); el;
       el = el->NextSiblingElement("joint"))
    m.joints.push_back(read_urdf_joint(r, el));
  check_joint_names(m);
  // a link named "world" is the world frame (DART's and ROS's convention)
  const bool has_world = link_lines.count("world") != 0;
  if (has_world) {
    m.links.erase(std::find_if(m.links.begin(), m.links.end(),
                               [](const RobotLink& l) { return l.name == "world"; }));
    link_lines.erase("world");
    for (const RobotJoint& j : m.joints)
      if (j.child == "world")
        throw InputError(located(
            m.file, j.line, fmt::format("joint '{}': the link 'world' cannot be a child", j.name)));
  }
  check_tree(r, robot, m, link_lines);
  if (m.root != "world") m.root_joint = options.fixed_base ? "" : "rootJoint";
  for (const RobotJoint& j : m.joints)
    if (j.type == RobotJointType::kFloating && j.parent != "world")
      throw InputError(located(m.file, j.line,
                               fmt::format("joint '{}': a floating joint must hang from the "
                                           "world or be the root",
                                           j.name)));
  return m;
}

RobotModel read_sdf(const std::string& shown_name, const std::string& path,
                    const RobotOptions& options, const tinyxml2::XMLDocument& doc) {
  RobotReader r(shown_name);
  const XMLElement* sdf = doc.RootElement();
  if (std::strcmp(sdf->Name(), "sdf") != 0)
    r.fail(sdf, fmt::format("expected an <sdf> root element, found <{}>", sdf->Name()));
  if (const XMLElement* world = sdf->FirstChildElement("world"))
    r.fail(world, "SDF <world> files are not supported: give a file with one <model>");
  const XMLElement* model = r.need(sdf, "model");
  if (const XMLElement* second = model->NextSiblingElement("model"))
    r.fail(second, "a second <model>: stance reads one model per SDF file");
  if (const XMLElement* nested = model->FirstChildElement("model"))
    r.fail(nested, "nested <model> elements are not supported");
  if (const XMLElement* include = model->FirstChildElement("include"))
    r.fail(include, "<include> is not supported: give the model inline");
  RobotModel m;
  m.file = shown_name;
  m.format = ModelFormat::kSdf;
  m.name = r.attribute(model, "name");
  m.pose = sdf_pose(r, model);
  bool is_static = false;
  if (const XMLElement* s = model->FirstChildElement("static")) is_static = r.boolean(s);
  std::map<std::string, int> link_lines;
  std::map<std::string, Isometry3d> in_model;
  for (const XMLElement* el = model->FirstChildElement("link"); el;
       el = el->NextSiblingElement("link")) {
    Isometry3d pose;
    RobotLink link = read_sdf_link(r, el, path, options, pose);
    in_model[link.name] = pose;
    add_link(r, el, m, link_lines, std::move(link));
  }
  if (m.links.empty()) r.fail(model, "<model> has no <link>");
  for (const XMLElement* el = model->FirstChildElement("joint"); el;
       el = el->NextSiblingElement("joint"))
    m.joints.push_back(read_sdf_joint(r, el));
  check_joint_names(m);
  check_tree(r, model, m, link_lines);
  // links are placed in the model frame: the child relative to its parent at q = 0
  for (RobotJoint& j : m.joints) {
    const Isometry3d parent = j.parent == "world" ? m.pose.inverse() : in_model.at(j.parent);
    j.parent_to_child = parent.inverse() * in_model.at(j.child);
  }
  if (m.root != "world") {
    m.pose = m.pose * in_model.at(m.root);  // the root link's world pose
    m.root_joint = (options.fixed_base || is_static) ? "" : "root";
  }
  return m;
}

}  // namespace

namespace {
// RobotOptions::lock_joints: each named joint becomes a fixed one at its zero position
void lock_joints(RobotModel& m, const std::vector<std::string>& names) {
  for (const std::string& name : names) {
    auto it = std::find_if(m.joints.begin(), m.joints.end(),
                           [&](const RobotJoint& j) { return j.name == name; });
    if (it == m.joints.end())
      throw InputError(fmt::format("{}: lock_joints: no joint '{}' in the file", m.file, name));
    it->type = RobotJointType::kFixed;
  }
}

// the same in the text DART parses: each named <joint> gets type="fixed"
void lock_joints_in_text(XMLElement* parent, const std::vector<std::string>& names) {
  for (XMLElement* j = parent->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
    const char* name = j->Attribute("name");
    if (name != nullptr && std::find(names.begin(), names.end(), name) != names.end())
      j->SetAttribute("type", "fixed");
  }
}
}  // namespace

RobotModel read_robot(const std::string& shown_name, const std::string& path,
                      const RobotOptions& options) {
  if (options.mesh_collision != "box" && options.mesh_collision != "mesh")
    throw InputError(fmt::format("{}: mesh_collision: expected box or mesh, found '{}'", shown_name,
                                 options.mesh_collision));
  tinyxml2::XMLDocument doc;
  load_document(shown_name, path, doc);
  const ModelFormat format = model_format(path);
  if (format != ModelFormat::kUrdf && format != ModelFormat::kSdf)
    throw InputError(shown_name + ": not a URDF or SDF file");
  RobotModel m = format == ModelFormat::kUrdf ? read_urdf(shown_name, path, options, doc)
                                              : read_sdf(shown_name, path, options, doc);
  lock_joints(m, options.lock_joints);
  robot_detail::check_robot_masses(m);
  return m;
}

// ---------------------------------------------------------------------------------------------
// the text DART parses

std::string robot_text_for_dart(const std::string& shown_name, const std::string& path,
                                const RobotOptions& options) {
  const ModelFormat format = model_format(path);
  tinyxml2::XMLDocument doc;
  load_document(shown_name, path, doc);
  RobotReader r(shown_name);
  const bool boxes = options.mesh_collision == "box";
  if (format == ModelFormat::kUrdf) {
    for (XMLElement* link = doc.RootElement()->FirstChildElement("link"); link;
         link = link->NextSiblingElement("link")) {
      for (XMLElement* g = link->FirstChildElement(); g; g = g->NextSiblingElement()) {
        const bool collision = std::strcmp(g->Name(), "collision") == 0;
        if (!collision && std::strcmp(g->Name(), "visual") != 0) continue;
        XMLElement* geometry = g->FirstChildElement("geometry");
        XMLElement* mesh = geometry != nullptr ? geometry->FirstChildElement("mesh") : nullptr;
        if (mesh == nullptr) continue;
        const std::string file =
            resolve_mesh(r, mesh, path, r.attribute(mesh, "filename"), options);
        mesh->SetAttribute("filename", file.c_str());
        if (!collision || !boxes) continue;
        const std::vector<double> s = r.attribute_numbers(mesh, "scale", 3, {1, 1, 1});
        const FittedBox box =
            fit_box(shown_name, mesh->GetLineNum(), file, Vector3d(s[0], s[1], s[2]));
        const Isometry3d origin = urdf_origin(r, g);
        XMLElement* o = g->FirstChildElement("origin");
        if (o == nullptr) {
          o = doc.NewElement("origin");
          g->InsertFirstChild(o);
        }
        o->SetAttribute("xyz", vec(origin * box.centre).c_str());
        geometry->DeleteChildren();
        XMLElement* b = doc.NewElement("box");
        b->SetAttribute("size", vec(box.size).c_str());
        geometry->InsertEndChild(b);
      }
    }
  } else {
    XMLElement* model = doc.RootElement()->FirstChildElement("model");
    for (XMLElement* link = model->FirstChildElement("link"); link;
         link = link->NextSiblingElement("link")) {
      for (XMLElement* g = link->FirstChildElement(); g; g = g->NextSiblingElement()) {
        const bool collision = std::strcmp(g->Name(), "collision") == 0;
        if (!collision && std::strcmp(g->Name(), "visual") != 0) continue;
        XMLElement* geometry = g->FirstChildElement("geometry");
        XMLElement* mesh = geometry != nullptr ? geometry->FirstChildElement("mesh") : nullptr;
        if (mesh == nullptr) continue;
        XMLElement* uri = mesh->FirstChildElement("uri");
        const std::string file = resolve_mesh(r, uri, path, r.trimmed_text(uri), options);
        uri->SetText(file.c_str());
        if (!collision || !boxes) continue;
        Vector3d scale = Vector3d::Ones();
        if (const XMLElement* s = mesh->FirstChildElement("scale")) {
          const std::vector<double> v = r.text_numbers(s, 3);
          scale = Vector3d(v[0], v[1], v[2]);
        }
        const FittedBox box = fit_box(shown_name, uri->GetLineNum(), file, scale);
        const Isometry3d pose = sdf_pose(r, g);
        XMLElement* p = g->FirstChildElement("pose");
        std::vector<double> rpy = {0, 0, 0};
        if (p != nullptr) {
          const std::vector<double> v = r.text_numbers(p, 6);
          rpy = {v[3], v[4], v[5]};
        } else {
          p = doc.NewElement("pose");
          g->InsertFirstChild(p);
        }
        p->SetText(fmt::format("{} {} {} {}", vec(pose * box.centre), num(rpy[0]), num(rpy[1]),
                               num(rpy[2]))
                       .c_str());
        geometry->DeleteChildren();
        XMLElement* b = doc.NewElement("box");
        XMLElement* size = doc.NewElement("size");
        size->SetText(vec(box.size).c_str());
        b->InsertEndChild(size);
        geometry->InsertEndChild(b);
      }
    }
  }
  XMLElement* root = doc.RootElement();
  lock_joints_in_text(format == ModelFormat::kUrdf ? root : root->FirstChildElement("model"),
                      options.lock_joints);
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace stance
