// DART 6.12 backend of stance::Engine.
//
// Conventions of this backend (see engine.h for the shared ones):
//  - only mobile skeletons are simulated state: immobile ones (e.g. a ground skeleton) add no
//    dofs, bodies or mass, and count as "the world" (body -1) in contacts.
//  - nq == nv: free and ball joints store exponential coordinates, as DART does. A free
//    joint's q is (rotation vector, translation of the child frame in the parent frame) and its
//    v is the child body's twist in the child body frame (angular, linear); positions are
//    integrated as T(q) * T(v dt), exactly as DART's FreeJoint::integratePositions does.
//  - Euler and universal joints appear as one hinge JointInfo per dof, named like the dof.
//  - contacts: DART reports normal from its 2nd to its 1st object and force on its 1st; we
//    swap the pair, so Contact::normal points from body1 to body2 and Contact::force (normal
//    plus friction, world frame, N) acts on body2.
//  - contacts come from the last step (with forces) or, when positions were set since,
//    from forward() (geometry only, zero forces).
//  - collision detection uses DART's own detector whenever every collision shape is a box or
//    sphere: it tests pairs in a fixed order. Models with other shapes keep the detector the
//    file asks for; FCL and Bullet order contacts by their broad-phase trees, which depend on
//    history, so the tree is rebuilt from the state at save, restore and forward's contact
//    query (rebuild_broad_phase): restore_state + step replays bit-exactly on every detector.
//  - MJCF through DART 6.12's MjcfParser: <option> timestep/gravity are read here (the parser
//    ignores them), a missing <default> is supplied (the parser asserts on it), <freejoint/>
//    becomes <joint type="free"/> (the parser skips the shorthand and welds the body), and
//    <inertial> diaginertia/fullinertia/quat are applied (the parser leaves a unit moment).
#include <fmt/format.h>
#include <tinyxml2.h>
#include <dart/dart.hpp>
#include <dart/utils/mjcf/MjcfParser.hpp>
#include <dart/utils/sdf/SdfParser.hpp>
#include <dart/utils/urdf/urdf.hpp>
#include <dart/utils/utils.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "core/error.h"
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/backend_world.h"
#include "engine/engine.h"

namespace stance {

namespace {

using dart::dynamics::BallJoint;
using dart::dynamics::BodyNode;
using dart::dynamics::FreeJoint;
using dart::dynamics::Joint;
using dart::dynamics::SkeletonPtr;

// how a run of coordinates moves on its configuration space
enum class PositionGroupKind { kVector, kFree, kBall };

struct PositionGroup {
  PositionGroupKind kind = PositionGroupKind::kVector;
  int start = 0;  // in q (== in v)
  int size = 0;
};

// one mobile skeleton's slice of the global vectors
// a number as printf's `format` writes it, for messages
std::string number_text(double x, const char* format = "%.6f") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

struct SkeletonBlock {
  SkeletonPtr skeleton;
  int dof_start = 0;
  int ndof = 0;
};

// collects what DART prints to std::cerr while parsing, so errors can quote it
class CerrCapture {
 public:
  CerrCapture() : old_(std::cerr.rdbuf(buffer_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old_); }
  CerrCapture(const CerrCapture&) = delete;
  CerrCapture& operator=(const CerrCapture&) = delete;
  std::string text() const { return buffer_.str(); }

 private:
  std::ostringstream buffer_;
  std::streambuf* old_;
};

// DART's messages are multi-line and colour-coded; keep the first few lines, joined
std::string leading_message_lines(const std::string& text, int max_lines = 3) {
  std::istringstream in(text);
  std::string line, out;
  int taken = 0;
  while (taken < max_lines && std::getline(in, line)) {
    std::string clean;
    for (size_t i = 0; i < line.size(); ++i) {
      if (line[i] == '\033') {  // skip an ANSI colour escape
        while (i < line.size() && line[i] != 'm') ++i;
        continue;
      }
      clean += line[i];
    }
    const size_t b = clean.find_first_not_of(" \t-");
    if (b == std::string::npos) continue;
    if (!out.empty()) out += ' ';
    out.append(clean, b, std::string::npos);
    ++taken;
  }
  return out;
}

// a read-only in-memory file for DART's resource interface
class MemoryResource final : public dart::common::Resource {
 public:
  explicit MemoryResource(std::string text) : text_(std::move(text)) {}
  std::size_t getSize() override { return text_.size(); }
  std::size_t tell() override { return pos_; }
  bool seek(ptrdiff_t offset, SeekType origin) override {
    ptrdiff_t base = origin == SEEKTYPE_CUR   ? static_cast<ptrdiff_t>(pos_)
                     : origin == SEEKTYPE_END ? static_cast<ptrdiff_t>(text_.size())
                                              : 0;
    ptrdiff_t target = base + offset;
    if (target < 0 || target > static_cast<ptrdiff_t>(text_.size())) return false;
    pos_ = static_cast<std::size_t>(target);
    return true;
  }
  std::size_t read(void* buffer, std::size_t size, std::size_t count) override {
    if (size == 0) return 0;
    const std::size_t items = std::min(count, (text_.size() - pos_) / size);
    std::memcpy(buffer, text_.data() + pos_, items * size);
    pos_ += items * size;
    return items;
  }
  std::string readAll() override { return text_; }

 private:
  std::string text_;
  std::size_t pos_ = 0;
};

// serves one URI from memory (a patched model file) and everything else from disk
class PatchedFileRetriever final : public dart::common::ResourceRetriever {
 public:
  PatchedFileRetriever(std::string uri, std::string text)
      : uri_(std::move(uri)),
        text_(std::move(text)),
        disk_(std::make_shared<dart::common::LocalResourceRetriever>()) {}
  bool exists(const dart::common::Uri& uri) override {
    return uri.toString() == uri_ || disk_->exists(uri);
  }
  dart::common::ResourcePtr retrieve(const dart::common::Uri& uri) override {
    if (uri.toString() == uri_) return std::make_shared<MemoryResource>(text_);
    return disk_->retrieve(uri);
  }
  std::string readAll(const dart::common::Uri& uri) override {
    if (uri.toString() == uri_) return text_;
    return disk_->readAll(uri);
  }
  std::string getFilePath(const dart::common::Uri& uri) override { return disk_->getFilePath(uri); }

 private:
  std::string uri_, text_;
  dart::common::LocalResourceRetrieverPtr disk_;
};

// an MJCF <inertial>, in its body's frame
struct MjcfInertial {
  double mass = 0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();  // about the COM
};

// all model formats are XML: check well-formedness here, where the line number is known
void load_xml(const std::string& shown_name, const std::string& file, tinyxml2::XMLDocument& doc) {
  if (doc.LoadFile(file.c_str()) != tinyxml2::XML_SUCCESS) {
    throw InputError(located(shown_name, doc.ErrorLineNum(),
                             std::string("malformed XML (") +
                                 tinyxml2::XMLDocument::ErrorIDToName(doc.ErrorID()) + ")"));
  }
}

// what DART's MJCF parser needs done before and after it runs
struct MjcfPreflight {
  double timestep = 0.002;  // MuJoCo's defaults, which DART 6.12 does not read
  Eigen::Vector3d gravity{0, 0, -9.81};
  std::string patched_text;  // non-empty: parse this instead of the file
  // DART 6.12 keeps <inertial> mass and pos but drops diaginertia/fullinertia (unit moment)
  std::map<std::string, MjcfInertial> inertials;  // by body name
};

// reads n numbers from an attribute; false when absent
bool read_numbers(const std::string& shown_name, const tinyxml2::XMLElement* e, const char* name,
                  int n, double* out) {
  const char* text = e->Attribute(name);
  if (!text) return false;
  std::istringstream in(text);
  for (int i = 0; i < n; ++i) {
    if (!(in >> out[i]))
      throw InputError(located(shown_name, e->GetLineNum(),
                               std::string(e->Name()) + " " + name + ": expected " +
                                   std::to_string(n) + " numbers, got '" + text + "'"));
  }
  return true;
}

// every <body>'s <inertial> below `parent`
void collect_inertials(const std::string& shown_name, const tinyxml2::XMLElement* parent,
                       std::map<std::string, MjcfInertial>& out) {
  for (const tinyxml2::XMLElement* body = parent->FirstChildElement("body"); body;
       body = body->NextSiblingElement("body")) {
    const tinyxml2::XMLElement* in = body->FirstChildElement("inertial");
    const char* name = body->Attribute("name");
    if (in && name) {
      MjcfInertial inertial;
      in->QueryDoubleAttribute("mass", &inertial.mass);
      read_numbers(shown_name, in, "pos", 3, inertial.com.data());
      double d[6] = {0, 0, 0, 0, 0, 0};
      if (read_numbers(shown_name, in, "diaginertia", 3, d)) {
        inertial.moment = Eigen::Vector3d(d[0], d[1], d[2]).asDiagonal();
      } else if (read_numbers(shown_name, in, "fullinertia", 6, d)) {
        // MuJoCo order: ixx iyy izz ixy ixz iyz
        inertial.moment << d[0], d[3], d[4], d[3], d[1], d[5], d[4], d[5], d[2];
      }
      double q[4];
      if (read_numbers(shown_name, in, "quat", 4, q)) {
        const Eigen::Matrix3d r =
            Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
        inertial.moment = r * inertial.moment * r.transpose();
      } else if (in->Attribute("euler") || in->Attribute("axisangle") || in->Attribute("xyaxes") ||
                 in->Attribute("zaxis")) {
        throw InputError(located(shown_name, in->GetLineNum(),
                                 "inertial orientation: only 'quat' is supported by the DART "
                                 "backend"));
      }
      out[name] = inertial;
    }
    collect_inertials(shown_name, body, out);
  }
}

// every whitespace character in attribute values and element text -> a space. The readers that
// check a file first (MuJoCo's, stance's SKEL and URDF/SDF checks) take a tab, a line break, a
// form feed or a vertical tab as the separator it is; DART 6.12's parsers split numbers on spaces
// only and assert on the count (a capsule's fromto with "\r0.15" became a zero length; "0 1\f0"
// as an SDF axis or "0 0 0\v0 0 0" as a SKEL transformation abort in toVector3d/toIsometry3d).
// True when anything changed.
bool normalize_whitespace_for_dart(tinyxml2::XMLElement* parent) {
  static constexpr const char* kOtherSpaces = "\t\n\v\f\r";
  auto normalized = [](std::string& value) {
    if (value.find_first_of(kOtherSpaces) == std::string::npos) return false;
    for (char& c : value)
      if (std::strchr(kOtherSpaces, c) != nullptr && c != '\0') c = ' ';
    return true;
  };
  bool changed = false;
  for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
    for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
      std::string value = a->Value();
      if (!normalized(value)) continue;
      e->SetAttribute(a->Name(), value.c_str());
      changed = true;
    }
    if (e->FirstChildElement() == nullptr && e->GetText() != nullptr) {
      std::string text = e->GetText();
      if (normalized(text)) {
        e->SetText(text.c_str());
        changed = true;
      }
    }
    changed = normalize_whitespace_for_dart(e) || changed;
  }
  return changed;
}

