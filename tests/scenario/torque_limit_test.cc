// Torque limits: a pendulum held horizontal by joint PD against gravity (9.81 N m) with a 5 N m
// limit sags until gravity's torque is the limit, cos(theta) = 5 / 9.81, on both engines; the
// metrics report the peak against the limit.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

// 2 kg at 0.5 m on a hinge about y, fixed to the world, effort limit 5 N m; the joint's damping
// settles it (a saturated PD has no damping of its own)
constexpr const char* kPendulumUrdf = R"(<robot name="pendulum">
  <link name="base"/>
  <link name="rod">
    <inertial>
      <origin xyz="0.5 0 0"/>
      <mass value="2"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
    </inertial>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="base"/>
    <child link="rod"/>
    <axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="5" velocity="10"/>
    <dynamics damping="2"/>
  </joint>
</robot>
)";

// the same pendulum in MJCF, its limit a motor's gear x ctrlrange: 2 x 2.5 N m
constexpr const char* kPendulumMjcf = R"(<mujoco model="pendulum">
  <option timestep="0.001"/>
  <worldbody>
    <body name="rod">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="2"/>
      <inertial pos="0.5 0 0" mass="2" diaginertia="0.001 0.01 0.01"/>
    </body>
  </worldbody>
  <actuator>
    <motor joint="hinge" gear="2" ctrllimited="true" ctrlrange="-2.5 2.5"/>
  </actuator>
</mujoco>
)";

struct Held {
  double angle = 0;  // rad, at the end
  RunResult result;
};

Held hold(const std::string& model, const std::string& engine, const std::string& limits) {
  const std::string fixed = model.ends_with(".urdf") ? ", fixed_base: true" : "";
  const std::string yaml =
      "name: torque_limit\nmodel:\n  - {file: " + model + fixed +
      "}\nduration: 4\ntimestep: 0.001\ntorque_limits: " + limits +
      "\nfall: {enabled: false}\ncontrollers:\n  - {type: pd, kp: 200, kd: 20}\n";
  LoadedScenario s = parse_scenario(YAML::Load(yaml), "torque_limit.yaml", "");
  RunOptions opt;
  opt.engine = engine;
  Simulation run(s, opt);
  Held h;
  h.result = run.run();
  h.angle = run.engine().dof_position(run.engine().require_dof("hinge"));
  return h;
}

TEST(TorqueLimit, UrdfEffortClampsOnBothEngines) {
  const std::string urdf = test::write_temp_file("pendulum_limit.urdf", kPendulumUrdf);
  const double sag = std::acos(5 / (2 * 9.81 * 0.5));  // 1.036 rad
  for (const char* engine : {"mujoco", "dart"}) {
    const Held clamped = hold(urdf, engine, "auto");
    EXPECT_NEAR(clamped.angle, sag, 0.01) << engine;
    const nlohmann::json& tl = clamped.result.metrics["torque_limit"];
    EXPECT_EQ(tl["dof"], "hinge") << engine;
    EXPECT_EQ(tl["limit"], 5.0) << engine;
    EXPECT_EQ(tl["clamping"], true) << engine;
    EXPECT_GT(tl["peak_ratio"].get<double>(), 1.0) << engine;
    EXPECT_GT(tl["clamped_steps"].get<long>(), 1000) << engine;
    EXPECT_LE(clamped.result.metrics["max_abs_torque"].get<double>(), 5.0) << engine;
    // unclamped, PD holds it near horizontal: 9.81 N m / 200 N m/rad
    const Held free = hold(urdf, engine, "off");
    EXPECT_NEAR(free.angle, 9.81 / 200, 0.005) << engine;
    EXPECT_EQ(free.result.metrics["torque_limit"]["clamped_steps"], 0) << engine;
    // at least gravity's 9.81 N m over 5 (more while it swings in)
    EXPECT_GT(free.result.metrics["torque_limit"]["peak_ratio"].get<double>(), 9.81 / 5) << engine;
    EXPECT_LT(free.result.metrics["torque_limit"]["peak_ratio"].get<double>(), 2.5) << engine;
  }
}

// the share of steps at a limit counts requests at or over it, clamped or not: the pendulum
// starts at rest on its target (no torque asked) and asks for more than 5 N m once it sags
TEST(TorqueLimit, SummaryReportsTheShareOfStepsAtALimit) {
  const std::string urdf = test::write_temp_file("pendulum_limit.urdf", kPendulumUrdf);
  for (const char* limits : {"on", "off"}) {
    const Held held = hold(urdf, "mujoco", limits);
    const nlohmann::json& tl = held.result.metrics["torque_limit"];
    const long at_limit = tl["steps_at_limit"].get<long>();
    EXPECT_EQ(held.result.steps, 4000) << limits;
    EXPECT_DOUBLE_EQ(tl["share_at_limit"].get<double>(), at_limit / 4000.0) << limits;
    EXPECT_GT(at_limit, 3600) << limits;
    EXPECT_LT(at_limit, 4000) << limits;  // not the first step
    if (std::string(limits) == "on") EXPECT_EQ(tl["clamped_steps"].get<long>(), at_limit);
  }
}

TEST(TorqueLimit, MjcfGearTimesCtrlrange) {
  const std::string xml = test::write_temp_file("pendulum_limit.xml", kPendulumMjcf);
  const double sag = std::acos(5 / (2 * 9.81 * 0.5));
  // auto: MJCF models are not clamped, but reported, on both engines (DART's from the factory)
  for (const char* engine : {"mujoco", "dart"}) {
    const Held reported = hold(xml, engine, "auto");
    EXPECT_NEAR(reported.angle, 9.81 / 200, 0.005) << engine;
    EXPECT_EQ(reported.result.metrics["torque_limit"]["limit"], 5.0) << engine;
    EXPECT_EQ(reported.result.metrics["torque_limit"]["clamping"], false) << engine;
    const Held clamped = hold(xml, engine, "on");
    EXPECT_NEAR(clamped.angle, sag, 0.01) << engine;
  }
}

}  // namespace
}  // namespace stance
