// LQR balance about a static pose on one foot or several (after DeepMind's humanoid LQR
// tutorial, seed 002):
//
//  1. set-point: the target pose with qacc = 0, the root shifted along the up axis until inverse
//     dynamics needs no fictitious vertical root force (bracket, then Brent's method); when the
//     root still needs more than root_tolerance_N (a two-foot stance whose COM is not where the
//     flat feet's pressure puts it), the whole body is also tilted about the stance feet's centre
//     (Gauss-Newton on height and two tilts) so that the contacts carry it. Then
//     ctrl0 = pinv(actuator_moment)^T qfrc0, checked by forward dynamics. A set-point that leaves
//     more than max_root_residual_N on the root, or that rests on a body that is not a stance
//     foot, is an error naming the force and the feet;
//  2. cost: Q = blkdiag(balance_cost (J_com - J_feet)^T (J_com - J_feet) + Q_joint, 0) + eps I,
//     R = I, with J_com the subtree-COM Jacobian of the root body and J_feet the mean COM
//     Jacobian of the stance feet;
//  3. A, B by centred finite differences of one step;
//  4. the DARE (math/dare.h) and K = (R + B'PB)^-1 B'PA;
//  5. per step, ctrl = ctrl0 - K [q (-) q0; v], allocation-free.
//
// The controller is engine-agnostic: the set-point and the linearisation use the engine
// interface's inverse dynamics, actuator moments, Jacobians and steps (control/lqr_design.cc).
// They need actuators, so the design runs on MuJoCo only (DART models have none).
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"

namespace stance {

struct LqrParams {
  std::string root_body = "torso";  // its subtree COM is balanced; has the free joint
  // the COM is kept above the centre of these bodies' COMs: a body name, several separated by
  // commas, or "left", "right", "both" (the bodies named like a foot on that side; where no body
  // is named a foot, the lowest body named on that side)
  std::string stance_foot = "left_foot";
  double balance_cost = 1000;     // weight of |COM - foot| (m^-2)
  double balance_joint_cost = 3;  // stance leg and abdomen (rad^-2)
  double other_joint_cost = 0.3;  // all other non-root joints (rad^-2)
  // dofs with balance_joint_cost: regular expressions matched against whole dof names
  std::vector<std::string> balance_dofs = {"abdomen_.*", "left_(hip_.*|knee|ankle_.*)"};
  double velocity_cost = 1e-10;       // eps I on the whole of Q (the velocity block is 0 otherwise)
  double fd_eps = 1e-6;               // finite-difference perturbation
  double offset_tolerance_m = 1e-9;   // height offset bracket width at convergence
  double offset_first_step_m = 1e-4;  // first bracketing step, doubled until the sign changes
  double root_tolerance_N = 0.1;      // above it after the height search: tilt the pose too
  double max_root_residual_N = 5;     // a set-point leaving more on the root is an error
  bool feedback = true;               // false: ctrl0 only (shows that the pose is unstable)
  bool force_plot = false;  // write force_offset.png with gnuplot (force_offset.csv always)

