// The maths as free functions: finite-difference linearisation, the DARE, and the LQR design
// steps (set-point, state cost, gain) on an engine.
#include "analysis/finite_difference.h"
#include "bindings.h"
#include "control/lqr.h"
#include "math/dare.h"
#include "params/yaml_params.h"

namespace stance::python {
namespace {

LqrParams lqr_params(const py::kwargs& kw) {
  YAML::Node node = to_yaml(py::dict(kw));
  ControllerContext ctx;
  ctx.source = {"lqr"};
  return read_params<LqrParams>(node, ctx, {});
}

// a design step of the lqr controller at the engine's pose, the keyword arguments its parameters,
// the GIL released; the engine forwarded again after it
template <class Result, Result (*step)(const LqrParams&, Engine&)>
Result with_lqr_params(Engine& e, py::kwargs kw) {
  LqrParams p = lqr_params(kw);
  py::gil_scoped_release release;
  Result r = step(p, e);
  e.forward();
  return r;
}

// linearize_fd, linearize_fd_forces
void bind_linearization(py::module_& m) {
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
}

// solve_dare, spectral_radius
void bind_dare(py::module_& m) {
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
}

// the LQR design and its steps
void bind_lqr(py::module_& m) {
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
  m.def("find_lqr_setpoint", &with_lqr_params<LqrSetPoint, &find_lqr_setpoint>, py::arg("engine"),
        "the lqr controller's set-point search at the engine's pose; keyword arguments are the "
        "lqr controller's parameters (root_body, stance_foot, ...)");
  m.def("design_lqr", &with_lqr_params<LqrDesign, &design_lqr>, py::arg("engine"),
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
  m.def(
      "plot_force_offset",
      [](const LqrSetPoint& setpoint, const PathArg& csv, const PathArg& png) {
        plot_force_offset(setpoint, csv.string(), png.string());
      },
      py::arg("setpoint"), py::arg("csv_path"), py::arg("png_path"),
      "the set-point's force-against-offset plot with gnuplot");
}

}  // namespace

void bind_maths(py::module_& m) {
  bind_linearization(m);
  bind_dare(m);
  bind_lqr(m);
}

}  // namespace stance::python