// the file's text with normalize_whitespace_for_dart applied; empty when nothing changed
std::string text_normalized_for_dart(tinyxml2::XMLDocument& doc) {
  if (doc.RootElement() == nullptr || !normalize_whitespace_for_dart(doc.RootElement())) return "";
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

// the numeric vectors DART 6.12's MJCF parser reads with a fixed size (its toVector3d and kin
// assert on any other count, where MuJoCo reads what is there): every one must hold exactly that
// many finite numbers; a geom's or site's `size` holds 1 to 3. Lengths (pos, fromto, size) are at
// most kMaxModelLength.

void check_vector_attributes(const std::string& shown_name, const tinyxml2::XMLElement* parent) {
  static const std::map<std::string, int> kCounts = {
      {"pos", 3},         {"axis", 3},  {"euler", 3},     {"zaxis", 3},  {"gravity", 3},
      {"diaginertia", 3}, {"quat", 4},  {"axisangle", 4}, {"xyaxes", 6}, {"fromto", 6},
      {"fullinertia", 6}, {"range", 2}, {"rgba", 4}};
  for (const tinyxml2::XMLElement* e = parent->FirstChildElement(); e;
       e = e->NextSiblingElement()) {
    for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
      const std::string name = a->Name();
      const auto it = kCounts.find(name);
      const bool shape = std::strcmp(e->Name(), "geom") == 0 || std::strcmp(e->Name(), "site") == 0;
      if (it == kCounts.end() && !(name == "size" && shape)) continue;
      std::istringstream in(a->Value());
      std::string token;
      int count = 0;
      while (in >> token) {
        char* end = nullptr;
        const double x = std::strtod(token.c_str(), &end);
        if (*end != '\0' || !std::isfinite(x))
          throw InputError(
              located(shown_name, e->GetLineNum(),
                      fmt::format("<{}> {}: '{}' is not a finite number", e->Name(), name, token)));
        const bool length = name == "pos" || name == "fromto" || name == "size";
        if (length && std::abs(x) > kMaxModelLength)
          throw InputError(
              located(shown_name, e->GetLineNum(),
                      fmt::format("<{}> {}: {} is out of range (at most {} in size on DART)",
                                  e->Name(), name, token, kMaxModelLength)));
        ++count;
      }
      const bool ok = it != kCounts.end() ? count == it->second : count >= 1 && count <= 3;
      if (!ok)
        throw InputError(located(
            shown_name, e->GetLineNum(),
            fmt::format("<{}> {}: expected {} numbers, got '{}'", e->Name(), name,
                        it != kCounts.end() ? std::to_string(it->second) : "1 to 3", a->Value())));
    }
    check_vector_attributes(shown_name, e);
  }
}

// DART 6.12's MJCF reader dereferences a null joint for a body welded to its parent body (one
// without <joint>; MuJoCo reads it): such a body is refused with its line. A body directly in
// <worldbody> may have none (it is welded to the world, which DART handles).
void check_bodies_have_joints(const std::string& shown_name, const tinyxml2::XMLElement* parent,
                              bool in_body) {
  for (const tinyxml2::XMLElement* e = parent->FirstChildElement("body"); e;
       e = e->NextSiblingElement("body")) {
    if (in_body && !e->FirstChildElement("joint") && !e->FirstChildElement("freejoint")) {
      const char* name = e->Attribute("name");
      throw InputError(located(
          shown_name, e->GetLineNum(),
          fmt::format("<body{}> has no joint: DART 6.12's MJCF reader cannot weld a body to its "
                      "parent body; give it a joint or merge it into its parent",
                      name ? fmt::format(" name=\"{}\"", name) : "")));
    }
    check_bodies_have_joints(shown_name, e, true);
  }
}

// DART 6.12's MJCF reader crashes on an unnamed joint: each gets the name MuJoCo's reading gives
// it in stance ("joint<k>", k its index in the model's joint order, which is the document order
// under <worldbody>), so that dofs are named alike on both engines; true when any was named
bool name_unnamed_joints(tinyxml2::XMLElement* worldbody) {
  std::set<std::string> taken;
  std::vector<tinyxml2::XMLElement*> joints;
  std::function<void(tinyxml2::XMLElement*)> collect = [&](tinyxml2::XMLElement* parent) {
    for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
      if (std::strcmp(e->Name(), "joint") == 0 || std::strcmp(e->Name(), "freejoint") == 0) {
        joints.push_back(e);
        if (const char* name = e->Attribute("name")) taken.insert(name);
      }
      if (std::strcmp(e->Name(), "body") == 0) collect(e);
    }
  };
  collect(worldbody);
  bool changed = false;
  for (size_t k = 0; k < joints.size(); ++k) {
    if (joints[k]->Attribute("name")) continue;
    std::string name = fmt::format("joint{}", k);
    while (taken.count(name)) name += "_";
    taken.insert(name);
    joints[k]->SetAttribute("name", name.c_str());
    changed = true;
  }
  return changed;
}

// DART 6.12's MJCF reader names a geom's shape node after the geom, and an unnamed one
// "default": its NameManager then printed a line for each further unnamed geom of a skeleton
// ("The name [default] is a duplicate, so it has been renamed to [default(1)]"). Each gets a
// name of its own, "geom<k>" (k its index in document order); true when any was named
bool name_unnamed_geoms(tinyxml2::XMLElement* worldbody) {
  std::set<std::string> taken;
  std::vector<tinyxml2::XMLElement*> geoms;
  std::function<void(tinyxml2::XMLElement*)> collect = [&](tinyxml2::XMLElement* parent) {
    for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
      if (std::strcmp(e->Name(), "geom") == 0) {
        geoms.push_back(e);
        if (const char* name = e->Attribute("name")) taken.insert(name);
      }
      if (std::strcmp(e->Name(), "body") == 0) collect(e);
    }
  };
  collect(worldbody);
  bool changed = false;
  for (size_t k = 0; k < geoms.size(); ++k) {
    if (geoms[k]->Attribute("name")) continue;
    std::string name = fmt::format("geom{}", k);
    while (taken.count(name)) name += "_";
    taken.insert(name);
    geoms[k]->SetAttribute("name", name.c_str());
    changed = true;
  }
  return changed;
}

