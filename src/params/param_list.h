// Flattens a parameter struct into a list of numeric entries through its visit function: the
// viewer's slider panel is built from this list, so no controller needs GUI code.
//
// Paths use the `--set` syntax of params/yaml_params.h ("gains.torso.kp", "states.0.cd",
// "heel_point.0"), so an edited entry is applied with apply_yaml_override().
#pragma once

#include <yaml-cpp/yaml.h>

#include <fmt/format.h>

#include <cmath>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "params/params.h"

namespace stance {

struct ParamEntry {
  enum class Kind { kDouble, kInt, kBool };
  std::string path;  // "gains.torso.kp"
  Kind kind = Kind::kDouble;
  double value = 0;  // ints and bools as 0/1
  ParamMeta meta;    // unit/help point at string literals of the visit
};

// the visitor: numbers, bools, 3-vectors, number lists, name->number tables and nested structs
// (strings and string lists are not tunable and are skipped)
class ParamListBuilder {
 public:
  explicit ParamListBuilder(std::vector<ParamEntry>& out, std::string prefix = "")
      : out_(out), prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(std::string_view key, T& value, const ParamMeta& meta = {}) {
    std::string path = join(key);
    if constexpr (Visitable<T, ParamListBuilder>) {
      ParamListBuilder sub(out_, path);
      value.visit(sub);
    } else if constexpr (std::is_same_v<T, double>) {
      out_.push_back({path, ParamEntry::Kind::kDouble, value, meta});
    } else if constexpr (std::is_same_v<T, int>) {
      out_.push_back({path, ParamEntry::Kind::kInt, static_cast<double>(value), meta});
    } else if constexpr (std::is_same_v<T, bool>) {
      out_.push_back({path, ParamEntry::Kind::kBool, value ? 1.0 : 0.0, meta});
    } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      for (int i = 0; i < 3; ++i)
        out_.push_back({fmt::format("{}.{}", path, i), ParamEntry::Kind::kDouble, value[i], meta});
    } else if constexpr (std::is_same_v<T, NamedValues>) {
      for (const auto& [name, x] : value)
        out_.push_back({path + "." + name, ParamEntry::Kind::kDouble, x, meta});
    } else if constexpr (std::is_same_v<T, std::vector<double>>) {
      for (size_t i = 0; i < value.size(); ++i)
        out_.push_back({fmt::format("{}.{}", path, i), ParamEntry::Kind::kDouble, value[i], meta});
    } else if constexpr (requires { typename T::value_type; } && !std::is_same_v<T, std::string>) {
      if constexpr (Visitable<typename T::value_type, ParamListBuilder>) {
        for (size_t i = 0; i < value.size(); ++i) {
          ParamListBuilder sub(out_, fmt::format("{}.{}", path, i));
          value[i].visit(sub);
        }
      }
    }
  }

 private:
  std::string join(std::string_view key) const {
    return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
  }
  std::vector<ParamEntry>& out_;
  std::string prefix_;
};

// the numeric entries of a parameter struct (a copy is visited: the struct is not changed)
template <class Params>
std::vector<ParamEntry> list_params(const Params& params) {
  std::vector<ParamEntry> out;
  Params copy = params;
  ParamListBuilder b(out);
  copy.visit(b);
  return out;
}

// the numeric and boolean scalars of a YAML tree, without units or ranges (for parameter
// structs that do not list themselves); "type" keys are skipped
inline void list_yaml_params(const YAML::Node& node, const std::string& prefix,
                             std::vector<ParamEntry>& out) {
  auto join = [&](const std::string& k) { return prefix.empty() ? k : prefix + "." + k; };
  if (node.IsMap()) {
    for (const auto& kv : node) {
      if (!kv.first.IsScalar()) continue;  // the loader rejected such keys already
      std::string key = kv.first.Scalar();
      if (prefix.empty() && key == "type") continue;
      list_yaml_params(kv.second, join(key), out);
    }
  } else if (node.IsSequence()) {
    for (size_t i = 0; i < node.size(); ++i)
      list_yaml_params(node[i], join(std::to_string(i)), out);
  } else if (node.IsScalar()) {
    const std::string& s = node.Scalar();
    if (s == "true" || s == "false") {
      out.push_back({prefix, ParamEntry::Kind::kBool, s == "true" ? 1.0 : 0.0, {}});
      return;
    }
    try {
      size_t used = 0;
      double x = std::stod(s, &used);
      if (used == s.size()) out.push_back({prefix, ParamEntry::Kind::kDouble, x, {}});
    } catch (const std::exception&) {
      // not a number: not tunable
    }
  }
}

// "path=value" in the syntax of apply_yaml_override, with ints and bools written as such
inline std::string param_assignment(const ParamEntry& e, double value) {
  switch (e.kind) {
    case ParamEntry::Kind::kBool:
      return e.path + (value != 0 ? "=true" : "=false");
    case ParamEntry::Kind::kInt:
      return fmt::format("{}={}", e.path, static_cast<long>(std::lround(value)));
    default:
      return fmt::format("{}={:.17g}", e.path, value);
  }
}

}  // namespace stance
