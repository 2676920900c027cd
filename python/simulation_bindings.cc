// Running scenarios from Python: stance.load, Simulation (run, step, save/restore, clone),
// RunResult, and stance.view. The loop, the metrics and the files are the library's own.
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>

#include "bindings.h"
#include "core/error.h"
#include "core/timestep.h"
#include "sim/scenario.h"
#ifdef STANCE_HAVE_VIEWER
#include "viz/viewer.h"
#endif

namespace stance::python {

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

namespace {

constexpr auto kSignalCheckPeriod = std::chrono::milliseconds(50);

// Python's signal handlers, run every kSignalCheckPeriod of a run from its step loop, on the
// thread that called run() (they run on the main thread only): an exception they raise
// (KeyboardInterrupt) is kept and the run's interrupt flag set, so it stops before its next step
class SignalCheck final : public StepObserver {
 public:
  void on_start(const Simulation&) override { next_ = Clock::now() + kSignalCheckPeriod; }
  void on_step(const Simulation&) override {
    if (raised || Clock::now() < next_) return;
    next_ = Clock::now() + kSignalCheckPeriod;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) {
      raised.emplace();  // fetches the exception
      python_interrupt().store(true);
    }
  }
  std::optional<py::error_already_set> raised;

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point next_;
};

}  // namespace

std::atomic<bool>& python_interrupt() {
  static std::atomic<bool> flag{false};
  return flag;
}

void run_checking_signals(const std::function<void()>& work) {
  python_interrupt().store(false);
  std::mutex mutex;
  std::condition_variable finished_cv;
  bool finished = false;
  std::exception_ptr failure;
  std::thread worker([&] {
    try {
      work();
    } catch (...) {
      failure = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex);
    finished = true;
    finished_cv.notify_all();
  });
  std::optional<py::error_already_set> raised;
  for (bool done = false; !done;) {
    {
      py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(mutex);
      done = finished_cv.wait_for(lock, kSignalCheckPeriod, [&] { return finished; });
    }
    if (!done && !raised && PyErr_CheckSignals() != 0) {
      raised.emplace();
      python_interrupt().store(true);
    }
  }
  worker.join();
  if (raised) throw std::move(*raised);
  if (failure) std::rethrow_exception(failure);
}

PyRunResult run_simulation(Simulation& sim, long max_steps) {
  MemoryLog log;
  SignalCheck signals;
  sim.add_observer(&log);
  sim.add_observer(&signals);
  python_interrupt().store(false);
  RunResult r;
  try {
    py::gil_scoped_release release;
    r = sim.run(max_steps);
  } catch (...) {
    sim.remove_observer(&signals);
    sim.remove_observer(&log);
    throw;
  }
  sim.remove_observer(&signals);
  sim.remove_observer(&log);
  if (signals.raised) throw std::move(*signals.raised);
  PyRunResult out{r, log_arrays(log)};
  if (r.diverged) raise_divergence(r, py::cast(out));
  return out;
}

namespace {

// a Python Simulation keeps what it was loaded from (for stance.view's saving and replays)
py::object with_loaded(std::unique_ptr<Simulation> sim, const py::object& loaded) {
  py::object obj = py::cast(std::move(sim));
  if (!loaded.is_none()) obj.attr("_loaded") = loaded;
  return obj;
}

py::object load_simulation(const PathArg& path, const py::object& overrides,
                           const std::string& engine, std::optional<double> duration,
                           const PathArg& out_dir, const std::vector<std::string>& pushes,
                           bool past_fall) {
  LoadedScenario loaded = load_scenario(path.string(), override_list(overrides));
  // as stance run names it
  if (loaded.scenario.name.empty()) loaded.scenario.name = path.stem().string();
  RunOptions opt;
  opt.engine = engine;
  opt.duration = duration;
  opt.out_dir = out_dir.string();
  opt.quiet = true;
  opt.interrupt = &python_interrupt();
  for (const auto& p : pushes) opt.extra_pushes.push_back(parse_push(p));
  if (past_fall) opt.stop_after_fall_s = -1;
  std::string dir = path.parent_path().string();
  opt.external_controllers = python_factory(dir.empty() ? "." : dir);
  auto sim = std::make_unique<Simulation>(loaded, opt);
  py::capsule kept(new LoadedScenario(loaded),
                   [](void* p) { delete static_cast<LoadedScenario*>(p); });
  return with_loaded(std::move(sim), kept);
}

// a controller for sim.add_controller: a Python object, or a dict naming a registered type
std::shared_ptr<const Controller> make_added_controller(Simulation& sim, py::object c) {
  if (!py::isinstance<py::dict>(c)) return make_python_controller(c);
  YAML::Node node = to_yaml(c);
  if (!node["type"]) throw InputError("add_controller: the dict needs a 'type'");
  ControllerContext ctx = controller_context(sim.model(), sim.controllers().size());
  ctx.source = {"add_controller"};
  return find_controller_type(node["type"].Scalar()).make(node, ctx, sim.engine());
}

// stance.RunResult
void bind_run_result(py::module_& m) {
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
}

// stance.SimulationState and stance.Simulation
void bind_simulation_class(py::module_& m) {
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
      .def(
          "write_state", [](const Simulation& s, const PathArg& p) { s.write_state(p.string()); },
          py::arg("path"))
      .def(
          "read_state", [](Simulation& s, const PathArg& p) { s.read_state(p.string()); },
          py::arg("path"))
      .def("__repr__", [](const Simulation& s) {
        return fmt::format("<stance.Simulation {} on {} t={:.4f} s>", s.scenario().name,
                           s.engine().engine_name(), s.time());
      });
}

}  // namespace

void bind_simulation(py::module_& m) {
  bind_run_result(m);
  bind_simulation_class(m);
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
}

void bind_view([[maybe_unused]] py::module_& m) {
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
}

}  // namespace stance::python
