// stance.InputError (a ValueError: bad input, the CLI's exit code 2) and stance.DivergenceError
// (a RuntimeError: the CLI's exit code 3, with the run's .result)
#include <fmt/format.h>

#include "bindings.h"
#include "core/error.h"

namespace stance::python {
namespace {

// stance.DivergenceError, made in the module's init and never freed (a py::object here would be
// released after the interpreter is gone)
PyObject* divergence_error_type = nullptr;

}  // namespace

void bind_errors(py::module_& m) {
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

}  // namespace stance::python
