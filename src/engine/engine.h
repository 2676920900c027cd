// The one engine interface. Controllers and scenarios see physics only through this class;
// no controller includes a MuJoCo or DART header.
//
// Conventions shared by both backends:
//  - generalised positions q (dim nq) and velocities v (dim nv). nq != nv when a model has free
//    or ball joints (MuJoCo stores quaternions). Never subtract positions directly: use
//    difference_positions / integrate_positions.
//  - every "dof" has a name. Single-dof joints use the joint name; multi-dof joints use the
//    DART suffixes: free "<j>_rot_x.._rot_z", "<j>_pos_x.._pos_z"; ball "<j>_x.._z"; euler
//    "<j>_<axis>"; universal "<j>_1", "<j>_2". Dof order inside q/v is the backend's own: look
//    indices up by name.
//  - forces: M(q) v' + bias(q, v) = tau_applied + tau_constraint + J^T f_ext.
//  - all vectors and points are in the world frame unless the name says otherwise.
//  - per-step inputs (generalised forces, external body forces) are consumed by the next step()
//    and then cleared; actuator controls persist until changed.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

// MuJoCo's model and data (mujoco/mjmodel.h, mjdata.h), named for drawing only
struct mjModel_;
struct mjData_;

namespace stance {

enum class JointType { kFree, kBall, kHinge, kSlide };

struct JointInfo {
  std::string name;
  JointType type = JointType::kHinge;
  int body = -1;      // child body index
  int qpos_adr = -1;  // first index in q
  int dof_adr = -1;   // first index in v
  int nq = 0;
  int nv = 0;
  bool has_limits = false;
  double lower = 0, upper = 0;  // hinge/slide only
  // the largest |generalised force| the model allows on each of the joint's dofs (N m or N):
  // a URDF/SDF effort limit (DART's joint force limit), or on MuJoCo the sum over the joint's
  // force-limited actuators of |gear| x max |ctrlrange|; infinite: no limit
  double force_limit = std::numeric_limits<double>::infinity();
};

struct BodyPose {
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  Eigen::Quaterniond quat = Eigen::Quaterniond::Identity();
};

struct Contact {
  int body1 = -1;  // -1: the world or an immobile body
  int body2 = -1;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // from body1 to body2
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // on body2, world frame
};

// the constraint solver's effort (MuJoCo's mjOption), for a cheaper planning model: a field at
// its default keeps the model file's own setting
struct SolverSettings {
  int iterations = 0;          // main solver iterations; 0: the model's
  double tolerance = -1;       // early termination tolerance; < 0: the model's
  int noslip_iterations = -1;  // noslip iterations (0: off); -1: the model's
  std::string solver;          // "pgs", "cg" or "newton"; empty: the model's
  std::string cone;            // "pyramidal" or "elliptic"; empty: the model's
  bool any() const {
    return iterations > 0 || tolerance >= 0 || noslip_iterations >= 0 || !solver.empty() ||
           !cone.empty();
  }
};

// full simulation state, restorable bit-exactly on the same engine.
struct EngineState {
  double time = 0;
  Eigen::VectorXd q, v, act, ctrl;
  // backend data a continued run depends on (MuJoCo: the solver's warm start and the last
  // step's constraint forces); empty: a cold start
  std::vector<double> extra;
};

// what MuJoCo's renderer (mjv_updateScene, mjv_addGeoms, mj_ray) draws an engine's world from
struct RenderModel {
  mjModel_* model = nullptr;  // its visual settings (vis, quality) may be changed by the renderer
  mjData_* data = nullptr;    // body, geom and site frames of the engine's current state
  // the model's body id of each engine body, dim nbody(); -1: not drawn
  const std::vector<int>* body_ids = nullptr;
};

class Engine {
 public:
  virtual ~Engine() = default;

  virtual std::string_view engine_name() const = 0;  // "mujoco" or "dart"

  // sizes. Bodies exclude the world and immobile bodies.
  virtual int nq() const = 0;
  virtual int nv() const = 0;
  virtual int nu() const = 0;
  virtual int nbody() const = 0;
  virtual int njoint() const = 0;
  virtual double total_mass() const = 0;  // of the mobile bodies, kg

  // names and lookup; lookups return -1 when absent (see require_* below for errors).
  virtual int body_index(std::string_view name) const = 0;
  virtual int joint_index(std::string_view name) const = 0;
  virtual int dof_index(std::string_view name) const = 0;  // index into v
  virtual int actuator_index(std::string_view name) const = 0;
  virtual const std::string& body_name(int body) const = 0;
  virtual const std::string& dof_name(int dof) const = 0;
  virtual const std::string& actuator_name(int actuator) const = 0;
  virtual const JointInfo& joint(int joint) const = 0;
  virtual int dof_joint(int dof) const = 0;  // joint owning dof
  virtual double body_mass(int body) const = 0;
  // the body this one hangs from; -1 for the world (or a body fixed to it)
  virtual int body_parent(int body) const = 0;