// DART 6.12's MJCF reader crashes on a <site> in <worldbody> and on one without a type; sites
// carry no mass or contact, so they are left out of the text DART reads; true when any was
bool drop_sites(tinyxml2::XMLElement* parent) {
  bool changed = false;
  for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e;) {
    tinyxml2::XMLElement* next = e->NextSiblingElement();
    if (std::strcmp(e->Name(), "site") == 0) {
      parent->DeleteChild(e);
      changed = true;
    } else {
      changed = drop_sites(e) || changed;
    }
    e = next;
  }
  return changed;
}

// a plane's zero half-size is infinite in MuJoCo, but DART 6.12 builds a box of that size and
// asserts: such sides become 100 m on DART; true when any plane changed
bool bound_infinite_planes(tinyxml2::XMLElement* parent) {
  bool changed = false;
  for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const char* type = e->Attribute("type");
    if (std::strcmp(e->Name(), "geom") == 0 && type && std::strcmp(type, "plane") == 0) {
      double size[3] = {0, 0, 0.1};
      if (const char* text = e->Attribute("size")) {
        std::istringstream in(text);
        for (double& x : size)
          if (!(in >> x)) break;
      }
      if (!(size[0] > 0) || !(size[1] > 0) || !(size[2] > 0)) {
        for (double& x : size)
          if (!(x > 0)) x = &x == &size[2] ? 0.1 : 100;
        e->SetAttribute("size", fmt::format("{} {} {}", size[0], size[1], size[2]).c_str());
        changed = true;
      }
    }
    changed = bound_infinite_planes(e) || changed;
  }
  return changed;
}

// <freejoint/> (MuJoCo's shorthand) -> <joint type="free"/>, which DART 6.12's parser knows;
// true when anything changed
bool expand_freejoints(tinyxml2::XMLElement* parent) {
  bool changed = false;
  for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
    if (std::strcmp(e->Name(), "freejoint") == 0) {
      e->SetName("joint");
      e->SetAttribute("type", "free");
      changed = true;
    }
    changed = expand_freejoints(e) || changed;
  }
  return changed;
}

// checks the XML (with line numbers in errors), reads <option>, and supplies <default/>
MjcfPreflight preflight_mjcf(const std::string& shown_name, const std::string& file) {
  tinyxml2::XMLDocument doc;
  load_xml(shown_name, file, doc);
  const tinyxml2::XMLElement* root = doc.RootElement();
  if (!root || std::strcmp(root->Name(), "mujoco") != 0)
    throw InputError(
        located(shown_name, root ? root->GetLineNum() : 0, "expected a <mujoco> root element"));
  MjcfPreflight out;
  if (const tinyxml2::XMLElement* option = root->FirstChildElement("option")) {
    option->QueryDoubleAttribute("timestep", &out.timestep);
    if (const char* g = option->Attribute("gravity")) {
      std::istringstream in(g);
      Eigen::Vector3d v;
      if (!(in >> v.x() >> v.y() >> v.z()))
        throw InputError(
            located(shown_name, option->GetLineNum(),
                    std::string("option gravity: expected 3 numbers, got '") + g + "'"));
      out.gravity = v;
    }
    if (const std::string problem = timestep_problem(out.timestep); !problem.empty())
      throw InputError(located(shown_name, option->GetLineNum(), "<option> timestep: " + problem));
  }
  if (const tinyxml2::XMLElement* worldbody = root->FirstChildElement("worldbody")) {
    collect_inertials(shown_name, worldbody, out.inertials);
    check_bodies_have_joints(shown_name, worldbody, false);
  }
  bool patched = false;
  if (tinyxml2::XMLElement* worldbody = doc.RootElement()->FirstChildElement("worldbody")) {
    patched = name_unnamed_joints(worldbody);
    patched = name_unnamed_geoms(worldbody) || patched;
  }
  patched = expand_freejoints(doc.RootElement()) || patched;
  patched = drop_sites(doc.RootElement()) || patched;
  patched = bound_infinite_planes(doc.RootElement()) || patched;
  patched = normalize_whitespace_for_dart(doc.RootElement()) || patched;
  check_vector_attributes(shown_name, doc.RootElement());
  if (!root->FirstChildElement("default")) {
    tinyxml2::XMLElement* fill = doc.NewElement("default");
    doc.RootElement()->InsertFirstChild(fill);
    patched = true;
  }
  if (patched) {
    tinyxml2::XMLPrinter printer;
    doc.Print(&printer);
    out.patched_text = printer.CStr();
  }
  return out;
}

// puts the file's <inertial> values on the parsed bodies
void apply_inertials(dart::simulation::World& world,
                     const std::map<std::string, MjcfInertial>& inertials) {
  for (size_t s = 0; s < world.getNumSkeletons(); ++s) {
    const SkeletonPtr& skel = world.getSkeleton(s);
    for (size_t b = 0; b < skel->getNumBodyNodes(); ++b) {
      BodyNode* bn = skel->getBodyNode(b);
      auto it = inertials.find(bn->getName());
      if (it == inertials.end()) continue;
      bn->setInertia(dart::dynamics::Inertia(it->second.mass, it->second.com, it->second.moment));
    }
  }
}

// joints' effort limits, by name, as their dofs' force limits
void apply_effort_limits(dart::dynamics::Skeleton& skeleton,
                         const std::vector<std::pair<std::string, double>>& limits) {
  for (const auto& [name, effort] : limits) {
    Joint* j = skeleton.getJoint(name);
    if (j == nullptr) continue;
    for (size_t k = 0; k < j->getNumDofs(); ++k) {
      j->setForceLowerLimit(k, -effort);
      j->setForceUpperLimit(k, effort);
    }
  }
}
void apply_effort_limits(dart::simulation::World& world,
                         const std::vector<std::pair<std::string, double>>& limits) {
  for (size_t s = 0; s < world.getNumSkeletons(); ++s)
    apply_effort_limits(*world.getSkeleton(s), limits);
}

