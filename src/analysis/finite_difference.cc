#include "analysis/finite_difference.h"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace stance {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// one step from (q, v) with inputs u, starting from x0 for everything else
struct StepEvaluator {
  Engine& engine;
  const EngineState& x0;
  const InputWriter& write_inputs;
  VectorXd q_next, v_next;  // result of the last evaluate()

  void evaluate(const VectorXd& q, const VectorXd& v, const VectorXd& u, const char* what,
                int index) {
    engine.restore_state(x0);
    engine.set_positions(q);
    engine.set_velocities(v);
    write_inputs(engine, u);
    engine.step();
    if (!engine.state_is_finite()) {
      engine.restore_state(x0);
      throw std::runtime_error(fmt::format(
          "linearize_fd: the step from the state perturbed in {} {} is not finite{}", what, index,
          engine.last_warning().empty() ? "" : " (" + engine.last_warning() + ")"));
    }
    q_next.resize(engine.nq());
    v_next.resize(engine.nv());
    engine.get_positions(q_next);
    engine.get_velocities(v_next);
  }
};

// column = [(q_plus (-) q_ref) / h ; (v_plus - v_ref) / h], dim 2nv
void write_column(const Engine& engine, const VectorXd& q_ref, const VectorXd& v_ref,
                  const VectorXd& q_plus, const VectorXd& v_plus, double h,
                  Eigen::Ref<VectorXd> column) {
  const int nv = engine.nv();
  VectorXd dq(nv);
  engine.difference_positions(q_ref, q_plus, dq);
  column.head(nv) = dq / h;
  column.tail(nv) = (v_plus - v_ref) / h;
}

}  // namespace

void linearize_fd_inputs(Engine& engine, const EngineState& x0, const VectorXd& u0,
                         const InputWriter& write_inputs, double eps, bool centered, MatrixXd& A,
                         MatrixXd& B) {
  // validate
  const int nq = engine.nq(), nv = engine.nv();
  const int k = static_cast<int>(u0.size());
  if (!(eps > 0) || !std::isfinite(eps)) {
    throw std::invalid_argument(fmt::format("linearize_fd: eps must be > 0, got {}", eps));
  }
  if (x0.q.size() != nq || x0.v.size() != nv) {
    throw std::invalid_argument(
        fmt::format("linearize_fd: state x0 has dim q {} and v {}, the engine has nq {} and nv {}",
                    x0.q.size(), x0.v.size(), nq, nv));
  }
  if (!x0.q.allFinite() || !x0.v.allFinite() || !u0.allFinite()) {
    throw std::invalid_argument("linearize_fd: x0 or u0 has a NaN or Inf entry");
  }
  if (!write_inputs) throw std::invalid_argument("linearize_fd: no input writer given");

  A.resize(2 * nv, 2 * nv);
  B.resize(2 * nv, k);
  StepEvaluator step{engine, x0, write_inputs, {}, {}};

  // nominal next state (forward differences only)
  VectorXd q_nominal, v_nominal;
  if (!centered) {
    step.evaluate(x0.q, x0.v, u0, "nothing, nominal", 0);
    q_nominal = step.q_next;
    v_nominal = step.v_next;
  }
  const double h = centered ? 2 * eps : eps;
  VectorXd q_plus, v_plus;

  // d x+ / d x_i for a given perturbation of the state; sign +1 or -1
  auto perturbed_state = [&](int i, double sign, VectorXd& q, VectorXd& v) {
    q = x0.q;
    v = x0.v;
    if (i < nv) {
      VectorXd dq = VectorXd::Zero(nv);
      dq[i] = 1;
      engine.integrate_positions(x0.q, dq, sign * eps, q);
    } else {
      v[i - nv] += sign * eps;
    }
  };

  // states: positions through the tangent space, then velocities
  VectorXd q, v;
  for (int i = 0; i < 2 * nv; ++i) {
    const char* what = i < nv ? "position dof" : "velocity dof";
    const int index = i < nv ? i : i - nv;
    perturbed_state(i, +1, q, v);
    step.evaluate(q, v, u0, what, index);
    q_plus = step.q_next;
    v_plus = step.v_next;
    if (centered) {
      perturbed_state(i, -1, q, v);
      step.evaluate(q, v, u0, what, index);
      write_column(engine, step.q_next, step.v_next, q_plus, v_plus, h, A.col(i));
    } else {
      write_column(engine, q_nominal, v_nominal, q_plus, v_plus, h, A.col(i));
    }
  }

  // inputs
  VectorXd u;
  for (int j = 0; j < k; ++j) {
    u = u0;
    u[j] += eps;
    step.evaluate(x0.q, x0.v, u, "input", j);
    q_plus = step.q_next;
    v_plus = step.v_next;
    if (centered) {
      u[j] = u0[j] - eps;
      step.evaluate(x0.q, x0.v, u, "input", j);
      write_column(engine, step.q_next, step.v_next, q_plus, v_plus, h, B.col(j));
    } else {
      write_column(engine, q_nominal, v_nominal, q_plus, v_plus, h, B.col(j));
    }
  }
  engine.restore_state(x0);
}

void linearize_fd(Engine& engine, const EngineState& x0, const VectorXd& u0, double eps,
                  bool centered, MatrixXd& A, MatrixXd& B) {
  if (u0.size() != engine.nu()) {
    throw std::invalid_argument(fmt::format(
        "linearize_fd: u0 has dim {}, the engine has {} actuators", u0.size(), engine.nu()));
  }
  InputWriter controls = [](Engine& e, const VectorXd& u) { e.set_controls(u); };
  linearize_fd_inputs(engine, x0, u0, controls, eps, centered, A, B);
}

void linearize_fd_forces(Engine& engine, const EngineState& x0, const std::vector<int>& dofs,
                         const VectorXd& tau0, double eps, bool centered, MatrixXd& A, MatrixXd& B,
                         const std::function<void(Engine&)>& apply_inputs) {
  const int nv = engine.nv();
  if (tau0.size() != nv) {
    throw std::invalid_argument(fmt::format(
        "linearize_fd_forces: tau0 has dim {}, the engine has nv = {}", tau0.size(), nv));
  }
  for (int dof : dofs) {
    if (dof < 0 || dof >= nv) {
      throw std::invalid_argument(
          fmt::format("linearize_fd_forces: dof index {} is outside [0, {})", dof, nv));
    }
  }
  // u holds the force increments on the selected dofs
  VectorXd tau(nv);
  InputWriter forces = [&](Engine& e, const VectorXd& u) {
    if (apply_inputs) apply_inputs(e);
    tau = tau0;
    for (size_t j = 0; j < dofs.size(); ++j) tau[dofs[j]] += u[j];
    e.set_generalized_forces(tau);
  };
  VectorXd u0 = VectorXd::Zero(static_cast<Eigen::Index>(dofs.size()));
  linearize_fd_inputs(engine, x0, u0, forces, eps, centered, A, B);
}

}  // namespace stance