  // state
  virtual double time() const = 0;
  virtual double timestep() const = 0;
  virtual void set_timestep(double dt) = 0;
  // the solver's settings in use (DART: the defaults, meaning its own solver's); setting them
  // changes only this engine's copy of the model. DART keeps its solver and returns false.
  // Throws InputError for a solver or cone name the engine does not know.
  virtual SolverSettings solver_settings() const { return {}; }
  virtual bool set_solver_settings(const SolverSettings&) { return false; }
  virtual Eigen::Vector3d gravity() const = 0;
  virtual void set_gravity(const Eigen::Vector3d& g) = 0;
  virtual void get_positions(Eigen::Ref<Eigen::VectorXd> q) const = 0;   // dim nq
  virtual void get_velocities(Eigen::Ref<Eigen::VectorXd> v) const = 0;  // dim nv
  // the engine's own storage of q (dim nq) and v (dim nv) when it is one contiguous array that
  // lives as long as the engine (MuJoCo's qpos/qvel), for zero-copy read-only views (the Python
  // module's engine.q); null when there is none (DART: per-skeleton storage). Read only.
  virtual const double* positions_data() const { return nullptr; }
  virtual const double* velocities_data() const { return nullptr; }
  virtual void set_positions(const Eigen::Ref<const Eigen::VectorXd>& q) = 0;
  virtual void set_velocities(const Eigen::Ref<const Eigen::VectorXd>& v) = 0;
  virtual double dof_position(int dof) const = 0;  // hinge/slide dofs only
  virtual double dof_velocity(int dof) const = 0;
  // set one named coordinate. For free/ball rotation dofs the three values are a rotation
  // vector (exponential coordinates, as DART stores them); backends convert.
  virtual void set_dof_position(int dof, double value) = 0;

  // position algebra: v = q1 (-) q0, such that integrate(q0, v, 1) == q1. dims nq, nq -> nv.
  virtual void difference_positions(const Eigen::Ref<const Eigen::VectorXd>& q0,
                                    const Eigen::Ref<const Eigen::VectorXd>& q1,
                                    Eigen::Ref<Eigen::VectorXd> v) const = 0;
  // q_out = q (+) v*dt. dims nq, nv -> nq.
  virtual void integrate_positions(const Eigen::Ref<const Eigen::VectorXd>& q,
                                   const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                                   Eigen::Ref<Eigen::VectorXd> q_out) const = 0;

  // dynamics, valid after forward(). Mass matrix M is nv x nv.
  virtual void forward() = 0;
  virtual void mass_matrix(Eigen::Ref<Eigen::MatrixXd> m) const = 0;
  // x <- M^-1 x using the engine's own factorisation. dim nv.
  virtual void solve_mass(Eigen::Ref<Eigen::VectorXd> x) const = 0;
  // x <- (M + diag(d))^-1 x, dims nv (stable PD's solve). The default factors a dense copy;
  // MuJoCo refactors its sparse tree factorisation with the shifted diagonal instead.
  virtual void solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                                  Eigen::Ref<Eigen::VectorXd> x) const;
  virtual void bias_forces(Eigen::Ref<Eigen::VectorXd> c) const = 0;        // Coriolis + gravity
  virtual void constraint_forces(Eigen::Ref<Eigen::VectorXd> f) const = 0;  // last step's
  // inverse dynamics at the current q and v: the generalised force tau (dim nv) that, applied
  // together with nothing else, gives the acceleration vdot (dim nv). MuJoCo computes it as
  // mj_inverse does, tau = M vdot + bias - passive - the constraint forces this vdot implies
  // (soft contacts and limits); DART as M vdot + bias (no contact or limit forces). The
  // simulation state, its constraint forces included, is unchanged.
  virtual void inverse_dynamics(const Eigen::Ref<const Eigen::VectorXd>& vdot,
                                Eigen::Ref<Eigen::VectorXd> tau) const = 0;