  template <class V>
  void visit(V& v) {
    v("root_body", root_body, {.help = "body whose subtree COM is balanced (free joint)"});
    v("stance_foot", stance_foot,
      {.help = "body (or a,b or left, right, both) the COM is kept above"});
    v("balance_cost", balance_cost, {.unit = "1/m^2", .min = 0, .max = 1e9});
    v("balance_joint_cost", balance_joint_cost, {.unit = "1/rad^2", .min = 0, .max = 1e9});
    v("other_joint_cost", other_joint_cost, {.unit = "1/rad^2", .min = 0, .max = 1e9});
    v("balance_dofs", balance_dofs, {.help = "regexes of dofs with balance_joint_cost"});
    v("velocity_cost", velocity_cost, {.min = 0, .max = 1e3, .help = "eps I added to Q"});
    v("fd_eps", fd_eps, {.min = 1e-12, .max = 1e-2, .help = "finite-difference step"});
    v("offset_tolerance_m", offset_tolerance_m, {.unit = "m", .min = 1e-15, .max = 1e-6});
    v("offset_first_step_m", offset_first_step_m, {.unit = "m", .min = 1e-9, .max = 0.1});
    v("root_tolerance_N", root_tolerance_N,
      {.unit = "N", .min = 1e-9, .max = 1e3, .help = "root force left before the pose is tilted"});
    v("max_root_residual_N", max_root_residual_N,
      {.unit = "N", .min = 0, .max = 1e6, .help = "largest root force the set-point may leave"});
    v("feedback", feedback, {.help = "false: open loop ctrl0"});
    v("force_plot", force_plot, {.help = "write force_offset.png (needs gnuplot)"});
  }
};

// the static operating point
struct LqrSetPoint {
  Eigen::VectorXd q0;                    // dim nq: the pose with the root height offset
  Eigen::VectorXd qfrc0;                 // dim nv: inverse dynamics forces at q0, qacc = 0
  Eigen::VectorXd ctrl0;                 // dim nu: pinv(actuator_moment)^T qfrc0
  double height_offset_m = 0;            // root shift along the up axis
  double residual_vertical_force_N = 0;  // up-axis root force left at the offset
  double weight_N = 0;                   // total mass times |g|
  int offset_evaluations = 0;            // inverse-dynamics calls of the search
  double mismatch_actuated_N = 0;        // max |qfrc_actuator(ctrl0) - qfrc0| on actuated dofs
  double mismatch_root_N = 0;            // max |qfrc_actuator(ctrl0) - qfrc0| on root dofs
  double root_residual_N = 0;            // max |qfrc0| on the root dofs (what no motor gives)
  Eigen::Vector2d tilt_rad = Eigen::Vector2d::Zero();  // about two horizontal axes at the feet
  int tilt_iterations = 0;                             // Gauss-Newton steps; 0: not tilted
  // the body other than the stance feet (and their children) that carries the most contact
  // force at the set-point, and that force's component along up; empty: none touches
  std::string other_support_body;
  double other_support_force_N = 0;
  // the force-versus-offset curve around the solution, for the plot
  std::vector<double> curve_offset_m, curve_force_N;
};

// the linear model at the set-point
struct LqrPlant {
  Eigen::MatrixXd jac_com;   // 3 x nv: subtree COM of the root body
  Eigen::MatrixXd jac_foot;  // 3 x nv: mean COM of the stance feet
  Eigen::MatrixXd A;         // 2nv x 2nv: d x+/d x, x = [dq; v]
  Eigen::MatrixXd B;         // 2nv x nu: d x+/d ctrl
};

struct LqrDesign {
  LqrSetPoint setpoint;
  LqrPlant plant;
  Eigen::MatrixXd Q;                                   // 2nv x 2nv
  Eigen::MatrixXd R;                                   // nu x nu
  Eigen::MatrixXd K;                                   // nu x 2nv, ctrl = ctrl0 - K x
  double dare_residual = 0;                            // relative DARE residual
  double spectral_radius = 0;                          // of A - BK
  std::vector<int> balance_dofs;                       // dofs with balance_joint_cost
  std::vector<std::string> actuator_names, dof_names;  // rows and (half the) columns of K
  std::vector<int> foot_bodies;                        // engine body indices of the feet
  double setpoint_ms = 0, linearize_ms = 0, dare_ms = 0, design_ms = 0;  // wall times
};

// the stance feet that params.stance_foot names, in order, without repeats; throws InputError
// naming the bodies it saw when a name or a side is not found
std::vector<int> find_stance_feet(const std::string& stance_foot, const Engine& engine);

// the design's steps (control/lqr_design.cc). `engine` is at the target pose; they move it and
// restore its state on return. Throw InputError for unknown bodies, a root without a free
// joint, no sign change of the vertical force, or a model without actuators (DART).
LqrSetPoint find_lqr_setpoint(const LqrParams& params, Engine& engine);
// throws InputError when the set-point leaves more than max_root_residual_N on the root or
// rests more than that on a body that is not a stance foot, naming the force and the feet
void check_lqr_setpoint(const LqrParams& params, const Engine& engine, const LqrSetPoint& sp);
void linearize_lqr_plant(const LqrParams& params, Engine& engine, const LqrSetPoint& sp,
                         LqrPlant& plant);

// Q (2nv x 2nv) from the Jacobians and the dof classes: root dofs 0, balance_dofs
// balance_joint_cost, other dofs other_joint_cost; velocity block 0; plus velocity_cost I.
Eigen::MatrixXd lqr_state_cost(const LqrParams& params, const Eigen::MatrixXd& jac_com,
                               const Eigen::MatrixXd& jac_foot, const std::vector<bool>& is_root,
                               const std::vector<int>& balance_dofs);
// dofs whose names fully match one of the patterns; throws InputError on a bad regex
std::vector<int> match_dofs(const Engine& engine, const std::vector<std::string>& patterns);

// the whole pipeline; throws InputError when the DARE fails
LqrDesign design_lqr(const LqrParams& params, Engine& engine);
// how many designs this process has made (design_lqr calls that got as far as the set-point):
// a sweep that reuses one model designs once
long lqr_designs_made();
// the same on the context's scratch engine put at `engine`'s pose: the run's engine is not moved
LqrDesign design_lqr(const LqrParams& params, const ControllerContext& ctx, const Engine& engine);

// a root of f in [a, b] by Brent's method, given f(a) f(b) <= 0; stops when the bracket is
// narrower than tol. Returns the end of the final bracket with the smaller |f|.
struct RootResult {
  double x = 0, fx = 0;
  double bracket_width = 0;
  int evaluations = 0;
};
RootResult find_root_brent(const std::function<double(double)>& f, double a, double b, double fa,
                           double fb, double tol, int max_evaluations = 200);

// the runtime's per-run state: work vectors and the metrics of one run
struct LqrState {
  Eigen::VectorXd q;  // nq
  Eigen::VectorXd x;  // 2nv: [dq; v]
  Eigen::VectorXd u;  // nu: K x
  double com_foot_distance_m = 0;
  double max_com_foot_distance_m = 0;
  double compute_ns_sum = 0;
  long computes = 0;

