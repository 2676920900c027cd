#include "control/skateboard_drive.h"

#include <algorithm>

#include "core/error.h"

namespace stance {

SkateboardDrive::SkateboardDrive(const SkateboardDriveParams& params, const ControllerContext&,
                                 const Engine& engine)
    : params_(params) {
  if (params.wheel_dofs.empty()) throw InputError("skateboard_drive.wheel_dofs: empty");
  for (const auto& n : params.wheel_dofs) {
    int dof = engine.require_dof(n);
    JointType t = engine.joint(engine.dof_joint(dof)).type;
    if (t != JointType::kHinge && t != JointType::kSlide)
      throw InputError("skateboard_drive.wheel_dofs: '" + n + "' is not a hinge or slide dof");
    wheel_dofs_.push_back(dof);
  }
  board_ = engine.require_body(params.board_body);
  if (params.forward_axis.norm() < 1e-9)
    throw InputError("skateboard_drive.forward_axis: must be a non-zero vector");
  axis_ = params.forward_axis.normalized();
}

void SkateboardDrive::reset_state(State& s, const Engine& engine) const {
  s.command = 0;
  s.distance = 0;
  s.start = axis_.dot(engine.body_pose(board_).pos);
}

void SkateboardDrive::compute_step(State& s, const Engine& engine, ControlOutput& out) const {
  // linear ramp from 0 to the current speed
  double t = engine.time() - params_.start_s;
  double fraction = t < 0 ? 0.0 : (params_.ramp_s > 0 ? std::min(1.0, t / params_.ramp_s) : 1.0);
  s.command = fraction * params_.speed;
  for (int dof : wheel_dofs_) out.dof_velocity[dof] = s.command;
  out.dof_velocity_used = true;
  s.distance = axis_.dot(engine.body_pose(board_).pos) - s.start;
}

void SkateboardDrive::signal_names(std::vector<std::string>& names) const {
  names.push_back("wheel_speed_command");
  names.push_back("board_distance_m");
}
void SkateboardDrive::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.command);
  values.push_back(s.distance);
}
void SkateboardDrive::add_metrics(const ControllerState& state, nlohmann::json& metrics) const {
  const State& s = cast(state);
  metrics["board_distance_m"] = s.distance;
  metrics["wheel_speed"] = params_.speed;
}

}  // namespace stance
