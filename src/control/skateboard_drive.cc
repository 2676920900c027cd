#include "control/skateboard_drive.h"

#include <algorithm>

#include "core/error.h"

namespace stance {

SkateboardDrive::SkateboardDrive(const SkateboardDriveParams& params, const Engine& engine)
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
  speed_ = params.speed;
}

void SkateboardDrive::reset(const Engine& engine) {
  speed_ = params_.speed;
  command_ = 0;
  distance_ = 0;
  start_ = axis_.dot(engine.body_pose(board_).pos);
}

void SkateboardDrive::compute(const Engine& engine, ControlOutput& out) {
  // linear ramp from 0 to the current speed
  double t = engine.time() - params_.start_s;
  double fraction = t < 0 ? 0.0 : (params_.ramp_s > 0 ? std::min(1.0, t / params_.ramp_s) : 1.0);
  command_ = fraction * speed_;
  for (int dof : wheel_dofs_) out.dof_velocity[dof] = command_;
  out.dof_velocity_used = true;
  distance_ = axis_.dot(engine.body_pose(board_).pos) - start_;
}

void SkateboardDrive::signal_names(std::vector<std::string>& names) const {
  names.push_back("wheel_speed_command");
  names.push_back("board_distance_m");
}
void SkateboardDrive::signals(std::vector<double>& values) const {
  values.push_back(command_);
  values.push_back(distance_);
}
void SkateboardDrive::add_metrics(nlohmann::json& metrics) const {
  metrics["board_distance_m"] = distance_;
  metrics["wheel_speed"] = speed_;
}

}  // namespace stance
