// The MuJoCo side of the LQR design: inverse dynamics (mj_inverse) for the set-point, the COM
// Jacobians, and mjd_transitionFD for A and B. Everything runs on a private mjData, so the
// scenario's engine keeps its state.
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <memory>

#include "control/lqr.h"
#include "core/error.h"
#include "engine/mujoco/mujoco_engine.h"

namespace stance {

namespace {

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

const MujocoEngine& require_mujoco(const Engine& engine) {
  auto* mj = dynamic_cast<const MujocoEngine*>(&engine);
  if (!mj)
    throw InputError(fmt::format(
        "lqr: the set-point needs inverse dynamics, available on the mujoco engine only "
        "(found '{}')",
        engine.engine_name()));
  return *mj;
}

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

Eigen::Vector3d up_axis(const mjModel* m) {
  Eigen::Vector3d g(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]);
  if (g.norm() == 0) throw InputError("lqr: the set-point search needs gravity");
  return -g.normalized();
}

}  // namespace

LqrSetPoint find_lqr_setpoint(const LqrParams& params, const Engine& engine) {
  const MujocoEngine& mj = require_mujoco(engine);
  const mjModel* m = mj.model();
  const int nq = m->nq, nv = m->nv, nu = m->nu;
  if (nu == 0) throw InputError("lqr: the model has no actuators");
  if (m->na != 0) throw InputError("lqr: actuators with activation states are not supported");
  const RootJoint root = find_root_joint(params, engine);
  const Eigen::Vector3d up = up_axis(m);
  DataPtr d(mj_makeData(m));

  LqrSetPoint sp;
  Eigen::VectorXd pose(nq);
  engine.get_positions(pose);
  sp.weight_N = engine.total_mass() *
                Eigen::Vector3d(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]).norm();

  // inverse dynamics at rest with the root shifted by h along up: qfrc_inverse lands in d
  auto place = [&](double h) {
    Eigen::Map<Eigen::VectorXd>(d->qpos, nq) = pose;
    for (int k = 0; k < 3; ++k) d->qpos[root.qpos_adr + k] += h * up[k];
    mju_zero(d->qvel, nv);
    mju_zero(d->ctrl, nu);
    mj_forward(m, d.get());
    mju_zero(d->qacc, nv);
    mj_inverse(m, d.get());
  };
  // the fictitious force along up on the root: positive when the body is held up by it
  auto vertical_force = [&](double h) {
    place(h);
    ++sp.offset_evaluations;
    return up.dot(Eigen::Map<const Eigen::Vector3d>(d->qfrc_inverse + root.dof_adr));
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
  sp.q0 = Eigen::Map<const Eigen::VectorXd>(d->qpos, nq);
  sp.qfrc0 = Eigen::Map<const Eigen::VectorXd>(d->qfrc_inverse, nv);
  // MuJoCo 2.2 stores actuator_moment dense, nu x nv row-major: qfrc_actuator = M^T (gain ctrl)
  Eigen::Map<const RowMatrix> moment(d->actuator_moment, nu, nv);
  Eigen::MatrixXd moment_t = moment.transpose();
  // least-squares, minimum-norm: pinv(M)^T qfrc0 == pinv(M^T) qfrc0
  sp.ctrl0 = moment_t.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(sp.qfrc0);

  // verify by forward dynamics: the actuator forces ctrl0 produces, against qfrc0
  Eigen::Map<Eigen::VectorXd>(d->ctrl, nu) = sp.ctrl0;
  mj_forward(m, d.get());
  Eigen::Map<const Eigen::VectorXd> qfrc_actuator(d->qfrc_actuator, nv);
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
    sp.curve_force_N.push_back(
        up.dot(Eigen::Map<const Eigen::Vector3d>(d->qfrc_inverse + root.dof_adr)));
  }
  return sp;
}

void linearize_lqr_plant(const LqrParams& params, const Engine& engine, const LqrSetPoint& sp,
                         LqrPlant& plant) {
  const MujocoEngine& mj = require_mujoco(engine);
  const mjModel* m = mj.model();
  const int nv = m->nv, nu = m->nu;
  const int root = require_body(engine, params.root_body, "root_body");
  const int foot = require_body(engine, params.stance_foot, "stance_foot");
  DataPtr d(mj_makeData(m));
  Eigen::Map<Eigen::VectorXd>(d->qpos, m->nq) = sp.q0;
  Eigen::Map<Eigen::VectorXd>(d->ctrl, nu) = sp.ctrl0;
  mj_forward(m, d.get());

  // COM Jacobians at the set-point
  RowMatrix jac(3, nv);
  mj_jacSubtreeCom(m, d.get(), jac.data(), mj.mj_body_id(root));
  plant.jac_com = jac;
  mj_jacBodyCom(m, d.get(), jac.data(), nullptr, mj.mj_body_id(foot));
  plant.jac_foot = jac;

  // A and B of one step, centred differences
  RowMatrix a(2 * nv, 2 * nv), b(2 * nv, nu);
  mjd_transitionFD(m, d.get(), params.fd_eps, 1, a.data(), b.data(), nullptr, nullptr);
  plant.A = a;
  plant.B = b;
}

}  // namespace stance
