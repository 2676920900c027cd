#include "control/slope_walker.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "analysis/gait.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace stance {

namespace {
// room for the step table, so that compute() never reallocates it
constexpr size_t kMaxSteps = 100000;

int require_slide_or_hinge(const Engine& engine, const std::string& name, JointType type,
                           const char* what) {
  int dof = engine.require_dof(name);
  const JointInfo& j = engine.joint(engine.dof_joint(dof));
  if (j.type != type)
    throw InputError(fmt::format("slope_walker: {} '{}' must be a {} joint", what, name,
                                 type == JointType::kHinge ? "hinge" : "slide"));
  return dof;
}
}  // namespace

double twist_angle(const Eigen::Quaterniond& q, const Eigen::Vector3d& axis) {
  // q = cos(a/2) + sin(a/2) n: the twist about `axis` has angle 2 atan2(v . axis, w)
  double a = 2 * std::atan2(q.vec().dot(axis), q.w());
  if (a > M_PI) a -= 2 * M_PI;
  if (a <= -M_PI) a += 2 * M_PI;
  return a;
}

SlopeWalker::SlopeWalker(const SlopeWalkerParams& params, const ControllerContext&,
                         const Engine& engine) {
  model_.params = params;
  model_.leg1 = engine.require_body(params.leg1_body);
  model_.leg2 = engine.require_body(params.leg2_body);
  model_.foot1 = engine.require_body(params.foot1_body);
  model_.foot2 = engine.require_body(params.foot2_body);
  model_.hip = require_slide_or_hinge(engine, params.hip_dof, JointType::kHinge, "hip_dof");
  model_.knee1 = require_slide_or_hinge(engine, params.knee1_dof, JointType::kSlide, "knee1_dof");
  model_.knee2 = require_slide_or_hinge(engine, params.knee2_dof, JointType::kSlide, "knee2_dof");
  if (params.hinge_axis.norm() < 1e-9)
    throw InputError("slope_walker.hinge_axis: expected a non-zero vector");
  model_.axis = params.hinge_axis.normalized();
}

void SlopeWalker::reset_state(State& s, const Engine& engine) const {
  // keep the step table's storage
  std::vector<WalkerStep> steps = std::move(s.steps);
  steps.clear();
  s = State{};
  s.steps = std::move(steps);
  s.steps.reserve(kMaxSteps);
  s.hip = model_.params.first_swing_leg == 1 ? kLeg1Swing : kLeg2Swing;
  s.start_x = engine.body_pose(model_.leg1).pos.x();
  s.last_step_time = engine.time();
}

void SlopeWalker::compute_step(State& s, const Engine& engine, ControlOutput& out) const {
  const Model& model = model_;
  const SlopeWalkerParams& p = model.params;
  const double t = engine.time();

  // state estimate: absolute leg angles from body orientations, feet from body positions
  const BodyPose leg1 = engine.body_pose(model.leg1);
  s.leg1_angle = twist_angle(leg1.quat, model.axis);
  s.leg2_angle = twist_angle(engine.body_pose(model.leg2).quat, model.axis);
  const Eigen::Vector3d foot1 = engine.body_pose(model.foot1).pos;
  const Eigen::Vector3d foot2 = engine.body_pose(model.foot2).pos;
  s.foot1_z = foot1.z();
  s.foot2_z = foot2.z();
  s.foot1_x = foot1.x();
  s.foot2_x = foot2.x();
  s.hip_pos = leg1.pos;
  s.hip_vel = engine.body_velocity(model.leg1).tail<3>();

  // hip transitions: the swing foot is down and the stance leg has passed vertical
  const bool foot1_down = s.foot1_z < p.foot_contact_height_m;
  const bool foot2_down = s.foot2_z < p.foot_contact_height_m;
  const bool leg1_past = s.leg1_angle < p.stance_past_vertical_rad;
  const bool leg2_past = s.leg2_angle < p.stance_past_vertical_rad;
  int landed = 0;
  if (s.hip == kLeg2Swing && foot2_down && leg1_past) {
    s.hip = kLeg1Swing;
    landed = 2;
  } else if (s.hip == kLeg1Swing && foot1_down && leg2_past) {
    s.hip = kLeg2Swing;
    landed = 1;
  }
  if (landed != 0 && !s.fell && s.steps.size() < kMaxSteps) {
    WalkerStep step;
    step.time_s = t;
    step.stance_leg = landed;
    step.length_m = landed == 2 ? s.foot2_x - s.foot1_x : s.foot1_x - s.foot2_x;
    step.duration_s = t - s.last_step_time;
    s.steps.push_back(step);
    s.last_step_time = t;
  }

  // knee transitions: retract when the other foot lands, extend once swung past the angle
  if (p.knee_fsm) {
    if (s.knee1 == kKneeStance && foot2_down && leg1_past)
      s.knee1 = kKneeRetract;
    else if (s.knee1 == kKneeRetract && s.leg1_angle > p.knee_extend_angle_rad)
      s.knee1 = kKneeStance;
    if (s.knee2 == kKneeStance && foot1_down && leg2_past)
      s.knee2 = kKneeRetract;
    else if (s.knee2 == kKneeRetract && s.leg2_angle > p.knee_extend_angle_rad)
      s.knee2 = kKneeStance;
  }

  // actions: position servos as PD torques
  const double hip_target = s.hip == kLeg2Swing ? p.hip_target_rad : -p.hip_target_rad;
  const double hip_tau = p.hip_kp * (hip_target - engine.dof_position(model.hip)) -
                         p.hip_kv * engine.dof_velocity(model.hip);
  out.tau[model.hip] += std::clamp(hip_tau, -p.max_hip_torque, p.max_hip_torque);
  auto knee_force = [&](int dof, KneeState k) {
    const double target = k == kKneeRetract ? p.knee_retract_m : 0.0;
    const double f =
        p.knee_kp * (target - engine.dof_position(dof)) - p.knee_kv * engine.dof_velocity(dof);
    out.tau[dof] += std::clamp(f, -p.max_knee_force, p.max_knee_force);
  };
  knee_force(model.knee1, s.knee1);
  knee_force(model.knee2, s.knee2);

  // scuffing: the swing foot on the ground while its leg is still behind the hip
  const double dt = engine.timestep();
  const bool leg1_swings = s.hip == kLeg1Swing;
  const int swing_foot = leg1_swings ? model.foot1 : model.foot2;
  const double swing_angle = leg1_swings ? s.leg1_angle : s.leg2_angle;
  if (!s.fell) {
    s.swing_time += dt;
    if (swing_angle < 0 && engine.body_touches_ground(swing_foot)) s.swing_scuff_time += dt;
  }

  // falls and stalls
  if (!s.fell && s.hip_pos.z() < p.fall_hip_height_m) {
    s.fell = true;
    s.fall_time = t;
  }
  if (!s.stalled && !s.fell && t - s.last_step_time > p.stall_time_s) {
    s.stalled = true;
    s.stall_time = t;
  }
}

