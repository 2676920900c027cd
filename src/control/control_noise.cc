#include "control/control_noise.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <regex>

#include "core/error.h"
#include "engine/engine.h"

namespace stance {

ControlNoise::ControlNoise(const ControlNoiseParams& params, const ControllerContext& ctx,
                           const Engine& engine)
    : params_(params), seed_(ctx.seed + static_cast<uint64_t>(params.seed_offset)) {
  const int nu = engine.nu();
  nu_ = nu;
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
}

bool ControlNoise::keeps_state_of(const Controller& previous) const {
  const auto* p = dynamic_cast<const ControlNoise*>(&previous);
  return p && p->kernel_.size() == kernel_.size() && p->seed_ == seed_ && p->nu_ == nu_;
}

namespace {
void draw_column(ControlNoiseState& s, int column) {
  for (int a = 0; a < s.white.rows(); ++a) s.white(a, column) = s.normal(s.rng);
}
}  // namespace

void ControlNoise::reset_state(State& s, const Engine&) const {
  s.white.resize(nu_, kernel_.size());
  s.noise.setZero(nu_);
  s.rng.seed(seed_);
  s.normal.reset();
  // pre-fill the window so that the noise is stationary from the first step
  for (int c = 0; c < s.white.cols(); ++c) draw_column(s, c);
  s.head = static_cast<int>(s.white.cols()) - 1;
  s.sq_sum = 0;
  s.samples = 0;
}

void ControlNoise::compute_step(State& s, const Engine&, ControlOutput& out) const {
  const int w = static_cast<int>(s.white.cols());
  s.head = (s.head + 1) % w;
  draw_column(s, s.head);
  // causal convolution: kernel[0] weighs the newest sample
  s.noise.setZero();
  for (int k = 0; k < w; ++k) {
    int col = s.head - k;
    if (col < 0) col += w;
    s.noise += kernel_[k] * s.white.col(col);
  }
  s.noise.array() *= std_.array();
  out.ctrl += s.noise;
  out.ctrl_used = true;
  s.sq_sum += s.noise.squaredNorm() / static_cast<double>(s.noise.size());
  ++s.samples;
}

void ControlNoise::signal_names(std::vector<std::string>& names) const {
  names.push_back("control_noise_rms");
}

void ControlNoise::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(std::sqrt(s.noise.squaredNorm() / static_cast<double>(s.noise.size())));
}

void ControlNoise::add_metrics(const ControllerState& state, nlohmann::json& metrics) const {
  const State& s = cast(state);
  metrics["control_noise_rms"] = s.samples ? std::sqrt(s.sq_sum / s.samples) : 0.0;
}

}  // namespace stance
