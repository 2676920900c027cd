// Every field of a parameter struct as documentation: its `--set` path, its default as YAML
// text, and the unit, range and help of its visit (`stance list CONTROLLER` prints these, so a
// user need not read the headers). Unlike param_list.h it keeps strings and lists, and a list
// of structs is described once, by its item's fields ("states[].cd").
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "params/params.h"

namespace stance {

struct ParamDoc {
  std::string path;           // "gains.torso.kp"; a list item's field: "states[].cd"
  std::string default_value;  // YAML text: "400", "true", "[0, 0, 1]", "walk"
  ParamMeta meta;             // unit/help point at string literals of the visit
};

class ParamDocBuilder {
 public:
  explicit ParamDocBuilder(std::vector<ParamDoc>& out, std::string prefix = "")
      : out_(out), prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(std::string_view key, T& value, const ParamMeta& meta = {}) {
    const std::string path = prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
    if constexpr (Visitable<T, ParamDocBuilder>) {
      ParamDocBuilder sub(out_, path);
      value.visit(sub);
    } else if constexpr (std::is_same_v<T, bool>) {
      out_.push_back({path, value ? "true" : "false", meta});
    } else if constexpr (std::is_arithmetic_v<T>) {
      out_.push_back({path, number(value), meta});
    } else if constexpr (std::is_same_v<T, std::string>) {
      out_.push_back({path, value.empty() ? "\"\"" : value, meta});
    } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      out_.push_back(
          {path, fmt::format("[{}, {}, {}]", number(value[0]), number(value[1]), number(value[2])),
           meta});
    } else if constexpr (std::is_same_v<T, NamedValues>) {
      std::string text;
      for (const auto& [name, x] : value)
        text += (text.empty() ? "" : ", ") + name + ": " + number(x);
      out_.push_back({path, "{" + text + "}", meta});
    } else if constexpr (requires { typename T::value_type; }) {
      using Item = typename T::value_type;
      if constexpr (Visitable<Item, ParamDocBuilder>) {
        // the list itself, then its item's fields once (from its first default item)
        out_.push_back({path, value.empty() ? "[]" : fmt::format("{} items", value.size()), meta});
        Item item = value.empty() ? Item{} : value.front();
        ParamDocBuilder sub(out_, path + "[]");
        item.visit(sub);
      } else {
        std::string text;
        for (const auto& x : value) text += (text.empty() ? "" : ", ") + item_text(x);
        out_.push_back({path, "[" + text + "]", meta});
      }
    }
  }

 private:
  template <class N>
  static std::string number(N x) {
    if constexpr (std::is_floating_point_v<N>)
      if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
    return fmt::format("{}", x);
  }
  template <class X>
  static std::string item_text(const X& x) {
    if constexpr (std::is_arithmetic_v<X>)
      return number(x);
    else
      return fmt::format("{}", x);
  }

  std::vector<ParamDoc>& out_;
  std::string prefix_;
};

// the fields of a default-constructed Params, in visit order
template <class Params>
std::vector<ParamDoc> document_params() {
  std::vector<ParamDoc> out;
  Params params{};
  ParamDocBuilder builder(out);
  params.visit(builder);
  return out;
}

// a range as text: "0 .. 1", ">= 0", "<= 5", or "" when unbounded
inline std::string range_text(const ParamMeta& m) {
  auto num = [](double x) { return fmt::format("{}", x); };
  const bool lo = std::isfinite(m.min), hi = std::isfinite(m.max);
  if (lo && hi) return num(m.min) + " .. " + num(m.max);
  if (lo) return ">= " + num(m.min);
  if (hi) return "<= " + num(m.max);
  return "";
}

}  // namespace stance
