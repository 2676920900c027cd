#include "model/model_path.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>

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

ModelFormat model_format(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".xml" || ext == ".mjcf") return ModelFormat::kMjcf;
  if (ext == ".urdf") return ModelFormat::kUrdf;
  if (ext == ".skel") return ModelFormat::kSkel;
  throw InputError(path + ": unknown model format '" + ext +
                   "' (expected .xml or .mjcf for MJCF, .urdf, or .skel)");
}

}  // namespace stance
