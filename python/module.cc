// The Python module's native part, stance._stance: a thin layer over the library. Scenarios load
// and run through Simulation, engines through the Engine interface, the maths through the free
// functions; nothing here computes physics or control itself. python/stance/__init__.py
// re-exports it with the Python-side helpers. Each group of bindings is its own file
// (bindings.h); the order below is the order types become known to the signatures.
#include "bindings.h"

PYBIND11_MODULE(_stance, m) {
  using namespace stance::python;
  m.doc() = "stance's native module: see help(stance)";
  bind_errors(m);
  bind_engine(m);
  bind_control_output(m);
  bind_simulation(m);
  bind_view(m);
  bind_maths(m);
  bind_batch(m);
  bind_bvh(m);
}
