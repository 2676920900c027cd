// Python controllers: an object with compute(engine, out), run inside the library's step loop
// as any Controller, from a scenario's `type: python` entry or Simulation.add_controller.
#include <fmt/format.h>

#include "bindings.h"
#include "core/error.h"
#include "sim/scenario.h"

namespace stance::python {
namespace {

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
class PyController final : public Controller, public Reporting {
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
  // metrics() into summary.json, when the class has one
  void add_metrics(const ControllerState&, nlohmann::json& metrics) const override {
    py::gil_scoped_acquire gil;
    if (!py::hasattr(instance_, "metrics")) return;
    nlohmann::json m = py_to_json(instance_.attr("metrics")());
    if (m.is_object())
      for (auto it = m.begin(); it != m.end(); ++it) metrics[it.key()] = it.value();
  }
  // not Retunable (no sliders): a live edit rebuilds through the registry, which Python
  // classes are not in
  YAML::Node params_yaml() const override { return params_; }

 protected:
  const void* find_interface(ControllerInterface id) const override {
    return id == Reporting::kInterface ? static_cast<const Reporting*>(this) : nullptr;
  }

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

}  // namespace

std::shared_ptr<const Controller> make_python_controller(py::object instance) {
  return std::make_shared<PyController>(std::move(instance), YAML::Node());
}

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

void bind_control_output(py::module_& m) {
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
}

}  // namespace stance::python
