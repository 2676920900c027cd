// The seed's optional lesson 5: velocity commands on the skateboard's wheel dofs. `speed` is the
// wheel angular velocity; the viewer's a/s keys change it by `speed_step`. The command ramps
// from 0 to `speed` over `ramp_s`, so the board does not jerk out from under the feet.
// Reports the board's distance travelled along `forward_axis`.
#pragma once

#include "control/controller.h"
#include "control/legacy_controller.h"
#include "engine/engine.h"

namespace stance {

struct SkateboardDriveParams {
  std::vector<std::string> wheel_dofs = {"joint_front_left_2", "joint_front_right_2",
                                         "joint_back_left", "joint_back_right"};
  // rad/s about the wheel axes; on skateboard.skel (axes +z, Y-up) negative rolls toward +x
  double speed = 0;
  double speed_step = 0.5;  // the seed's default_speed_increment
  double start_s = 0;       // s, time the ramp starts
  double ramp_s = 1;        // s, 0: step to `speed`
  std::string board_body = "main_body";
  Eigen::Vector3d forward_axis = Eigen::Vector3d::UnitX();  // world

  template <class V>
  void visit(V& v) {
    v("wheel_dofs", wheel_dofs, {.help = "dofs given velocity commands"});
    v("speed", speed, {.unit = "rad/s", .min = -100, .max = 100, .help = "wheel velocity"});
    v("speed_step", speed_step,
      {.unit = "rad/s", .min = 0, .max = 100, .help = "increase/decrease step (viewer keys a/s)"});
    v("start_s", start_s, {.unit = "s", .min = 0, .help = "when the ramp starts"});
    v("ramp_s", ramp_s, {.unit = "s", .min = 0, .max = 100, .help = "ramp time to speed"});
    v("board_body", board_body, {.help = "body whose travel is reported"});
    v("forward_axis", forward_axis, {.help = "world direction of travel for the metric"});
  }
};

class SkateboardDrive final : public LegacyController {
 public:
  SkateboardDrive(const SkateboardDriveParams& params, const Engine& engine);
  std::string_view type() const override { return "skateboard_drive"; }
  void reset(const Engine& engine) override;
  void compute(const Engine& engine, ControlOutput& out) override;
  void signal_names(std::vector<std::string>& names) const override;
  void signals(std::vector<double>& values) const override;
  void add_metrics(nlohmann::json& metrics) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(params_); }

  // the viewer's a/s keys
  void increase_speed() { speed_ += params_.speed_step; }
  void decrease_speed() { speed_ -= params_.speed_step; }
  double speed() const { return speed_; }
  // forward travel of the board since reset, m
  double board_distance() const { return distance_; }

 private:
  SkateboardDriveParams params_;
  std::vector<int> wheel_dofs_;
  int board_ = -1;
  Eigen::Vector3d axis_;
  // state
  double speed_ = 0, command_ = 0, start_ = 0, distance_ = 0;
};

}  // namespace stance
