// Cross-check of solve_dare against SLICOT's SB02OD (Debian libslicot-dev), which solves the
// DARE by a different method: deflating subspaces of the extended symplectic pencil (QZ).
// Link: -lslicot -llapack -lblas -lgfortran.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstddef>
#include <random>
#include <vector>

#include "math/dare.h"
#include "math/random_matrix.h"

// SLICOT 5.0 SB02OD (Fortran 77). gfortran passes every CHARACTER argument's length as a
// trailing size_t; LOGICAL is a 4-byte int.
extern "C" void sb02od_(const char* dico, const char* jobb, const char* fact, const char* uplo,
                        const char* jobl, const char* sort, const int* n, const int* m,
                        const int* p, const double* a, const int* lda, const double* b,
                        const int* ldb, const double* q, const int* ldq, const double* r,
                        const int* ldr, const double* l, const int* ldl, double* rcond, double* x,
                        const int* ldx, double* alfar, double* alfai, double* beta, double* s,
                        const int* lds, double* t, const int* ldt, double* u, const int* ldu,
                        const double* tol, int* iwork, double* dwork, const int* ldwork, int* bwork,
                        int* info, std::size_t dico_len, std::size_t jobb_len, std::size_t fact_len,
                        std::size_t uplo_len, std::size_t jobl_len, std::size_t sort_len);

namespace stance {
namespace {

using Eigen::MatrixXd;

struct SlicotSolution {
  MatrixXd X;
  int info = -100;
  double rcond = 0;
};

// X = A'XA - A'XB (R + B'XB)^-1 B'XA + Q by SB02OD (DICO='D', B and R given, L = 0,
// stable eigenvalues first). Eigen's column-major storage is Fortran's.
SlicotSolution slicot_dare(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q,
                           const MatrixXd& R) {
  const int n = static_cast<int>(A.rows()), m = static_cast<int>(B.cols()), p = 0;
  const int nn = 2 * n, nnm = 2 * n + m;
  const int lda = n, ldb = n, ldq = n, ldr = m, ldl = 1, ldx = n, lds = nnm, ldt = nnm, ldu = nn;
  // the routine's own comments say its documented minimum workspace can be too small for
  // large N and suggest ~1000 N; be generous
  const int ldwork = std::max({7 * (2 * n + 1) + 16, 16 * n, nnm, 3 * m, 1000 * n});
  MatrixXd a = A, b = B, q = Q, r = R;  // copies: the Fortran side takes non-const views
  double l = 0, tol = 0;
  SlicotSolution out;
  out.X = MatrixXd::Zero(n, n);
  std::vector<double> alfar(nn), alfai(nn), beta(nn), s(lds * nnm), t(ldt * nn), u(ldu * nn);
  std::vector<double> dwork(ldwork);
  std::vector<int> iwork(std::max(m, nn) + 1), bwork(nn);
  sb02od_("D", "B", "N", "U", "Z", "S", &n, &m, &p, a.data(), &lda, b.data(), &ldb, q.data(), &ldq,
          r.data(), &ldr, &l, &ldl, &out.rcond, out.X.data(), &ldx, alfar.data(), alfai.data(),
          beta.data(), s.data(), &lds, t.data(), &ldt, u.data(), &ldu, &tol, iwork.data(),
          dwork.data(), &ldwork, bwork.data(), &out.info, 1, 1, 1, 1, 1, 1);
  return out;
}

void expect_agreement(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R) {
  DareResult ours = solve_dare(A, B, Q, R);
  ASSERT_TRUE(ours.success) << ours.message;
  SlicotSolution ref = slicot_dare(A, B, Q, R);
  ASSERT_EQ(ref.info, 0) << "SB02OD failed";
  MatrixXd X = 0.5 * (ref.X + ref.X.transpose());
  double rel = (ours.P - X).norm() / X.norm();
  EXPECT_LE(rel, 1e-8) << "||P - X_slicot|| / ||X_slicot|| = " << rel;
  // and ours is at least as accurate as SLICOT's by the DARE residual
  double slicot_residual = dare_relative_residual(A, B, Q, R, X);
  EXPECT_LE(ours.relative_residual, std::max(1e-12, 10 * slicot_residual));
}

TEST(SlicotDareTest, DoubleIntegrator) {
  MatrixXd A(2, 2), B(2, 1), Q(2, 2), R(1, 1);
  A << 1, 1, 0, 1;
  B << 0, 1;
  Q << 1, 0, 0, 0;
  R << 1;
  SlicotSolution ref = slicot_dare(A, B, Q, R);
  ASSERT_EQ(ref.info, 0);
  // the wrapper itself must be right: SB02OD reproduces the closed form
  EXPECT_NEAR(ref.X(0, 0), 2.60048518044024, 1e-10);
  EXPECT_NEAR(ref.X(0, 1), 2.08101899662454, 1e-10);
  EXPECT_NEAR(ref.X(1, 1), 3.33064006431219, 1e-10);
  expect_agreement(A, B, Q, R);
}

TEST(SlicotDareTest, RandomMildlyUnstableSystems) {
  struct Case {
    int n, m;
    unsigned seed;
  };
  for (Case c : {Case{10, 3, 21}, Case{30, 8, 22}, Case{54, 21, 23}}) {
    SCOPED_TRACE(::testing::Message() << "n = " << c.n << ", m = " << c.m);
    std::mt19937 rng(c.seed);
    MatrixXd A = test::random_matrix(rng, c.n, c.n);
    A *= 1.05 / spectral_radius(A);
    MatrixXd B = test::random_matrix(rng, c.n, c.m);
    MatrixXd C = test::random_matrix(rng, c.n / 2, c.n);
    MatrixXd Q = C.transpose() * C;  // rank n/2: semidefinite
    MatrixXd R = MatrixXd::Identity(c.m, c.m) + 0.1 * MatrixXd::Ones(c.m, c.m);
    expect_agreement(A, B, Q, R);
  }
}

TEST(SlicotDareTest, HumanoidLikeSecondOrderSystem) {
  std::mt19937 rng(31);
  const int nv = 27, n = 2 * nv, m = 21;
  const double dt = 0.005;
  MatrixXd stiffness = test::random_matrix(rng, nv, nv);
  stiffness = 10.0 * (stiffness + stiffness.transpose()) / std::sqrt(nv);
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
  expect_agreement(A, B, Q, MatrixXd::Identity(m, m));
}

}  // namespace
}  // namespace stance
