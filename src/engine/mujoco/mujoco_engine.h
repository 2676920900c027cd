// MuJoCo backend of the engine interface. Only src/engine/mujoco and the renderer (src/viz),
// which needs MuJoCo's own API, include this header; everything else sees the Engine.
#pragma once

#include <mujoco/mujoco.h>

#include <string>
#include <vector>

#include "engine/backend_world.h"
#include "engine/engine.h"
#include "engine/mujoco/tree_ldl.h"

namespace stance {

class MujocoEngine final : public Engine {
 public:
  // takes ownership of model; `source` names the file for messages
  MujocoEngine(mjModel* model, std::string source);
  ~MujocoEngine() override;
  // each joint's force limit the tighter of its own and limits[joint] (dim njoint)
  void tighten_force_limits(const std::vector<double>& limits);
  MujocoEngine(const MujocoEngine&) = delete;
  MujocoEngine& operator=(const MujocoEngine&) = delete;

  std::string_view engine_name() const override { return "mujoco"; }
  int nq() const override { return m_->nq; }
  int nv() const override { return m_->nv; }
  int nu() const override { return m_->nu; }
  int nbody() const override { return static_cast<int>(mobile_bodies_.size()); }
  int njoint() const override { return static_cast<int>(joints_.size()); }
  double total_mass() const override { return total_mass_; }

  int body_index(std::string_view name) const override;
  int joint_index(std::string_view name) const override;
  int dof_index(std::string_view name) const override;
  int actuator_index(std::string_view name) const override;
  const std::string& body_name(int body) const override { return body_names_[body]; }
  const std::string& dof_name(int dof) const override { return dof_names_[dof]; }
  const std::string& actuator_name(int a) const override { return actuator_names_[a]; }
  const JointInfo& joint(int j) const override { return joints_[j]; }
  int dof_joint(int dof) const override { return m_->dof_jntid[dof]; }
  double body_mass(int body) const override { return m_->body_mass[mobile_bodies_[body]]; }
  int body_parent(int body) const override {
    return mj_to_body_[m_->body_parentid[mobile_bodies_[body]]];
  }

  double time() const override { return d_->time; }
  double timestep() const override { return m_->opt.timestep; }
  void set_timestep(double dt) override { m_->opt.timestep = dt; }
  SolverSettings solver_settings() const override;
  bool set_solver_settings(const SolverSettings& s) override;
  Eigen::Vector3d gravity() const override;
  void set_gravity(const Eigen::Vector3d& g) override;
  void get_positions(Eigen::Ref<Eigen::VectorXd> q) const override;
  void get_velocities(Eigen::Ref<Eigen::VectorXd> v) const override;
  const double* positions_data() const override { return d_->qpos; }
  const double* velocities_data() const override { return d_->qvel; }
  void set_positions(const Eigen::Ref<const Eigen::VectorXd>& q) override;
  void set_velocities(const Eigen::Ref<const Eigen::VectorXd>& v) override;
  double dof_position(int dof) const override;
  double dof_velocity(int dof) const override { return d_->qvel[dof]; }
  void set_dof_position(int dof, double value) override;
  void difference_positions(const Eigen::Ref<const Eigen::VectorXd>& q0,
                            const Eigen::Ref<const Eigen::VectorXd>& q1,
                            Eigen::Ref<Eigen::VectorXd> v) const override;
  void integrate_positions(const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                           Eigen::Ref<Eigen::VectorXd> q_out) const override;

  void forward() override;
  void mass_matrix(Eigen::Ref<Eigen::MatrixXd> m) const override;
  void solve_mass(Eigen::Ref<Eigen::VectorXd> x) const override;
  void solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                          Eigen::Ref<Eigen::VectorXd> x) const override;
  void bias_forces(Eigen::Ref<Eigen::VectorXd> c) const override;
  void constraint_forces(Eigen::Ref<Eigen::VectorXd> f) const override;
  void inverse_dynamics(const Eigen::Ref<const Eigen::VectorXd>& vdot,
                        Eigen::Ref<Eigen::VectorXd> tau) const override;

