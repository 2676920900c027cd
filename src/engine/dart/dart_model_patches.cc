// Checks and patches of model text before DART 6.12's parsers read it: they assert (abort) on
// much that MuJoCo and the other readers take, so such input is refused at its line or rewritten.
#include "engine/dart/dart_model_patches.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <set>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/dart/dart_engine.h"

namespace stance::dart_backend {

namespace {

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

// DART 6.12's MJCF reader skips <include> (a robot's scene file then loads as an empty world):
// each is replaced by the included file's elements, as MuJoCo assembles them, the file resolved
// from the main file's folder; each file's bodies are checked and its inertials read under its
// own name and lines first. Nested includes too; true when any was inlined
bool inline_includes(const std::string& shown_name, const std::filesystem::path& folder,
                     tinyxml2::XMLDocument& doc, tinyxml2::XMLElement* parent,
                     std::map<std::string, MjcfInertial>& inertials, int depth = 0) {
  bool changed = false;
  for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e;) {
    tinyxml2::XMLElement* next = e->NextSiblingElement();
    const char* file = e->Attribute("file");
    if (std::strcmp(e->Name(), "include") != 0 || file == nullptr) {
      changed = inline_includes(shown_name, folder, doc, e, inertials, depth) || changed;
      e = next;
      continue;
    }
    if (depth > 20)
      throw InputError(located(shown_name, e->GetLineNum(), "<include>: nested too deep"));
    const std::string path = (folder / file).string();
    tinyxml2::XMLDocument included;
    load_xml(path, path, included);
    tinyxml2::XMLElement* root = included.RootElement();
    if (root == nullptr) throw InputError(located(path, 0, "an included file has no element"));
    if (tinyxml2::XMLElement* worldbody = root->FirstChildElement("worldbody")) {
      collect_inertials(path, worldbody, inertials);
      check_bodies_have_joints(path, worldbody, false);
    }
    inline_includes(path, folder, included, root, inertials, depth + 1);
    tinyxml2::XMLNode* at = e->PreviousSibling();
    for (const tinyxml2::XMLElement* c = root->FirstChildElement(); c;
         c = c->NextSiblingElement()) {
      tinyxml2::XMLNode* copy = c->DeepClone(&doc);
      at = at ? parent->InsertAfterChild(at, copy) : parent->InsertFirstChild(copy);
    }
    parent->DeleteChild(e);
    changed = true;
    e = next;
  }
  return changed;
}

// after inlining, a section written in both files (two <worldbody>, two <asset>) is one for
// DART, which reads only the first of each: later ones move into it
void merge_repeated_sections(tinyxml2::XMLElement* root) {
  for (const char* name :
       {"worldbody", "asset", "actuator", "contact", "keyframe", "sensor", "tendon", "equality"}) {
    tinyxml2::XMLElement* first = root->FirstChildElement(name);
    if (first == nullptr) continue;
    for (tinyxml2::XMLElement* later = first->NextSiblingElement(name); later;) {
      tinyxml2::XMLElement* after = later->NextSiblingElement(name);
      while (tinyxml2::XMLNode* child = later->FirstChild()) first->InsertEndChild(child);
      root->DeleteChild(later);
      later = after;
    }
  }
}

// DART 6.12's MJCF reader asserts on a geom whose mesh asset has no name (MuJoCo names it after
// its file, without folder and extension): each unnamed <mesh> gets that name; true when any did
bool name_unnamed_meshes(tinyxml2::XMLElement* root) {
  bool changed = false;
  for (tinyxml2::XMLElement* asset = root->FirstChildElement("asset"); asset;
       asset = asset->NextSiblingElement("asset"))
    for (tinyxml2::XMLElement* mesh = asset->FirstChildElement("mesh"); mesh;
         mesh = mesh->NextSiblingElement("mesh")) {
      const char* file = mesh->Attribute("file");
      if (mesh->Attribute("name") || file == nullptr) continue;
      mesh->SetAttribute("name", std::filesystem::path(file).stem().string().c_str());
      changed = true;
    }
  return changed;
}

}  // namespace

// all model formats are XML: check well-formedness here, where the line number is known
void load_xml(const std::string& shown_name, const std::string& file, tinyxml2::XMLDocument& doc) {
  if (doc.LoadFile(file.c_str()) != tinyxml2::XML_SUCCESS) {
    throw InputError(located(shown_name, doc.ErrorLineNum(),
                             std::string("malformed XML (") +
                                 tinyxml2::XMLDocument::ErrorIDToName(doc.ErrorID()) + ")"));
  }
}

// the file's text with normalize_whitespace_for_dart applied; empty when nothing changed
std::string text_normalized_for_dart(tinyxml2::XMLDocument& doc) {
  if (doc.RootElement() == nullptr || !normalize_whitespace_for_dart(doc.RootElement())) return "";
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
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
  bool patched = inline_includes(shown_name, std::filesystem::path(file).parent_path(), doc,
                                 doc.RootElement(), out.inertials);
  if (patched) merge_repeated_sections(doc.RootElement());
  patched = name_unnamed_meshes(doc.RootElement()) || patched;
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

}  // namespace stance::dart_backend
