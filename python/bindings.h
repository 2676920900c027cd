// What the files of the Python module's native part (stance._stance) share: the conversions
// between Python and the library's values, the errors, the run result, and one bind_* function
// per group of bindings, called in order by module.cc.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "control/controller.h"
#include "engine/engine.h"
#include "sim/observers.h"
#include "sim/simulation.h"

namespace stance::python {

namespace py = pybind11;

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using ConstVec = Eigen::Ref<const Eigen::VectorXd>;
using ConstMat = Eigen::Ref<const Eigen::MatrixXd>;
// a path argument: a str or any os.PathLike (pathlib.Path)
using PathArg = std::filesystem::path;

// ---- conversions (conversions.cc)

// a Python value (None, bool, int, float, str, list, tuple, dict, numpy array) as YAML
YAML::Node to_yaml(py::handle o);
// YAML as Python values (scalars read as int, float, bool or str, in that order)
py::object from_yaml(const YAML::Node& n);
// {"controllers.0.kp": 500} as the CLI's --set assignments
std::vector<std::string> override_list(const py::object& overrides);
py::object json_to_py(const nlohmann::json& j);
nlohmann::json py_to_json(py::handle o);
// InputError "what: expected `want` values, found `got`"
void check_size(const char* what, Eigen::Index got, int want);
// a state the engine would take in and quietly lose (MuJoCo resets a NaN state in its next
// step): "set_q: q[3] is nan: positions must be finite numbers"
void check_finite(const char* what, const char* arg, ConstVec x, const char* meaning);
// a body, dof or joint given by name or index
int body_arg(const Engine& e, py::handle b);
int dof_arg(const Engine& e, py::handle d);
int joint_arg(const Engine& e, py::handle j);
// a read-only 1-D array: a view of `data` kept alive by `owner`, or a copy when data is null
py::array read_only(const double* data, Eigen::Index n, py::handle owner, const Vec* copy);
// clears an array's writeable flag; returns it
py::array make_read_only(py::array a);

// ---- errors (errors.cc)

// stance.InputError and stance.DivergenceError
void bind_errors(py::module_& m);
// Engine.step on a state that diverged (MuJoCo's warning, DART's instability): .result is None
[[noreturn]] void raise_engine_divergence(const Engine& e);
// a run that diverged: .result is `result`
[[noreturn]] void raise_divergence(const RunResult& r, py::object result);

// ---- Python controllers (python_controller.cc)

// a Python object with compute(engine, out) and optionally reset(engine) and metrics()
std::shared_ptr<const Controller> make_python_controller(py::object instance);
// builds `type: python, module: m, class: C` entries; the scenario's folder is searched first
ControllerFactory python_factory(const std::string& scenario_dir);
// stance.ControlOutput, what compute(engine, out) writes into
void bind_control_output(py::module_& m);

// ---- runs (simulation_bindings.cc)

struct PyRunResult {
  RunResult r;
  py::object log = py::dict();
};
// the log's columns as numpy arrays, keyed by log.csv's names
py::dict log_arrays(const MemoryLog& log);
// runs `sim` (max_steps < 0: to its end) with the GIL released and the log kept in memory;
// raises DivergenceError when it diverges
PyRunResult run_simulation(Simulation& sim, long max_steps);

// ---- Ctrl-C (simulation_bindings.cc)
// the interrupt flag of the runs the module makes (RunOptions::interrupt): set when Python's
// signal handlers, run from the calling thread every 50 ms while C++ works, raise (SIGINT's
// KeyboardInterrupt); cleared when a run starts
std::atomic<bool>& python_interrupt();
// work() on a thread of its own, the GIL released, while this thread runs Python's signal
// handlers every 50 ms: on an exception from them (KeyboardInterrupt) python_interrupt() is set,
// work is waited for and the exception raised
void run_checking_signals(const std::function<void()>& work);

// ---- the groups of bindings, in the order module.cc calls them
void bind_engine(py::module_& m);      // engine_bindings.cc
void bind_simulation(py::module_& m);  // simulation_bindings.cc: RunResult, Simulation, load
void bind_view(py::module_& m);        // simulation_bindings.cc: with the viewer only
void bind_maths(py::module_& m);       // maths_bindings.cc
void bind_batch(py::module_& m);       // batch_bindings.cc
void bind_bvh(py::module_& m);         // bvh_bindings.cc

// ---- many clips (track_batch_bindings.cc)
struct TrackBatchOptions {
  int jobs = 0;  // clips at once per process; 0: as many as threads
  bool resume = false;
  bool plot = true;
};
// true when the inputs make a batch (several, a folder, a glob), as `stance bvh track` decides
bool is_batch(const std::vector<std::string>& inputs);
// `stance bvh track INPUTS --out track.out_dir`: a stance.TrackBatchResult
py::object track_batch(const BvhTrackCommand& track, const std::vector<std::string>& inputs,
                       const TrackBatchOptions& options);
void bind_track_batch_result(py::module_& m);

}  // namespace stance::python
