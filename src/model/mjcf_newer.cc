#include "model/mjcf_newer.h"

#include <tinyxml2.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <regex>
#include <sstream>

#include "core/error.h"

namespace stance {

namespace {

using tinyxml2::XMLElement;

// the joint attributes (MuJoCo 3) that bound the total actuator torque on a joint
constexpr const char* kRange = "actuatorfrcrange";
constexpr const char* kLimited = "actuatorfrclimited";

// one attribute as written, with where
struct Written {
  std::string value;
  std::string file;
  int line = 0;
};

// a joint's (or a default class's joint's) force-range attributes
struct ForceRange {
  std::optional<Written> range;
  std::optional<Written> limited;
};

struct DefaultClass {
  std::string parent;  // empty for "main"
  ForceRange joint;
};

struct JointEntry {
  std::string name;  // MuJoCo's, or "joint<id>" as the engines name an unnamed joint
  std::string class_name;
  ForceRange own;
};

std::optional<Written> written(const XMLElement* el, const char* attribute,
                               const std::string& file) {
  const char* v = el->Attribute(attribute);
  if (v == nullptr) return std::nullopt;
  return Written{v, file, el->GetLineNum()};
}

ForceRange force_range(const XMLElement* el, const std::string& file) {
  return {written(el, kRange, file), written(el, kLimited, file)};
}

// a model file, parsed, with its text
struct MjcfSourceFile {
  std::string path;
  std::string shown;
  std::string text;
  tinyxml2::XMLDocument doc;
};

// the files of one model and what they say about actuator force ranges, in document order
class NewerMjcfReader {
 public:
  explicit NewerMjcfReader(std::string main_dir) : main_dir_(std::move(main_dir)) {}

  // false when the file is unreadable or not well-formed XML (MuJoCo's message then)
  bool read(const std::string& shown, const std::string& path) {
    auto file = std::make_unique<MjcfSourceFile>();
    file->path = path;
    file->shown = shown;
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    std::stringstream buffer;
    buffer << in.rdbuf();
    file->text = buffer.str();
    if (file->doc.Parse(file->text.c_str(), file->text.size()) != tinyxml2::XML_SUCCESS)
      return false;
    const XMLElement* root = file->doc.RootElement();
    if (root == nullptr || files_.size() > 100) return false;  // an include cycle: MuJoCo's
    files_.push_back(std::move(file));
    const MjcfSourceFile& f = *files_.back();
    for (const XMLElement* el = root->FirstChildElement(); el; el = el->NextSiblingElement())
      if (!visit_top(f, el)) return false;
    return true;
  }

  const std::vector<std::unique_ptr<MjcfSourceFile>>& files() const { return files_; }
  const std::map<std::string, DefaultClass>& defaults() const { return defaults_; }
  const std::vector<JointEntry>& joints() const { return joints_; }

 private:
  bool visit_top(const MjcfSourceFile& f, const XMLElement* el) {
    const std::string name = el->Name();
    if (name == "include") return visit_include(el);
    if (name == "default") visit_default(f, el, "");
    if (name == "worldbody") return visit_body_children(f, el, "main");
    return true;
  }

  // an included file's elements stand in the place of its <include> (MuJoCo 2.2.2 resolves
  // its path against the main file's folder)
  bool visit_include(const XMLElement* el) {
    const char* file = el->Attribute("file");
    if (file == nullptr) return true;
    return read(file, (std::filesystem::path(main_dir_) / file).string());
  }

  void visit_default(const MjcfSourceFile& f, const XMLElement* el, const std::string& parent) {
    const char* c = el->Attribute("class");
    const std::string name = parent.empty() ? "main" : (c != nullptr ? c : "");
    DefaultClass& d = defaults_[name];
    d.parent = parent;
    for (const XMLElement* child = el->FirstChildElement(); child;
         child = child->NextSiblingElement()) {
      const std::string kind = child->Name();
      if (kind == "joint") d.joint = force_range(child, f.shown);
      if (kind == "default") visit_default(f, child, name);
    }
  }

