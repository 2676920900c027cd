// Discrete-time algebraic Riccati equation (DARE), the core of infinite-horizon LQR:
//
//   P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q
//
// with A (n x n), B (n x m), Q (n x n, symmetric positive semidefinite) and R (m x m, symmetric
// positive definite). The stabilising solution P gives the LQR gain K = (R + B'PB)^-1 B'PA
// for u = -K x, which makes A - BK stable when (A, B) is stabilisable and (Q, A) detectable.
#pragma once

#include <Eigen/Core>
#include <string>

namespace stance {

struct DareOptions {
  // structure-preserving doubling: stop when ||H_{k+1} - H_k||_F <= sda_tolerance ||H_{k+1}||_F
  int max_sda_iterations = 100;
  double sda_tolerance = 1e-14;
  // Newton (Hewer/Kleinman) refinement steps run while the residual is above target_residual
  int max_newton_steps = 4;
  double target_residual = 1e-13;
  // success requires relative_residual <= success_residual and a stable closed loop
  double success_residual = 1e-9;
};

struct DareResult {
  Eigen::MatrixXd P;  // n x n, symmetric: the stabilising solution
  Eigen::MatrixXd K;  // m x n: (R + B'PB)^-1 B'PA, control u = -K x
  // ||A'PA - P - A'PB (R + B'PB)^-1 B'PA + Q||_F / max(1, ||P||_F)
  double relative_residual = 0;
  int iterations = 0;          // doubling iterations
  int newton_steps = 0;        // refinement steps that were accepted
  double spectral_radius = 0;  // of the closed loop A - BK; < 1 when stabilising
  bool success = false;
  std::string message;  // what happened, for logs and error messages
};

// solves the DARE above by the structure-preserving doubling algorithm (SDA; Chu, Fan, Lin
// 2005), then polishes P with Newton steps whose Stein equations are solved by Smith doubling.
// P is symmetrised. Throws std::invalid_argument on inconsistent dimensions, non-finite
// entries, non-symmetric Q or R, Q not positive semidefinite, or R not positive definite.
// Does not throw when the iteration fails to converge: then success is false and message says
// why (e.g. (A, B) not stabilisable).
DareResult solve_dare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                      const Eigen::MatrixXd& R, const DareOptions& options = {});

// ||A'PA - P - A'PB (R + B'PB)^-1 B'PA + Q||_F / max(1, ||P||_F): the relative DARE residual
// reported by solve_dare, usable to check any candidate P (n x n).
double dare_relative_residual(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                              const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
                              const Eigen::MatrixXd& P);

// largest eigenvalue modulus of a square matrix
double spectral_radius(const Eigen::MatrixXd& M);

}  // namespace stance