  Eigen::Vector3d com() const override;
  Eigen::Vector3d com_velocity() const override;
  BodyPose body_pose(int body) const override;
  Eigen::Vector3d body_com(int body) const override;
  Eigen::Matrix<double, 6, 1> body_velocity(int body) const override;
  void point_jacobian(int body, const Eigen::Vector3d& point_world,
                      Eigen::Ref<Eigen::MatrixXd> jac_pos,
                      Eigen::Ref<Eigen::MatrixXd> jac_rot) const override;
  void com_jacobian(Eigen::Ref<Eigen::MatrixXd> jac) const override;
  void subtree_com_jacobian(int body, Eigen::Ref<Eigen::MatrixXd> jac) const override;
  Eigen::Vector3d subtree_com(int body) const override;

  int num_contacts() const override { return d_->ncon; }
  Contact contact(int i) const override;

  void set_generalized_forces(const Eigen::Ref<const Eigen::VectorXd>& tau) override;
  void set_controls(const Eigen::Ref<const Eigen::VectorXd>& ctrl) override;
  void get_controls(Eigen::Ref<Eigen::VectorXd> ctrl) const override;
  void actuator_moment(Eigen::Ref<Eigen::MatrixXd> moment) const override;
  void apply_external_force(int body, const Eigen::Vector3d& force_world,
                            const Eigen::Vector3d& point_world) override;
  void set_dof_velocity_command(int dof, double velocity) override;

  std::vector<std::string> keyframe_names() const override;
  void apply_keyframe(std::string_view name) override;

  void save_state(EngineState& s) const override;
  void restore_state(const EngineState& s) override;
  void step() override;
  bool state_is_finite() const override;
  std::string last_warning() const override { return last_warning_; }
  std::string load_note() const override { return load_note_; }
  void set_load_note(std::string note) { load_note_ = std::move(note); }
  RenderModel render_model() override { return {m_, d_, &mobile_bodies_}; }
  bool applied_joint_forces(Eigen::Ref<Eigen::VectorXd> tau) const override;

  // MuJoCo's own structures, for code that needs MuJoCo-specific API
  const mjModel* model() const { return m_; }
  mjModel* mutable_model() { return m_; }
  mjData* data() const { return d_; }
  int mj_body_id(int body) const { return mobile_bodies_[body]; }
  int body_from_mj(int mj_body) const { return mj_to_body_[mj_body]; }

  // recompute derived quantities after the model's options changed (timestep, gravity, ...)
  void invalidate() { forwarded_ = false; }

 private:
  void build_tables();

  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  std::string source_;
  std::vector<int> mobile_bodies_;  // engine body index -> mj body id
  std::vector<int> mj_to_body_;     // mj body id -> engine body index or -1
  std::vector<std::string> body_names_, dof_names_, actuator_names_;
  std::vector<JointInfo> joints_;
  double total_mass_ = 0;
  bool forwarded_ = false;  // mj_step1 done for the current state
  // a restored state's last-step constraint forces, put back after the next mj_step1 (which
  // must not overwrite it)
  Eigen::VectorXd restored_constraint_;
  bool constraint_restored_ = false;
  // qpos as it was before the last mj_step1, which normalises quaternions in place: a saved
  // state holds these bits, so that restoring and forwarding again gives the same bits
  Eigen::VectorXd qpos_before_forward_;

  // per-step inputs and scratch, sized once
  Eigen::VectorXd pending_tau_;
  Eigen::VectorXd velocity_command_;  // NaN: none
  bool has_velocity_commands_ = false;
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jac_scratch_,
      jac_scratch2_;
  mutable std::vector<double> vec_scratch_;
  mutable TreeLdl shifted_mass_ldl_;  // M + diag(shift), apart from mjData's own factor
  // inverse dynamics runs on data of its own, so the simulation's constraint forces stay;
  // made on first use
  mutable mjData* inverse_data_ = nullptr;
  int warnings_seen_ = 0;
  bool diverged_ = false;
  std::string last_warning_;
  std::string load_note_;
};

// load the backend's input (one MJCF/URDF file, or MJCF text) into a MuJoCo model. Throws
// InputError with the file (and line, when MuJoCo reports one). Servo actuators (biastype affine on
// a joint) become torque motors within their forcerange; their count goes to *servos_made_motors.
mjModel* load_mujoco_model(const BackendWorld& world, int* servos_made_motors = nullptr);

}  // namespace stance