  // a body's joints come before its children's, as MuJoCo numbers them
  bool visit_body_children(const MjcfSourceFile& f, const XMLElement* body,
                           const std::string& childclass) {
    for (const XMLElement* el = body->FirstChildElement(); el; el = el->NextSiblingElement()) {
      const std::string kind = el->Name();
      if (kind == "freejoint") joints_.push_back({joint_name(el), "", {}});
      if (kind != "joint") continue;
      const char* c = el->Attribute("class");
      joints_.push_back({joint_name(el), c != nullptr ? c : childclass, force_range(el, f.shown)});
    }
    for (const XMLElement* el = body->FirstChildElement(); el; el = el->NextSiblingElement()) {
      const std::string kind = el->Name();
      if (kind == "include" && !visit_include(el)) return false;
      if (kind != "body") continue;
      const char* c = el->Attribute("childclass");
      if (!visit_body_children(f, el, c != nullptr ? c : childclass)) return false;
    }
    return true;
  }

  std::string joint_name(const XMLElement* el) const {
    const char* n = el->Attribute("name");
    return (n != nullptr && *n != '\0') ? std::string(n) : fmt::format("joint{}", joints_.size());
  }

  std::string main_dir_;
  std::vector<std::unique_ptr<MjcfSourceFile>> files_;
  std::map<std::string, DefaultClass> defaults_;
  std::vector<JointEntry> joints_;
};

// an attribute of a joint: its own, else its class's, else the class's parents'
std::optional<Written> resolved(const JointEntry& j,
                                const std::map<std::string, DefaultClass>& defaults,
                                std::optional<Written> ForceRange::*which) {
  if (j.own.*which) return j.own.*which;
  std::string c = j.class_name;
  for (int depth = 0; !c.empty() && depth < 1000; ++depth) {
    const auto it = defaults.find(c);
    if (it == defaults.end()) return std::nullopt;  // MuJoCo names the unknown class
    if (it->second.joint.*which) return it->second.joint.*which;
    c = it->second.parent;
  }
  return std::nullopt;
}

// the largest magnitude of a limited range; nullopt when the joint is not limited
std::optional<double> force_limit(const JointEntry& j,
                                  const std::map<std::string, DefaultClass>& defaults) {
  const std::optional<Written> range = resolved(j, defaults, &ForceRange::range);
  const std::optional<Written> limited = resolved(j, defaults, &ForceRange::limited);
  if (limited && limited->value != "true" && limited->value != "false" && limited->value != "auto")
    throw InputError(located(limited->file, limited->line,
                             fmt::format("joint '{}': {} must be true, false or auto, found '{}'",
                                         j.name, kLimited, limited->value)));
  if (limited && limited->value == "false") return std::nullopt;
  if (!range) {
    if (limited && limited->value == "true")
      throw InputError(
          located(limited->file, limited->line,
                  fmt::format("joint '{}': {}=\"true\" needs an {}", j.name, kLimited, kRange)));
    return std::nullopt;
  }
  std::istringstream in(range->value);
  double low = NAN, high = NAN;
  std::string rest;
  if (!(in >> low >> high) || (in >> rest) || !std::isfinite(low) || !std::isfinite(high) ||
      low > 0 || high < 0)
    throw InputError(located(
        range->file, range->line,
        fmt::format("joint '{}': {} must be two finite numbers 'lower upper' with lower <= 0 <= "
                    "upper, found '{}'",
                    j.name, kRange, range->value)));
  return std::max(std::abs(low), std::abs(high));
}

// `out` gets a space for the removed text [first, last), and its line breaks, so that the
// lines after it keep their numbers
template <class Iterator>
void append_removed(std::string& out, Iterator first, Iterator last) {
  out.push_back(' ');
  for (auto c = first; c != last; ++c)
    if (*c == '\n') out.push_back('\n');
}

// the text without the force-range attributes; its line breaks kept
std::string without_force_ranges(const std::string& text) {
  static const std::regex kAttribute(R"(\s+actuatorfrc(range|limited)\s*=\s*("[^"]*"|'[^']*'))");
  std::string out;
  auto last = text.cbegin();
  for (std::sregex_iterator it(text.begin(), text.end(), kAttribute), end; it != end; ++it) {
    out.append(last, (*it)[0].first);
    append_removed(out, (*it)[0].first, (*it)[0].second);
    last = (*it)[0].second;
  }
  out.append(last, text.cend());
  return out;
}

bool has_force_range(const std::string& text) {
  return text.find(kRange) != std::string::npos || text.find(kLimited) != std::string::npos;
}

// <option integrator="implicitfast"> (MuJoCo 2.3.3 and later, in most current collections'
// robots): 2.2.2 refuses the keyword; its "implicit" integrates damping alike, and also the
// Coriolis terms that implicitfast leaves out
const std::regex kImplicitFast(R"((integrator\s*=\s*["'])implicitfast(["']))");

bool has_implicit_fast(const std::string& text) {
  return text.find("implicitfast") != std::string::npos && std::regex_search(text, kImplicitFast);
}

// a <position>'s kv (damping) and inheritrange (ctrlrange from the joint's range), a newer
// MuJoCo's (T1's files have both): 2.2.2 refuses them; stance makes every servo a torque motor
// (engine/mujoco/mujoco_engine.cc), which needs neither
const std::regex kPositionTag(R"(<position\b[^>]*>)");
const std::regex kServoAttribute(R"(\s+(kv|inheritrange)\s*=\s*("[^"]*"|'[^']*'))");

bool has_servo_attributes(const std::string& text) {
  if (text.find("<position") == std::string::npos) return false;
  for (std::sregex_iterator it(text.begin(), text.end(), kPositionTag), end; it != end; ++it)
    if (std::regex_search(it->str(), kServoAttribute)) return true;
  return false;
}

// the text without them in <position> tags; its line breaks kept
std::string without_servo_attributes(const std::string& text) {
  std::string out;
  auto last = text.cbegin();
  for (std::sregex_iterator it(text.begin(), text.end(), kPositionTag), end; it != end; ++it) {
    out.append(last, (*it)[0].first);
    const std::string tag = it->str();
    auto tag_last = tag.cbegin();
    for (std::sregex_iterator a(tag.begin(), tag.end(), kServoAttribute); a != end; ++a) {
      out.append(tag_last, (*a)[0].first);
      append_removed(out, (*a)[0].first, (*a)[0].second);
      tag_last = (*a)[0].second;
    }
    out.append(tag_last, tag.cend());
    last = (*it)[0].second;
  }
  out.append(last, text.cend());
  return out;
}

}  // namespace

NewerMjcf read_newer_mjcf(const std::string& shown_name, const std::string& path) {
  NewerMjcf out;
  // most models have none: no parse then
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  bool any = has_force_range(buffer.str()) || has_implicit_fast(buffer.str()) ||
             has_servo_attributes(buffer.str()) ||
             buffer.str().find("<include") != std::string::npos;
  if (!any) return out;
  NewerMjcfReader reader(std::filesystem::path(path).parent_path().string());
  if (!reader.read(shown_name, path)) return out;
  bool ranges = false, implicit_fast = false, servo_attributes = false;
  for (const auto& f : reader.files()) {
    const bool range = has_force_range(f->text), fast = has_implicit_fast(f->text);
    const bool servo = has_servo_attributes(f->text);
    if (!range && !fast && !servo) continue;
    ranges = ranges || range;
    implicit_fast = implicit_fast || fast;
    servo_attributes = servo_attributes || servo;
    const std::string text = servo ? without_servo_attributes(f->text) : f->text;
    out.patched.push_back(
        {f->path, std::regex_replace(without_force_ranges(text), kImplicitFast, "$1implicit$2")});
  }
  if (out.patched.empty()) return out;
  for (const JointEntry& j : reader.joints())
    if (const std::optional<double> limit = force_limit(j, reader.defaults()))
      out.joint_force_limits.emplace_back(j.name, *limit);
  std::vector<std::string> done;
  if (ranges)
    done.push_back(fmt::format(
        "{} (an attribute of a newer MuJoCo than 2.2.2, which stance "
        "links) read as the torque limit of {} joint{} and removed before "
        "MuJoCo parses the model",
        kRange, out.joint_force_limits.size(), out.joint_force_limits.size() == 1 ? "" : "s"));
  if (implicit_fast)
    done.push_back(
        "integrator implicitfast (a newer MuJoCo's) run as 2.2.2's implicit, which also "
        "integrates the Coriolis terms implicitly");
  if (servo_attributes)
    done.push_back(
        "kv and inheritrange of <position> (a newer MuJoCo's) removed: stance makes position "
        "servos torque motors, which need neither");
  out.note = fmt::format("{}: {}", shown_name, fmt::join(done, "; "));
  return out;
}

}  // namespace stance
