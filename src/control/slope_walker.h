// The seed's 2D slope walker: two small state machines drive a planar biped down a slope
// (gravity tilted by the scenario's slope_rad).
//  - hip: swing leg 1 or leg 2. The swing leg changes when the swing foot is near the ground
//    and the stance leg has passed vertical; the hip servo then aims the new swing leg
//    +-hip_target_rad ahead of the stance leg.
//  - knees: stance or retract. A knee retracts (shortens its leg) when the other foot lands,
//    and re-extends once its leg has swung forward past knee_extend_angle_rad.
// The hip and knee position servos are PD torques computed here, so their gains are
// parameters (a sweep over hip_kp gives the bifurcation diagram).
//
// Leg angles are absolute: the twist of each leg body's orientation about hinge_axis, positive
// with the foot ahead of the hip. Each hip-FSM switch is a step: its length is the x distance
// from the old stance foot to the new one.
#pragma once

#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"

namespace stance {

struct SlopeWalkerParams {
  // model names
  std::string leg1_body = "leg1";  // carries the planar root
  std::string leg2_body = "leg2";
  std::string foot1_body = "foot1";
  std::string foot2_body = "foot2";
  std::string hip_dof = "hip";  // leg2 relative to leg1
  std::string knee1_dof = "knee1";
  std::string knee2_dof = "knee2";
  Eigen::Vector3d hinge_axis{0, -1, 0};  // leg angles are measured about this axis

  // servos
  double hip_kp = 10;            // N m/rad
  double hip_kv = 1;             // N m s/rad
  double knee_kp = 1000;         // N/m
  double knee_kv = 10;           // N s/m
  double max_hip_torque = 100;   // N m
  double max_knee_force = 1000;  // N

  // state machines
  double hip_target_rad = 0.5;          // swing leg ahead of the stance leg
  double knee_retract_m = -0.25;        // knee slide while retracted (negative: shorter leg)
  double foot_contact_height_m = 0.05;  // a foot below this is "near the ground"
  double stance_past_vertical_rad = 0;  // stance leg angle below this has passed vertical
  double knee_extend_angle_rad = 0.1;   // a retracted leg re-extends past this angle
  bool knee_fsm = true;                 // false: knees locked straight (the seed's failure)
  int first_swing_leg = 2;              // 1 or 2

  // analysis
  int transient_steps = 30;          // steps ignored before the gait is analysed
  int max_period = 16;               // longest period looked for
  double period_tolerance_m = 0.04;  // step lengths this close count as equal
  double fall_hip_height_m = 0.5;    // hip below this height above the floor: fell
  double stall_time_s = 3;           // no step for this long: stalled