FallVerdict SlopeWalker::fall_verdict(const ControllerState& state, const Engine&,
                                      std::string& reason) const {
  const State& s = cast(state);
  if (!s.fell) return FallVerdict::kUp;
  reason = fmt::format("hip below {} m above the floor", model_.params.fall_hip_height_m);
  return FallVerdict::kFell;
}

void SlopeWalker::signal_names(std::vector<std::string>& names) const {
  for (const char* n : {"hip_vx", "hip_vz", "leg1_angle", "leg2_angle", "foot1_z", "foot2_z",
                        "hip_fsm", "knee1_fsm", "knee2_fsm", "step_count", "last_step_length_m"})
    names.emplace_back(n);
}

void SlopeWalker::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.hip_vel.x());
  values.push_back(s.hip_vel.z());
  values.push_back(s.leg1_angle);
  values.push_back(s.leg2_angle);
  values.push_back(s.foot1_z);
  values.push_back(s.foot2_z);
  values.push_back(s.hip);
  values.push_back(s.knee1);
  values.push_back(s.knee2);
  values.push_back(static_cast<double>(s.steps.size()));
  values.push_back(s.steps.empty() ? 0.0 : s.steps.back().length_m);
}

std::vector<double> SlopeWalker::steady_step_lengths(const State& s) const {
  std::vector<double> out;
  for (size_t i = std::max(0, model_.params.transient_steps); i < s.steps.size(); ++i)
    out.push_back(s.steps[i].length_m);
  return out;
}

void SlopeWalker::add_metrics(const ControllerState& state, nlohmann::json& m) const {
  const State& s = cast(state);
  const SlopeWalkerParams& p = model_.params;
  std::vector<double> lengths;
  std::vector<int> legs;
  double duration_sum = 0;
  for (const auto& step : s.steps) {
    lengths.push_back(step.length_m);
    legs.push_back(step.stance_leg);
    duration_sum += step.duration_s;
  }
  m["steps_taken"] = static_cast<int>(s.steps.size());
  m["walker_fell"] = s.fell;
  m["walker_fall_time_s"] = s.fell ? nlohmann::json(s.fall_time) : nlohmann::json(nullptr);
  m["walker_stalled"] = s.stalled;
  m["walker_stall_time_s"] = s.stalled ? nlohmann::json(s.stall_time) : nlohmann::json(nullptr);
  m["distance_m"] = s.hip_pos.x() - s.start_x;
  m["scuff_fraction"] = s.swing_time > 0 ? s.swing_scuff_time / s.swing_time : 0.0;
  double mean_len = 0;
  for (double l : lengths) mean_len += l;
  m["mean_step_length_m"] = lengths.empty() ? 0.0 : mean_len / lengths.size();
  m["mean_step_duration_s"] = lengths.empty() ? 0.0 : duration_sum / lengths.size();

  GaitPeriodOptions opt;
  opt.transient_steps = p.transient_steps;
  opt.max_period = p.max_period;
  opt.tolerance = p.period_tolerance_m;
  GaitPeriod period = detect_gait_period(lengths, opt);
  m["gait_period"] = period.period;
  m["gait"] = gait_period_label(period.period);
  m["gait_cycle_step_lengths_m"] = period.cycle;
  m["step_length_asymmetry"] = step_length_asymmetry(lengths, legs, p.transient_steps);
  m["step_length_spread"] = step_length_spread(lengths, p.transient_steps);
  m["steady_step_lengths_m"] = steady_step_lengths(s);
}

void write_steps_csv(const std::string& path, const std::vector<WalkerStep>& steps) {
  AtomicFile file(path);
  std::ostream& f = file.stream();
  f << "step,time_s,stance_leg,step_length_m,step_duration_s\n";
  for (size_t i = 0; i < steps.size(); ++i)
    f << fmt::format("{},{:.6f},{},{:.9g},{:.9g}\n", i, steps[i].time_s, steps[i].stance_leg,
                     steps[i].length_m, steps[i].duration_s);
  file.commit();
}

void SlopeWalker::write_outputs(const ControllerState& state, const std::string& out_dir) const {
  const State& s = cast(state);
  write_steps_csv((std::filesystem::path(out_dir) / "steps.csv").string(), s.steps);
}

}  // namespace stance