// parses one model file into a temporary world of its own
dart::simulation::WorldPtr read_model_world(const BackendModel& model, std::string& warnings) {
  const std::string& shown_name = model.name;
  const std::string& file = model.file;
  const ModelFormat format = model.format;
  const std::string absolute = std::filesystem::absolute(file).string();
  const dart::common::Uri uri = dart::common::Uri::createFromPath(absolute);
  dart::simulation::WorldPtr world;
  std::string printed;
  {
    CerrCapture capture;
    try {
      if (format == ModelFormat::kSkel) {
        tinyxml2::XMLDocument doc;
        load_xml(shown_name, file, doc);
        const std::string patched = text_normalized_for_dart(doc);
        world = patched.empty()
                    ? dart::utils::SkelParser::readWorld(uri)
                    : dart::utils::SkelParser::readWorld(
                          uri, std::make_shared<PatchedFileRetriever>(uri.toString(), patched));
      } else if (format == ModelFormat::kMjcf) {
        const MjcfPreflight mjcf = preflight_mjcf(shown_name, file);
        dart::utils::MjcfParser::Options options;
        if (!mjcf.patched_text.empty())
          options.mRetriever =
              std::make_shared<PatchedFileRetriever>(uri.toString(), mjcf.patched_text);
        world = dart::utils::MjcfParser::readWorld(uri, options);
        if (world) {
          world->setTimeStep(mjcf.timestep);
          world->setGravity(mjcf.gravity);
          apply_inertials(*world, mjcf.inertials);
          apply_effort_limits(*world, model.effort_limits);
        }
      } else {
        // URDF and SDF: checked and patched by the factory (model/robot_model.h)
        dart::common::ResourceRetrieverPtr retriever;
        if (!model.text.empty()) {
          tinyxml2::XMLDocument doc;
          std::string text = model.text;
          if (doc.Parse(text.c_str(), text.size()) == tinyxml2::XML_SUCCESS) {
            const std::string patched = text_normalized_for_dart(doc);
            if (!patched.empty()) text = patched;
          }
          retriever = std::make_shared<PatchedFileRetriever>(uri.toString(), text);
        }
        SkeletonPtr skeleton;
        if (format == ModelFormat::kSdf) {
          dart::utils::SdfParser::Options options(
              retriever, model.fixed_base ? dart::utils::SdfParser::RootJointType::FIXED
                                          : dart::utils::SdfParser::RootJointType::FLOATING);
          skeleton = dart::utils::SdfParser::readSkeleton(uri, options);
        } else {
          dart::utils::DartLoader::Options options(
              retriever, model.fixed_base ? dart::utils::DartLoader::RootJointType::FIXED
                                          : dart::utils::DartLoader::RootJointType::FLOATING);
          dart::utils::DartLoader loader(options);
          skeleton = loader.parseSkeleton(uri);
        }
        if (skeleton) {
          // effort limits as joint force limits (DART's SdfParser does not read them)
          apply_effort_limits(*skeleton, model.effort_limits);
          // a robot welded whole to the world (a ground) cannot move: it is part of the world,
          // as MuJoCo's static bodies are
          if (skeleton->getNumDofs() == 0) skeleton->setMobile(false);
          world = dart::simulation::World::create();
          world->addSkeleton(skeleton);
        }
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      printed = e.what();
      world = nullptr;
    }
    printed = capture.text() + printed;
  }
  if (!world) {
    // DART prints warnings before the error that stopped it: the error lines say why
    std::string errors;
    std::istringstream lines(printed);
    for (std::string line; std::getline(lines, line);)
      if (line.find("rror") != std::string::npos) errors += line + "\n";
    std::string why = leading_message_lines(errors.empty() ? printed : errors);
    if (why.empty()) why = "DART could not parse the file";
    throw InputError(located(shown_name, 0, "cannot load model: " + why));
  }
  if (!printed.empty()) warnings += printed;
  return world;
}

class DartEngine final : public Engine {
 public:
  explicit DartEngine(const BackendWorld& spec) {
    load(spec);
    index_model();
    check_moving_masses(spec);
  }

  std::string_view engine_name() const override { return "dart"; }

  int nq() const override { return ndof_; }
  int nv() const override { return ndof_; }
  int nu() const override { return 0; }
  int nbody() const override { return static_cast<int>(bodies_.size()); }
  int njoint() const override { return static_cast<int>(joints_.size()); }
  double total_mass() const override { return total_mass_; }

  int body_index(std::string_view name) const override { return find(body_lookup_, name); }
  int joint_index(std::string_view name) const override { return find(joint_lookup_, name); }
  int dof_index(std::string_view name) const override { return find(dof_lookup_, name); }
  int actuator_index(std::string_view) const override { return -1; }
  const std::string& body_name(int body) const override { return body_names_.at(body); }
  const std::string& dof_name(int dof) const override { return dof_names_.at(dof); }
  const std::string& actuator_name(int actuator) const override {
    throw std::out_of_range("DART backend has no actuators (index " + std::to_string(actuator) +
                            ")");
  }
  const JointInfo& joint(int joint) const override { return joints_.at(joint); }
  int dof_joint(int dof) const override { return dof_joint_.at(dof); }
  double body_mass(int body) const override { return bodies_.at(body)->getMass(); }
  int body_parent(int body) const override {
    const BodyNode* parent = bodies_.at(body)->getParentBodyNode();
    if (!parent) return -1;
    auto it = body_of_node_.find(parent);
    return it == body_of_node_.end() ? -1 : it->second;
  }

  double time() const override { return world_->getTime(); }
  double timestep() const override { return world_->getTimeStep(); }
  void set_timestep(double dt) override {
    if (!(dt > 0) || !std::isfinite(dt))
      throw std::invalid_argument("timestep must be positive, got " + std::to_string(dt));
    world_->setTimeStep(dt);
  }
  Eigen::Vector3d gravity() const override { return world_->getGravity(); }
  void set_gravity(const Eigen::Vector3d& g) override { world_->setGravity(g); }

  void get_positions(Eigen::Ref<Eigen::VectorXd> q) const override {
    // per dof: getPositions() returns a fresh vector
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) q[b.dof_start + i] = b.skeleton->getPosition(i);
  }
  void get_velocities(Eigen::Ref<Eigen::VectorXd> v) const override {
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) v[b.dof_start + i] = b.skeleton->getVelocity(i);
  }
  void set_positions(const Eigen::Ref<const Eigen::VectorXd>& q) override {
    check_size(q.size(), ndof_, "set_positions");
    for (const SkeletonBlock& b : blocks_) b.skeleton->setPositions(q.segment(b.dof_start, b.ndof));
    positions_set_since_step_ = true;
    positions_usable_ = -1;
    broad_phase_rebuilt_ = false;
  }
  void set_velocities(const Eigen::Ref<const Eigen::VectorXd>& v) override {
    check_size(v.size(), ndof_, "set_velocities");
    for (const SkeletonBlock& b : blocks_)
      b.skeleton->setVelocities(v.segment(b.dof_start, b.ndof));
  }
  double dof_position(int dof) const override {
    const SkeletonBlock& b = block_of(dof);
    return b.skeleton->getPosition(dof - b.dof_start);
  }
  double dof_velocity(int dof) const override {
    const SkeletonBlock& b = block_of(dof);
    return b.skeleton->getVelocity(dof - b.dof_start);
  }
  void set_dof_position(int dof, double value) override {
    // rotation dofs of free/ball joints are exponential coordinates already: set directly
    const SkeletonBlock& b = block_of(dof);
    b.skeleton->setPosition(dof - b.dof_start, value);
    positions_set_since_step_ = true;
    positions_usable_ = -1;
    broad_phase_rebuilt_ = false;
  }

  void difference_positions(const Eigen::Ref<const Eigen::VectorXd>& q0,
                            const Eigen::Ref<const Eigen::VectorXd>& q1,
                            Eigen::Ref<Eigen::VectorXd> v) const override {
    check_size(q0.size(), ndof_, "difference_positions q0");
    check_size(q1.size(), ndof_, "difference_positions q1");
    check_size(v.size(), ndof_, "difference_positions v");
    for (const PositionGroup& g : position_groups_) {
      switch (g.kind) {
        case PositionGroupKind::kVector:
          v.segment(g.start, g.size) = q1.segment(g.start, g.size) - q0.segment(g.start, g.size);
          break;
        case PositionGroupKind::kFree: {
          // same as FreeJoint::getPositionDifferencesStatic: log of T0^-1 T1, piecewise
          const Eigen::Isometry3d t0 = FreeJoint::convertToTransform(q0.segment<6>(g.start));
          const Eigen::Isometry3d t1 = FreeJoint::convertToTransform(q1.segment<6>(g.start));
          v.segment<6>(g.start) = FreeJoint::convertToPositions(t0.inverse() * t1);
          break;
        }
        case PositionGroupKind::kBall: {
          const Eigen::Matrix3d r0 = BallJoint::convertToRotation(q0.segment<3>(g.start));
          const Eigen::Matrix3d r1 = BallJoint::convertToRotation(q1.segment<3>(g.start));
          v.segment<3>(g.start) =
              BallJoint::convertToPositions(Eigen::Matrix3d(r0.transpose() * r1));
          break;
        }
      }
    }
  }

  void integrate_positions(const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                           Eigen::Ref<Eigen::VectorXd> q_out) const override {
    check_size(q.size(), ndof_, "integrate_positions q");
    check_size(v.size(), ndof_, "integrate_positions v");
    check_size(q_out.size(), ndof_, "integrate_positions q_out");
    for (const PositionGroup& g : position_groups_) {
      switch (g.kind) {
        case PositionGroupKind::kVector:
          q_out.segment(g.start, g.size) =
              q.segment(g.start, g.size) + dt * v.segment(g.start, g.size);
          break;
        case PositionGroupKind::kFree: {
          // FreeJoint::integratePositions: Q_next = Q * T(v dt), i.e. a body-frame step
          const Eigen::Vector6d step = v.segment<6>(g.start) * dt;
          const Eigen::Isometry3d t = FreeJoint::convertToTransform(q.segment<6>(g.start)) *
                                      FreeJoint::convertToTransform(step);
          q_out.segment<6>(g.start) = FreeJoint::convertToPositions(t);
          break;
        }
        case PositionGroupKind::kBall: {
          // BallJoint::integratePositions: R_next = R * exp(w dt)
          const Eigen::Vector3d step = v.segment<3>(g.start) * dt;
          const Eigen::Matrix3d r = BallJoint::convertToRotation(q.segment<3>(g.start)) *
                                    BallJoint::convertToRotation(step);
          q_out.segment<3>(g.start) = BallJoint::convertToPositions(r);
          break;
        }
      }
    }
  }

  void forward() override {
    // a diverged state would trip DART's transform asserts (abort) instead of being reported
    if (!positions_usable()) return;
    // DART computes lazily; refresh kinematics now so later const reads are cheap
    for (const SkeletonBlock& b : blocks_) b.skeleton->computeForwardKinematics(true, true, false);
    // contact geometry for a state set by hand; after a step the step's own contacts stand
    if (positions_set_since_step_) {
      dart::constraint::ConstraintSolver* solver = world_->getConstraintSolver();
      forward_contacts_.clear();
      // the query, and the next step, each on a broad phase built from the state alone
      rebuild_broad_phase();
      solver->getCollisionGroup()->collide(solver->getCollisionOption(), &forward_contacts_);
      broad_phase_rebuilt_ = false;
      rebuild_broad_phase();
      use_forward_contacts_ = true;
      positions_set_since_step_ = false;
    }
  }

  void mass_matrix(Eigen::Ref<Eigen::MatrixXd> m) const override {
    m.setZero();
    for (const SkeletonBlock& b : blocks_)
      m.block(b.dof_start, b.dof_start, b.ndof, b.ndof) = b.skeleton->getMassMatrix();
  }
  void solve_mass(Eigen::Ref<Eigen::VectorXd> x) const override {
    // DART's inverse comes from its articulated-body recursion, not a dense inversion
    for (const SkeletonBlock& b : blocks_) {
      auto seg = x.segment(b.dof_start, b.ndof);
      auto out = solve_scratch_.head(b.ndof);
      out.noalias() = b.skeleton->getInvMassMatrix() * seg;
      seg = out;
    }
  }
  void solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                          Eigen::Ref<Eigen::VectorXd> x) const override {
    // DART's articulated-body forward dynamics solves (M + h D + h^2 K) a = tau - C - D v -
    // K (q + h v - q0) + F_ext for its implicit joint damping D and springs K, in O(n) and
    // without building M (about 240 us on fullbody1). With D = d / h, K = 0 and
    // tau = x + C + D v - F_ext (C and F_ext are cached by DART) it gives (M + diag d)^-1 x in
    // one pass. The joints' own damping, springs and forces are put back afterwards and the
    // articulated inertias marked stale for the real step.
    const double h = timestep();
    for (const SkeletonBlock& b : blocks_) {
      auto& skel = *b.skeleton;
      if (!force_driven(skel) || !(h > 0) || (d.array() < 0).any()) {
        Engine::solve_mass_shifted(d, x);  // velocity servos: ABA would prescribe them
        return;
      }
    }
    for (const SkeletonBlock& b : blocks_) {
      auto& skel = *b.skeleton;
      // per dof, so that nothing here allocates
      for (int i = 0; i < b.ndof; ++i) {
        dart::dynamics::DegreeOfFreedom* dof = skel.getDof(i);
        shift_forces_[b.dof_start + i] = dof->getForce();
        shift_damping_[b.dof_start + i] = dof->getDampingCoefficient();
        shift_springs_[b.dof_start + i] = dof->getSpringStiffness();
        dof->setDampingCoefficient(d[b.dof_start + i] / h);
        dof->setSpringStiffness(0.0);
      }
      const Eigen::VectorXd& bias = skel.getCoriolisAndGravityForces();
      // DART aggregates the external forces body by body (14 k instructions on fullbody1): only
      // when a force was applied since the last step; otherwise they are zero
      const Eigen::VectorXd* external =
          external_forces_since_step_ ? &skel.getExternalForces() : nullptr;
      for (int i = 0; i < b.ndof; ++i) {
        dart::dynamics::DegreeOfFreedom* dof = skel.getDof(i);
        dof->setForce(x[b.dof_start + i] + bias[i] - (external ? (*external)[i] : 0.0) +
                      d[b.dof_start + i] / h * dof->getVelocity());
      }
      mark_articulated_inertia_stale(skel);
      skel.computeForwardDynamics();
      for (int i = 0; i < b.ndof; ++i) {
        dart::dynamics::DegreeOfFreedom* dof = skel.getDof(i);
        x[b.dof_start + i] = dof->getAcceleration();
        dof->setDampingCoefficient(shift_damping_[b.dof_start + i]);
        dof->setSpringStiffness(shift_springs_[b.dof_start + i]);
        dof->setForce(shift_forces_[b.dof_start + i]);
      }
      mark_articulated_inertia_stale(skel);
    }
  }
  // every joint takes forces (no velocity or acceleration servo, which ABA would prescribe)
  static bool force_driven(const dart::dynamics::Skeleton& skel) {
    for (std::size_t j = 0; j < skel.getNumJoints(); ++j) {
      const auto type = skel.getJoint(j)->getActuatorType();
      if (type != dart::dynamics::Joint::FORCE && type != dart::dynamics::Joint::PASSIVE)
        return false;
    }
    return true;
  }
  // DART caches articulated inertias (which hold h D) until positions change
  static void mark_articulated_inertia_stale(dart::dynamics::Skeleton& skel) {
    for (std::size_t t = 0; t < skel.getNumTrees(); ++t) skel.dirtyArticulatedInertia(t);
  }

  void bias_forces(Eigen::Ref<Eigen::VectorXd> c) const override {
    for (const SkeletonBlock& b : blocks_)
      c.segment(b.dof_start, b.ndof) = b.skeleton->getCoriolisAndGravityForces();
  }
  void constraint_forces(Eigen::Ref<Eigen::VectorXd> f) const override {
    if (constraint_restored_) {
      f = restored_constraint_;
      return;
    }
    for (const SkeletonBlock& b : blocks_)
      f.segment(b.dof_start, b.ndof) = b.skeleton->getConstraintForces();
  }

  void inverse_dynamics(const Eigen::Ref<const Eigen::VectorXd>& vdot,
                        Eigen::Ref<Eigen::VectorXd> tau) const override {
    check_size(vdot.size(), ndof_, "inverse_dynamics vdot");
    check_size(tau.size(), ndof_, "inverse_dynamics tau");
    // M vdot + C, plus what the joints' damping and springs take away (DART treats them
    // implicitly in a step; here they are the continuous-time forces). Per dof: no allocation.
    for (const SkeletonBlock& b : blocks_) {
      auto out = tau.segment(b.dof_start, b.ndof);
      out.noalias() = b.skeleton->getMassMatrix() * vdot.segment(b.dof_start, b.ndof);
      out += b.skeleton->getCoriolisAndGravityForces();
      for (int i = 0; i < b.ndof; ++i) {
        const dart::dynamics::DegreeOfFreedom* dof = b.skeleton->getDof(i);
        out[i] += dof->getDampingCoefficient() * dof->getVelocity() +
                  dof->getSpringStiffness() * (dof->getPosition() - dof->getRestPosition());
      }
    }
  }

  Eigen::Vector3d com() const override {
    if (!positions_usable()) return Eigen::Vector3d::Constant(kNaN);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const SkeletonBlock& b : blocks_) sum += b.skeleton->getMass() * b.skeleton->getCOM();
    return total_mass_ > 0 ? Eigen::Vector3d(sum / total_mass_) : sum;
  }
  Eigen::Vector3d com_velocity() const override {
    if (!positions_usable()) return Eigen::Vector3d::Constant(kNaN);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const SkeletonBlock& b : blocks_)
      sum += b.skeleton->getMass() * b.skeleton->getCOMLinearVelocity();
    return total_mass_ > 0 ? Eigen::Vector3d(sum / total_mass_) : sum;
  }
  BodyPose body_pose(int body) const override {
    if (!positions_usable()) {
      BodyPose nan;
      nan.pos.setConstant(kNaN);
      nan.quat.coeffs().setConstant(kNaN);
      return nan;
    }
    const Eigen::Isometry3d& t = bodies_.at(body)->getWorldTransform();
    BodyPose pose;
    pose.pos = t.translation();
    pose.quat = Eigen::Quaterniond(t.linear());
    return pose;
  }
  Eigen::Vector3d body_com(int body) const override {
    if (!positions_usable()) return Eigen::Vector3d::Constant(kNaN);
    return bodies_.at(body)->getCOM();
  }
  Eigen::Matrix<double, 6, 1> body_velocity(int body) const override {
    const BodyNode* bn = bodies_.at(body);
    Eigen::Matrix<double, 6, 1> out;
    if (!positions_usable()) return out.setConstant(kNaN);
    out.head<3>() = bn->getAngularVelocity();
    out.tail<3>() = bn->getLinearVelocity();  // of the frame origin
    return out;
  }
  void point_jacobian(int body, const Eigen::Vector3d& point_world,
                      Eigen::Ref<Eigen::MatrixXd> jac_pos,
                      Eigen::Ref<Eigen::MatrixXd> jac_rot) const override {
    const BodyNode* bn = bodies_.at(body);
    const SkeletonBlock& b = blocks_[body_block_[body]];
    if (jac_pos.cols() > 0) jac_pos.setZero();
    if (jac_rot.cols() > 0) jac_rot.setZero();
    // Skeleton::getWorldJacobian(body, offset) without its two by-value copies: the body's
    // cached world Jacobian (rows angular; linear) over the dofs it depends on, the linear
    // rows moved to the point by omega x (R offset), as DART does
    const Eigen::Isometry3d& t = bn->getWorldTransform();
    const Eigen::Vector3d offset = t.inverse() * point_world;
    const Eigen::Vector3d r = t.linear() * offset;
    const dart::math::Jacobian& j = bn->getWorldJacobian();
    const std::vector<std::size_t>& deps = bn->getDependentGenCoordIndices();
    for (std::size_t k = 0; k < deps.size(); ++k) {
      const Eigen::Index col = b.dof_start + static_cast<Eigen::Index>(deps[k]);
      const Eigen::Vector3d w = j.col(k).head<3>();
      if (jac_rot.cols() > 0) jac_rot.col(col) = w;
      if (jac_pos.cols() > 0) jac_pos.col(col) = j.col(k).tail<3>() + w.cross(r);
    }
  }
  void com_jacobian(Eigen::Ref<Eigen::MatrixXd> jac) const override {
    jac.setZero();
    if (total_mass_ <= 0) return;
    for (const SkeletonBlock& b : blocks_) {
      jac.middleCols(b.dof_start, b.ndof) =
          (b.skeleton->getMass() / total_mass_) * b.skeleton->getCOMLinearJacobian();
    }
  }

  void subtree_com_jacobian(int body, Eigen::Ref<Eigen::MatrixXd> jac) const override {
    check_size(jac.cols(), ndof_, "subtree_com_jacobian columns");
    jac.setZero();
    const SkeletonBlock& b = blocks_[body_block_.at(body)];
    const double mass = subtree_mass(body);
    if (mass <= 0) return;
    // every body whose chain of parents reaches `body`, weighted by its mass
    for (int other = 0; other < nbody(); ++other) {
      if (!in_subtree(other, body)) continue;
      const BodyNode* bn = bodies_[other];
      jac.middleCols(b.dof_start, b.ndof) +=
          (bn->getMass() / mass) * b.skeleton->getLinearJacobian(bn, bn->getLocalCOM());
    }
  }
  Eigen::Vector3d subtree_com(int body) const override {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int other = 0; other < nbody(); ++other)
      if (in_subtree(other, body)) sum += bodies_[other]->getMass() * bodies_[other]->getCOM();
    const double mass = subtree_mass(body);
    return mass > 0 ? Eigen::Vector3d(sum / mass) : bodies_.at(body)->getCOM();
  }

  int num_contacts() const override { return static_cast<int>(contacts().getNumContacts()); }
  Contact contact(int i) const override {
    const dart::collision::Contact& c = contacts().getContact(i);
    // DART: normal points from its body 2 to its body 1 and force acts on its body 1.
    // Ours: normal from body1 to body2, force on body2. So DART's body 2 is our body1.
    Contact out;
    out.body1 = body_of(c.collisionObject2);
    out.body2 = body_of(c.collisionObject1);
    out.pos = c.point;
    out.normal = c.normal;
    out.force = use_forward_contacts_ ? Eigen::Vector3d::Zero() : c.force;
    return out;
  }

  void set_generalized_forces(const Eigen::Ref<const Eigen::VectorXd>& tau) override {
    check_size(tau.size(), ndof_, "set_generalized_forces");
    // per dof: setForces takes a VectorXd, so a segment would be copied into a fresh one
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) b.skeleton->setForce(i, tau[b.dof_start + i]);
  }
  void set_controls(const Eigen::Ref<const Eigen::VectorXd>& ctrl) override {
    check_size(ctrl.size(), 0, "set_controls (DART models have no actuators)");
  }
  void get_controls(Eigen::Ref<Eigen::VectorXd> ctrl) const override {
    check_size(ctrl.size(), 0, "get_controls (DART models have no actuators)");
  }
  void actuator_moment(Eigen::Ref<Eigen::MatrixXd>) const override {
    throw InputError("actuator moments: the dart engine has no actuators (nu = 0)");
  }
  void apply_external_force(int body, const Eigen::Vector3d& force_world,
                            const Eigen::Vector3d& point_world) override {
    // force and point both in world coordinates; DART clears it after the step
    bodies_.at(body)->addExtForce(force_world, point_world, false, false);
    external_forces_since_step_ = true;
  }
  void set_dof_velocity_command(int dof, double velocity) override {
    Joint* j = block_of(dof).skeleton->getDof(dof - block_of(dof).dof_start)->getJoint();
    // a multi-dof joint can never have been commanded, so releasing it (NaN) has nothing to do
    if (j->getNumDofs() != 1 && std::isnan(velocity)) return;
    if (j->getNumDofs() != 1)
      throw std::invalid_argument("velocity command on dof '" + dof_names_[dof] +
                                  "': DART actuates whole joints; only 1-dof joints supported");
    velocity_command_[dof] = velocity;
    if (std::isnan(velocity)) {
      j->setActuatorType(Joint::FORCE);
      j->setCommand(0, 0.0);
    } else {
      j->setActuatorType(Joint::VELOCITY);
      j->setCommand(0, velocity);
    }
  }

  // extra: the last step's constraint forces (dim nv; read by controllers before the next
  // step) and the velocity servos' commands (dim nv; NaN: none)
  void save_state(EngineState& s) const override {
    s.time = world_->getTime();
    s.q.resize(ndof_);
    s.v.resize(ndof_);
    get_positions(s.q);
    get_velocities(s.v);
    s.act.resize(0);
    s.ctrl.resize(0);
    s.extra.resize(2 * static_cast<size_t>(ndof_));
    Eigen::Map<Eigen::VectorXd> constraint(s.extra.data(), ndof_);
    constraint_forces(constraint);
    std::copy(velocity_command_.begin(), velocity_command_.end(), s.extra.begin() + ndof_);
    // what follows a saved state then depends on it alone, as after its restore
    rebuild_broad_phase();
  }
  // bit-exact: a run from a restored state repeats the run that followed its save, whatever
  // this engine (or another one built from the same files) ran in between
  void restore_state(const EngineState& s) override {
    world_->setTime(s.time);
    set_positions(s.q);
    set_velocities(s.v);
    // the per-step inputs of a run that was left before its step
    for (const SkeletonBlock& b : blocks_) {
      b.skeleton->clearInternalForces();
      b.skeleton->clearExternalForces();
    }
    external_forces_since_step_ = false;
    const bool warm = s.extra.size() == 2 * static_cast<size_t>(ndof_);
    if (warm)
      restored_constraint_ = Eigen::Map<const Eigen::VectorXd>(s.extra.data(), ndof_);
    else
      restored_constraint_.setZero(ndof_);  // a cold start (an older state file)
    constraint_restored_ = true;
    for (int dof = 0; dof < ndof_; ++dof) {
      const double command = warm ? s.extra[ndof_ + dof] : kNaN;
      const double now = velocity_command_[dof];
      if (command != now && !(std::isnan(command) && std::isnan(now)))
        set_dof_velocity_command(dof, command);
    }
    // contacts come from forward() now
    forward_contacts_.clear();
    use_forward_contacts_ = true;
    rebuild_broad_phase();
  }

  void step() override {
    // World::step resets joint commands afterwards; velocity servos persist, so re-arm them
    for (int dof = 0; dof < ndof_; ++dof) {
      if (std::isnan(velocity_command_[dof])) continue;
      const SkeletonBlock& b = block_of(dof);
      b.skeleton->getDof(dof - b.dof_start)->setCommand(velocity_command_[dof]);
    }
    // stepping a diverged state aborts in DART's FreeJoint assert; the runner reports it instead
    step_start_time_ = world_->getTime();
    if (!state_is_finite()) return;
    world_->step();
    broad_phase_rebuilt_ = false;
    constraint_restored_ = false;
    use_forward_contacts_ = false;
    positions_set_since_step_ = false;
    positions_usable_ = -1;
    external_forces_since_step_ = false;
  }

  // a speed no simulation reaches: beyond it the state is blowing up (an Euler joint near its
  // singularity), and DART's next step would overflow to NaN inside its forward dynamics and
  // abort in GenericJoint's assert instead of returning a NaN state (as MuJoCo's QACC check does)
  static constexpr double kBlownUpSpeed = 1e6;  // rad/s or m/s

  bool state_is_finite() const override {
    if (!positions_usable()) return false;
    // dof by dof: getVelocities() returns a fresh vector
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i)
        if (!(std::abs(b.skeleton->getVelocity(i)) <= kBlownUpSpeed)) return false;
    return true;
  }
  // after a divergence its cause (the load's warnings are not one), else the load's warnings
  std::string last_warning() const override {
    if (state_is_finite()) return load_warnings_;
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) {
        const double q = b.skeleton->getPosition(i), v = b.skeleton->getVelocity(i);
        if (std::isfinite(q) && std::abs(v) <= kBlownUpSpeed) continue;
        const bool bad_v = !(std::abs(v) <= kBlownUpSpeed);
        const char* what = !bad_v             ? "non-finite position "
                           : std::isfinite(v) ? "blown-up velocity "
                                              : "non-finite velocity ";
        return std::string("DART instability at t=") + number_text(step_start_time_) +
               " s: " + what + number_text(bad_v ? v : q, "%g") + " on dof '" +
               dof_name(b.dof_start + i) + "'";
      }
    // all finite, but the squared positions overflow: name the largest
    int worst = 0;
    double value = 0;
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i)
        if (std::abs(b.skeleton->getPosition(i)) > std::abs(value)) {
          value = b.skeleton->getPosition(i);
          worst = b.dof_start + i;
        }
    return "DART instability at t=" + number_text(step_start_time_) + " s: position too large " +
           number_text(value, "%g") + " on dof '" + dof_name(worst) + "'";
  }

 private:
  using Lookup = std::map<std::string, int, std::less<>>;

  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  // true when DART can build transforms from the positions: finite, and a rotation vector's
  // norm that does not overflow (exp of an infinite angle gives NaN, which DART asserts on)
  bool positions_usable() const {
    // once per change of the positions: every pose and COM query asks, and reading each dof
    // from its joint object misses the cache after a step (about 4 us a pass on fullbody1)
    if (positions_usable_ >= 0) return positions_usable_ == 1;
    // dof by dof: getPositions() would allocate in the controllers' hot loop
    double sum = 0;
    for (const SkeletonBlock& b : blocks_) {
      for (int i = 0; i < b.ndof; ++i) {
        const double q = b.skeleton->getPosition(i);
        sum += q * q;
      }
    }
    positions_usable_ = std::isfinite(sum) ? 1 : 0;
    return positions_usable_ == 1;
  }

  // true when `body` is `root` or hangs below it
  bool in_subtree(int body, int root) const {
    for (int b = body; b >= 0; b = body_parent(b))
      if (b == root) return true;
    return false;
  }
  double subtree_mass(int root) const {
    double mass = 0;
    for (int b = 0; b < nbody(); ++b)
      if (in_subtree(b, root)) mass += bodies_[b]->getMass();
    return mass;
  }

  static int find(const Lookup& lookup, std::string_view name) {
    auto it = lookup.find(name);
    return it == lookup.end() ? -1 : it->second;
  }
  static void check_size(Eigen::Index got, int want, const char* what) {
    if (got != want)
      throw std::invalid_argument(std::string(what) + ": expected size " + std::to_string(want) +
                                  ", got " + std::to_string(got));
  }
  const SkeletonBlock& block_of(int dof) const { return blocks_[dof_block_.at(dof)]; }
  const dart::collision::CollisionResult& contacts() const {
    return use_forward_contacts_ ? forward_contacts_ : world_->getLastCollisionResult();
  }

  int body_of(const dart::collision::CollisionObject* object) const {
    const dart::dynamics::ShapeFrame* frame = object->getShapeFrame();
    const dart::dynamics::ShapeNode* node = frame ? frame->asShapeNode() : nullptr;
    if (!node) return -1;
    auto it = body_of_node_.find(node->getBodyNodePtr().get());
    return it == body_of_node_.end() ? -1 : it->second;
  }

  // builds world_ from the spec's files
  void load(const BackendWorld& spec) {
    if (spec.models.empty()) throw InputError("world spec: no model files given");
    for (const BackendModel& model : spec.models) {
      if (model.file.empty())
        throw InputError(model.name + ": the DART backend reads model files, not text");
      dart::simulation::WorldPtr parsed = read_model_world(model, load_warnings_);
      std::vector<SkeletonPtr> skeletons;
      for (size_t i = 0; i < parsed->getNumSkeletons(); ++i)
        skeletons.push_back(parsed->getSkeleton(i));
      // offset: translate each root joint's parent frame, so q keeps its meaning
      if (!model.offset.isZero()) {
        for (const SkeletonPtr& skel : skeletons) {
          for (size_t t = 0; t < skel->getNumTrees(); ++t) {
            Joint* root = skel->getRootJoint(t);
            Eigen::Isometry3d shifted =
                Eigen::Translation3d(model.offset) * root->getTransformFromParentBodyNode();
            root->setTransformFromParentBodyNode(shifted);
          }
        }
      }
      if (!world_ && model.format != ModelFormat::kUrdf && model.format != ModelFormat::kSdf) {
        // the first world file supplies gravity, timestep and collision detector
        world_ = parsed;
        continue;
      }
      if (!world_) world_ = dart::simulation::World::create();
      for (const SkeletonPtr& skel : skeletons) {
        parsed->removeSkeleton(skel);
        // rename clashes ourselves, as DART would, but without its console message
        const std::string base = skel->getName();
        for (int k = 1; world_->getSkeleton(skel->getName()); ++k)
          skel->setName(base + "(" + std::to_string(k) + ")");
        world_->addSkeleton(skel);
      }
    }
    if (spec.timestep) set_timestep(*spec.timestep);
    if (spec.gravity) world_->setGravity(*spec.gravity);
    if (only_primitive_collision_shapes()) {
      world_->getConstraintSolver()->setCollisionDetector(
          dart::collision::DARTCollisionDetector::create());
    }
  }

  // FCL's and Bullet's broad phases keep a tree that each collision check refits from the last
  // one, and they report contact pairs in its order: two runs from one state differed in the
  // last bits when their histories did (a planner's result then depended on its thread count).
  // Each check also rebalances the tree a little, so it is rebuilt from the current poses after
  // a save, a restore and forward()'s check: a step's contacts are then a function of the
  // state alone. The collision objects (and the shapes' geometry) are kept: a second group holds
  // them meanwhile, and its check moves their bounding boxes to the current poses first.
  void rebuild_broad_phase() const {
    if (broad_phase_rebuilt_) return;
    broad_phase_rebuilt_ = true;
    dart::constraint::ConstraintSolver* solver = world_->getConstraintSolver();
    const auto detector = solver->getCollisionDetector();
    if (detector->getType() == dart::collision::DARTCollisionDetector::getStaticType()) return;
    const dart::collision::CollisionGroupPtr group = solver->getCollisionGroup();
    const auto holder = detector->createCollisionGroupAsSharedPtr();
    for (size_t i = 0; i < world_->getNumSkeletons(); ++i)
      holder->addShapeFramesOf(world_->getSkeleton(i).get());
    holder->collide(dart::collision::CollisionOption(false, 1));
    group->removeAllShapeFrames();
    for (size_t i = 0; i < world_->getNumSkeletons(); ++i)
      group->addShapeFramesOf(world_->getSkeleton(i).get());
  }

  // every mobile skeleton must move mass along each dof, or DART aborts in its first step
  // (mTotalMass != 0, !isNan(PI)). The readers check URDF, SDF and SKEL files and MuJoCo's
  // compiler an MJCF file, but DART 6.12's MJCF reader takes a body's mass from its first geom
  // only: a massless visual geom first left the body with none. A Cholesky factorisation of
  // the mass matrix at the initial state finds the first dof (parents come first) without.
  void check_moving_masses(const BackendWorld& spec) const {
    for (const SkeletonBlock& b : blocks_) {
      if (b.ndof == 0) continue;
      const Eigen::MatrixXd m = b.skeleton->getMassMatrix();
      const int dof = first_massless_dof(m);
      if (b.skeleton->getMass() > 0 && dof < 0) continue;
      const Joint* joint = b.skeleton->getDof(std::max(dof, 0))->getJoint();
      const std::string body = joint->getChildBodyNode()->getName();
      const auto [file, line] = body_line(spec, body);
      throw InputError(located(
          file, line,
          fmt::format("body '{}': joint '{}' moves no mass on DART{}: give the body an "
                      "<inertial> (or a first geom with mass)",
                      body, joint->getName(),
                      spec.models.size() == 1 && spec.models[0].format == ModelFormat::kMjcf
                          ? " (DART 6.12's MJCF reader takes a body's mass from its first geom)"
                          : "")));
    }
  }

  // the first dof whose pivot in M = L L^T vanishes, or -1 when M is positive definite
  static int first_massless_dof(Eigen::MatrixXd m) {
    const Eigen::Index n = m.rows();
    for (Eigen::Index j = 0; j < n; ++j) {
      const double diagonal = m(j, j);
      const double pivot = diagonal - m.row(j).head(j).squaredNorm();
      if (!(pivot > 1e-15 && pivot > 1e-10 * diagonal)) return static_cast<int>(j);
      m(j, j) = std::sqrt(pivot);
      for (Eigen::Index i = j + 1; i < n; ++i)
        m(i, j) = (m(i, j) - m.row(i).head(j).dot(m.row(j).head(j))) / m(j, j);
      for (Eigen::Index i = j + 1; i < n; ++i) m(j, i) = 0;
    }
    return -1;
  }

  // the file and line of an MJCF <body> of that name (line 0 when not found)
  static std::pair<std::string, int> body_line(const BackendWorld& spec, const std::string& body) {
    for (const BackendModel& model : spec.models) {
      if (model.format != ModelFormat::kMjcf) continue;
      tinyxml2::XMLDocument doc;
      if (doc.LoadFile(model.file.c_str()) != tinyxml2::XML_SUCCESS) continue;
      std::function<int(const tinyxml2::XMLElement*)> find = [&](const tinyxml2::XMLElement* e) {
        for (const tinyxml2::XMLElement* c = e->FirstChildElement(); c;
             c = c->NextSiblingElement()) {
          const char* name = c->Attribute("name");
          if (std::strcmp(c->Name(), "body") == 0 && name != nullptr && body == name)
            return c->GetLineNum();
          if (const int line = find(c)) return line;
        }
        return 0;
      };
      if (doc.RootElement() != nullptr)
        if (const int line = find(doc.RootElement())) return {model.name, line};
    }
    return {spec.models.front().name, 0};
  }

  // true when DART's own (deterministic) detector handles every collision shape
  bool only_primitive_collision_shapes() const {
    using dart::dynamics::CollisionAspect;
    for (size_t s = 0; s < world_->getNumSkeletons(); ++s) {
      const SkeletonPtr& skel = world_->getSkeleton(s);
      for (size_t b = 0; b < skel->getNumBodyNodes(); ++b) {
        for (const dart::dynamics::ShapeNode* node :
             skel->getBodyNode(b)->getShapeNodesWith<CollisionAspect>()) {
          const std::string& type = node->getShape()->getType();
          if (type == dart::dynamics::BoxShape::getStaticType()) continue;
          if (type == dart::dynamics::SphereShape::getStaticType()) continue;
          const auto* ellipsoid =
              dynamic_cast<const dart::dynamics::EllipsoidShape*>(node->getShape().get());
          if (ellipsoid && ellipsoid->isSphere()) continue;
          return false;
        }
      }
    }
    return true;
  }

  // names, index maps and position groups over the mobile skeletons, in world order
  void index_model() {
    Lookup skeleton_of_dof_name, skeleton_of_body_name, skeleton_of_joint_name;
    for (size_t s = 0; s < world_->getNumSkeletons(); ++s) {
      SkeletonPtr skel = world_->getSkeleton(s);
      if (!skel->isMobile()) continue;
      SkeletonBlock block{skel, ndof_, static_cast<int>(skel->getNumDofs())};
      const int block_index = static_cast<int>(blocks_.size());
      blocks_.push_back(block);
      total_mass_ += skel->getMass();
      const std::string prefix = skel->getName() + "/";
      auto unique = [&](Lookup& seen, const std::string& name) {
        std::string out = seen.count(name) ? prefix + name : name;
        seen.emplace(name, block_index);
        return out;
      };

      // bodies
      for (size_t i = 0; i < skel->getNumBodyNodes(); ++i) {
        BodyNode* bn = skel->getBodyNode(i);
        const int index = static_cast<int>(bodies_.size());
        bodies_.push_back(bn);
        body_block_.push_back(block_index);
        body_names_.push_back(unique(skeleton_of_body_name, bn->getName()));
        body_lookup_.emplace(body_names_.back(), index);
        body_of_node_.emplace(bn, index);
      }
      // dofs
      for (size_t i = 0; i < skel->getNumDofs(); ++i) {
        dof_names_.push_back(unique(skeleton_of_dof_name, skel->getDof(i)->getName()));
        dof_lookup_.emplace(dof_names_.back(), static_cast<int>(dof_names_.size()) - 1);
        dof_block_.push_back(block_index);
        dof_joint_.push_back(-1);
      }
      // joints
      for (size_t i = 0; i < skel->getNumJoints(); ++i) {
        Joint* j = skel->getJoint(i);
        const int n = static_cast<int>(j->getNumDofs());
        if (n == 0) continue;  // weld
        const int first = block.dof_start + static_cast<int>(j->getIndexInSkeleton(0));
        const int child = body_of_node_.at(j->getChildBodyNode());
        PositionGroup group{PositionGroupKind::kVector, first, n};
        if (dynamic_cast<FreeJoint*>(j)) {
          group.kind = PositionGroupKind::kFree;
          add_joint(unique(skeleton_of_joint_name, j->getName()), JointType::kFree, child, first, n,
                    nullptr);
        } else if (dynamic_cast<BallJoint*>(j)) {
          group.kind = PositionGroupKind::kBall;
          add_joint(unique(skeleton_of_joint_name, j->getName()), JointType::kBall, child, first, n,
                    nullptr);
        } else if (n == 1) {
          add_joint(unique(skeleton_of_joint_name, j->getName()), dof_type(j, 0), child, first, 1,
                    j->getDof(0));
        } else {
          // multi-dof joints other than free/ball: one hinge/slide entry per dof
          for (int k = 0; k < n; ++k) {
            add_joint(unique(skeleton_of_joint_name, j->getDof(k)->getName()), dof_type(j, k),
                      child, first + k, 1, j->getDof(k));
          }
        }
        position_groups_.push_back(group);
      }
      ndof_ += block.ndof;
    }
    velocity_command_.assign(ndof_, std::nan(""));
    solve_scratch_.setZero(ndof_);
    shift_forces_.setZero(ndof_);
    shift_damping_.setZero(ndof_);
    shift_springs_.setZero(ndof_);
  }

  // translational dofs of prismatic/translational/planar joints are slides
  static JointType dof_type(const Joint* j, int k) {
    const std::string& type = j->getType();
    if (type == dart::dynamics::PrismaticJoint::getStaticType()) return JointType::kSlide;
    if (type == dart::dynamics::TranslationalJoint::getStaticType()) return JointType::kSlide;
    if (type == dart::dynamics::TranslationalJoint2D::getStaticType()) return JointType::kSlide;
    if (type == dart::dynamics::PlanarJoint::getStaticType() && k < 2) return JointType::kSlide;
    return JointType::kHinge;
  }

  void add_joint(const std::string& name, JointType type, int body, int first, int n,
                 const dart::dynamics::DegreeOfFreedom* limits_from) {
    JointInfo info;
    info.name = name;
    info.type = type;
    info.body = body;
    info.qpos_adr = first;
    info.dof_adr = first;
    info.nq = n;
    info.nv = n;
    if (limits_from) {
      info.lower = limits_from->getPositionLowerLimit();
      info.upper = limits_from->getPositionUpperLimit();
      info.has_limits = std::isfinite(info.lower) || std::isfinite(info.upper);
      if (!info.has_limits) info.lower = info.upper = 0;
      info.force_limit = std::max(std::abs(limits_from->getForceLowerLimit()),
                                  std::abs(limits_from->getForceUpperLimit()));
    }
    const int index = static_cast<int>(joints_.size());
    joints_.push_back(info);
    joint_lookup_.emplace(name, index);
    for (int d = first; d < first + n; ++d) dof_joint_[d] = index;
  }

  dart::simulation::WorldPtr world_;
  std::vector<SkeletonBlock> blocks_;
  std::vector<PositionGroup> position_groups_;
  int ndof_ = 0;
  double total_mass_ = 0;

  std::vector<BodyNode*> bodies_;
  std::vector<int> body_block_;
  std::vector<std::string> body_names_;
  std::unordered_map<const BodyNode*, int> body_of_node_;
  Lookup body_lookup_;

  std::vector<std::string> dof_names_;
  std::vector<int> dof_block_;
  std::vector<int> dof_joint_;
  Lookup dof_lookup_;

  std::vector<JointInfo> joints_;
  Lookup joint_lookup_;

  std::vector<double> velocity_command_;   // NaN: no servo
  mutable Eigen::VectorXd solve_scratch_;  // dim nv; keeps solve_mass allocation-free
  // solve_mass_shifted's saved joint forces, damping and spring stiffnesses; dim nv
  mutable Eigen::VectorXd shift_forces_, shift_damping_, shift_springs_;
  std::string load_warnings_;
  double step_start_time_ = 0;  // s, of the last step (for the divergence message)

  // contacts: the last step's, or those forward() found for positions set since
  dart::collision::CollisionResult forward_contacts_;
  bool use_forward_contacts_ = false;
  bool positions_set_since_step_ = true;
  // positions_usable() of the current positions: -1 not known yet, else 0 or 1
  mutable int positions_usable_ = -1;
  // an external force was added since the last step (DART clears them in the step)
  bool external_forces_since_step_ = false;
  // the broad phase was rebuilt from the current poses and has not been used since
  mutable bool broad_phase_rebuilt_ = false;
  // restore_state's constraint forces (dim nv), reported until the next step
  Eigen::VectorXd restored_constraint_;
  bool constraint_restored_ = false;
};

}  // namespace

std::unique_ptr<Engine> open_dart_engine(const BackendWorld& spec) {
  return std::make_unique<DartEngine>(spec);
}

}  // namespace stance
