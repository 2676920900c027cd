// Finite-difference linearisation of one discrete simulation step over the engine interface,
// for any backend (MuJoCo has mjd_transitionFD; DART has nothing alike).
//
// The step maps x = (q, v) and inputs u to x+ = f(x, u). States are perturbed in the tangent
// space, dx = [dq (nv); dv (nv)], with q (+) dq from Engine::integrate_positions, and the
// output position block is (q+_a (-) q+_b) / h from Engine::difference_positions, so free and
// ball joints (quaternions in q) are handled. This mirrors MuJoCo's mjd_transitionFD (2.2.2):
// the position rows are a plain Jacobian d(q+)/dx, divided by the perturbation size and not
// by the timestep. Activation states (act) are held at x0's values and not differentiated.
//
//   A = d x+ / d x  (2nv x 2nv),   B = d x+ / d u  (2nv x k).
//
// Each evaluation starts from Engine::restore_state(x0), so every step sees the same time,
// warm start and (cleared) per-step inputs. On return the engine is restored to x0.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "engine/engine.h"

namespace stance {

// writes inputs u (dim k) into the engine before a step; called after restore_state(x0)
using InputWriter = std::function<void(Engine& engine, const Eigen::VectorXd& u)>;

// generic form: the inputs are whatever `write_inputs` applies; u0 has dim k and B gets k
// columns. eps > 0 is the perturbation size for both states and inputs. centered: central
// differences (2 steps per column) instead of forward (1 step per column, plus the nominal).
// Throws std::invalid_argument on wrong sizes or eps, std::runtime_error when a perturbed step
// is not finite.
void linearize_fd_inputs(Engine& engine, const EngineState& x0, const Eigen::VectorXd& u0,
                         const InputWriter& write_inputs, double eps, bool centered,
                         Eigen::MatrixXd& A, Eigen::MatrixXd& B);

// inputs are the actuator controls (Engine::set_controls), u0 of dim nu, B is 2nv x nu.
// The counterpart of mjd_transitionFD(m, d, eps, centered, A, B, NULL, NULL) with na = 0.
void linearize_fd(Engine& engine, const EngineState& x0, const Eigen::VectorXd& u0, double eps,
                  bool centered, Eigen::MatrixXd& A, Eigen::MatrixXd& B);

// inputs are generalised forces on selected dofs, for models without actuators (DART):
// B is 2nv x k with column j = d x+ / d tau[dofs[j]]. tau0 (dim nv) is the nominal
// generalised force, applied with Engine::set_generalized_forces before every step (per-step
// inputs are consumed by each step). apply_inputs, when given, runs after restore_state and
// before the forces are set, for other inputs (controls, body forces); it must not set
// generalised forces itself, since they are overwritten.
void linearize_fd_forces(Engine& engine, const EngineState& x0, const std::vector<int>& dofs,
                         const Eigen::VectorXd& tau0, double eps, bool centered, Eigen::MatrixXd& A,
                         Eigen::MatrixXd& B, const std::function<void(Engine&)>& apply_inputs = {});

}  // namespace stance
