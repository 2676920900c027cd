// Conversions between Python values and the library's: YAML parameters, JSON results, checked
// vectors, and bodies, dofs and joints given by name or index.
#include <fmt/format.h>

#include <cmath>

#include "bindings.h"
#include "core/error.h"

namespace stance::python {

YAML::Node to_yaml(py::handle o) {
  if (o.is_none()) return YAML::Node(YAML::NodeType::Null);
  if (py::isinstance<py::bool_>(o)) return YAML::Node(o.cast<bool>());
  if (py::isinstance<py::int_>(o)) return YAML::Node(o.cast<long long>());
  if (py::isinstance<py::float_>(o)) return YAML::Node(o.cast<double>());
  if (py::isinstance<py::str>(o)) return YAML::Node(o.cast<std::string>());
  if (py::isinstance<py::array>(o)) return to_yaml(o.attr("tolist")());
  if (py::isinstance<py::dict>(o)) {
    YAML::Node n(YAML::NodeType::Map);
    for (auto [k, v] : o.cast<py::dict>()) n[py::str(k).cast<std::string>()] = to_yaml(v);
    return n;
  }
  if (py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o)) {
    YAML::Node n(YAML::NodeType::Sequence);
    for (auto v : o) n.push_back(to_yaml(v));
    return n;
  }
  // numpy scalars and anything else with a float value
  if (py::hasattr(o, "__float__")) return YAML::Node(o.cast<double>());
  throw InputError(fmt::format("cannot use a {} as a parameter value",
                               py::str(o.get_type().attr("__name__")).cast<std::string>()));
}

// YAML as Python values (scalars read as int, float, bool or str, in that order)
py::object from_yaml(const YAML::Node& n) {
  if (!n || n.IsNull()) return py::none();
  if (n.IsSequence()) {
    py::list l;
    for (const auto& e : n) l.append(from_yaml(e));
    return l;
  }
  if (n.IsMap()) {
    py::dict d;
    for (const auto& kv : n) d[py::str(kv.first.Scalar())] = from_yaml(kv.second);
    return d;
  }
  long long i = 0;
  double x = 0;
  bool b = false;
  if (YAML::convert<long long>::decode(n, i)) return py::int_(i);
  if (YAML::convert<double>::decode(n, x)) return py::float_(x);
  if (YAML::convert<bool>::decode(n, b)) return py::bool_(b);
  return py::str(n.Scalar());
}

// {"controllers.0.kp": 500} as the CLI's --set assignments
std::vector<std::string> override_list(const py::object& overrides) {
  std::vector<std::string> sets;
  if (overrides.is_none()) return sets;
  for (auto [k, v] : overrides.cast<py::dict>()) {
    YAML::Emitter e;
    e << YAML::Flow << to_yaml(v);
    sets.push_back(py::str(k).cast<std::string>() + "=" + e.c_str());
  }
  return sets;
}

py::object json_to_py(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

nlohmann::json py_to_json(py::handle o) {
  return nlohmann::json::parse(py::module_::import("json").attr("dumps")(o).cast<std::string>());
}

void check_size(const char* what, Eigen::Index got, int want) {
  if (got != want)
    throw InputError(fmt::format("{}: expected {} values, found {}", what, want, got));
}

void check_finite(const char* what, const char* arg, ConstVec x, const char* meaning) {
  for (Eigen::Index i = 0; i < x.size(); ++i)
    if (!std::isfinite(x[i]))
      throw InputError(
          fmt::format("{}: {}[{}] is {}: {} must be finite numbers", what, arg, i, x[i], meaning));
}

int body_arg(const Engine& e, py::handle b) {
  if (py::isinstance<py::str>(b)) return e.require_body(b.cast<std::string>());
  int i = b.cast<int>();
  if (i < 0 || i >= e.nbody())
    throw InputError(fmt::format("body index {} out of range [0, {})", i, e.nbody()));
  return i;
}
int dof_arg(const Engine& e, py::handle d) {
  if (py::isinstance<py::str>(d)) return e.require_dof(d.cast<std::string>());
  int i = d.cast<int>();
  if (i < 0 || i >= e.nv())
    throw InputError(fmt::format("dof index {} out of range [0, {})", i, e.nv()));
  return i;
}
int joint_arg(const Engine& e, py::handle j) {
  if (py::isinstance<py::str>(j)) return e.require_joint(j.cast<std::string>());
  int i = j.cast<int>();
  if (i < 0 || i >= e.njoint())
    throw InputError(fmt::format("joint index {} out of range [0, {})", i, e.njoint()));
  return i;
}

py::array make_read_only(py::array a) {
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

py::array read_only(const double* data, Eigen::Index n, py::handle owner, const Vec* copy) {
  py::array a = data ? py::array(py::dtype::of<double>(), {n}, {sizeof(double)}, data, owner)
                     : py::array(py::dtype::of<double>(), {n}, {sizeof(double)}, copy->data());
  return make_read_only(a);
}

}  // namespace stance::python
