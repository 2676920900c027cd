// Reading model files (SKEL, MJCF, URDF, SDF) with DART 6.12's parsers: the checks and patches
// that keep its readers from asserting, and its console output turned into one error line.
#include <fmt/format.h>
#include <tinyxml2.h>
#include <dart/utils/mjcf/MjcfParser.hpp>
#include <dart/utils/sdf/SdfParser.hpp>
#include <dart/utils/urdf/urdf.hpp>
#include <dart/utils/utils.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/error.h"
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/dart/dart_engine.h"

namespace stance::dart_backend {

namespace {

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

}  // namespace

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

}  // namespace stance::dart_backend
