#include "math/dare.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cmath>
#include <stdexcept>

namespace stance {
namespace {

using Eigen::MatrixXd;

void require_finite(const MatrixXd& M, const char* name) {
  if (!M.allFinite()) {
    throw std::invalid_argument(fmt::format("solve_dare: {} has a NaN or Inf entry", name));
  }
}

void require_size(const MatrixXd& M, const char* name, Eigen::Index rows, Eigen::Index cols) {
  if (M.rows() != rows || M.cols() != cols) {
    throw std::invalid_argument(fmt::format("solve_dare: {} must be {} x {}, got {} x {}", name,
                                            rows, cols, M.rows(), M.cols()));
  }
}

void require_symmetric(const MatrixXd& M, const char* name) {
  double asym = (M - M.transpose()).norm();
  if (asym > 1e-10 * std::max(1.0, M.norm())) {
    throw std::invalid_argument(fmt::format(
        "solve_dare: {} must be symmetric, ||{} - {}'||_F = {:.3g}", name, name, name, asym));
  }
}

MatrixXd symmetric_part(const MatrixXd& M) {
  return 0.5 * (M + M.transpose());
}

// K = (R + B'PB)^-1 B'PA through a Cholesky factor (R + B'PB is SPD for P >= 0)
MatrixXd lqr_gain(const MatrixXd& A, const MatrixXd& B, const MatrixXd& R, const MatrixXd& P) {
  MatrixXd BtP = B.transpose() * P;
  MatrixXd S = symmetric_part(R + BtP * B);
  Eigen::LLT<MatrixXd> llt(S);
  if (llt.info() == Eigen::Success) return llt.solve(BtP * A);
  // P slightly indefinite during iteration: fall back to a pivoted LU
  return S.partialPivLu().solve(BtP * A);
}

// the DARE residual A'PA - P - A'PB (R + B'PB)^-1 B'PA + Q, symmetrised
MatrixXd dare_residual(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R,
                       const MatrixXd& P) {
  MatrixXd K = lqr_gain(A, B, R, P);
  MatrixXd AtPB = A.transpose() * P * B;
  return symmetric_part(A.transpose() * P * A - P - AtPB * K + Q);
}

// Smith doubling for the Stein equation E = M'EM + C with rho(M) < 1:
// E = sum_k (M')^k C M^k, summed two terms, four, eight, ... at a time.
MatrixXd solve_stein(const MatrixXd& M, const MatrixXd& C, int max_iterations) {
  MatrixXd E = C;
  MatrixXd Mk = M;
  for (int i = 0; i < max_iterations; ++i) {
    MatrixXd increment = Mk.transpose() * E * Mk;
    E += increment;
    E = symmetric_part(E);
    if (increment.norm() <= 1e-17 * std::max(1e-300, E.norm())) break;
    Mk = Mk * Mk;
    if (Mk.norm() == 0) break;
  }
  return E;
}

}  // namespace

double spectral_radius(const MatrixXd& M) {
  if (M.size() == 0) return 0;
  Eigen::EigenSolver<MatrixXd> es(M, /*computeEigenvectors=*/false);
  return es.eigenvalues().cwiseAbs().maxCoeff();
}

double dare_relative_residual(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q,
                              const MatrixXd& R, const MatrixXd& P) {
  return dare_residual(A, B, Q, R, P).norm() / std::max(1.0, P.norm());
}

DareResult solve_dare(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R,
                      const DareOptions& options) {
  // validate: dimensions, finiteness, symmetry and definiteness
  const Eigen::Index n = A.rows(), m = B.cols();
  if (n == 0) throw std::invalid_argument("solve_dare: A is empty (n = 0)");
  require_size(A, "A", n, n);
  require_size(B, "B", n, m);
  require_size(Q, "Q", n, n);
  require_size(R, "R", m, m);
  require_finite(A, "A");
  require_finite(B, "B");
  require_finite(Q, "Q");
  require_finite(R, "R");
  require_symmetric(Q, "Q");
  require_symmetric(R, "R");
  MatrixXd Qs = symmetric_part(Q), Rs = symmetric_part(R);
  {
    Eigen::SelfAdjointEigenSolver<MatrixXd> eq(Qs, Eigen::EigenvaluesOnly);
    double qmin = eq.eigenvalues().minCoeff();
    if (qmin < -1e-10 * std::max(1.0, eq.eigenvalues().cwiseAbs().maxCoeff())) {
      throw std::invalid_argument(fmt::format(
          "solve_dare: Q must be positive semidefinite, its smallest eigenvalue is {:.3g}", qmin));
    }
  }
  Eigen::LLT<MatrixXd> r_llt(Rs);
  if (m > 0 && r_llt.info() != Eigen::Success) {
    throw std::invalid_argument("solve_dare: R must be positive definite (Cholesky failed)");
  }

  DareResult out;
  const MatrixXd I = MatrixXd::Identity(n, n);

  // SDA on the symplectic pencil: A_0 = A, G_0 = B R^-1 B', H_0 = Q;
  //   W = I + G_k H_k,
  //   A_{k+1} = A_k W^-1 A_k, G_{k+1} = G_k + A_k W^-1 G_k A_k', H_{k+1} = H_k + A_k' H_k W^-1 A_k.
  // H_k converges quadratically to P; A_k to zero when the closed loop is stable.
  MatrixXd Ak = A;
  MatrixXd Gk = m > 0 ? symmetric_part(B * r_llt.solve(B.transpose())) : MatrixXd::Zero(n, n);
  MatrixXd Hk = Qs;
  bool converged = false;
  for (int k = 0; k < options.max_sda_iterations; ++k) {
    Eigen::PartialPivLU<MatrixXd> W(I + Gk * Hk);
    MatrixXd WinvA = W.solve(Ak);  // W^-1 A_k
    MatrixXd WinvG = W.solve(Gk);  // W^-1 G_k (symmetric in exact arithmetic)
    MatrixXd HWinvA = Hk * WinvA;  // H_k W^-1 A_k
    MatrixXd G_next = symmetric_part(Gk + Ak * WinvG * Ak.transpose());
    MatrixXd H_next = symmetric_part(Hk + Ak.transpose() * HWinvA);
    MatrixXd A_next = Ak * WinvA;
    out.iterations = k + 1;
    // a norm that overflows also means divergence (P grows like |unstable uncontrolled mode|^2^k)
    const double h_norm = H_next.norm();
    if (!std::isfinite(h_norm) || !A_next.allFinite() || !std::isfinite(G_next.norm())) {
      out.message =
          fmt::format("doubling diverged at iteration {} (is (A, B) stabilisable?)", k + 1);
      break;
    }
    double change = (H_next - Hk).norm();
    Ak = std::move(A_next);
    Gk = std::move(G_next);
    Hk = std::move(H_next);
    if (change <= options.sda_tolerance * std::max(1.0, h_norm)) {
      converged = true;
      break;
    }
  }
  if (!std::isfinite(Hk.norm())) {
    out.P = MatrixXd::Zero(n, n);
    out.K = MatrixXd::Zero(m, n);
    out.relative_residual = INFINITY;
    out.spectral_radius = INFINITY;
    if (out.message.empty()) out.message = "doubling produced a non-finite P";
    return out;
  }
  MatrixXd P = Hk;
  double residual = dare_relative_residual(A, B, Qs, Rs, P);

  // Newton refinement in defect-correction form: with Acl = A - BK(P), the correction E solves
  // E = Acl' E Acl + Res(P), i.e. the Hewer/Kleinman step P+ = P + E. Keep a step only when it
  // lowers the residual.
  for (int s = 0; s < options.max_newton_steps && residual > options.target_residual; ++s) {
    MatrixXd K = lqr_gain(A, B, Rs, P);
    MatrixXd Acl = A - B * K;
    if (spectral_radius(Acl) >= 1) break;  // Smith doubling needs a stable closed loop
    MatrixXd E = solve_stein(Acl, dare_residual(A, B, Qs, Rs, P), 64);
    MatrixXd P_next = symmetric_part(P + E);
    double residual_next = dare_relative_residual(A, B, Qs, Rs, P_next);
    if (!(residual_next < residual)) break;
    P = std::move(P_next);
    residual = residual_next;
    ++out.newton_steps;
  }

  // results
  out.P = symmetric_part(P);
  out.K = lqr_gain(A, B, Rs, out.P);
  out.relative_residual = residual;
  out.spectral_radius = spectral_radius(A - B * out.K);
  bool stable = out.spectral_radius < 1;
  out.success = stable && residual <= options.success_residual;
  if (out.message.empty()) {
    out.message = fmt::format(
        "doubling {} after {} iterations, then {} Newton steps: relative residual {:.3g}, "
        "closed-loop spectral radius {:.6f}",
        converged ? "converged" : "stopped unconverged", out.iterations, out.newton_steps, residual,
        out.spectral_radius);
    if (!stable)
      out.message += " (not stabilising: is (A, B) stabilisable and (Q, A) detectable?)";
    else if (residual > options.success_residual)
      out.message += " (residual above tolerance)";
  }
  return out;
}

}  // namespace stance
