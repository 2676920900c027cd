// The Python module's native part, stance._stance: a thin layer over the library. Scenarios load
// and run through Simulation, engines through the Engine interface, the maths through the free
// functions; nothing here computes physics or control itself. python/stance/__init__.py
// re-exports it with the Python-side helpers.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "analysis/finite_difference.h"
#include "control/controller.h"
#include "control/lqr.h"
#include "core/error.h"
#include "core/timestep.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "math/dare.h"
#include "params/yaml_params.h"
#include "scenario/observers.h"
#include "scenario/robustness.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "scenario/sweep.h"
#include "scenario/tune.h"
#ifdef STANCE_HAVE_VIEWER
#include "viz/viewer.h"
#endif

namespace py = pybind11;

namespace stance {
namespace {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using ConstVec = Eigen::Ref<const Eigen::VectorXd>;
using ConstMat = Eigen::Ref<const Eigen::MatrixXd>;

// stance.DivergenceError, made in the module's init and never freed (a py::object here would be
// released after the interpreter is gone)
PyObject* divergence_error_type = nullptr;

// ---- conversions

// a Python value (None, bool, int, float, str, list, tuple, dict, numpy array) as YAML
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

// a state the engine would take in and quietly lose (MuJoCo resets a NaN state in its next
// step): "set_q: q[3] is nan: positions must be finite numbers"
void check_finite(const char* what, const char* arg, ConstVec x, const char* meaning) {
  for (Eigen::Index i = 0; i < x.size(); ++i)
    if (!std::isfinite(x[i]))
      throw InputError(
          fmt::format("{}: {}[{}] is {}: {} must be finite numbers", what, arg, i, x[i], meaning));
}

// a body, dof, joint or actuator given by name or index
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

// a read-only 1-D array: a view of `data` kept alive by `owner`, or a copy when data is null
py::array read_only(const double* data, Eigen::Index n, py::handle owner, const Vec* copy) {
  py::array a = data ? py::array(py::dtype::of<double>(), {n}, {sizeof(double)}, data, owner)
                     : py::array(py::dtype::of<double>(), {n}, {sizeof(double)}, copy->data());
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

// ---- Python controllers

// what compute(engine, out) writes into: writable views of this step's summed outputs. Valid
// during the call only.
struct OutputView {
  ControlOutput* out = nullptr;
  ControlOutput& get() const {
    if (!out) throw std::runtime_error("out is valid only inside compute()");
    return *out;
  }
};

// a Python controller's per-run state: the wrappers handed to compute(). The Python object
// keeps its own attributes; they are not saved, restored or branched.
class PyControllerState final : public ControllerState {
 public:
  ~PyControllerState() override {
    if (engine_obj || out_obj) {
      py::gil_scoped_acquire gil;
      engine_obj = py::object();
      out_obj = py::object();
    }
  }
  std::unique_ptr<ControllerState> clone() const override {
    return std::make_unique<PyControllerState>();
  }
  void assign(const ControllerState&) override {}
  void write(std::string&) const override {}
  void read(const std::string&, size_t&) override {}

  const Engine* engine = nullptr;
  py::object engine_obj, out_obj;
  OutputView* view = nullptr;
};

// a Python object with compute(engine, out) and optionally reset(engine) and metrics()
class PyController final : public Controller {
 public:
  PyController(py::object instance, YAML::Node params)
      : instance_(std::move(instance)), params_(std::move(params)) {
    if (!py::hasattr(instance_, "compute"))
      throw InputError(fmt::format("python controller {}: has no compute(engine, out) method",
                                   py::repr(instance_).cast<std::string>()));
    compute_ = instance_.attr("compute");
    if (py::hasattr(instance_, "reset")) reset_ = instance_.attr("reset");
  }
  ~PyController() override {
    py::gil_scoped_acquire gil;
    instance_ = compute_ = reset_ = py::object();
  }
  std::string_view type() const override { return kExternalControllerType; }
  const py::object& instance() const { return instance_; }

  std::unique_ptr<ControllerState> make_state(const Engine& engine) const override {
    auto s = std::make_unique<PyControllerState>();
    reset(*s, engine);
    return s;
  }
  void reset(ControllerState& state, const Engine& engine) const override {
    py::gil_scoped_acquire gil;
    auto& s = static_cast<PyControllerState&>(state);
    bind(s, engine);
    if (reset_) reset_(s.engine_obj);
  }
  void compute(ControllerState& state, const Engine& engine, ControlOutput& out) const override {
    py::gil_scoped_acquire gil;
    auto& s = static_cast<PyControllerState&>(state);
    if (s.engine != &engine) bind(s, engine);
    s.view->out = &out;
    compute_(s.engine_obj, s.out_obj);
    s.view->out = nullptr;
  }
  void add_metrics(const ControllerState&, nlohmann::json& metrics) const override {
    py::gil_scoped_acquire gil;
    if (!py::hasattr(instance_, "metrics")) return;
    nlohmann::json m = py_to_json(instance_.attr("metrics")());
    if (m.is_object())
      for (auto it = m.begin(); it != m.end(); ++it) metrics[it.key()] = it.value();
  }
  YAML::Node params_yaml() const override { return params_; }
  // no sliders: a live edit rebuilds through the registry, which Python classes are not in
  std::vector<ParamEntry> tunable_params() const override { return {}; }

 private:
  static void bind(PyControllerState& s, const Engine& engine) {
    s.engine = &engine;
    s.engine_obj = py::cast(const_cast<Engine*>(&engine), py::return_value_policy::reference);
    if (!s.out_obj) {
      s.out_obj = py::cast(OutputView{});
      s.view = s.out_obj.cast<OutputView*>();
    }
  }

  py::object instance_, compute_, reset_;
  YAML::Node params_;
};

// builds `type: python, module: m, class: C` entries: the other keys are the class's keyword
// arguments; the scenario's folder is searched first
ControllerFactory python_factory(const std::string& scenario_dir) {
  return [scenario_dir](const YAML::Node& node, const ControllerContext& ctx,
                        const Engine&) -> std::shared_ptr<const Controller> {
    py::gil_scoped_acquire gil;
    const YAML::Node module = node["module"], cls = node["class"];
    if (!module || !module.IsScalar() || !cls || !cls.IsScalar())
      throw InputError(located(ctx.source.file, node.Mark().line + 1,
                               ctx.path + ": a python controller needs 'module' and 'class'"));
    py::dict kwargs;
    for (const auto& kv : node) {
      const std::string key = kv.first.Scalar();
      if (key != "type" && key != "module" && key != "class")
        kwargs[py::str(key)] = from_yaml(kv.second);
    }
    py::object instance;
    py::list path = py::module_::import("sys").attr("path");
    try {
      path.insert(0, scenario_dir);
      py::object m = py::module_::import(module.Scalar().c_str());
      path.attr("remove")(scenario_dir);
      if (!py::hasattr(m, cls.Scalar().c_str()))
        throw InputError(located(ctx.source.file, cls.Mark().line + 1,
                                 fmt::format("{}: module '{}' has no class '{}'", ctx.path,
                                             module.Scalar(), cls.Scalar())));
      instance = m.attr(cls.Scalar().c_str())(**kwargs);
    } catch (py::error_already_set& e) {
      if (path.contains(scenario_dir)) path.attr("remove")(scenario_dir);
      if (!e.matches(PyExc_ImportError)) throw;
      throw InputError(located(ctx.source.file, module.Mark().line + 1,
                               fmt::format("{}: cannot import python module '{}': {}", ctx.path,
                                           module.Scalar(), e.what())));
    }
    return std::make_shared<PyController>(instance, node);
  };
}

// ---- results

struct PyRunResult {
  RunResult r;
  py::object log = py::dict();
};

py::dict log_arrays(const MemoryLog& log) {
  py::dict d;
  const size_t cols = log.columns.size();
  const size_t rows = cols ? log.values.size() / cols : 0;
  for (size_t c = 0; c < cols; ++c) {
    py::array_t<double> a(static_cast<py::ssize_t>(rows));
    auto w = a.mutable_unchecked<1>();
    for (size_t r = 0; r < rows; ++r) w(r) = log.values[r * cols + c];
    d[py::str(log.columns[c])] = a;
  }
  return d;
}

// Engine.step on a state that diverged (MuJoCo's warning, DART's instability): .result is None
[[noreturn]] void raise_engine_divergence(const Engine& e) {
  py::handle type(divergence_error_type);
  const std::string why = e.last_warning();
  py::object error =
      type(fmt::format("simulation diverged: {}", why.empty() ? "the state is not finite" : why));
  error.attr("result") = py::none();
  PyErr_SetObject(type.ptr(), error.ptr());
  throw py::error_already_set();
}

[[noreturn]] void raise_divergence(const RunResult& r, py::object result) {
  py::handle type(divergence_error_type);
  py::object e = type(fmt::format("simulation diverged: {}", r.divergence));
  e.attr("result") = result;
  PyErr_SetObject(type.ptr(), e.ptr());
  throw py::error_already_set();
}

PyRunResult run_simulation(Simulation& sim, long max_steps) {
  MemoryLog log;
  sim.add_observer(&log);
  RunResult r;
  try {
    py::gil_scoped_release release;
    r = sim.run(max_steps);
  } catch (...) {
    sim.remove_observer(&log);
    throw;
  }
  sim.remove_observer(&log);
  PyRunResult out{r, log_arrays(log)};
  if (r.diverged) raise_divergence(r, py::cast(out));
  return out;
}

// ---- the simulation

// a Python Simulation keeps what it was loaded from (for stance.view's saving and replays)
py::object with_loaded(std::unique_ptr<Simulation> sim, const py::object& loaded) {
  py::object obj = py::cast(std::move(sim));
  if (!loaded.is_none()) obj.attr("_loaded") = loaded;
  return obj;
}

py::object load_simulation(const std::string& path, const py::object& overrides,
                           const std::string& engine, std::optional<double> duration,
                           const std::string& out_dir, const std::vector<std::string>& pushes,
                           bool past_fall) {
  LoadedScenario loaded = load_scenario(path, override_list(overrides));
  // as stance run names it
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(path).stem().string();
  RunOptions opt;
  opt.engine = engine;
  opt.duration = duration;
  opt.out_dir = out_dir;
  opt.quiet = true;
  for (const auto& p : pushes) opt.extra_pushes.push_back(parse_push(p));
  if (past_fall) opt.stop_after_fall_s = -1;
  std::string dir = std::filesystem::path(path).parent_path().string();
  opt.external_controllers = python_factory(dir.empty() ? "." : dir);
  auto sim = std::make_unique<Simulation>(loaded, opt);
  py::capsule kept(new LoadedScenario(loaded),
                   [](void* p) { delete static_cast<LoadedScenario*>(p); });
  return with_loaded(std::move(sim), kept);
}

// a controller for sim.add_controller: a Python object, or a dict naming a registered type
std::shared_ptr<const Controller> make_added_controller(Simulation& sim, py::object c) {
  if (!py::isinstance<py::dict>(c)) return std::make_shared<PyController>(c, YAML::Node());
  YAML::Node node = to_yaml(c);
  if (!node["type"]) throw InputError("add_controller: the dict needs a 'type'");
  ControllerContext ctx = controller_context(sim.model(), sim.controllers().size());
  ctx.source = {"add_controller"};
  return find_controller_type(node["type"].Scalar()).make(node, ctx, sim.engine());
}

std::unique_ptr<Engine> load_engine(const std::string& path, const std::string& engine,
                                    std::optional<double> timestep,
                                    std::optional<Eigen::Vector3d> gravity) {
  WorldSpec spec;
  spec.models.push_back({path, Eigen::Vector3d::Zero()});
  spec.timestep = timestep;
  spec.gravity = gravity;
  std::lock_guard<std::mutex> lock(model_load_mutex());
  auto e = make_engine(engine, spec);
  e->forward();
  return e;
}

LqrParams lqr_params(const py::kwargs& kw) {
  YAML::Node node = to_yaml(py::dict(kw));
  ControllerContext ctx;
  ctx.source = {"lqr"};
  return read_params<LqrParams>(node, ctx, {});
}

}  // namespace
}  // namespace stance

using namespace stance;

PYBIND11_MODULE(_stance, m) {
  m.doc() = "stance's native module: see help(stance)";

  // ---- errors
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError).doc() =
      "Bad input (a scenario, a parameter, a name): the message names the file and line or the "
      "parameter, as the CLI's exit code 2 does.";
  m.attr("InputError").attr("__module__") = "stance";
  divergence_error_type = PyErr_NewExceptionWithDoc(
      "stance.DivergenceError",
      "The simulation diverged (NaN or engine instability); .result holds the run's result up "
      "to then (the CLI's exit code 3).",
      PyExc_RuntimeError, nullptr);
  m.attr("DivergenceError") = py::handle(divergence_error_type);

