#include "motion/joint_map.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "params/yaml_params.h"

namespace stance {

namespace {

std::string scalar_of(const YAML::Node& node, const std::string& source, const char* key) {
  if (!node.IsScalar())
    throw InputError(
        located(source, node.Mark().line + 1, fmt::format("{}: expected a value", key)));
  return node.Scalar();
}

double number_of(const YAML::Node& node, const std::string& source, const char* key) {
  std::string text = scalar_of(node, source, key);
  try {
    size_t used = 0;
    double x = std::stod(text, &used);
    if (used == text.size() && std::isfinite(x)) return x;
  } catch (const std::exception&) {
  }
  throw InputError(located(source, node.Mark().line + 1,
                           fmt::format("{}: expected a number, found '{}'", key, text)));
}

}  // namespace

JointMap parse_joint_map(const YAML::Node& node, const std::string& source) {
  JointMap map;
  map.source = source;
  if (!node.IsMap())
    throw InputError(located(source, node.Mark().line + 1, "expected a map with a 'joints' entry"));
  for (const auto& kv : node) {
    const std::string key = kv.first.Scalar();
    const YAML::Node& value = kv.second;
    if (key == "joints") {
      if (!value.IsMap())
        throw InputError(located(source, value.Mark().line + 1,
                                 "joints: expected a map of clip joint: model body"));
      for (const auto& pair : value)
        map.joints.push_back({pair.first.Scalar(), scalar_of(pair.second, source, "joints"),
                              pair.first.Mark().line + 1});
    } else if (key == "model_up") {
      std::string up = scalar_of(value, source, "model_up");
      if (up != "y" && up != "z")
        throw InputError(located(source, value.Mark().line + 1,
                                 fmt::format("model_up: expected y or z, found '{}'", up)));
      map.model_up = up[0];
    } else if (key == "yaw_deg") {
      if (scalar_of(value, source, "yaw_deg") != "auto")
        map.yaw_deg = number_of(value, source, "yaw_deg");
    } else if (key == "scale") {
      if (scalar_of(value, source, "scale") != "auto") {
        map.scale = number_of(value, source, "scale");
        if (*map.scale <= 0)
          throw InputError(located(source, value.Mark().line + 1, "scale: must be positive"));
      }
    } else if (key == "height_offset") {
      if (scalar_of(value, source, "height_offset") != "auto")
        map.height_offset_m = number_of(value, source, "height_offset");
    } else if (key == "align_bones") {
      std::string b = scalar_of(value, source, "align_bones");
      if (b != "true" && b != "false")
        throw InputError(
            located(source, value.Mark().line + 1,
                    fmt::format("align_bones: expected true or false, found '{}'", b)));
      map.align_bones = b == "true";
    } else {
      throw InputError(
          located(source, kv.first.Mark().line + 1,
                  fmt::format("unknown key '{}'{}", key,
                              did_you_mean(key, {"joints", "model_up", "yaw_deg", "scale",
                                                 "height_offset", "align_bones"}))));
    }
  }
  if (map.joints.empty())
    throw InputError(located(source, node.Mark().line + 1, "joints: the map pairs no joints"));
  return map;
}

JointMap read_joint_map(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": cannot read the joint map (a folder)");
  if (!std::filesystem::exists(path, ec) || !std::ifstream(path))
    throw InputError(path + ": cannot read the joint map");
  // the scenarios' strict reader: duplicate keys, non-word keys and aliases are located errors
  return parse_joint_map(load_yaml_file(path), path);
}

}  // namespace stance
