// Stable PD (Tan, Liu and Turk 2011) and plain PD with the same parameters, for comparison.
//
//   p   = -Kp (q + v dt (-) q_target)
//   d   = -Kd v
//   v'  = (M + Kd dt)^-1 (-C + p + d + tau_constraint)
//   tau = p + d - Kd v' dt
//
// Root (free-joint) dofs get zero gains. Positions are differenced by the engine, so ball and
// free joints are handled; when only hinges and slides have gains the error is taken per dof. M +
// Kd dt is solved by Engine::solve_mass_shifted (MuJoCo: its sparse factorisation; otherwise a
// dense Cholesky whose storage is made once): no allocation per step. The solve is
// stable_pd_torque (control/pose_tracking.h), the one the motion-capture tracker uses.
#pragma once

#include <Eigen/Cholesky>

#include "control/controller.h"
#include "control/pose_tracking.h"
#include "engine/engine.h"

namespace stance {

struct JointPdParams {
  double kp = 400;                     // N m/rad (N/m on slides)
  double kd = 40;                      // N m s/rad
  NamedValues kp_dofs;                 // per-dof overrides of kp
  NamedValues kd_dofs;                 // per-dof overrides of kd
  std::vector<std::string> free_dofs;  // dofs left alone (zero gains), e.g. skateboard wheels
  NamedValues target;                  // dof -> target; unnamed dofs hold their initial value
  bool constraint_forces = true;       // include last step's constraint forces (SPD only)
  double max_torque = 0;               // N m, symmetric clamp; 0: none
  // the planner's hook: hinge/slide dofs whose targets it may offset, by `planner_scale` per unit
  std::vector<std::string> planner_dofs;
  double planner_scale = 0.1;  // rad (m on slides)

  template <class V>
  void visit(V& v) {
    v("kp", kp, {.unit = "N m/rad", .min = 0, .max = 1e7, .help = "position gain, non-root dofs"});
    v("kd", kd, {.unit = "N m s/rad", .min = 0, .max = 1e6, .help = "velocity gain"});
    v("kp_dofs", kp_dofs, {.unit = "N m/rad", .help = "per-dof kp overrides"});
    v("kd_dofs", kd_dofs, {.unit = "N m s/rad", .help = "per-dof kd overrides"});
    v("free_dofs", free_dofs, {.help = "dofs with zero gains"});
    v("target", target, {.unit = "rad or m", .help = "target pose; default: the initial pose"});
    v("constraint_forces", constraint_forces, {.help = "SPD: include constraint forces"});
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "torque clamp; 0: none"});
    v("planner_dofs", planner_dofs, {.help = "dofs whose targets the planner offsets"});
    v("planner_scale", planner_scale,
      {.unit = "rad or m", .min = 0, .max = 10, .help = "planner target offset per unit"});
  }
};

// the Model shared by SPD and PD: gains per dof, fixed once built
struct JointPdModel {
  JointPdParams params;
  Eigen::VectorXd kp, kd;                       // dim nv; zero on root and free dofs
  std::vector<std::pair<int, double>> targets;  // (qpos index, value) for named targets
  // when every dof with a gain is a hinge or slide, its position error is q[adr] - q_target[adr]
  // and the engine's manifold difference (ball and free joints) can be skipped
  bool scalar_gains_only = false;
  std::vector<std::pair<int, int>> scalar_dofs;  // (dof, qpos index) of the dofs with a gain
  std::vector<int> planner_qpos;                 // qpos index per planner dof
};

JointPdModel make_joint_pd_model(const JointPdParams& params, const Engine& engine);

// the per-run data: the target pose captured at reset, work vectors, the error statistics
struct StablePdState {
  Eigen::VectorXd q_target, q, v, q_pred, err, tau;  // nq or nv
  Eigen::VectorXd q_planned;  // nq: the target with the planner's offsets, while computing
  StablePdWork solve;
  double last_error_norm = 0;  // rad, RMS over the controlled dofs
  double error_sq_sum = 0;     // rad^2, sum over steps of the mean squared error
  long error_samples = 0;

  void resize(int nq, int nv);
  template <class A>
  void serialize(A& a) {
    a(q_target), a(q), a(v), a(q_pred), a(err), a(tau), a(q_planned);
    a(last_error_norm), a(error_sq_sum), a(error_samples);
  }
};

// tau (dim nv) is added into out.tau
void compute_stable_pd(const JointPdModel& model, StablePdState& s, const Engine& engine,
                       ControlOutput& out);
void compute_plain_pd(const JointPdModel& model, StablePdState& s, const Engine& engine,
                      ControlOutput& out);

// SPD (kStable) or plain PD on the same Model: the registry's stable_pd and pd
template <bool kStable>
class JointPd final : public CorrectedController<StablePdState, Reporting, Retunable> {
 public:
  JointPd(const JointPdParams& params, const ControllerContext& ctx, const Engine& engine);
  std::string_view type() const override { return kStable ? "stable_pd" : "pd"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(model_.params, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(model_.params); }
  // one target offset per planner dof
  void correction_dims(std::vector<CorrectionDim>& dims) const override;
  // the named targets are captured into the State at reset: a State made for other targets
  // would hold the old ones
  bool keeps_state_of(const Controller& previous) const override;

  const JointPdModel& model() const { return model_; }

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  void compute_with(State& state, const Engine& engine, const double* correction,
                    ControlOutput& out) const override;

 private:
  JointPdModel model_;
};

using StablePd = JointPd<true>;
using PlainPd = JointPd<false>;
extern template class JointPd<true>;
extern template class JointPd<false>;

}  // namespace stance