  // ---- engine
  py::enum_<JointType>(m, "JointType")
      .value("FREE", JointType::kFree)
      .value("BALL", JointType::kBall)
      .value("HINGE", JointType::kHinge)
      .value("SLIDE", JointType::kSlide);

  py::class_<JointInfo>(m, "JointInfo", "a joint: its type, child body and where it sits in q, v")
      .def_readonly("name", &JointInfo::name)
      .def_readonly("type", &JointInfo::type)
      .def_readonly("body", &JointInfo::body, "child body index")
      .def_readonly("qpos_adr", &JointInfo::qpos_adr, "first index in q")
      .def_readonly("dof_adr", &JointInfo::dof_adr, "first index in v")
      .def_readonly("nq", &JointInfo::nq)
      .def_readonly("nv", &JointInfo::nv)
      .def_readonly("has_limits", &JointInfo::has_limits)
      .def_readonly("lower", &JointInfo::lower)
      .def_readonly("upper", &JointInfo::upper)
      .def("__repr__", [](const JointInfo& j) {
        return fmt::format("<JointInfo {} qpos_adr={} dof_adr={} nq={} nv={}>", j.name, j.qpos_adr,
                           j.dof_adr, j.nq, j.nv);
      });

  py::class_<Contact>(m, "Contact", "a contact: bodies (-1: the world), point, normal, force")
      .def_readonly("body1", &Contact::body1)
      .def_readonly("body2", &Contact::body2)
      .def_readonly("pos", &Contact::pos)
      .def_readonly("normal", &Contact::normal, "from body1 to body2")
      .def_readonly("force", &Contact::force, "on body2, world frame (N)");

