// The LQR design's engine side: inverse dynamics for the set-point, the COM Jacobians and one
// step's A and B by finite differences, all through the engine interface. The design moves
// the engine it is given and puts it back; the controller gives it a scratch engine of the
// scenario's world, so the run's engine keeps its state.
#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <memory>

#include "analysis/finite_difference.h"
#include "control/lqr.h"
#include "core/error.h"

namespace stance {

namespace {

// the free joint of the root body: its qpos and dof addresses
struct RootJoint {
  int qpos_adr = -1;
  int dof_adr = -1;
};

RootJoint find_root_joint(const LqrParams& params, const Engine& engine) {
  int body = engine.body_index(params.root_body);
  if (body < 0)
    throw InputError(fmt::format("lqr: root_body: unknown body '{}'{}", params.root_body,
                                 did_you_mean(params.root_body, engine.body_names())));
  for (int j = 0; j < engine.njoint(); ++j) {
    const JointInfo& info = engine.joint(j);
    if (info.body == body && info.type == JointType::kFree) return {info.qpos_adr, info.dof_adr};
  }
  throw InputError(fmt::format("lqr: root_body '{}' has no free joint", params.root_body));
}

int require_body(const Engine& engine, const std::string& name, const char* what) {
  int body = engine.body_index(name);
  if (body < 0)
    throw InputError(fmt::format("lqr: {}: unknown body '{}'{}", what, name,
                                 did_you_mean(name, engine.body_names())));
  return body;
}

Eigen::Vector3d up_axis(const Engine& engine) {
  Eigen::Vector3d g = engine.gravity();
  if (g.norm() == 0) throw InputError("lqr: the set-point search needs gravity");
  return -g.normalized();
}

// puts the engine back into the state it had when the design started
struct StateGuard {
  Engine& engine;
  EngineState saved;
  explicit StateGuard(Engine& e) : engine(e) { engine.save_state(saved); }
  ~StateGuard() {
    engine.restore_state(saved);
    engine.forward();
  }
};

}  // namespace

LqrSetPoint find_lqr_setpoint(const LqrParams& params, Engine& engine) {
  const int nq = engine.nq(), nv = engine.nv(), nu = engine.nu();
  if (nu == 0)
    throw InputError(
        fmt::format("lqr: the model has no actuators (on the {} engine)", engine.engine_name()));
  StateGuard guard(engine);
  if (guard.saved.act.size() != 0)
    throw InputError("lqr: actuators with activation states are not supported");
  const RootJoint root = find_root_joint(params, engine);
  const Eigen::Vector3d up = up_axis(engine);

  LqrSetPoint sp;
  Eigen::VectorXd pose(nq), q(nq), tau(nv);
  const Eigen::VectorXd zero_v = Eigen::VectorXd::Zero(nv);
  engine.get_positions(pose);
  sp.weight_N = engine.total_mass() * engine.gravity().norm();
  engine.set_velocities(zero_v);
  engine.set_controls(Eigen::VectorXd::Zero(nu));

  // inverse dynamics at rest with the root shifted by h along up: the force lands in tau
  auto place = [&](double h) {
    q = pose;
    for (int k = 0; k < 3; ++k) q[root.qpos_adr + k] += h * up[k];
    engine.set_positions(q);
    engine.forward();
    engine.inverse_dynamics(zero_v, tau);
  };
  // the fictitious force along up on the root: positive when the body is held up by it
  auto vertical_force = [&](double h) {
    place(h);
    ++sp.offset_evaluations;
    return up.dot(tau.segment<3>(root.dof_adr));
  };

  // bracket: walk away from 0, doubling the step, in the direction that reduces the force
  double a = 0, fa = vertical_force(0);
  double step = fa > 0 ? -params.offset_first_step_m : params.offset_first_step_m;
  double b = a, fb = fa;
  const double max_offset = 0.5;  // m: beyond this the pose is not near the ground at all
  while (fb != 0 && (fb > 0) == (fa > 0)) {
    a = b;
    fa = fb;
    b = a + step;
    if (std::abs(b) > max_offset)
      throw InputError(fmt::format(
          "lqr: the vertical root force does not change sign within {} m of the pose (force "
          "{:.3g} N at {:+.4f} m): is the stance foot near the ground?",
          max_offset, fb, a));
    fb = vertical_force(b);
    step *= 2;
  }
  RootResult root_result = find_root_brent(vertical_force, a, b, fa, fb, params.offset_tolerance_m);
  sp.height_offset_m = root_result.x;
  sp.residual_vertical_force_N = root_result.fx;

  // the set-point itself
  place(sp.height_offset_m);
  sp.q0 = q;
  sp.qfrc0 = tau;
  Eigen::MatrixXd moment(nu, nv);
  engine.actuator_moment(moment);
  // least-squares, minimum-norm: the generalised force of ctrl is moment^T ctrl
  Eigen::MatrixXd moment_t = moment.transpose();
  sp.ctrl0 = moment_t.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(sp.qfrc0);

  // the actuator forces ctrl0 produces, against qfrc0
  const Eigen::VectorXd qfrc_actuator = moment_t * sp.ctrl0;
  for (int i = 0; i < nv; ++i) {
    double err = std::abs(qfrc_actuator[i] - sp.qfrc0[i]);
    bool is_root = i >= root.dof_adr && i < root.dof_adr + 6;
    bool actuated = moment.col(i).cwiseAbs().maxCoeff() > 0;
    if (is_root)
      sp.mismatch_root_N = std::max(sp.mismatch_root_N, err);
    else if (actuated)
      sp.mismatch_actuated_N = std::max(sp.mismatch_actuated_N, err);
  }

  // the curve for the plot: the seed's +-1 mm, widened to show the solution with margin
  const double half = std::max(1e-3, 2 * std::abs(sp.height_offset_m));
  const int samples = 401;
  for (int i = 0; i < samples; ++i) {
    double h = sp.height_offset_m - half + 2 * half * i / (samples - 1);
    place(h);
    sp.curve_offset_m.push_back(h);
    sp.curve_force_N.push_back(up.dot(tau.segment<3>(root.dof_adr)));
  }
  return sp;
}

void linearize_lqr_plant(const LqrParams& params, Engine& engine, const LqrSetPoint& sp,
                         LqrPlant& plant) {
  const int nv = engine.nv();
  const int root = require_body(engine, params.root_body, "root_body");
  const int foot = require_body(engine, params.stance_foot, "stance_foot");
  StateGuard guard(engine);
  engine.set_positions(sp.q0);
  engine.set_velocities(Eigen::VectorXd::Zero(nv));
  engine.set_controls(sp.ctrl0);
  engine.forward();

  // COM Jacobians at the set-point
  plant.jac_com.resize(3, nv);
  plant.jac_foot.resize(3, nv);
  engine.subtree_com_jacobian(root, plant.jac_com);
  Eigen::MatrixXd none(3, 0);
  engine.point_jacobian(foot, engine.body_com(foot), plant.jac_foot, none);

  // the solver's warm start from the set-point alone, not from the engine's history: one step
  // from a cold start leaves its solution there
  EngineState x0, stepped;
  engine.save_state(x0);
  x0.extra.clear();
  engine.restore_state(x0);
  engine.step();
  engine.save_state(stepped);
  x0.extra = stepped.extra;

  // A and B of one step, centred differences
  linearize_fd(engine, x0, sp.ctrl0, params.fd_eps, true, plant.A, plant.B);
}

LqrDesign design_lqr(const LqrParams& params, const ControllerContext& ctx, const Engine& engine) {
  if (!ctx.scratch_engine)
    throw InputError("lqr: the design needs a scratch engine of the scenario's world");
  std::unique_ptr<Engine> scratch = ctx.scratch_engine();
  if (scratch->nq() != engine.nq() || scratch->nv() != engine.nv() || scratch->nu() != engine.nu())
    throw InputError("lqr: the scratch engine is not the run's model");
  // the run's pose on the scratch engine
  Eigen::VectorXd q(engine.nq());
  engine.get_positions(q);
  scratch->set_positions(q);
  scratch->forward();
  return design_lqr(params, *scratch);
}

}  // namespace stance
