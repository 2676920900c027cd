// The ankle strategy of DART's biped tutorial: keep the COM over the feet by torquing the heel
// and toe dofs in proportion to the COM's forward offset from a point on the heel.
//
//   offset = (com - heel_point) . forward_axis
//   in the forward band:  tau_heel += -k1 offset - kd rate,  tau_toe += -k2 offset - kd rate
//   in the backward band: the same with the backward gains
// where rate is d(offset)/dt (from velocities), or the seed's per-step change of the offset.
// A band with tip_lever > 0 clamps each of its torques to |tau| <= (m g / feet) * tip_lever, the
// moment a foot carrying its share of the weight transmits before it tips about its edge (an
// extension to the seed, which applies the band's torques unclamped).
// The optional capture term (off by default, also an extension) acts on the capture point
//   xi = offset + rate / omega,  omega = sqrt(g / h), h = the COM's height over the heel point,
// and adds tau_heel += gain (lower - xi) when xi < lower, -gain (xi - upper) when xi > upper,
// clamped to +-max_torque: it puts the centre of pressure toward the feet's edge as soon as a
// push sends the capture point there, before the offset reaches the seed's bands.
#pragma once

#include "control/controller.h"
#include "engine/engine.h"

namespace stance {

struct AnkleBand {
  double lower = 0, upper = 0.1;  // m, the band is lower < offset < upper
  double k1 = 200;                // heel gain, N m/m
  double k2 = 100;                // toe gain, N m/m
  double kd = 10;                 // derivative gain
  // m, distance from the ankle to the foot's edge it tips about under this band's torques;
  // 0 leaves the torques unclamped (the seed)
  double tip_lever = 0;
  // m, the torques ramp in linearly over this distance from the band's inner edge (the one
  // nearer zero offset); 0 switches them on as a step (the seed)
  double ramp = 0;

  template <class V>
  void visit(V& v) {
    v("lower", lower, {.unit = "m"});
    v("upper", upper, {.unit = "m"});
    v("k1", k1, {.unit = "N m/m", .min = 0, .help = "heel gain"});
    v("k2", k2, {.unit = "N m/m", .min = 0, .help = "toe gain"});
    v("kd", kd, {.min = 0, .help = "derivative gain on the offset's change"});
    v("tip_lever", tip_lever,
      {.unit = "m",
       .min = 0,
       .help = "ankle-to-tipping-edge distance; clamps torques to (m g / feet) * lever, 0 = off"});
    v("ramp", ramp, {.unit = "m", .min = 0, .help = "ramp-in distance from the inner edge"});
  }
};

struct AnkleCaptureTerm {
  double gain = 0;  // N m per m of capture point outside the band; 0 = off (the seed)
  double lower = -0.02, upper = 0.2;  // m, capture point relative to the heel point
  double max_torque = 8;              // N m per heel dof (about what a foot holds before tipping)

  template <class V>
  void visit(V& v) {
    v("gain", gain, {.unit = "N m/m", .min = 0, .help = "0 = off (the seed)"});
    v("lower", lower, {.unit = "m", .help = "capture point offset below which the term acts"});
    v("upper", upper, {.unit = "m", .help = "capture point offset above which the term acts"});
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "clamp per heel dof"});
  }
};

struct AnkleStrategyParams {
  bool enabled = true;
  std::string heel_body = "h_heel_left";
  Eigen::Vector3d heel_point = Eigen::Vector3d(0.05, 0, 0);  // in the heel body's frame
  Eigen::Vector3d forward_axis = Eigen::Vector3d::UnitX();   // world; the seed's model is Y-up
  std::vector<std::string> heel_dofs = {"j_heel_left_1", "j_heel_right_1"};
  std::vector<std::string> toe_dofs = {"j_toe_left", "j_toe_right"};
  AnkleBand forward{0.0, 0.1, 200, 100, 10};
  AnkleBand backward{-0.2, -0.05, 2000, 100, 100};
  AnkleCaptureTerm capture;
  // "velocity": rate = d(offset)/dt (DART's C++ tutorial); "per_step": the change of the offset
  // since the last step (the dartpy seed), which is dt times smaller
  std::string derivative = "velocity";
  // kg, the mass the feet carry, for the bands' tip_lever clamps; 0 = the engine's total mass
  double supported_mass = 0;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("heel_body", heel_body, {.help = "body carrying the reference point"});
    v("heel_point", heel_point, {.unit = "m", .help = "reference point in the heel's frame"});
    v("forward_axis", forward_axis, {.help = "world direction of 'forward'"});
    v("heel_dofs", heel_dofs);
    v("toe_dofs", toe_dofs);
    v("forward", forward, {.help = "band and gains for a COM ahead of the heel point"});
    v("backward", backward, {.help = "band and gains for a COM behind it"});
    v("capture", capture, {.help = "heel torque on the capture point (off by default)"});
    v("derivative", derivative, {.help = "velocity or per_step"});
    v("supported_mass", supported_mass,
      {.unit = "kg", .min = 0, .help = "mass on the feet for tip_lever; 0 = total mass"});
  }
};

// the per-run data: the last measurement, the band in use and the offset statistics
struct AnkleStrategyState {
  double offset = 0, prev_offset = 0, rate = 0;
  double heel_point = 0;      // forward coordinate of the reference point, m
  double capture_point = 0;   // m, relative to the heel point (when the capture term is on)
  double capture_torque = 0;  // N m per heel dof from the capture term
  bool first = true;
  int band = 0;                                   // +1 forward, -1 backward, 0 none
  double max_abs_offset = 0, abs_offset_sum = 0;  // m
  long samples = 0;

  template <class A>
  void serialize(A& a) {
    a(offset), a(prev_offset), a(rate), a(heel_point), a(capture_point), a(capture_torque);
    a(first), a(band), a(max_abs_offset), a(abs_offset_sum), a(samples);
  }
};

class AnkleStrategy final : public TypedController<AnkleStrategyState, Reporting, Retunable> {
 public:
  struct Model {
    AnkleStrategyParams params;
    int heel_body = -1;
    std::vector<int> heel_dofs, toe_dofs;
    Eigen::Vector3d axis;  // unit
    bool per_step = false;
    double foot_weight = 0;  // N, the weight each foot carries (supported mass g / heel dofs)
    Eigen::Vector3d up = Eigen::Vector3d::UnitY();  // unit, against gravity
    double gravity = 9.81;                          // m/s^2
  };

  AnkleStrategy(const AnkleStrategyParams& params, const ControllerContext& ctx,
                const Engine& engine);
  std::string_view type() const override { return "ankle_strategy"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(model_.params, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(model_.params); }

  const Model& model() const { return model_; }

  // the Controller's compute(state, engine, out) beside the static one below
  using TypedController::compute;
  // one step on a given model: the measurement and the band's torques (not the statistics)
  static void compute(const Model& model, State& state, const Engine& engine, ControlOutput& out);
  // the offset and its rate, dims scalar
  static void measure(const Model& model, const Engine& engine, double& offset, double& rate,
                      double& heel_point);
  // the capture term's heel torque for a capture point xi (m, relative to the heel point)
  static double capture_torque(const AnkleCaptureTerm& c, double xi);

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  void compute_step(State& state, const Engine& engine, ControlOutput& out) const override;

 private:
  Model model_;
};

}  // namespace stance
