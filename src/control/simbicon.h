// SIMBICON (Yin, Loken and van de Panne, SIGGRAPH 2007): a 4-state finite state machine of
// PD targets with balance feedback on the swing hip.
//
// States 0 and 1 have the right leg in stance (the left swings); states 2 and 3 the left.
// States 0 and 2 end after their duration; states 1 and 3 end when the swing foot touches the
// ground, and then the stance side swaps. The torso and the swing thigh are servoed in the
// world frame; knees and ankles relative to their parent. The stance hip supplies the torso's
// torque: tau_stance_hip = -tau_torso - tau_swing_hip. Balance feedback moves the swing hip
// target: theta_d = theta_d0 + cd d + cv v, with d the horizontal distance from the stance
// ankle to the hip (or COM) and v the hip's (or COM's) horizontal velocity.
//
// Any biped: the skeleton names the bodies and dofs, and the character's up axis (default:
// minus gravity) and forward axis (default +x). They span the character frame: forward, left =
// up x forward, up. Every angle of the gait is in that frame, the same on every character:
// sagittal angles turn about the character's right axis (-left), so a positive hip angle swings
// the thigh forward, a negative knee angle bends the knee, a positive ankle angle lifts the toes;
// coronal angles turn about forward. A hinge whose axis points left rather than right (read in
// the world at the loaded pose) gets its targets and torques negated, so no sign is per
// character. World-frame servos assume body frames parallel to the world at the zero pose, as in
// URDF, SDF and the project's MJCF models.
//
// Planar models: angles are about the character's right axis (models/simbicon_2d.xml: -y);
// walking goes forward. Spatial models (models/simbicon_3d.xml) add coronal-plane feedback on
// the swing hip's roll, world-frame torso and swing-thigh orientation servos whose torques reach
// the 3-dof hips through the hip axes (the stance hip holds the torso in pitch, roll and
// heading), and a heading for the swing thigh and torso.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"

namespace stance {

// one FSM state of the half cycle; the other half cycle mirrors it onto the other leg
struct SimbiconStateTargets {
  double duration_s = 0.3;       // ends after this; for contact states, a timeout
  bool ends_on_contact = false;  // end when the swing foot touches the ground
  double min_duration_s = 0.0;   // contact is ignored before this time in the state
  double torso = 0;              // rad, world
  double swing_hip = 0;          // rad, world (thigh from vertical)
  double swing_knee = 0;         // rad, relative
  double swing_ankle = 0;        // rad, relative
  double stance_knee = 0;        // rad, relative
  double stance_ankle = 0;       // rad, relative
  double cd = 0;                 // rad/m, balance feedback on distance
  double cv = 0;                 // rad s/m, balance feedback on velocity
  // 3D only (coronal plane): mirrored so that positive is outward for either swing leg
  double swing_hip_roll = 0;  // rad, world, swing thigh abduction
  double torso_roll = 0;      // rad, world
  double cd_lateral = 0;      // rad/m, coronal feedback on the lateral distance
  double cv_lateral = 0;      // rad s/m, coronal feedback on the lateral velocity
  double spine_roll = 0;      // rad, the upper body's lean towards the stance leg

  template <class V>
  void visit(V& v) {
    v("duration_s", duration_s,
      {.unit = "s",
       .min = 0.001,
       .max = 100,
       .help = "state length, or timeout of a contact state"});
    v("ends_on_contact", ends_on_contact, {.help = "end when the swing foot lands"});
    v("min_duration_s", min_duration_s,
      {.unit = "s", .min = 0, .max = 100, .help = "ignore swing-foot contact before this"});
    v("torso", torso, {.unit = "rad", .min = -3.2, .max = 3.2, .help = "torso pitch, world"});
    v("swing_hip", swing_hip,
      {.unit = "rad", .min = -3.2, .max = 3.2, .help = "swing thigh angle from vertical, world"});
    v("swing_knee", swing_knee, {.unit = "rad", .min = -3.2, .max = 3.2});
    v("swing_ankle", swing_ankle, {.unit = "rad", .min = -3.2, .max = 3.2});
    v("stance_knee", stance_knee, {.unit = "rad", .min = -3.2, .max = 3.2});
    v("stance_ankle", stance_ankle, {.unit = "rad", .min = -3.2, .max = 3.2});
    v("cd", cd, {.unit = "rad/m", .min = -100, .max = 100, .help = "feedback on distance d"});
    v("cv", cv, {.unit = "rad s/m", .min = -100, .max = 100, .help = "feedback on velocity v"});
    v("swing_hip_roll", swing_hip_roll,
      {.unit = "rad",
       .min = -1.5,
       .max = 1.5,
       .help = "3D: swing thigh abduction, world, outward +"});
    v("torso_roll", torso_roll, {.unit = "rad", .min = -1.5, .max = 1.5, .help = "3D"});
    v("cd_lateral", cd_lateral,
      {.unit = "rad/m",
       .min = -100,
       .max = 100,
       .help = "3D: coronal feedback on lateral distance"});
    v("cv_lateral", cv_lateral,
      {.unit = "rad s/m",
       .min = -100,
       .max = 100,
       .help = "3D: coronal feedback on lateral velocity"});
    v("spine_roll", spine_roll,
      {.unit = "rad",
       .min = -1.5,
       .max = 1.5,
       .help = "3D: upper body's lean towards the stance leg (skeleton.spine_roll)"});
  }
};

// one servo; kd < 0 means kp / 10, as in the paper
struct SimbiconJointGain {
  double kp = 300;          // N m/rad
  double kd = -1;           // N m s/rad
  double max_torque = 1e9;  // N m, symmetric clamp

