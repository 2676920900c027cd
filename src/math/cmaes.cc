#include "math/cmaes.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace stance {

Cmaes::Cmaes(const Eigen::VectorXd& mean, double sigma, int lambda,
             std::optional<Eigen::VectorXd> lower, std::optional<Eigen::VectorXd> upper)
    : lambda_(lambda), lower_(std::move(lower)), upper_(std::move(upper)) {
  const int n = static_cast<int>(mean.size());
  if (n < 1) throw std::invalid_argument("Cmaes: the mean has no dimension");
  if (!mean.allFinite()) throw std::invalid_argument("Cmaes: the mean is not finite");
  if (!(sigma > 0) || !std::isfinite(sigma))
    throw std::invalid_argument("Cmaes: sigma must be a positive number");
  if (lambda < 2) throw std::invalid_argument("Cmaes: the population must be at least 2");
  if (lower_.has_value() != upper_.has_value())
    throw std::invalid_argument("Cmaes: give both bounds or neither");
  if (lower_ &&
      (lower_->size() != n || upper_->size() != n || !(lower_->array() < upper_->array()).all()))
    throw std::invalid_argument("Cmaes: bounds of the wrong size or with lower >= upper");

  // recombination weights: log-decreasing over the best mu = lambda / 2, summing to 1
  const int mu = lambda / 2;
  weights_.resize(mu);
  for (int i = 0; i < mu; ++i) weights_[i] = std::log((lambda + 1) / 2.0) - std::log(i + 1.0);
  weights_ /= weights_.sum();
  mu_eff_ = 1.0 / weights_.squaredNorm();

  // the tutorial's default strategy parameters (table 1)
  const double dn = n;
  c_sigma_ = (mu_eff_ + 2) / (dn + mu_eff_ + 5);
  d_sigma_ = 1 + 2 * std::max(0.0, std::sqrt((mu_eff_ - 1) / (dn + 1)) - 1) + c_sigma_;
  c_c_ = (4 + mu_eff_ / dn) / (dn + 4 + 2 * mu_eff_ / dn);
  c_1_ = 2 / ((dn + 1.3) * (dn + 1.3) + mu_eff_);
  c_mu_ = std::min(1 - c_1_, 2 * (mu_eff_ - 2 + 1 / mu_eff_) / ((dn + 2) * (dn + 2) + mu_eff_));
  chi_n_ = std::sqrt(dn) * (1 - 1 / (4 * dn) + 1 / (21 * dn * dn));

  state_.mean = mean;
  state_.sigma = sigma;
  state_.C = Eigen::MatrixXd::Identity(n, n);
  state_.p_sigma = Eigen::VectorXd::Zero(n);
  state_.p_c = Eigen::VectorXd::Zero(n);
  state_.generation = 0;
  update_eigen();
}

int Cmaes::default_lambda(int n) {
  return 4 + static_cast<int>(std::floor(3 * std::log(std::max(n, 1))));
}

void Cmaes::update_eigen() {
  // symmetric by construction; enforce it against rounding before the decomposition
  state_.C = 0.5 * (state_.C + state_.C.transpose()).eval();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(state_.C);
  B_ = eig.eigenvectors();
  // eigenvalues that rounding pushed to or below zero are lifted, so that C^-1/2 exists
  const double floor = 1e-20 * std::max(1.0, eig.eigenvalues().cwiseAbs().maxCoeff());
  D_ = eig.eigenvalues().cwiseMax(floor).cwiseSqrt();
}

Eigen::MatrixXd Cmaes::ask(std::mt19937_64& rng) const {
  const int n = dimension();
  // a fresh distribution per call: the generator is the only state carried between calls
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd x(n, lambda_);
  Eigen::VectorXd z(n);
  for (int k = 0; k < lambda_; ++k) {
    for (int attempt = 0;; ++attempt) {
      for (int i = 0; i < n; ++i) z[i] = normal(rng);
      x.col(k) = state_.mean + state_.sigma * (B_ * D_.cwiseProduct(z));
      if (!lower_) break;
      const bool inside = (x.col(k).array() >= lower_->array()).all() &&
                          (x.col(k).array() <= upper_->array()).all();
      if (inside) break;
      if (attempt + 1 >= kMaxResamples) {
        x.col(k) = x.col(k).cwiseMax(*lower_).cwiseMin(*upper_);
        break;
      }
    }
  }
  return x;
}

void Cmaes::tell(const Eigen::MatrixXd& x, const std::vector<double>& values) {
  const int n = dimension();
  if (x.rows() != n || x.cols() != lambda_ || static_cast<int>(values.size()) != lambda_)
    throw std::invalid_argument("Cmaes::tell: expected " + std::to_string(lambda_) +
                                " points of dimension " + std::to_string(n) + " and their values");
  for (double v : values)
    if (std::isnan(v)) throw std::invalid_argument("Cmaes::tell: a value is NaN");

  // the best mu points, in order
  std::vector<int> order(lambda_);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return values[a] < values[b]; });
  const int mu = this->mu();
  CmaesState& s = state_;
  Eigen::MatrixXd y(n, mu);  // the selected steps (x - m) / sigma
  for (int i = 0; i < mu; ++i) y.col(i) = (x.col(order[i]) - s.mean) / s.sigma;
  const Eigen::VectorXd y_w = y * weights_;

  // mean: weighted recombination
  s.mean += s.sigma * y_w;

  // step size: cumulative step-size adaptation on the conjugate path C^-1/2 y_w
  const Eigen::VectorXd c_inv_sqrt_y = B_ * (B_.transpose() * y_w).cwiseQuotient(D_);
  s.p_sigma =
      (1 - c_sigma_) * s.p_sigma + std::sqrt(c_sigma_ * (2 - c_sigma_) * mu_eff_) * c_inv_sqrt_y;
  const double p_sigma_norm = s.p_sigma.norm();
  s.sigma *= std::exp((c_sigma_ / d_sigma_) * (p_sigma_norm / chi_n_ - 1));

  // covariance: rank-one update from the evolution path (stalled while p_sigma is long, the
  // h_sigma test) plus the rank-mu update from the selected steps
  const double decay = 1 - std::pow(1 - c_sigma_, 2.0 * (s.generation + 1));
  const bool h_sigma = p_sigma_norm / std::sqrt(decay) < (1.4 + 2 / (n + 1.0)) * chi_n_;
  s.p_c = (1 - c_c_) * s.p_c + (h_sigma ? std::sqrt(c_c_ * (2 - c_c_) * mu_eff_) : 0.0) * y_w;
  const double delta_h = h_sigma ? 0.0 : c_c_ * (2 - c_c_);
  Eigen::MatrixXd rank_mu = y * weights_.asDiagonal() * y.transpose();
  s.C = (1 - c_1_ - c_mu_) * s.C + c_1_ * (s.p_c * s.p_c.transpose() + delta_h * s.C) +
        c_mu_ * rank_mu;
  ++s.generation;
  update_eigen();
}

void Cmaes::set_state(const CmaesState& state) {
  const int n = dimension();
  if (state.mean.size() != n || state.p_sigma.size() != n || state.p_c.size() != n ||
      state.C.rows() != n || state.C.cols() != n)
    throw std::invalid_argument("Cmaes::set_state: a state of another dimension");
  if (!(state.sigma > 0) || state.generation < 0)
    throw std::invalid_argument("Cmaes::set_state: sigma <= 0 or a negative generation");
  state_ = state;
  update_eigen();
}

}  // namespace stance