  py::class_<EngineState>(m, "EngineState",
                          "an engine's whole state (Engine.save_state / restore_state)")
      .def_readonly("time", &EngineState::time)
      .def_readonly("q", &EngineState::q)
      .def_readonly("v", &EngineState::v)
      .def_readonly("ctrl", &EngineState::ctrl);

  py::class_<Engine>(m, "Engine", R"(One physics engine (MuJoCo or DART) behind stance's interface.

Dimensions: q has nq entries, v has nv (nq = nv + 1 per free joint on MuJoCo, whose free joint
stores a quaternion); never subtract positions, use difference_positions / integrate_positions.
Arrays returned by methods are new float64 numpy arrays. `q` and `v` are read-only: on MuJoCo
they are views of the engine's own storage (they follow every step and set_q); on DART each
access returns a fresh copy. Write through set_q / set_v, which keep the engine's caches right.
Bodies, dofs and joints are given by name or index. Dynamics quantities are valid after
forward(); a simulation's engine is always forwarded between steps.)")
      .def_static(
          "load", &load_engine, py::arg("path"), py::arg("engine") = "mujoco",
          py::arg("timestep") = std::nullopt, py::arg("gravity") = std::nullopt,
          R"(Load a model file (MJCF .xml, URDF, .skel, dart://sample/..., mujoco://model/...)
into a new engine ("mujoco" or "dart"), forwarded.)")
      .def_property_readonly("name", &Engine::engine_name, "\"mujoco\" or \"dart\"")
      .def_property_readonly("nq", &Engine::nq)
      .def_property_readonly("nv", &Engine::nv)
      .def_property_readonly("nu", &Engine::nu, "number of actuators (0 on DART)")
      .def_property_readonly("nbody", &Engine::nbody, "mobile bodies")
      .def_property_readonly("njoint", &Engine::njoint)
      .def_property_readonly("total_mass", &Engine::total_mass, "kg, mobile bodies")
      .def_property_readonly("time", &Engine::time, "s")
      .def_property(
          "timestep", &Engine::timestep,
          [](Engine& e, double dt) {
            if (const std::string problem = timestep_problem(dt); !problem.empty())
              throw InputError("timestep: " + problem);
            e.set_timestep(dt);
          },
          "s, in [1e-5, 1]")
      .def_property("gravity", &Engine::gravity, &Engine::set_gravity, "m/s^2")
      .def_property_readonly(
          "q",
          [](py::object self) {
            const Engine& e = self.cast<const Engine&>();
            if (const double* p = e.positions_data()) return read_only(p, e.nq(), self, nullptr);
            Vec q(e.nq());
            e.get_positions(q);
            return read_only(nullptr, q.size(), py::handle(), &q);
          },
          "positions, dim nq, read-only (MuJoCo: a live view; DART: a copy)")
      .def_property_readonly(
          "v",
          [](py::object self) {
            const Engine& e = self.cast<const Engine&>();
            if (const double* p = e.velocities_data()) return read_only(p, e.nv(), self, nullptr);
            Vec v(e.nv());
            e.get_velocities(v);
            return read_only(nullptr, v.size(), py::handle(), &v);
          },
          "velocities, dim nv, read-only (MuJoCo: a live view; DART: a copy)")
      .def(
          "set_q",
          [](Engine& e, ConstVec q) {
            check_size("set_q", q.size(), e.nq());
            check_finite("set_q", "q", q, "positions");
            e.set_positions(q);
            e.forward();
          },
          py::arg("q"), "set the positions (dim nq) and forward")
      .def(
          "set_v",
          [](Engine& e, ConstVec v) {
            check_size("set_v", v.size(), e.nv());
            check_finite("set_v", "v", v, "velocities");
            e.set_velocities(v);
            e.forward();
          },
          py::arg("v"), "set the velocities (dim nv) and forward")
      .def(
          "set_dof_position",
          [](Engine& e, py::object dof, double value) {
            if (!std::isfinite(value))
              throw InputError(
                  fmt::format("set_dof_position: value is {}: positions must be "
                              "finite numbers",
                              value));
            e.set_dof_position(dof_arg(e, dof), value);
            e.forward();
          },
          py::arg("dof"), py::arg("value"),
          "set one named coordinate (free/ball rotation dofs: rotation-vector components)")
      .def(
          "difference_positions",
          [](const Engine& e, ConstVec q0, ConstVec q1) {
            check_size("difference_positions q0", q0.size(), e.nq());
            check_size("difference_positions q1", q1.size(), e.nq());
            Vec v(e.nv());
            e.difference_positions(q0, q1, v);
            return v;
          },
          py::arg("q0"), py::arg("q1"), "v (dim nv) such that integrate_positions(q0, v, 1) == q1")
      .def(
          "integrate_positions",
          [](const Engine& e, ConstVec q, ConstVec v, double dt) {
            check_size("integrate_positions q", q.size(), e.nq());
            check_size("integrate_positions v", v.size(), e.nv());
            Vec out(e.nq());
            e.integrate_positions(q, v, dt, out);
            return out;
          },
          py::arg("q"), py::arg("v"), py::arg("dt") = 1.0, "q (+) v dt, dim nq")
      // names and indices
      .def_property_readonly("dof_names", &Engine::dof_names, "dim nv")
      .def_property_readonly("body_names", &Engine::body_names, "dim nbody")
      .def_property_readonly("actuator_names", &Engine::actuator_names, "dim nu")
      .def_property_readonly("joint_names",
                             [](const Engine& e) {
                               std::vector<std::string> n;
                               for (int j = 0; j < e.njoint(); ++j) n.push_back(e.joint(j).name);
                               return n;
                             })
      .def("body_index", &Engine::require_body, py::arg("name"),
           "index of a body (InputError naming the nearest when absent)")
      .def("dof_index", &Engine::require_dof, py::arg("name"), "index into v")
      .def("joint_index", &Engine::require_joint, py::arg("name"))
      .def("actuator_index", &Engine::require_actuator, py::arg("name"))
      .def(
          "joint", [](const Engine& e, py::object j) { return e.joint(joint_arg(e, j)); },
          py::arg("joint"), py::return_value_policy::copy)
      .def(
          "dof_joint", [](const Engine& e, py::object d) { return e.dof_joint(dof_arg(e, d)); },
          py::arg("dof"), "index of the joint owning a dof")
      .def(
          "dof_is_root", [](const Engine& e, py::object d) { return e.dof_is_root(dof_arg(e, d)); },
          py::arg("dof"))
      .def(
          "body_mass", [](const Engine& e, py::object b) { return e.body_mass(body_arg(e, b)); },
          py::arg("body"))
      .def(
          "body_parent",
          [](const Engine& e, py::object b) { return e.body_parent(body_arg(e, b)); },
          py::arg("body"), "-1 for the world")
      // dynamics
      .def("forward", &Engine::forward, "compute everything that depends on q and v")
      .def(
          "step",
          [](Engine& e) {
            e.step();
            if (!e.state_is_finite()) raise_engine_divergence(e);
          },
          "advance one timestep, consuming the per-step inputs; DivergenceError (its .result "
          "None) when the state diverged, as MuJoCo's warnings or DART's checks tell")
      .def(
          "mass_matrix",
          [](const Engine& e) {
            Mat M(e.nv(), e.nv());
            e.mass_matrix(M);
            return M;
          },
          "M, nv x nv")
      .def(
          "solve_mass",
          [](const Engine& e, ConstVec x) {
            check_size("solve_mass", x.size(), e.nv());
            Vec y = x;
            e.solve_mass(y);
            return y;
          },
          py::arg("x"), "M^-1 x with the engine's own factorisation, dim nv")
      .def(
          "solve_mass_shifted",
          [](const Engine& e, ConstVec d, ConstVec x) {
            check_size("solve_mass_shifted d", d.size(), e.nv());
            check_size("solve_mass_shifted x", x.size(), e.nv());
            Vec y = x;
            e.solve_mass_shifted(d, y);
            return y;
          },
          py::arg("d"), py::arg("x"), "(M + diag(d))^-1 x (stable PD's solve), dim nv")
      .def(
          "bias_forces",
          [](const Engine& e) {
            Vec c(e.nv());
            e.bias_forces(c);
            return c;
          },
          "Coriolis + gravity, dim nv")
      .def(
          "constraint_forces",
          [](const Engine& e) {
            Vec f(e.nv());
            e.constraint_forces(f);
            return f;
          },
          "the last step's constraint forces (contacts, limits), dim nv")
      .def(
          "inverse_dynamics",
          [](const Engine& e, ConstVec vdot) {
            check_size("inverse_dynamics", vdot.size(), e.nv());
            Vec tau(e.nv());
            e.inverse_dynamics(vdot, tau);
            return tau;
          },
          py::arg("vdot"),
          "tau (dim nv) giving the acceleration vdot at the current q, v (MuJoCo: with the "
          "constraint forces it implies, as mj_inverse; DART: M vdot + bias)")
      // kinematics
      .def("com", &Engine::com, "COM of the mobile bodies (world)")
      .def("com_velocity", &Engine::com_velocity)
      .def(
          "body_pose",
          [](const Engine& e, py::object b) {
            BodyPose p = e.body_pose(body_arg(e, b));
            Eigen::Vector4d wxyz(p.quat.w(), p.quat.x(), p.quat.y(), p.quat.z());
            return std::make_pair(Vec(p.pos), Vec(wxyz));
          },
          py::arg("body"), "(position, quaternion w x y z) of the body frame, world")
      .def(
          "body_rotation",
          [](const Engine& e, py::object b) {
            return Eigen::Matrix3d(e.body_pose(body_arg(e, b)).quat.toRotationMatrix());
          },
          py::arg("body"), "3 x 3 rotation of the body frame")
      .def(
          "body_com", [](const Engine& e, py::object b) { return e.body_com(body_arg(e, b)); },
          py::arg("body"), "world position of the body's COM")
      .def(
          "body_velocity",
          [](const Engine& e, py::object b) { return Vec(e.body_velocity(body_arg(e, b))); },
          py::arg("body"), "(angular, linear) velocity of the body frame origin, world, dim 6")
      .def(
          "point_jacobian",
          [](const Engine& e, py::object b, const Eigen::Vector3d& point) {
            Mat jp(3, e.nv()), jr(3, e.nv());
            e.point_jacobian(body_arg(e, b), point, jp, jr);
            return std::make_pair(jp, jr);
          },
          py::arg("body"), py::arg("point"),
          "(positional, rotational) Jacobians, each 3 x nv, of a world point fixed to the body")
      .def(
          "com_jacobian",
          [](const Engine& e) {
            Mat j(3, e.nv());
            e.com_jacobian(j);
            return j;
          },
          "3 x nv")
      .def(
          "subtree_com_jacobian",
          [](const Engine& e, py::object b) {
            Mat j(3, e.nv());
            e.subtree_com_jacobian(body_arg(e, b), j);
            return j;
          },
          py::arg("body"), "3 x nv, the COM of the body and all below it")
      .def(
          "subtree_com",
          [](const Engine& e, py::object b) { return e.subtree_com(body_arg(e, b)); },
          py::arg("body"))
      .def(
          "contacts",
          [](const Engine& e) {
            std::vector<Contact> c;
            for (int i = 0; i < e.num_contacts(); ++i) c.push_back(e.contact(i));
            return c;
          },
          "the current contacts (forces valid after a step)")
      .def(
          "body_in_contact",
          [](const Engine& e, py::object b) { return e.body_in_contact(body_arg(e, b)); },
          py::arg("body"))
      .def(
          "body_touches_ground",
          [](const Engine& e, py::object b) { return e.body_touches_ground(body_arg(e, b)); },
          py::arg("body"))
      // inputs
      .def(
          "set_generalized_forces",
          [](Engine& e, ConstVec tau) {
            check_size("set_generalized_forces", tau.size(), e.nv());
            e.set_generalized_forces(tau);
          },
          py::arg("tau"), "generalised forces for the next step, dim nv")
      .def(
          "set_controls",
          [](Engine& e, ConstVec u) {
            check_size("set_controls", u.size(), e.nu());
            e.set_controls(u);
          },
          py::arg("ctrl"), "actuator controls, dim nu (persist until changed)")
      .def_property_readonly("controls",
                             [](const Engine& e) {
                               Vec u(e.nu());
                               e.get_controls(u);
                               return u;
                             })
      .def(
          "actuator_moment",
          [](const Engine& e) {
            Mat mom(e.nu(), e.nv());
            e.actuator_moment(mom);
            return mom;
          },
          "nu x nv: the controls' generalised force is moment.T @ ctrl")
      .def(
          "apply_external_force",
          [](Engine& e, py::object b, const Eigen::Vector3d& force,
             std::optional<Eigen::Vector3d> point) {
            int body = body_arg(e, b);
            e.apply_external_force(body, force, point ? *point : e.body_com(body));
          },
          py::arg("body"), py::arg("force"), py::arg("point") = std::nullopt,
          "a force (N, world) for the next step at a world point (default: the body's COM)")
      .def(
          "set_dof_velocity_command",
          [](Engine& e, py::object d, double v) { e.set_dof_velocity_command(dof_arg(e, d), v); },
          py::arg("dof"), py::arg("velocity"), "a velocity servo; NaN releases it")
      .def_property_readonly("keyframe_names", &Engine::keyframe_names)
      .def("apply_keyframe", &Engine::apply_keyframe, py::arg("name"))
      .def(
          "save_state",
          [](const Engine& e) {
            EngineState s;
            e.save_state(s);
            return s;
          },
          "the whole state, restorable bit-exactly on this engine")
      .def(
          "restore_state",
          [](Engine& e, const EngineState& s) {
            e.restore_state(s);
            e.forward();
          },
          py::arg("state"))
      .def("state_is_finite", &Engine::state_is_finite)
      .def("__repr__", [](const Engine& e) {
        return fmt::format("<stance.Engine {} nq={} nv={} nu={} nbody={}>", e.engine_name(), e.nq(),
                           e.nv(), e.nu(), e.nbody());
      });

  // ---- controllers' output
  py::class_<OutputView>(m, "ControlOutput",
                         "what a Python controller's compute(engine, out) adds to (valid during "
                         "the call only)")
      .def_property_readonly(
          "tau",
          [](py::object self) {
            ControlOutput& o = self.cast<OutputView&>().get();
            return py::array(py::dtype::of<double>(), {o.tau.size()}, {sizeof(double)},
                             o.tau.data(), self);
          },
          "writable view, dim nv: the step's generalised forces, summed over controllers (add "
          "to it)")
      .def_property_readonly(
          "ctrl",
          [](py::object self) {
            ControlOutput& o = self.cast<OutputView&>().get();
            // reading it commits the controls: the step sends them to the engine
            o.ctrl_used = true;
            return py::array(py::dtype::of<double>(), {o.ctrl.size()}, {sizeof(double)},
                             o.ctrl.data(), self);
          },
          "writable view, dim nu: the step's actuator controls (accessing it makes the step "
          "send them)");

  // ---- results
  py::class_<PyRunResult>(m, "RunResult", "a run's outcome: summary.json's fields and the log")
      .def_property_readonly("fell", [](const PyRunResult& r) { return r.r.fell; })
      .def_property_readonly(
          "fall_time", [](const PyRunResult& r) { return r.r.fall_time; }, "s, or None")
      .def_property_readonly("fall_reason", [](const PyRunResult& r) { return r.r.fall_reason; })
      .def_property_readonly("diverged", [](const PyRunResult& r) { return r.r.diverged; })
      .def_property_readonly("divergence", [](const PyRunResult& r) { return r.r.divergence; })
      .def_property_readonly("sim_time", [](const PyRunResult& r) { return r.r.sim_time; })
      .def_property_readonly("steps", [](const PyRunResult& r) { return r.r.steps; })
      .def_property_readonly("wall_time_s", [](const PyRunResult& r) { return r.r.wall_time_s; })
      .def_property_readonly(
          "metrics", [](const PyRunResult& r) { return json_to_py(r.r.metrics); }, "a dict")
      .def_property_readonly(
          "summary", [](const PyRunResult& r) { return json_to_py(r.r.to_json()); },
          "the dict summary.json holds")
      .def_readonly("log", &PyRunResult::log,
                    "dict of numpy arrays keyed by log.csv's columns (full precision)")
      .def("__repr__", [](const PyRunResult& r) {
        return fmt::format("<RunResult {} on {}: {:.3f} s, fell={}>", r.r.scenario, r.r.engine,
                           r.r.sim_time, r.r.fell ? "True" : "False");
      });

  py::class_<SimulationState>(m, "SimulationState",
                              "a simulation's whole state (Simulation.save / restore)");

  // ---- the simulation
  py::class_<Simulation>(m, "Simulation", py::dynamic_attr(),
                         R"(A loaded scenario: an engine, the controllers and their
states, the pushes, fall detection and metrics, stepped in stance's one loop.

Made by stance.load(). Python controllers (`type: python` entries, add_controller) run inside
the loop; their own attributes are not saved, restored or cloned with the state.)")
      .def(
          "run",
          [](Simulation& s, std::optional<double> duration) {
            if (duration) {
              const double dt = s.engine().timestep();
              if (!(*duration >= 0))
                throw InputError(
                    fmt::format("run: duration is {}: expected seconds >= 0", *duration));
              if (const std::string problem = step_count_problem(*duration, dt); !problem.empty())
                throw InputError("run: " + problem);
            }
            long steps = duration ? std::lround(*duration / s.engine().timestep()) : -1;
            return run_simulation(s, steps);
          },
          py::arg("duration") = std::nullopt,
          R"(Run to the scenario's end (or `duration` more seconds, stopping early when done):
returns a RunResult (fell, fall_time, metrics, summary, log); raises DivergenceError when the
simulation diverges. The GIL is released while C++ runs (Python controllers take it per step).)")
      .def(
          "step",
          [](Simulation& s, int n) {
            bool ok = true;
            {
              py::gil_scoped_release release;
              for (int i = 0; i < n && ok; ++i) ok = s.step();
            }
            if (!ok) {
              RunResult r = s.result();
              raise_divergence(r, py::cast(PyRunResult{r}));
            }
          },
          py::arg("n") = 1, "n control + physics steps (DivergenceError when diverged)")
      .def_property_readonly("time", &Simulation::time, "s")
      .def_property_readonly("done", &Simulation::done,
                             "the scenario's length reached, diverged, or 1 s past a fall")
      .def_property_readonly("engine", py::overload_cast<>(&Simulation::engine),
                             py::return_value_policy::reference_internal)
      .def_property_readonly("name", [](const Simulation& s) { return s.scenario().name; })
      .def_property_readonly("source", &Simulation::source)
      .def_property_readonly("duration", [](const Simulation& s) { return s.scenario().duration; })
      .def_property_readonly("controller_types",
                             [](const Simulation& s) {
                               std::vector<std::string> t;
                               for (const auto& c : s.controllers()) t.emplace_back(c->type());
                               return t;
                             })
      .def(
          "result", [](const Simulation& s) { return PyRunResult{s.result()}; },
          "the result and metrics as of now (no log)")
      .def_property_readonly(
          "last_tau", [](const Simulation& s) { return Vec(s.last_output().tau); },
          "the generalised forces the last step applied (after torque_scale), dim nv")
      .def_property_readonly(
          "last_ctrl", [](const Simulation& s) { return Vec(s.last_output().ctrl); },
          "the controls the controllers summed in the last step, dim nu")
      .def(
          "add_controller",
          [](Simulation& s, py::object c) { s.add_controller(make_added_controller(s, c)); },
          py::arg("controller"),
          R"(Compose one more controller: a Python object with compute(engine, out) (and optionally
reset(engine), metrics()), or a dict naming a registered C++ type, e.g.
{"type": "stable_pd", "kp": 400}. Its state starts at the current state.)")
      .def(
          "save",
          [](const Simulation& s) {
            SimulationState st;
            s.save(st);
            return st;
          },
          "the whole state: engine, controller states, fall and metric progress, time")
      .def("restore", &Simulation::restore, py::arg("state"))
      .def("reset", &Simulation::reset, "back to the initial state")
      .def(
          "clone",
          [](py::object self) {
            return with_loaded(self.cast<const Simulation&>().clone(),
                               py::getattr(self, "_loaded", py::none()));
          },
          "the same model on a new engine, at this state")
      .def("write_state", &Simulation::write_state, py::arg("path"))
      .def("read_state", &Simulation::read_state, py::arg("path"))
      .def("__repr__", [](const Simulation& s) {
        return fmt::format("<stance.Simulation {} on {} t={:.4f} s>", s.scenario().name,
                           s.engine().engine_name(), s.time());
      });

