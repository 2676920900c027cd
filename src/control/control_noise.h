// Smoothed Gaussian control noise (the LQR tutorial's perturbation): white noise per actuator,
// filtered by a Gaussian kernel of width `smoothing_s` normalised to unit L2 norm (so the
// filtered noise keeps unit variance), scaled by balance_std on the balance actuators and
// other_std on the rest, and added to out.ctrl. A controller of its own, so it composes with
// any actuator-level controller listed before it.
//
// The sequence is deterministic: the stream is seeded from the scenario's seed and the
// controller's place, and reset() restarts it. The filter is causal (a ring buffer of the last
// kernel-width samples, pre-filled at reset), so a step allocates nothing.
#pragma once

#include <Eigen/Core>
#include <random>
#include <string>
#include <vector>

#include "control/controller.h"
#include "control/legacy_controller.h"

namespace stance {

struct ControlNoiseParams {
  double balance_std = 0.01;  // ctrl units
  double other_std = 0.08;    // ctrl units
  double smoothing_s = 0.8;   // kernel width (spans +-3 sigma)
  // actuators with balance_std: regexes matched against whole actuator names
  std::vector<std::string> balance_actuators = {"abdomen_.*", "left_(hip_.*|knee|ankle_.*)"};
  int seed_offset = 0;  // added to the scenario-derived seed, to draw another sequence

  template <class V>
  void visit(V& v) {
    v("balance_std", balance_std, {.unit = "ctrl", .min = 0, .max = 1e3});
    v("other_std", other_std, {.unit = "ctrl", .min = 0, .max = 1e3});
    v("smoothing_s", smoothing_s,
      {.unit = "s", .min = 0, .max = 100, .help = "Gaussian kernel width; 0: white noise"});
    v("balance_actuators", balance_actuators, {.help = "regexes of actuators with balance_std"});
    v("seed_offset", seed_offset, {.min = 0, .max = 1e9});
  }
};

class ControlNoise final : public LegacyController {
 public:
  ControlNoise(const ControlNoiseParams& params, const Engine& engine, uint64_t seed);
  std::string_view type() const override { return "control_noise"; }
  void reset(const Engine& engine) override;
  void compute(const Engine& engine, ControlOutput& out) override;
  void signal_names(std::vector<std::string>& names) const override;
  void signals(std::vector<double>& values) const override;
  void add_metrics(nlohmann::json& metrics) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }

  const Eigen::VectorXd& kernel() const { return kernel_; }
  const Eigen::VectorXd& std_per_actuator() const { return std_; }
  const Eigen::VectorXd& last_noise() const { return noise_; }

 private:
  void draw_column(int column);

  ControlNoiseParams params_;
  uint64_t seed_;
  Eigen::VectorXd kernel_;  // dim w, unit L2 norm
  Eigen::VectorXd std_;     // dim nu
  // state: white samples, nu x w ring buffer; `head_` is the newest column
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_;
  Eigen::MatrixXd white_;
  int head_ = 0;
  Eigen::VectorXd noise_;  // dim nu, last output
  double sq_sum_ = 0;
  long samples_ = 0;
};

}  // namespace stance