  void resize(int nq, int nv, int nu);
  template <class A>
  void serialize(A& a) {
    a(q), a(x), a(u), a(com_foot_distance_m), a(max_com_foot_distance_m), a(compute_ns_sum),
        a(computes);
  }
};

// the mean of the feet's COMs (world); allocation-free
Eigen::Vector3d feet_centre(const Engine& engine, const std::vector<int>& feet);

// writes ctrl0 - K [q (-) q0; v] into out.ctrl
void compute_lqr(const LqrDesign& design, bool feedback, LqrState& s, const Engine& engine,
                 ControlOutput& out);

// the model is the design, made once in the constructor (on ctx.scratch_engine, at `engine`'s
// pose) and shared by every run; a run's State is LqrState
class Lqr final : public TypedController<LqrState, Reporting, Retunable> {
 public:
  Lqr(const LqrParams& params, const ControllerContext& ctx, const Engine& engine);
  std::string_view type() const override { return "lqr"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }
  std::vector<ParamEntry> tunable_params() const override;
  // a rebuild designs the LQR again (linearisation and DARE): seconds on a large model
  bool slow_to_rebuild() const override { return true; }

  const LqrParams& params() const { return params_; }
  const LqrDesign& design() const { return design_; }

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;
  // K.csv, force_offset.csv and (force_plot) force_offset.png
  void write_outputs(const ControllerState& state, const std::string& out_dir) const override;

 protected:
  void reset_state(LqrState& state, const Engine& engine) const override;
  void compute_step(LqrState& state, const Engine& engine, ControlOutput& out) const override;

 private:
  const LqrParams params_;
  const LqrDesign design_;
};

// the force-versus-offset plot: a CSV and a gnuplot PNG with the weight line and the chosen
// offset. Throws InputError when gnuplot is missing or fails.
void write_force_offset_csv(const LqrSetPoint& sp, const std::string& csv_path);
void plot_force_offset(const LqrSetPoint& sp, const std::string& csv_path,
                       const std::string& png_path);

}  // namespace stance
