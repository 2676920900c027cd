#include "control/control_noise.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <regex>

#include "core/error.h"
#include "engine/engine.h"

namespace stance {

ControlNoise::ControlNoise(const ControlNoiseParams& params, const Engine& engine, uint64_t seed)
    : params_(params), seed_(seed + static_cast<uint64_t>(params.seed_offset)) {
  const int nu = engine.nu();
  if (nu == 0) throw InputError("control_noise: the model has no actuators");
  // the kernel: exp(-x^2/2) on [-3, 3] over smoothing_s / dt samples, unit L2 norm
  const int width =
      std::max(1, static_cast<int>(std::lround(params.smoothing_s / engine.timestep())));
  kernel_.resize(width);
  for (int i = 0; i < width; ++i) {
    double x = width == 1 ? 0.0 : -3.0 + 6.0 * i / (width - 1);
    kernel_[i] = std::exp(-0.5 * x * x);
  }
  kernel_ /= kernel_.norm();

  std::vector<std::regex> res;
  for (const auto& p : params.balance_actuators) {
    try {
      res.emplace_back(p);
    } catch (const std::regex_error& e) {
      throw InputError(
          fmt::format("control_noise: balance_actuators: bad pattern '{}': {}", p, e.what()));
    }
  }
  std_ = Eigen::VectorXd::Constant(nu, params.other_std);
  for (int a = 0; a < nu; ++a)
    for (const auto& re : res)
      if (std::regex_match(engine.actuator_name(a), re)) {
        std_[a] = params.balance_std;
        break;
      }
  white_.resize(nu, width);
  noise_ = Eigen::VectorXd::Zero(nu);
  reset(engine);
}

void ControlNoise::draw_column(int column) {
  for (int a = 0; a < white_.rows(); ++a) white_(a, column) = normal_(rng_);
}

void ControlNoise::reset(const Engine&) {
  rng_.seed(seed_);
  normal_.reset();
  // pre-fill the window so that the noise is stationary from the first step
  for (int c = 0; c < white_.cols(); ++c) draw_column(c);
  head_ = static_cast<int>(white_.cols()) - 1;
  noise_.setZero();
  sq_sum_ = 0;
  samples_ = 0;
}

void ControlNoise::compute(const Engine&, ControlOutput& out) {
  const int w = static_cast<int>(white_.cols());
  head_ = (head_ + 1) % w;
  draw_column(head_);
  // causal convolution: kernel[0] weighs the newest sample
  noise_.setZero();
  for (int k = 0; k < w; ++k) {
    int col = head_ - k;
    if (col < 0) col += w;
    noise_ += kernel_[k] * white_.col(col);
  }
  noise_.array() *= std_.array();
  out.ctrl += noise_;
  out.ctrl_used = true;
  sq_sum_ += noise_.squaredNorm() / static_cast<double>(noise_.size());
  ++samples_;
}

void ControlNoise::signal_names(std::vector<std::string>& names) const {
  names.push_back("control_noise_rms");
}

void ControlNoise::signals(std::vector<double>& values) const {
  values.push_back(std::sqrt(noise_.squaredNorm() / static_cast<double>(noise_.size())));
}

void ControlNoise::add_metrics(nlohmann::json& metrics) const {
  metrics["control_noise_rms"] = samples_ ? std::sqrt(sq_sum_ / samples_) : 0.0;
}

}  // namespace stance
