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
}  // namespace

std::string resolve_model_path(const std::string& path) {
  std::string resolved = path;
  if (path.starts_with(kDartSample))
    resolved = under(path, kDartSample, "STANCE_DART_DATA", kDefaultDartData);
  else if (path.starts_with(kMujocoModel))
    resolved = under(path, kMujocoModel, "STANCE_MUJOCO_MODELS", kDefaultMujocoModels);
  // a directory is no model file either
  std::error_code ec;
  if (!std::filesystem::is_regular_file(resolved, ec)) {
    if (resolved == path) throw InputError(path + ": no such file");
    throw InputError(path + ": no such file (looked for " + resolved + ")");
  }
  return resolved;
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

}  // namespace stance