  m.def("load", &load_simulation, py::arg("path"), py::arg("overrides") = py::none(),
        py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("out") = "",
        py::arg("pushes") = std::vector<std::string>{}, py::arg("past_fall") = false,
        R"(Load a scenario YAML into a Simulation.

overrides: {"controllers.0.kp": 500, "duration": 3}, the CLI's --set key paths
engine: "mujoco" or "dart" (default: the scenario's)
duration: s, the run's length (default: the scenario's)
out: a folder for summary.json, log.csv and the controllers' files, as `stance run --out`
pushes: ["body,fx,fy,fz,start,duration", ...], as --push
past_fall: run to the end after a fall (default: stop 1 s after it)
Bad input raises stance.InputError with the file and line.)");

#ifdef STANCE_HAVE_VIEWER
  m.def(
      "view",
      [](py::object sim_obj, int width, int height, int frames) {
        const Simulation& sim = sim_obj.cast<const Simulation&>();
        py::object kept = py::getattr(sim_obj, "_loaded", py::none());
        if (kept.is_none()) throw InputError("view: a simulation made by stance.load is needed");
        const auto& loaded = *static_cast<LoadedScenario*>(kept.cast<py::capsule>().get_pointer());
        ViewerOptions o;
        o.engine = std::string(sim.engine().engine_name());
        o.width = width;
        o.height = height;
        o.save_path = loaded.source;
        std::unique_ptr<Simulation> run = sim.clone();
        double t = 0;
        // the viewer's physics thread takes the GIL per step for Python controllers: the
        // window loop and the viewer's end run without it
        py::gil_scoped_release release;
        {
          Viewer v(loaded, o, std::move(run));
          if (frames > 0)
            for (int i = 0; i < frames; ++i) v.frame();
          else
            v.run();
          t = v.sim_time();
        }
        return t;
      },
      py::arg("sim"), py::arg("width") = 1400, py::arg("height") = 900, py::arg("frames") = 0,
      R"(Open stance's viewer on a clone of `sim` at its current state, Python controllers included,
until the window is closed (frames > 0: that many frames). `sim` itself is not advanced. Returns
the simulated time the viewer reached. Needs a display (RuntimeError without one).)");
#endif

