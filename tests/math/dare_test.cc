#include "math/dare.h"
#include "math/random_matrix.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <cmath>
#include <random>
#include <stdexcept>

namespace stance {
namespace {

using Eigen::MatrixXd;

MatrixXd random_orthogonal(std::mt19937& rng, int n) {
  Eigen::HouseholderQR<MatrixXd> qr(test::random_matrix(rng, n, n));
  return qr.householderQ() * MatrixXd::Identity(n, n);
}

// random A scaled to a given spectral radius (mildly unstable for radius > 1)
MatrixXd random_dynamics(std::mt19937& rng, int n, double radius) {
  MatrixXd A = test::random_matrix(rng, n, n);
  return A * (radius / spectral_radius(A));
}

void expect_solution_ok(const DareResult& r, const MatrixXd& A, const MatrixXd& B,
                        const MatrixXd& Q, const MatrixXd& R) {
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_LE(r.relative_residual, 1e-9) << r.message;
  // independent residual check, not the solver's own number
  EXPECT_LE(dare_relative_residual(A, B, Q, R, r.P), 1e-9);
  EXPECT_LT(r.spectral_radius, 1.0);
  EXPECT_NEAR(r.spectral_radius, spectral_radius(A - B * r.K), 1e-12);
  EXPECT_EQ((r.P - r.P.transpose()).norm(), 0.0);
  // stabilising solution is positive semidefinite
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(r.P);
  EXPECT_GE(es.eigenvalues().minCoeff(), -1e-9 * r.P.norm());
  // K matches its definition
  MatrixXd K = (R + B.transpose() * r.P * B).ldlt().solve(B.transpose() * r.P * A);
  EXPECT_LE((K - r.K).norm(), 1e-10 * std::max(1.0, K.norm()));
}

TEST(DareTest, DoubleIntegratorMatchesClosedForm) {
  MatrixXd A(2, 2), B(2, 1), Q(2, 2), R(1, 1);
  A << 1, 1, 0, 1;
  B << 0, 1;
  Q << 1, 0, 0, 0;
  R << 1;
  DareResult r = solve_dare(A, B, Q, R);
  expect_solution_ok(r, A, B, Q, R);
  // closed form (solved symbolically): s = sqrt(17), t = sqrt(26 + 10 s)
  double s = std::sqrt(17.0), t = std::sqrt(26 + 10 * s);
  MatrixXd expected(2, 2);
  expected(0, 0) = 1 + t * (s - 1) / 16;
  expected(0, 1) = expected(1, 0) = (1 + s) / 4 + t * (s - 1) / 32;
  expected(1, 1) = (1 + s) / 4 + t / 4;
  EXPECT_LE((r.P - expected).norm(), 1e-12 * expected.norm()) << r.P;
  EXPECT_NEAR(r.P(0, 0), 2.60048518044024, 1e-12);
}

TEST(DareTest, ScalarSystemMatchesQuadraticRoot) {
  // p = a^2 p - a^2 b^2 p^2 / (r + b^2 p) + q  <=>  b^2 p^2 + (r - a^2 r - q b^2) p - q r = 0
  double a = 1.3, b = 0.7, q = 2.0, rr = 0.5;
  MatrixXd A(1, 1), B(1, 1), Q(1, 1), R(1, 1);
  A << a;
  B << b;
  Q << q;
  R << rr;
  double c1 = b * b, c2 = rr - a * a * rr - q * b * b, c3 = -q * rr;
  double p = (-c2 + std::sqrt(c2 * c2 - 4 * c1 * c3)) / (2 * c1);
  DareResult r = solve_dare(A, B, Q, R);
  expect_solution_ok(r, A, B, Q, R);
  EXPECT_NEAR(r.P(0, 0), p, 1e-12 * p);
}

struct RandomCase {
  int n, m;
  unsigned seed;
};

class DareRandomTest : public ::testing::TestWithParam<RandomCase> {};

TEST_P(DareRandomTest, MildlyUnstableSystemSolvedToResidual) {
  const RandomCase c = GetParam();
  std::mt19937 rng(c.seed);
  MatrixXd A = random_dynamics(rng, c.n, 1.05);
  MatrixXd B = test::random_matrix(rng, c.n, c.m);
  MatrixXd C = test::random_matrix(rng, c.n, c.n);
  MatrixXd Q = C.transpose() * C / c.n + 0.1 * MatrixXd::Identity(c.n, c.n);
  MatrixXd R = MatrixXd::Identity(c.m, c.m);
  ASSERT_GT(spectral_radius(A), 1.04);
  DareResult r = solve_dare(A, B, Q, R);
  expect_solution_ok(r, A, B, Q, R);
  EXPECT_LT(r.iterations, 40);
}

INSTANTIATE_TEST_SUITE_P(Sizes, DareRandomTest,
                         ::testing::Values(RandomCase{10, 3, 1}, RandomCase{30, 8, 2},
                                           RandomCase{54, 21, 3}, RandomCase{54, 21, 4}));

TEST(DareTest, HumanoidLikeScalingNearIdentityDynamics) {
  // discretised second-order system like an LQR on a humanoid: x = [q; v], dt = 2 ms,
  // large balance cost on positions, epsilon on velocities, R = I
  std::mt19937 rng(7);
  const int nv = 27, n = 2 * nv, m = 21;
  const double dt = 0.002;
  MatrixXd stiffness = test::random_matrix(rng, nv, nv);
  stiffness = 20.0 * (stiffness + stiffness.transpose()) / std::sqrt(nv);  // unstable directions
  MatrixXd actuation = test::random_matrix(rng, nv, m);
  MatrixXd A = MatrixXd::Identity(n, n), B = MatrixXd::Zero(n, m);
  A.topRightCorner(nv, nv) = dt * MatrixXd::Identity(nv, nv);
  A.bottomLeftCorner(nv, nv) = dt * stiffness;
  A.topLeftCorner(nv, nv) += dt * dt * stiffness;
  B.bottomRows(nv) = dt * actuation;
  B.topRows(nv) = dt * dt * actuation;
  MatrixXd J = test::random_matrix(rng, 3, nv);
  MatrixXd Q = MatrixXd::Zero(n, n);
  Q.topLeftCorner(nv, nv) = 1000.0 * J.transpose() * J + 3.0 * MatrixXd::Identity(nv, nv);
  Q += 1e-6 * MatrixXd::Identity(n, n);
  MatrixXd R = MatrixXd::Identity(m, m);
  DareResult r = solve_dare(A, B, Q, R);
  expect_solution_ok(r, A, B, Q, R);

  // closed loop near the unit circle: doubling stopped early leaves a stabilising but coarse P
  // (residual ~1e-3 here) that the Newton steps must polish
  DareOptions coarse;
  coarse.max_sda_iterations = 10;
  DareResult polished = solve_dare(A, B, Q, R, coarse);
  expect_solution_ok(polished, A, B, Q, R);
  EXPECT_GT(polished.newton_steps, 0);
  EXPECT_LE((polished.P - r.P).norm(), 1e-9 * r.P.norm());
  coarse.max_newton_steps = 0;
  EXPECT_GT(solve_dare(A, B, Q, R, coarse).relative_residual, 1e-6);
}

TEST(DareTest, SingularQAndUncontrollableStableMode) {
  // blockdiag(unstable controllable part, stable uncontrollable mode), rank-1 Q, then hidden
  // behind a random orthogonal change of coordinates
  std::mt19937 rng(11);
  const int n1 = 5, n = n1 + 2, m = 2;
  MatrixXd A = MatrixXd::Zero(n, n);
  A.topLeftCorner(n1, n1) = random_dynamics(rng, n1, 1.05);
  A(n1, n1) = 0.5;
  A(n1 + 1, n1 + 1) = -0.8;
  A(n1, n1 + 1) = 0.3;
  MatrixXd B = MatrixXd::Zero(n, m);
  B.topRows(n1) = test::random_matrix(rng, n1, m);
  MatrixXd c = test::random_matrix(rng, 1, n);
  MatrixXd Q = c.transpose() * c;  // rank 1
  MatrixXd R = MatrixXd::Identity(m, m);
  MatrixXd T = random_orthogonal(rng, n);
  MatrixXd At = T * A * T.transpose(), Bt = T * B, Qt = T * Q * T.transpose();
  Qt = 0.5 * (Qt + Qt.transpose());
  for (const auto& [a, b, q] : {std::tuple{A, B, Q}, std::tuple{At, Bt, Qt}}) {
    DareResult r = solve_dare(a, b, q, R);
    expect_solution_ok(r, a, b, q, R);
    // the uncontrollable modes stay in the closed loop
    Eigen::EigenSolver<MatrixXd> es(a - b * r.K);
    int found = 0;
    for (const auto& lambda : es.eigenvalues()) {
      if (std::abs(lambda - std::complex<double>(0.5, 0)) < 1e-8) ++found;
      if (std::abs(lambda - std::complex<double>(-0.8, 0)) < 1e-8) ++found;
    }
    EXPECT_EQ(found, 2);
  }
}

TEST(DareTest, UndetectableUnstableModeReportedAsNotStabilising) {
  // Q = 0 leaves the unstable mode 1.2 unseen: doubling returns the minimal solution P = 0,
  // which does not stabilise, and the result must say so rather than claim success
  MatrixXd A(2, 2), B(2, 1), Q = MatrixXd::Zero(2, 2), R = MatrixXd::Identity(1, 1);
  A << 1.2, 0.1, 0, 0.5;
  B << 1, 1;
  DareResult r = solve_dare(A, B, Q, R);
  EXPECT_LE(r.relative_residual, 1e-9);
  EXPECT_NEAR(r.spectral_radius, 1.2, 1e-12);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("not stabilising"), std::string::npos) << r.message;
}

TEST(DareTest, UnstabilisableSystemReportsFailure) {
  // unstable mode 1.5 that no input reaches, seen by Q: no stabilising solution exists
  MatrixXd A(2, 2), B(2, 1), Q = MatrixXd::Identity(2, 2), R = MatrixXd::Identity(1, 1);
  A << 0.5, 0, 0, 1.5;
  B << 1, 0;
  DareResult r = solve_dare(A, B, Q, R);
  EXPECT_FALSE(r.success);
  EXPECT_FALSE(r.message.empty());
}

TEST(DareTest, RejectsBadInput) {
  MatrixXd A = MatrixXd::Identity(3, 3), B = MatrixXd::Ones(3, 1);
  MatrixXd Q = MatrixXd::Identity(3, 3), R = MatrixXd::Identity(1, 1);
  EXPECT_THROW(solve_dare(MatrixXd::Identity(3, 2), B, Q, R), std::invalid_argument);
  EXPECT_THROW(solve_dare(A, MatrixXd::Ones(2, 1), Q, R), std::invalid_argument);
  EXPECT_THROW(solve_dare(A, B, MatrixXd::Identity(2, 2), R), std::invalid_argument);
  EXPECT_THROW(solve_dare(A, B, Q, MatrixXd::Identity(2, 2)), std::invalid_argument);
  MatrixXd bad = A;
  bad(1, 2) = NAN;
  EXPECT_THROW(solve_dare(bad, B, Q, R), std::invalid_argument);
  MatrixXd asym = Q;
  asym(0, 1) = 0.5;
  EXPECT_THROW(solve_dare(A, B, asym, R), std::invalid_argument);
  EXPECT_THROW(solve_dare(A, B, -Q, R), std::invalid_argument);
  EXPECT_THROW(solve_dare(A, B, Q, MatrixXd::Zero(1, 1)), std::invalid_argument);
  try {
    solve_dare(A, MatrixXd::Ones(2, 1), Q, R);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("B must be 3 x 1, got 2 x 1"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace stance