  double damping() const { return kd < 0 ? kp / 10 : kd; }
  template <class V>
  void visit(V& v) {
    v("kp", kp, {.unit = "N m/rad", .min = 0, .max = 1e6});
    v("kd", kd, {.unit = "N m s/rad", .min = -1, .max = 1e5, .help = "-1: kp/10"});
    v("max_torque", max_torque, {.unit = "N m", .min = 0, .help = "torque limit"});
  }
};

struct SimbiconGains {
  SimbiconJointGain torso, swing_hip, swing_knee, swing_ankle, stance_knee, stance_ankle, spine;
  double stance_hip_max_torque = 1e9;  // N m

  template <class V>
  void visit(V& v) {
    v("torso", torso);
    v("swing_hip", swing_hip);
    v("swing_knee", swing_knee);
    v("swing_ankle", swing_ankle);
    v("stance_knee", stance_knee);
    v("stance_ankle", stance_ankle);
    v("spine", spine, {.help = "3D: the spine_roll servo"});
    v("stance_hip_max_torque", stance_hip_max_torque, {.unit = "N m", .min = 0});
  }
};

// a gait: the half cycle's two states, with optional per-side replacements
struct SimbiconGait {
  std::vector<SimbiconStateTargets> states;        // 2 entries: timed swing, then until contact
  std::vector<SimbiconStateTargets> right_stance;  // empty, or 2 entries used in states 0, 1
  std::vector<SimbiconStateTargets> left_stance;   // empty, or 2 entries used in states 2, 3
  SimbiconGains gains;                             // both sides
  std::vector<SimbiconGains> right_stance_gains;   // empty, or 1 entry for states 0, 1
  std::vector<SimbiconGains> left_stance_gains;    // empty, or 1 entry for states 2, 3

  template <class V>
  void visit(V& v) {
    v("states", states, {.help = "the half cycle: [timed state, contact state]"});
    v("right_stance", right_stance, {.help = "replaces states while the right leg stands"});
    v("left_stance", left_stance, {.help = "replaces states while the left leg stands"});
    v("gains", gains);
    v("right_stance_gains", right_stance_gains, {.help = "[gains] while the right leg stands"});
    v("left_stance_gains", left_stance_gains, {.help = "[gains] while the left leg stands"});
  }
};

// the names the controller needs from the model
struct SimbiconSkeleton {
  std::string torso = "torso";
  std::string left_thigh = "left_thigh", right_thigh = "right_thigh";  // origin at the hip joint
  std::string left_foot = "left_foot", right_foot = "right_foot";      // frame origin at the ankle
  std::string left_hip = "left_hip", right_hip = "right_hip";          // dofs
  std::string left_knee = "left_knee", right_knee = "right_knee";
  std::string left_ankle = "left_ankle", right_ankle = "right_ankle";
  // 3D: the hip rolls make a spatial biped (empty = planar); hip yaw and ankle roll are
  // optional pairs there (without ankle roll, coronal balance is the swing hip's roll and foot
  // placement; without hip yaw, the heading is not held). What is off is said at load.
  std::string left_hip_roll, right_hip_roll, left_hip_yaw, right_hip_yaw;
  std::string left_ankle_roll, right_ankle_roll;
  // 3D, optional: a roll hinge between the torso and the upper body, leaned by spine_roll
  std::string spine_roll;
  // the character frame in the world: zero up = minus gravity; forward is made normal to up
  Eigen::Vector3d up = Eigen::Vector3d::Zero();
  Eigen::Vector3d forward = Eigen::Vector3d::UnitX();

