// The covariance matrix adaptation evolution strategy, (mu/mu_w, lambda)-CMA-ES, as in Hansen,
// "The CMA Evolution Strategy: A Tutorial" (arXiv:1604.00772): weighted recombination of the
// best half, cumulative step-size adaptation, and a rank-one plus rank-mu covariance update.
// Positive recombination weights only (the tutorial's default before active CMA).
//
// The caller owns the loop and the random generator: ask() draws lambda points from the
// generator it is given, on the calling thread; the caller evaluates them however it likes (in
// parallel, say) and hands the values back to tell(). The whole state is a plain struct, so a
// search can be saved after a generation and resumed to the same result.
//
// Bounds (optional): a point outside the box [lower, upper] is drawn again, up to
// kMaxResamples times, and then clamped into the box. tell() uses the points as evaluated
// (clamped), which keeps the update consistent with what was measured.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <random>
#include <vector>

namespace stance {

struct CmaesState {
  Eigen::VectorXd mean;     // dim n: the distribution's mean
  double sigma = 0;         // the overall step size
  Eigen::MatrixXd C;        // n x n, symmetric positive definite: the covariance's shape
  Eigen::VectorXd p_sigma;  // dim n: the conjugate evolution path (step size)
  Eigen::VectorXd p_c;      // dim n: the evolution path (rank-one update)
  int generation = 0;       // tell() calls so far
};

class Cmaes {
 public:
  static constexpr int kMaxResamples = 10;

  // mean (dim n >= 1), initial step size sigma > 0, population lambda >= 2; lower and upper
  // (dim n each, lower < upper) bound the points when given. Throws std::invalid_argument.
  Cmaes(const Eigen::VectorXd& mean, double sigma, int lambda,
        std::optional<Eigen::VectorXd> lower = std::nullopt,
        std::optional<Eigen::VectorXd> upper = std::nullopt);

  // Hansen's default population for dimension n: 4 + floor(3 ln n)
  static int default_lambda(int n);

  int dimension() const { return static_cast<int>(state_.mean.size()); }
  int lambda() const { return lambda_; }
  int mu() const { return static_cast<int>(weights_.size()); }
  double mu_eff() const { return mu_eff_; }

  // lambda new points, the columns of an n x lambda matrix, drawn from rng
  Eigen::MatrixXd ask(std::mt19937_64& rng) const;
  // updates the state from the values (lower is better) of the columns of x (n x lambda): the
  // points of the last ask(), possibly with some replaced (an injected start point, say).
  // Ties keep column order. Throws std::invalid_argument on a size mismatch or a NaN value.
  void tell(const Eigen::MatrixXd& x, const std::vector<double>& values);

  const CmaesState& state() const { return state_; }
  // restores a saved state (dimensions checked; throws std::invalid_argument)
  void set_state(const CmaesState& state);

 private:
  void update_eigen();

  int lambda_;
  std::optional<Eigen::VectorXd> lower_, upper_;
  Eigen::VectorXd weights_;  // dim mu, positive, summing to 1
  double mu_eff_ = 1, c_sigma_ = 0, d_sigma_ = 1, c_c_ = 0, c_1_ = 0, c_mu_ = 0;
  double chi_n_ = 1;  // E||N(0, I)||
  CmaesState state_;
  // C = B diag(D^2) B^T, kept in step with state_.C
  Eigen::MatrixXd B_;
  Eigen::VectorXd D_;
};

}  // namespace stance
