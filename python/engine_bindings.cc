// stance.Engine and its value types: the library's Engine interface (MuJoCo or DART) as Python
// sees it. Positions and velocities read as numpy arrays, writes go through setters.
#include <fmt/format.h>

#include <cmath>
#include <mutex>
#include <optional>

#include "bindings.h"
#include "core/error.h"
#include "core/timestep.h"
#include "engine/world_spec.h"

namespace stance::python {
namespace {

std::unique_ptr<Engine> load_engine(const PathArg& path, const std::string& engine,
                                    std::optional<double> timestep,
                                    std::optional<Eigen::Vector3d> gravity) {
  WorldSpec spec;
  spec.models.push_back({path.string(), Eigen::Vector3d::Zero()});
  spec.timestep = timestep;
  spec.gravity = gravity;
  std::lock_guard<std::mutex> lock(model_load_mutex());
  auto e = make_engine(engine, spec);
  e->forward();
  return e;
}

// JointType, JointInfo, Contact, EngineState
void bind_engine_values(py::module_& m) {
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
}

// loading, sizes, the state and its setters
void add_engine_state(py::class_<Engine>& c) {
  c.def_static("load", &load_engine, py::arg("path"), py::arg("engine") = "mujoco",
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
          py::arg("q"), py::arg("v"), py::arg("dt") = 1.0, "q (+) v dt, dim nq");
}

// names and indices, dynamics
void add_engine_dynamics(py::class_<Engine>& c) {
  c.def_property_readonly("dof_names", &Engine::dof_names, "dim nv")
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
          "constraint forces it implies, as mj_inverse; DART: M vdot + bias)");
}

// kinematics and contacts
void add_engine_kinematics(py::class_<Engine>& c) {
  c.def("com", &Engine::com, "COM of the mobile bodies (world)")
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
          py::arg("body"));
}

// inputs (forces, controls, servos), keyframes, saved states
void add_engine_inputs(py::class_<Engine>& c) {
  c.def(
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
}

}  // namespace

void bind_engine(py::module_& m) {
  bind_engine_values(m);
  py::class_<Engine> c(m, "Engine",
                       R"(One physics engine (MuJoCo or DART) behind stance's interface.

Dimensions: q has nq entries, v has nv (nq = nv + 1 per free joint on MuJoCo, whose free joint
stores a quaternion); never subtract positions, use difference_positions / integrate_positions.
Arrays returned by methods are new float64 numpy arrays. `q` and `v` are read-only: on MuJoCo
they are views of the engine's own storage (they follow every step and set_q); on DART each
access returns a fresh copy. Write through set_q / set_v, which keep the engine's caches right.
Bodies, dofs and joints are given by name or index. Dynamics quantities are valid after
forward(); a simulation's engine is always forwarded between steps.)");
  add_engine_state(c);
  add_engine_dynamics(c);
  add_engine_kinematics(c);
  add_engine_inputs(c);
}

}  // namespace stance::python
