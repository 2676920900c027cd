// The seed's optional lesson 5: velocity commands on the skateboard's wheel dofs. `speed` is the
// wheel angular velocity; the viewer's a/s keys change it by `speed_step` (a parameter edit: the
// run's State is kept and the command follows the new speed, read from the model every step). The
// command ramps from 0 to `speed` over `ramp_s`, so the board does not jerk out from under the
// feet. Reports the board's distance travelled along `forward_axis`.
#pragma once

#include "control/controller.h"
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

// the per-run data: the last command and the board's travel
struct SkateboardDriveState {
  double command = 0;   // rad/s, the last wheel velocity command
  double start = 0;     // m, the board's forward coordinate at reset
  double distance = 0;  // m, forward travel of the board since reset

  template <class A>
  void serialize(A& a) {
    a(command), a(start), a(distance);
  }
};

class SkateboardDrive final : public TypedController<SkateboardDriveState, Reporting, Retunable> {
 public:
  SkateboardDrive(const SkateboardDriveParams& params, const ControllerContext& ctx,
                  const Engine& engine);
  std::string_view type() const override { return "skateboard_drive"; }
  void signal_names(std::vector<std::string>& names) const override;
  YAML::Node params_yaml() const override { return params_to_yaml(params_, type()); }
  std::vector<ParamEntry> tunable_params() const override { return list_params(params_); }

  double speed() const { return params_.speed; }  // rad/s, what the ramp reaches

  void signals(const ControllerState& state, std::vector<double>& values) const override;
  void add_metrics(const ControllerState& state, nlohmann::json& metrics) const override;

 protected:
  void reset_state(State& state, const Engine& engine) const override;
  void compute_step(State& state, const Engine& engine, ControlOutput& out) const override;

 private:
  SkateboardDriveParams params_;
  std::vector<int> wheel_dofs_;
  int board_ = -1;
  Eigen::Vector3d axis_;
};

}  // namespace stance