  template <class V>
  void visit(V& v) {
    v("torso", torso,
      {.help = "body servoed in the world frame (the body the hips hang from, e.g. a pelvis)"});
    v("left_thigh", left_thigh, {.help = "body; its origin is the hip joint"});
    v("right_thigh", right_thigh);
    v("left_foot", left_foot, {.help = "body; its origin is the ankle"});
    v("right_foot", right_foot);
    v("left_hip", left_hip, {.help = "dof"});
    v("right_hip", right_hip);
    v("left_knee", left_knee);
    v("right_knee", right_knee);
    v("left_ankle", left_ankle);
    v("right_ankle", right_ankle);
    v("left_hip_roll", left_hip_roll, {.help = "3D: dof; empty = planar"});
    v("right_hip_roll", right_hip_roll);
    v("left_hip_yaw", left_hip_yaw, {.help = "3D, optional: dof; empty = heading not held"});
    v("right_hip_yaw", right_hip_yaw);
    v("left_ankle_roll", left_ankle_roll,
      {.help = "3D, optional: dof; empty = one-axis ankles (no ankle roll servo)"});
    v("right_ankle_roll", right_ankle_roll);
    v("spine_roll", spine_roll,
      {.help = "3D, optional: dof, roll hinge between the torso and the upper body"});
    v("up", up, {.help = "character's up axis, world; 0 0 0: minus gravity"});
    v("forward", forward, {.help = "character's forward axis, world (made normal to up)"});
  }
};

struct SimbiconParams {
  SimbiconSkeleton skeleton;
  SimbiconGait gait;
  std::string balance_point = "hip";  // "hip" or "com": where d and v are measured
  int initial_state = 0;              // 0..3
  double heading_rad = 0;             // 3D: walking direction, about z from +x
  double path_gain = 0;               // rad/m: 3D heading turn per metre off the start line
  double max_steer_rad = 0.3;         // clamp of the path correction
  int max_recorded_steps = 20000;     // steps.csv capacity (reserved up front)

  template <class V>
  void visit(V& v) {
    v("skeleton", skeleton);
    v("gait", gait);
    v("balance_point", balance_point, {.help = "hip or com"});
    v("initial_state", initial_state, {.min = 0, .max = 3, .help = "FSM state at the start"});
    v("heading_rad", heading_rad,
      {.unit = "rad", .min = -3.2, .max = 3.2, .help = "3D: desired heading about z"});
    v("path_gain", path_gain,
      {.unit = "rad/m",
       .min = 0,
       .max = 10,
       .help = "3D: heading turn per metre left of the start line"});
    v("max_steer_rad", max_steer_rad,
      {.unit = "rad", .min = 0, .max = 1.5, .help = "3D: clamp of the path correction"});
    v("max_recorded_steps", max_recorded_steps,
      {.min = 1, .max = 10000000, .help = "steps.csv capacity (reserved up front)"});
  }
};

// one foot strike: the end of state 1 or 3
struct SimbiconStep {
  double time_s = 0;      // of the strike
  int foot = 0;           // 0 right, 1 left: the foot that landed (the new stance foot)
  double ankle_x = 0;     // m, landing foot's ankle along +x
  double length_m = 0;    // ankle_x minus the previous stance ankle's
  double duration_s = 0;  // since the previous strike (or the start)
  double width_m = 0;     // 3D: sideways from the previous stance ankle (0 on a planar model)
};

// the per-run data: the FSM and what it has recorded
struct SimbiconState {
  int fsm = 0;
  double state_start_s = 0;
  double swing_hip_target = 0;  // rad, after feedback
  double d = 0, v = 0;          // m, m/s, the feedback inputs
  double start_x = 0, last_x = 0, start_time = 0, last_time = 0;
  double last_strike_s = 0;
  double last_stance_ankle_x = 0, last_stance_ankle_y = 0;  // m, along forward and left
  double flight_time_s = 0;         // with neither foot on the ground (a run's flight phases)
  std::vector<SimbiconStep> steps;  // reserved to max_recorded_steps at reset
  std::array<double, 4> state_time_sum{};  // s, completed states
  std::array<int, 4> state_count{};
  double lateral_start = 0, lateral_last = 0;  // m, hip along the heading's left axis
  Eigen::MatrixXd jac_rot, jac_none;           // 3 x nv, 3 x 0: work for the 3D hips

