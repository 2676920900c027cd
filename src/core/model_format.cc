#include "core/model_format.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/error.h"

namespace stance {

ModelFormat model_format(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".xml" || ext == ".mjcf") return ModelFormat::kMjcf;
  if (ext == ".urdf") return ModelFormat::kUrdf;
  if (ext == ".skel") return ModelFormat::kSkel;
  if (ext == ".sdf") return ModelFormat::kSdf;
  throw InputError(path + ": unknown model format '" + ext +
                   "' (expected .xml or .mjcf for MJCF, .urdf, .sdf, or .skel)");
}

}  // namespace stance
