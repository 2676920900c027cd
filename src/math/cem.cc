#include "math/cem.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace stance {

Cem::Cem(const Eigen::VectorXd& mean, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
         const CemParams& params)
    : params_(params), lower_(lower), upper_(upper) {
  const auto n = mean.size();
  if (n < 1) throw std::invalid_argument("Cem: the mean has no dimension");
  if (!mean.allFinite()) throw std::invalid_argument("Cem: the mean is not finite");
  if (lower.size() != n || upper.size() != n || !(lower.array() < upper.array()).all())
    throw std::invalid_argument("Cem: bounds of the wrong size or with lower >= upper");
  if (params.elites < 1) throw std::invalid_argument("Cem: elites must be at least 1");
  if (!(params.initial_spread >= 0) || !(params.min_spread >= 0) ||
      !std::isfinite(params.initial_spread) || !std::isfinite(params.min_spread))
    throw std::invalid_argument("Cem: the spreads must be finite numbers >= 0");
  if (!(params.spread_memory >= 0 && params.spread_memory <= 1))
    throw std::invalid_argument("Cem: spread_memory must be in [0, 1]");
  if (params.redraws < 0) throw std::invalid_argument("Cem: redraws must be >= 0");
  state_.mean = mean;
  state_.spread = Eigen::VectorXd::Constant(n, params.initial_spread);
}

void Cem::sample(std::mt19937_64& rng, std::normal_distribution<double>& normal,
                 Eigen::Ref<Eigen::VectorXd> point) const {
  const Eigen::VectorXd& mean = state_.mean;
  const Eigen::VectorXd& spread = state_.spread;
  for (Eigen::Index k = 0; k < point.size(); ++k) {
    double x = mean[k] + spread[k] * normal(rng);
    for (int tries = 0; tries < params_.redraws && (x < lower_[k] || x > upper_[k]); ++tries)
      x = mean[k] + spread[k] * normal(rng);
    point[k] = std::clamp(x, lower_[k], upper_[k]);
  }
}

void Cem::ask(std::mt19937_64& rng, Eigen::Ref<Eigen::MatrixXd> points) {
  if (points.rows() != dimension())
    throw std::invalid_argument("Cem::ask: points of another dimension");
  for (Eigen::Index c = 0; c < points.cols(); ++c) sample(rng, state_.normal, points.col(c));
}

void Cem::ask_latin_hypercube(std::mt19937_64& rng, Eigen::Ref<Eigen::MatrixXd> points) {
  if (points.rows() != dimension())
    throw std::invalid_argument("Cem::ask_latin_hypercube: points of another dimension");
  if (!lower_.allFinite() || !upper_.allFinite())
    throw std::invalid_argument("Cem::ask_latin_hypercube: the box is not finite");
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const int m = static_cast<int>(points.cols());
  strata_.resize(m);
  for (int k = 0; k < dimension() && m > 0; ++k) {
    // a Fisher-Yates shuffle of the strata, then a uniform point in each
    std::iota(strata_.begin(), strata_.end(), 0);
    for (int s = m - 1; s > 0; --s) {
      const int r = static_cast<int>(uniform(rng) * (s + 1));
      std::swap(strata_[s], strata_[std::min(r, s)]);
    }
    for (int s = 0; s < m; ++s)
      points(k, s) = lower_[k] + (upper_[k] - lower_[k]) * ((strata_[s] + uniform(rng)) / m);
  }
}

template <class PointAt>
void Cem::refit(const PointAt& point, int elites) {
  const int e = elites;
  const double memory = params_.spread_memory;
  for (int k = 0; k < dimension(); ++k) {
    double sum = 0, squares = 0;
    for (int i = 0; i < e; ++i) sum += point(order_[i])[k];
    const double mean = sum / e;
    for (int i = 0; i < e; ++i) {
      const double d = point(order_[i])[k] - mean;
      squares += d * d;
    }
    const double old = state_.spread[k];
    double deviation = old;  // a single elite under sample_deviation: nothing to measure
    if (!params_.sample_deviation)
      deviation = std::sqrt(squares / e);
    else if (e > 1)
      deviation = std::sqrt(squares / (e - 1));
    state_.mean[k] = mean;
    state_.spread[k] = std::max(params_.min_spread, memory * old + (1 - memory) * deviation);
  }
}

void Cem::tell(const Eigen::Ref<const Eigen::MatrixXd>& points, const std::vector<double>& values) {
  const int count = static_cast<int>(points.cols());
  if (points.rows() != dimension() || static_cast<int>(values.size()) != count || count < 1)
    throw std::invalid_argument("Cem::tell: expected points of dimension " +
                                std::to_string(dimension()) + ", at least one, and their values");
  for (double v : values)
    if (std::isnan(v)) throw std::invalid_argument("Cem::tell: a value is NaN");
  // the elites: a stable sort keeps the told order among ties
  auto by_value = [](const std::vector<double>& v) {
    return [&v](int a, int b) { return v[a] < v[b]; };
  };
  if (params_.elites_from_all) {
    for (int c = 0; c < count; ++c) {
      state_.told.push_back(points.col(c));
      state_.told_values.push_back(values[c]);
    }
    order_.resize(state_.told.size());
    std::iota(order_.begin(), order_.end(), 0);
    std::stable_sort(order_.begin(), order_.end(), by_value(state_.told_values));
    const int e = std::min(params_.elites, static_cast<int>(order_.size()));
    refit([&](int i) -> const Eigen::VectorXd& { return state_.told[i]; }, e);
  } else {
    order_.resize(count);
    std::iota(order_.begin(), order_.end(), 0);
    std::stable_sort(order_.begin(), order_.end(), by_value(values));
    const int e = std::min(params_.elites, count);
    refit([&](int i) { return points.col(i); }, e);
  }
}

void Cem::restart(const Eigen::Ref<const Eigen::VectorXd>& mean) {
  if (mean.size() != dimension())
    throw std::invalid_argument("Cem::restart: a mean of another dimension");
  state_.mean = mean;
  state_.spread.setConstant(params_.initial_spread);
  state_.told.clear();
  state_.told_values.clear();
}

void Cem::set_state(const CemState& state) {
  const auto n = dimension();
  if (state.mean.size() != n || state.spread.size() != n)
    throw std::invalid_argument("Cem::set_state: a state of another dimension");
  if (state.told.size() != state.told_values.size())
    throw std::invalid_argument("Cem::set_state: told points and values differ in number");
  for (const auto& p : state.told)
    if (p.size() != n) throw std::invalid_argument("Cem::set_state: a told point of another size");
  if (!(state.spread.array() >= 0).all())
    throw std::invalid_argument("Cem::set_state: a negative spread");
  state_ = state;
}

}  // namespace stance
