#include "model/model_path.h"

#include <cstdlib>
#include <filesystem>

#include <tinyxml2.h>

#include "core/error.h"

namespace stance {

namespace {
constexpr std::string_view kDartSample = "dart://sample/";
constexpr const char* kDefaultDartData = "/usr/share/doc/dart/data";
constexpr std::string_view kMujocoModel = "mujoco://model/";
constexpr const char* kDefaultMujocoModels = "/usr/share/mujoco/model";

// a prefix path under the folder an environment variable (or the default) names
std::string under(const std::string& path, std::string_view prefix, const char* variable,
                  const char* fallback) {
  const char* env = std::getenv(variable);
  std::string root = (env != nullptr && env[0] != '\0') ? env : fallback;
  if (!root.empty() && root.back() != '/') root += '/';
  return root + path.substr(prefix.size());
}

// what a path is when it is no regular file ("" when it is one): a model is read whole, and a
// device (/dev/zero) never ends
std::string not_a_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  switch (fs::status(path, ec).type()) {
    case fs::file_type::regular:
      return "";
    case fs::file_type::directory:
      return "a folder, not a file";
    case fs::file_type::character:
      return "not a regular file (a character device)";
    case fs::file_type::block:
      return "not a regular file (a block device)";
    case fs::file_type::fifo:
      return "not a regular file (a pipe)";
    case fs::file_type::socket:
      return "not a regular file (a socket)";
    case fs::file_type::not_found:
      return "no such file";
    default:
      return ec ? "cannot read it (" + ec.message() + ")" : "not a regular file";
  }
}
}  // namespace

std::string resolve_model_path(const std::string& path) {
  std::string resolved = path;
  if (path.starts_with(kDartSample))
    resolved = under(path, kDartSample, "STANCE_DART_DATA", kDefaultDartData);
  else if (path.starts_with(kMujocoModel))
    resolved = under(path, kMujocoModel, "STANCE_MUJOCO_MODELS", kDefaultMujocoModels);
  const std::string what = not_a_file(resolved);
  if (what.empty()) return resolved;
  if (resolved == path) throw InputError(path + ": " + what);
  throw InputError(path + ": " + what + " (looked for " + resolved + ")");
}

void check_mjcf_root(const std::string& name, const std::string& path) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) return;
  const tinyxml2::XMLElement* root = doc.RootElement();
  if (!root || std::string(root->Name()) == "mujoco") return;
  const std::string what = root->Name();
  std::string hint = "an MJCF file's root is <mujoco>";
  if (what == "robot") hint += "; a URDF file must be named .urdf";
  if (what == "sdf") hint += "; an SDF file must be named .sdf";
  if (what == "skel") hint += "; a SKEL file must be named .skel";
  throw InputError(located(name, root->GetLineNum(), "root element <" + what + ">: " + hint));
}

int mjcf_option_line(const std::string& path) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS || doc.RootElement() == nullptr) return 0;
  const tinyxml2::XMLElement* option = doc.RootElement()->FirstChildElement("option");
  return option != nullptr ? option->GetLineNum() : 0;
}

}  // namespace stance
