// Plain parameter structs with one visit function (after Drake's SimulatorConfig).
//
// A parameter struct looks like
//   struct StablePdParams {
//     double kp = 400;
//     template <class V> void visit(V& v) { v("kp", kp, {.unit = "N m/rad", .min = 0}); }
//   };
// and that single list drives YAML loading (params/yaml_params.h), `--set a.b=value`
// overrides, saving, and the viewer's sliders (params/param_list.h).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace stance {

struct ParamMeta {
  std::string_view unit;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  std::string_view help;
};

// a struct with a visit(V&) member is visited as a nested object (Eigen's matrices also have a
// visit member, with another meaning: they are values)
template <class T, class V>
concept Visitable = !std::is_base_of_v<Eigen::EigenBase<T>, T> && requires(T & t, V& v) {
  t.visit(v);
};

// string -> double table (e.g. an initial pose, dof name -> value)
using NamedValues = std::map<std::string, double>;

}  // namespace stance