  template <class A>
  void serialize(A& a) {
    a(fsm), a(state_start_s), a(swing_hip_target), a(d), a(v), a(start_x), a(last_x);
    a(start_time), a(last_time), a(last_strike_s), a(last_stance_ankle_x), a(last_stance_ankle_y);
    a(flight_time_s);
    a(steps), a(state_time_sum), a(state_count), a(lateral_start), a(lateral_last);
    a(jac_rot), a(jac_none);
  }
};

class Simbicon final : public CorrectedController<SimbiconState, Reporting, Retunable, Drawable> {
 public:
  enum Side { kRight = 0, kLeft = 1 };

  // model: indices and the resolved per-state targets and gains, fixed after construction
  struct Model {
    SimbiconParams params;
    int torso = -1;
    std::array<int, 2> thigh{}, foot{}, hip{}, knee{}, ankle{};  // by Side
    std::array<SimbiconStateTargets, 4> targets;                 // by FSM state
    std::array<SimbiconGains, 4> gains;                          // by FSM state
    bool use_com = false;
    bool spatial = false;  // 3D: hip roll dofs named
    // by Side; -1: not named (hip yaw and ankle roll are optional in 3D)
    std::array<int, 2> hip_roll{{-1, -1}}, hip_yaw{{-1, -1}}, ankle_roll{{-1, -1}};
    int spine_roll = -1;    // dof, or -1
    double spine_sign = 1;  // the spine hinge's angle per radian of lean about forward
    // the character frame in the world: the rotation whose columns are forward, left, up
    Eigen::Quaterniond frame_quat = Eigen::Quaterniond::Identity();
    Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // world, unit
    // the character frame turned by heading_rad about up: the canonical frame of the gait
    Eigen::Quaterniond heading = Eigen::Quaterniond::Identity();
    // +1 where the hinge turns about the character's right axis, -1 where about its left
    std::array<double, 2> hip_sign{{1, 1}}, knee_sign{{1, 1}}, ankle_sign{{1, 1}};
  };

  Simbicon(const SimbiconParams& params, const ControllerContext& ctx, const Engine& engine);
  std::string_view type() const override { return "simbicon"; }
  void signal_names(std::vector<std::string>& names) const override;
  // the planner's hook: offsets of the swing-thigh, torso and stance-ankle pitch targets (rad),
  // and in 3D of the swing thigh's and the torso's roll
  void correction_dims(std::vector<CorrectionDim>& dims) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(model_.params, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(model_.params); }

  const Model& model() const { return model_; }

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;
  void write_outputs(const ControllerState& state, const std::string& out_dir) const override;
  // the seed's circles: the stance ankle and the balance point (hip centre or COM) with the
  // distance d between them, and the swing thigh's target direction after feedback
  void markers(const ControllerState& state, const Engine& engine,
               std::vector<Marker>& out) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  // one control step: advance the FSM, then add the torques to out.tau. No allocation.
  void compute_with(State& state, const Engine& engine, const double* correction,
                    ControlOutput& out) const override;

 private:
  Model model_;
};

// planar pitch of a body about the world -y axis (rad, positive = top leaning back)
double pitch_about_minus_y(const Eigen::Quaterniond& q);

// the sign of a hinge in a character frame: +1 when its world axis points along `right`, -1
// when against it; throws InputError naming the dof when the axis is not within 45 degrees of
// that line (a roll or yaw hinge named as a pitch one)
double hinge_sign(const Eigen::Vector3d& axis_world, const Eigen::Vector3d& right,
                  const std::string& dof_name);

// the step statistics of a walk (metrics over SimbiconStep records)
struct SimbiconGaitStats {
  int steps = 0;
  double step_length_mean = 0, step_length_std = 0;      // m
  double step_duration_mean = 0, step_duration_std = 0;  // s
  double step_width_mean = 0;                            // m
  double length_asymmetry = 0;    // |mean right - mean left| / mean, right = right foot lands
  double duration_asymmetry = 0;  // same, for step durations
};
// statistics over steps, skipping the first `skip` (the start-up transient)
SimbiconGaitStats simbicon_gait_stats(const std::vector<SimbiconStep>& steps, int skip);

}  // namespace stance
