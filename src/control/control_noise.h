// Smoothed Gaussian control noise (the LQR tutorial's perturbation): white noise per actuator,
// filtered by a Gaussian kernel of width `smoothing_s` normalised to unit L2 norm (so the
// filtered noise keeps unit variance), scaled by balance_std on the balance actuators and
// other_std on the rest, and added to out.ctrl. A controller of its own, so it composes with
// any actuator-level controller listed before it.
//
// The sequence is deterministic: the stream is seeded from the scenario's seed and the
// controller's place, and lives in the run's State, so a reset restarts it and a branched run
// continues it. The filter is causal (a ring buffer of the last kernel-width samples,
// pre-filled at reset), so a step allocates nothing. A State is kept across a live edit only
// when the window (smoothing_s) and the seed stay the same.
#pragma once

#include <Eigen/Core>
#include <random>
#include <string>
#include <vector>

#include "control/controller.h"

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
    v("balance_std", balance_std,
      {.unit = "ctrl", .min = 0, .max = 1e3, .help = "noise deviation on the balance actuators"});
    v("other_std", other_std,
      {.unit = "ctrl", .min = 0, .max = 1e3, .help = "noise deviation on the other actuators"});
    v("smoothing_s", smoothing_s,
      {.unit = "s", .min = 0, .max = 100, .help = "Gaussian kernel width; 0: white noise"});
    v("balance_actuators", balance_actuators, {.help = "regexes of actuators with balance_std"});
    v("seed_offset", seed_offset,
      {.min = 0, .max = 1e9, .help = "added to the scenario's seed: another noise sequence"});
  }
};

// the per-run data: the random stream, the window of white samples and the last output
struct ControlNoiseState {
  std::mt19937_64 rng;
  std::normal_distribution<double> normal;
  Eigen::MatrixXd white;  // nu x w ring buffer of white samples; `head` is the newest column
  int head = 0;
  Eigen::VectorXd noise;  // dim nu, last output
  double sq_sum = 0;
  long samples = 0;

  template <class A>
  void serialize(A& a) {
    a(rng), a(normal), a(white), a(head), a(noise), a(sq_sum), a(samples);
  }
};

class ControlNoise final : public TypedController<ControlNoiseState, Reporting, Retunable> {
 public:
  ControlNoise(const ControlNoiseParams& params, const ControllerContext& ctx,
               const Engine& engine);
  std::string_view type() const override { return "control_noise"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(params_); }
  // the State's window is kernel-width long and its stream drawn from the seed
  bool keeps_state_of(const Controller& previous) const override;

  const Eigen::VectorXd& kernel() const { return kernel_; }
  const Eigen::VectorXd& std_per_actuator() const { return std_; }
  uint64_t seed() const { return seed_; }

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  void compute_step(State& state, const Engine& engine, ControlOutput& out) const override;

 private:
  ControlNoiseParams params_;
  uint64_t seed_;
  int nu_ = 0;
  Eigen::VectorXd kernel_;  // dim w, unit L2 norm
  Eigen::VectorXd std_;     // dim nu
};

}  // namespace stance