  template <class V>
  void visit(V& v) {
    v("leg1_body", leg1_body, {.help = "leg body carrying the planar root"});
    v("leg2_body", leg2_body);
    v("foot1_body", foot1_body);
    v("foot2_body", foot2_body);
    v("hip_dof", hip_dof, {.help = "hinge of leg2 relative to leg1"});
    v("knee1_dof", knee1_dof, {.help = "slide along leg1 (negative: shorter)"});
    v("knee2_dof", knee2_dof);
    v("hinge_axis", hinge_axis, {.help = "axis of the leg angles (world frame)"});
    v("hip_kp", hip_kp, {.unit = "N m/rad", .min = 0, .help = "hip servo stiffness"});
    v("hip_kv", hip_kv, {.unit = "N m s/rad", .min = 0, .help = "hip servo damping"});
    v("knee_kp", knee_kp, {.unit = "N/m", .min = 0, .help = "knee servo stiffness"});
    v("knee_kv", knee_kv, {.unit = "N s/m", .min = 0, .help = "knee servo damping"});
    v("max_hip_torque", max_hip_torque, {.unit = "N m", .min = 0, .help = "hip torque clamp"});
    v("max_knee_force", max_knee_force, {.unit = "N", .min = 0, .help = "knee force clamp"});
    v("hip_target_rad", hip_target_rad,
      {.unit = "rad", .min = 0, .max = 2, .help = "swing leg ahead of the stance leg"});
    v("knee_retract_m", knee_retract_m,
      {.unit = "m", .min = -1, .max = 0, .help = "knee slide while retracted (negative: shorter)"});
    v("foot_contact_height_m", foot_contact_height_m,
      {.unit = "m", .min = 0, .help = "a foot below this is near the ground"});
    v("stance_past_vertical_rad", stance_past_vertical_rad,
      {.unit = "rad",
       .min = -1,
       .max = 1,
       .help = "a stance leg below this angle is past vertical"});
    v("knee_extend_angle_rad", knee_extend_angle_rad,
      {.unit = "rad", .min = -1, .max = 1, .help = "a retracted leg re-extends past this angle"});
    v("knee_fsm", knee_fsm, {.help = "false: knees stay straight"});
    v("first_swing_leg", first_swing_leg, {.min = 1, .max = 2, .help = "leg 1 or 2"});
    v("transient_steps", transient_steps, {.min = 0, .help = "steps before gait analysis"});
    v("max_period", max_period,
      {.min = 1, .max = 1000, .help = "longest gait period looked for, steps"});
    v("period_tolerance_m", period_tolerance_m,
      {.unit = "m", .min = 0, .help = "step lengths this close count as equal"});
    v("fall_hip_height_m", fall_hip_height_m,
      {.unit = "m", .min = 0, .help = "hip below this height above the floor: fell"});
    v("stall_time_s", stall_time_s,
      {.unit = "s", .min = 0, .help = "no step for this long: stalled"});
  }
};

// one step: the hip FSM switched and a new stance foot landed
struct WalkerStep {
  double time_s = 0;
  int stance_leg = 0;     // 1 or 2: the leg that just landed
  double length_m = 0;    // x distance from the previous stance foot to this one
  double duration_s = 0;  // since the previous step (or the start)
};

enum SlopeWalkerHipState { kLeg1Swing = 1, kLeg2Swing = 2 };
enum SlopeWalkerKneeState { kKneeStance = 0, kKneeRetract = 1 };

// the per-run data: the state machines, the last readings, and the step table
struct SlopeWalkerState {
  SlopeWalkerHipState hip = kLeg2Swing;
  SlopeWalkerKneeState knee1 = kKneeStance, knee2 = kKneeStance;
  double leg1_angle = 0, leg2_angle = 0;  // rad, absolute
  double foot1_z = 0, foot2_z = 0;        // m
  double foot1_x = 0, foot2_x = 0;        // m
  Eigen::Vector3d hip_pos = Eigen::Vector3d::Zero();
  Eigen::Vector3d hip_vel = Eigen::Vector3d::Zero();
  double start_x = 0;
  double last_step_time = 0;
  std::vector<WalkerStep> steps;  // reserved at reset; grows at most once per step
  bool fell = false;
  double fall_time = -1;
  bool stalled = false;
  double stall_time = -1;
  double swing_time = 0;        // s in swing phase, summed over steps
  double swing_scuff_time = 0;  // s of that with the swing foot touching the ground

  template <class A>
  void serialize(A& a) {
    a(hip), a(knee1), a(knee2), a(leg1_angle), a(leg2_angle), a(foot1_z), a(foot2_z);
    a(foot1_x), a(foot2_x), a(hip_pos), a(hip_vel), a(start_x), a(last_step_time), a(steps);
    a(fell), a(fall_time), a(stalled), a(stall_time), a(swing_time), a(swing_scuff_time);
  }
};

class SlopeWalker final
    : public TypedController<SlopeWalkerState, Reporting, Retunable, FallJudge> {
 public:
  using HipState = SlopeWalkerHipState;
  using KneeState = SlopeWalkerKneeState;

  // model: indices and parameters, fixed after construction
  struct Model {
    SlopeWalkerParams params;
    int leg1 = -1, leg2 = -1, foot1 = -1, foot2 = -1;  // bodies
    int hip = -1, knee1 = -1, knee2 = -1;              // dofs
    Eigen::Vector3d axis = Eigen::Vector3d::UnitY();   // normalised hinge_axis
  };

  SlopeWalker(const SlopeWalkerParams& params, const ControllerContext& ctx, const Engine& engine);
  std::string_view type() const override { return "slope_walker"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(model_.params, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(model_.params); }

  const Model& model() const { return model_; }
  // the step lengths after the transient, in order (m)
  std::vector<double> steady_step_lengths(const State& state) const;

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;
  // the walker judges its own fall (hip below fall_hip_height_m above the floor): the run's
  // COM criterion measures along tilted gravity, which drops as the walker goes downhill
  FallVerdict fall_verdict(const ControllerState& state, const Engine& engine,
                           std::string& reason) const override;
  void write_outputs(const ControllerState& state, const std::string& out_dir) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  void compute_step(State& state, const Engine& engine, ControlOutput& out) const override;

 private:
  Model model_;
};

// the rotation angle of q about the unit axis (twist of the swing-twist split), in (-pi, pi]
double twist_angle(const Eigen::Quaterniond& q, const Eigen::Vector3d& axis);

// steps.csv: "step,time_s,stance_leg,step_length_m,step_duration_s"
void write_steps_csv(const std::string& path, const std::vector<WalkerStep>& steps);

}  // namespace stance