  // ---- maths
  m.def(
      "linearize_fd",
      [](Engine& e, std::optional<Vec> u0, double eps, bool centered) {
        EngineState x0;
        e.save_state(x0);
        Vec u = u0 ? *u0 : x0.ctrl;
        check_size("linearize_fd u0", u.size(), e.nu());
        Mat A, B;
        {
          py::gil_scoped_release release;
          linearize_fd(e, x0, u, eps, centered, A, B);
        }
        e.forward();
        return std::make_pair(A, B);
      },
      py::arg("engine"), py::arg("u0") = std::nullopt, py::arg("eps") = 1e-6,
      py::arg("centered") = true,
      R"((A, B) of one step at the engine's state, inputs the controls: x = [dq; v],
A = dx+/dx (2nv x 2nv), B = dx+/du (2nv x nu), as MuJoCo's mjd_transitionFD.)");
  m.def(
      "linearize_fd_forces",
      [](Engine& e, std::vector<py::object> dofs, std::optional<Vec> tau0, double eps,
         bool centered) {
        EngineState x0;
        e.save_state(x0);
        std::vector<int> idx;
        for (auto& d : dofs) idx.push_back(dof_arg(e, d));
        Vec t = tau0 ? *tau0 : Vec::Zero(e.nv());
        check_size("linearize_fd_forces tau0", t.size(), e.nv());
        Mat A, B;
        {
          py::gil_scoped_release release;
          linearize_fd_forces(e, x0, idx, t, eps, centered, A, B);
        }
        e.forward();
        return std::make_pair(A, B);
      },
      py::arg("engine"), py::arg("dofs"), py::arg("tau0") = std::nullopt, py::arg("eps") = 1e-6,
      py::arg("centered") = true,
      "(A, B) with generalised forces on `dofs` as inputs (models without actuators, DART)");

  py::class_<DareResult>(m, "DareResult", "solve_dare's result")
      .def_readonly("P", &DareResult::P, "n x n, the stabilising solution")
      .def_readonly("K", &DareResult::K, "m x n, the LQR gain: u = -K x")
      .def_readonly("relative_residual", &DareResult::relative_residual)
      .def_readonly("iterations", &DareResult::iterations)
      .def_readonly("newton_steps", &DareResult::newton_steps)
      .def_readonly("spectral_radius", &DareResult::spectral_radius, "of A - B K")
      .def_readonly("success", &DareResult::success)
      .def_readonly("message", &DareResult::message);
  m.def(
      "solve_dare",
      [](const Mat& A, const Mat& B, const Mat& Q, const Mat& R) {
        py::gil_scoped_release release;
        return solve_dare(A, B, Q, R);
      },
      py::arg("A"), py::arg("B"), py::arg("Q"), py::arg("R"),
      R"(The discrete algebraic Riccati equation P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q and the
LQR gain K = (R + B'PB)^-1 B'PA. Bad dimensions or matrices raise ValueError; a failure to
converge returns success False with a message.)");
  m.def("spectral_radius", &spectral_radius, py::arg("M"));

  py::class_<LqrSetPoint>(m, "LqrSetPoint", "the LQR's static operating point")
      .def_readonly("q0", &LqrSetPoint::q0, "dim nq, the pose with the root height offset")
      .def_readonly("qfrc0", &LqrSetPoint::qfrc0, "dim nv, inverse dynamics at q0, qacc = 0")
      .def_readonly("ctrl0", &LqrSetPoint::ctrl0, "dim nu")
      .def_readonly("height_offset_m", &LqrSetPoint::height_offset_m)
      .def_readonly("residual_vertical_force_N", &LqrSetPoint::residual_vertical_force_N)
      .def_readonly("weight_N", &LqrSetPoint::weight_N)
      .def_readonly("curve_offset_m", &LqrSetPoint::curve_offset_m)
      .def_readonly("curve_force_N", &LqrSetPoint::curve_force_N);
  py::class_<LqrDesign>(m, "LqrDesign", "the LQR design: set-point, plant, costs and gain")
      .def_readonly("setpoint", &LqrDesign::setpoint)
      .def_property_readonly("A", [](const LqrDesign& d) { return d.plant.A; })
      .def_property_readonly("B", [](const LqrDesign& d) { return d.plant.B; })
      .def_property_readonly("jac_com", [](const LqrDesign& d) { return d.plant.jac_com; })
      .def_property_readonly("jac_foot", [](const LqrDesign& d) { return d.plant.jac_foot; })
      .def_readonly("Q", &LqrDesign::Q)
      .def_readonly("R", &LqrDesign::R)
      .def_readonly("K", &LqrDesign::K, "nu x 2nv, ctrl = ctrl0 - K [q (-) q0; v]")
      .def_readonly("dare_residual", &LqrDesign::dare_residual)
      .def_readonly("spectral_radius", &LqrDesign::spectral_radius)
      .def_readonly("balance_dofs", &LqrDesign::balance_dofs)
      .def_readonly("actuator_names", &LqrDesign::actuator_names)
      .def_readonly("dof_names", &LqrDesign::dof_names);
  m.def(
      "find_lqr_setpoint",
      [](Engine& e, py::kwargs kw) {
        LqrParams p = lqr_params(kw);
        py::gil_scoped_release release;
        LqrSetPoint sp = find_lqr_setpoint(p, e);
        e.forward();
        return sp;
      },
      py::arg("engine"),
      "the lqr controller's set-point search at the engine's pose; keyword arguments are the "
      "lqr controller's parameters (root_body, stance_foot, ...)");
  m.def(
      "design_lqr",
      [](Engine& e, py::kwargs kw) {
        LqrParams p = lqr_params(kw);
        py::gil_scoped_release release;
        LqrDesign d = design_lqr(p, e);
        e.forward();
        return d;
      },
      py::arg("engine"),
      "the lqr controller's whole design (set-point, Q, FD linearisation, DARE) at the engine's "
      "pose; keyword arguments are the lqr controller's parameters");
  m.def(
      "lqr_state_cost",
      [](Engine& e, const Mat& jac_com, const Mat& jac_foot, py::kwargs kw) {
        LqrParams p = lqr_params(kw);
        std::vector<bool> root(e.nv());
        for (int i = 0; i < e.nv(); ++i) root[i] = e.dof_is_root(i);
        return lqr_state_cost(p, jac_com, jac_foot, root, match_dofs(e, p.balance_dofs));
      },
      py::arg("engine"), py::arg("jac_com"), py::arg("jac_foot"),
      "the lqr controller's Q (2nv x 2nv) from the COM and foot Jacobians (3 x nv)");
  m.def("plot_force_offset", &plot_force_offset, py::arg("setpoint"), py::arg("csv_path"),
        py::arg("png_path"), "the set-point's force-against-offset plot with gnuplot");

  // ---- batch
  m.def(
      "sweep",
      [](const std::string& path, const std::string& param, std::vector<double> values,
         const py::object& overrides, const std::string& engine, std::optional<double> duration,
         int threads) {
        SweepOptions o;
        o.scenario = path;
        o.sets = override_list(overrides);
        o.param = param;
        o.values = std::move(values);
        o.engine = engine;
        o.duration = duration;
        o.threads = threads;
        std::vector<SweepPoint> points;
        {
          py::gil_scoped_release release;
          points = run_sweep(o);
        }
        const py::ssize_t n = points.size();
        py::array_t<double> value(n), sim_time(n), fall_time(n);
        py::array_t<bool> fell(n), diverged(n);
        py::list metrics, errors;
        for (py::ssize_t i = 0; i < n; ++i) {
          const SweepPoint& p = points[i];
          value.mutable_at(i) = p.value;
          sim_time.mutable_at(i) = p.result.sim_time;
          fell.mutable_at(i) = p.result.fell;
          diverged.mutable_at(i) = p.result.diverged;
          fall_time.mutable_at(i) = p.result.fall_time ? *p.result.fall_time : std::nan("");
          metrics.append(json_to_py(without_wall_clock(p.result.metrics)));
          errors.append(p.error);
        }
        py::dict d;
        d["value"] = value;
        d["fell"] = fell;
        d["fall_time"] = fall_time;
        d["diverged"] = diverged;
        d["sim_time"] = sim_time;
        d["metrics"] = metrics;
        d["error"] = errors;
        return d;
      },
      py::arg("path"), py::arg("param"), py::arg("values"), py::arg("overrides") = py::none(),
      py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("threads") = 0,
      R"(`stance sweep`: the scenario run once per value of the key path `param`, on `threads`
threads (0: every core; results do not depend on it), the GIL released. Returns a dict of numpy
arrays (value, fell, fall_time (NaN: stood), diverged, sim_time) and lists (metrics without the
wall-clock ones, error: non-empty where that run's input was bad).)");

  m.def(
      "tune",
      [](const std::string& path, const std::vector<std::string>& params,
         const std::vector<std::string>& neighbours, int budget, int population,
         unsigned long long seed, const std::string& metric, double fall_penalty,
         const py::object& overrides, const std::string& engine, std::optional<double> duration,
         int threads, const std::string& method) {
        TuneOptions o;
        o.method = method;
        o.scenario = path;
        o.sets = override_list(overrides);
        for (const auto& p : params) o.params.push_back(parse_tune_param(p));
        for (const auto& n : neighbours) o.neighbours.push_back(parse_neighbour(n));
        o.budget = budget;
        o.population = population;
        o.seed = seed;
        o.metric = metric;
        o.fall_penalty = fall_penalty;
        o.engine = engine;
        o.duration = duration;
        o.threads = threads;
        TuneResult t;
        {
          py::gil_scoped_release release;
          t = run_tune(o);
        }
        const py::ssize_t n = t.candidates.size(), k = o.params.size();
        py::array_t<double> values({n, k}), score(n), time_up(n), metric_mean(n);
        py::array_t<int> generation(n), failed(n);
        for (py::ssize_t i = 0; i < n; ++i) {
          const TuneCandidate& c = t.candidates[i];
          for (py::ssize_t j = 0; j < k; ++j) values.mutable_at(i, j) = c.values[j];
          score.mutable_at(i) = c.robust_score;
          time_up.mutable_at(i) = c.worst_time_up;
          metric_mean.mutable_at(i) = c.mean_metric;
          generation.mutable_at(i) = c.generation;
          failed.mutable_at(i) = c.failed_runs;
        }
        py::dict d;
        d["params"] = params;
        d["values"] = values;
        d["robust_score"] = score;
        d["worst_time_up"] = time_up;
        d["mean_metric"] = metric_mean;
        d["generation"] = generation;
        d["failed_runs"] = failed;
        d["best"] = t.best;
        d["best_sets"] = n ? tune_assignments(o, t.candidates[t.best]) : std::vector<std::string>{};
        d["notes"] = t.notes;
        return d;
      },
      py::arg("path"), py::arg("params"), py::arg("neighbours") = std::vector<std::string>{},
      py::arg("budget") = 40, py::arg("population") = 8, py::arg("seed") = 1,
      py::arg("metric") = "", py::arg("fall_penalty") = 100.0, py::arg("overrides") = py::none(),
      py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("threads") = 0,
      py::arg("method") = "cem",
      R"(`stance tune`: a seeded search over params ("key=lo:hi[:log]"), method "cem" (the
cross-entropy method) or "cmaes" (CMA-ES), each
candidate scored by its worst run over the nominal setting and the neighbours ("k*=0.85,k2=v"),
the GIL released; the same results for any thread count. Returns a dict: values (candidates x
params), robust_score, worst_time_up, mean_metric, generation, failed_runs (numpy arrays in
evaluation order; row 0 is the start), best (an index), best_sets (--set lines), notes.)");
  m.def(
      "robustness",
      [](const std::string& path, const std::string& body, int directions, int phases,
         double push_duration, double max_force, double tolerance, double at, double phase_spacing,
         double recovery_window, int max_steps, const std::string& point,
         const py::object& overrides, const std::string& engine, std::optional<double> duration,
         int threads) {
        RobustnessOptions o;
        o.body = body;
        o.directions = directions;
        o.phases = phases;
        o.push_duration = push_duration;
        o.max_force = max_force;
        o.tolerance = tolerance;
        o.at = at;
        o.phase_spacing_s = phase_spacing;
        o.recovery_window_s = recovery_window;
        o.max_recovery_steps = max_steps;
        parse_push_point(point, o.point, o.offset);
        o.engine = engine;
        o.duration = duration;
        o.threads = threads;
        LoadedScenario loaded = load_scenario(path, override_list(overrides));
        RobustnessResult r;
        {
          py::gil_scoped_release release;
          r = run_robustness(loaded, o);
        }
        // thresholds as a directions x phases grid, trials flat in the order they ran
        const py::ssize_t nd = r.directions.size(), np_ = r.phase_fractions.size();
        py::array_t<double> threshold({nd, np_}), fell_at({nd, np_}), angles(nd), starts(np_);
        py::array_t<int> outcome({nd, np_});
        std::vector<const RobustnessTrial*> trials;
        for (py::ssize_t d = 0; d < nd; ++d) {
          angles.mutable_at(d) = r.angles_deg[d];
          for (py::ssize_t p = 0; p < np_; ++p) {
            const RobustnessCell& c = r.cell(d, p);
            threshold.mutable_at(d, p) = c.threshold;
            fell_at.mutable_at(d, p) = c.fell ? *c.fell : std::nan("");
            outcome.mutable_at(d, p) = c.outcome_at_threshold;
            for (const auto& t : c.trials) trials.push_back(&t);
          }
        }
        for (py::ssize_t p = 0; p < np_; ++p) starts.mutable_at(p) = r.push_starts[p];
        const py::ssize_t nt = trials.size();
        py::array_t<int> t_dir(nt), t_phase(nt), t_outcome(nt), t_steps(nt);
        py::array_t<double> t_force(nt), t_fall(nt), t_detour(nt);
        for (py::ssize_t i = 0; i < nt; ++i) {
          const RobustnessTrial& t = *trials[i];
          t_dir.mutable_at(i) = t.direction;
          t_phase.mutable_at(i) = t.phase;
          t_force.mutable_at(i) = t.force;
          t_outcome.mutable_at(i) = t.outcome;
          t_fall.mutable_at(i) = t.fall_time ? *t.fall_time : std::nan("");
          t_steps.mutable_at(i) = t.recovery_steps;
          t_detour.mutable_at(i) = t.detour_m;
        }
        py::dict trial;
        trial["direction"] = t_dir;
        trial["phase"] = t_phase;
        trial["force"] = t_force;
        trial["outcome"] = t_outcome;
        trial["fall_time"] = t_fall;
        trial["recovery_steps"] = t_steps;
        trial["detour_m"] = t_detour;
        py::dict d;
        d["threshold"] = threshold;
        d["fell_at"] = fell_at;
        d["outcome"] = outcome;
        d["angle_deg"] = angles;
        d["push_start"] = starts;
        d["walker"] = r.walker;
        d["planar"] = r.planar;
        d["feet"] = r.feet;
        d["trials"] = trial;
        d["summary"] = json_to_py(robustness_summary(o, r));
        d["notes"] = r.notes;
        return d;
      },
      py::arg("path"), py::arg("body"), py::arg("directions") = 8, py::arg("phases") = 4,
      py::arg("push_duration") = 0.2, py::arg("max_force") = 800.0, py::arg("tolerance") = 2.0,
      py::arg("at") = 2.0, py::arg("phase_spacing") = 0.25, py::arg("recovery_window") = 3.0,
      py::arg("max_steps") = 3, py::arg("point") = "com", py::arg("overrides") = py::none(),
      py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("threads") = 0,
      R"(`stance robustness`: the largest push survived per direction and phase (docs/robustness.md),
the GIL released; the same results for any thread count. Returns a dict: threshold, fell_at (NaN:
max_force survived) and outcome (outcome code at the threshold) as directions x phases numpy
arrays; angle_deg per direction; push_start per phase; walker, planar, feet; trials (numpy arrays
in the order the trials ran: direction, phase, force, outcome, fall_time, recovery_steps,
detour_m); summary (summary.json's content) and notes.)");
}