  // kinematics, valid after forward().
  virtual Eigen::Vector3d com() const = 0;           // of the mobile bodies
  virtual Eigen::Vector3d com_velocity() const = 0;  // of the mobile bodies
  virtual BodyPose body_pose(int body) const = 0;
  virtual Eigen::Vector3d body_com(int body) const = 0;  // world position of body's COM
  // spatial velocity of the body frame origin: (angular, linear), world frame.
  virtual Eigen::Matrix<double, 6, 1> body_velocity(int body) const = 0;
  // Jacobians w.r.t. v. jac_pos is 3 x nv (point fixed to body, given in world coordinates),
  // jac_rot is 3 x nv. Either may be empty (0 columns) to skip.
  virtual void point_jacobian(int body, const Eigen::Vector3d& point_world,
                              Eigen::Ref<Eigen::MatrixXd> jac_pos,
                              Eigen::Ref<Eigen::MatrixXd> jac_rot) const = 0;
  // Jacobian of the COM of all mobile bodies, 3 x nv.
  virtual void com_jacobian(Eigen::Ref<Eigen::MatrixXd> jac) const = 0;
  // Jacobian of the COM of `body` and all bodies below it, 3 x nv (MuJoCo's mj_jacSubtreeCom).
  virtual void subtree_com_jacobian(int body, Eigen::Ref<Eigen::MatrixXd> jac) const = 0;
  // world position of that subtree's COM
  virtual Eigen::Vector3d subtree_com(int body) const = 0;

  // contacts, valid after step() (forces) or forward() (geometry)
  virtual int num_contacts() const = 0;
  virtual Contact contact(int i) const = 0;
  // true when body touches anything (the ground, another body)
  bool body_in_contact(int body) const;
  // true when body touches the world or an immobile body
  bool body_touches_ground(int body) const;

  // inputs for the next step
  virtual void set_generalized_forces(const Eigen::Ref<const Eigen::VectorXd>& tau) = 0;
  virtual void set_controls(const Eigen::Ref<const Eigen::VectorXd>& ctrl) = 0;  // dim nu
  virtual void get_controls(Eigen::Ref<Eigen::VectorXd> ctrl) const = 0;
  // the actuators' moment matrix at the current state, nu x nv: the generalised force of the
  // controls is moment^T ctrl (transmission and gear times the fixed gain; plus the bias of
  // servo-like actuators; within control limits). Valid after forward(). Throws InputError on
  // engines without actuators (DART) and for actuators without a fixed gain.
  virtual void actuator_moment(Eigen::Ref<Eigen::MatrixXd> moment) const = 0;
  // force (N, world) at a world point fixed to the body.
  virtual void apply_external_force(int body, const Eigen::Vector3d& force_world,
                                    const Eigen::Vector3d& point_world) = 0;
  // velocity servo on a hinge/slide dof (e.g. skateboard wheels); NaN disables it.
  virtual void set_dof_velocity_command(int dof, double velocity) = 0;

  // keyframes stored in the model file (MuJoCo's <key>), by name. apply_keyframe sets the
  // time, q, v, activations and controls to the keyframe's and clears the per-step inputs; it
  // throws InputError for an unknown name (suggesting the nearest) and on engines without
  // keyframes (DART).
  virtual std::vector<std::string> keyframe_names() const { return {}; }
  virtual void apply_keyframe(std::string_view name);

  // state save/restore (finite differences, replay)
  virtual void save_state(EngineState& s) const = 0;
  virtual void restore_state(const EngineState& s) = 0;

  // advance one timestep, consuming the per-step inputs.
  virtual void step() = 0;

  // checks after a step: false when the state has a NaN/Inf or the engine reported instability
  virtual bool state_is_finite() const = 0;
  virtual std::string last_warning() const { return {}; }
  // what the backend changed in the model as it loaded it, for one note line; empty: nothing
  virtual std::string load_note() const { return {}; }

  // drawing (src/viz), after forward(). MuJoCo: its own model and data. Other engines (DART): a
  // MuJoCo copy of the same world that only draws, posed body by body on each call; the first
  // call loads it (hold the model loading lock). Empty when the engine cannot be drawn.
  virtual RenderModel render_model() { return {}; }
  // the generalised forces (dim nv) the last step applied at the joints besides the
  // constraints': the controls, servos and tau (and J^T of a push on a limb). False when the
  // engine does not tell them (DART: the caller knows the tau it gave).
  virtual bool applied_joint_forces(Eigen::Ref<Eigen::VectorXd> tau) const { return false; }

  // lookups that throw InputError naming the missing item and suggesting the nearest
  int require_body(std::string_view name) const;
  int require_dof(std::string_view name) const;
  int require_joint(std::string_view name) const;
  int require_actuator(std::string_view name) const;
  std::vector<std::string> body_names() const;
  std::vector<std::string> dof_names() const;
  std::vector<std::string> actuator_names() const;

  // the joints with a free/root role (dofs a PD on joints should leave alone)
  bool dof_is_root(int dof) const;

 private:
  // scratch of the default solve_mass_shifted, sized on first use
  mutable Eigen::MatrixXd shifted_mass_;
  mutable Eigen::LLT<Eigen::MatrixXd> shifted_llt_;
};

}  // namespace stance
