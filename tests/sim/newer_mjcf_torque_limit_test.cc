// A newer MuJoCo's joint actuatorfrcrange clamps as any torque limit: a pendulum held horizontal
// by joint PD against gravity (9.81 N m) with actuatorfrcrange 5 N m sags until gravity's torque
// is the limit, cos(theta) = 5 / 9.81, on both engines.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

// 2 kg at 0.5 m on a hinge about y; the damping settles it (a saturated PD has none of its own)
constexpr const char* kFrcrangePendulum = R"(<mujoco model="frcrange_pendulum">
  <option timestep="0.001"/>
  <worldbody>
    <body name="rod">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="2" actuatorfrcrange="-5 5"/>
      <inertial pos="0.5 0 0" mass="2" diaginertia="0.001 0.01 0.01"/>
    </body>
  </worldbody>
</mujoco>
)";

RunResult run_frcrange_pendulum(const std::string& xml, const std::string& engine, double& angle) {
  const std::string yaml =
      "name: frcrange\nmodel:\n  - {file: " + xml +
      "}\nduration: 3\ntimestep: 0.001\ntorque_limits: on\n"
      "fall: {enabled: false}\ncontrollers:\n  - {type: pd, kp: 200, kd: 20}\n";
  LoadedScenario s = parse_scenario(YAML::Load(yaml), "frcrange.yaml", "");
  RunOptions opt;
  opt.engine = engine;
  Simulation run(s, opt);
  RunResult result = run.run();
  angle = run.engine().dof_position(run.engine().require_dof("hinge"));
  return result;
}

TEST(TorqueLimit, MjcfJointActuatorfrcrangeClampsOnBothEngines) {
  const std::string xml = test::write_temp_file("frcrange_pendulum.xml", kFrcrangePendulum);
  const double sag = std::acos(5 / (2 * 9.81 * 0.5));  // 1.036 rad
  for (const char* engine : {"mujoco", "dart"}) {
    double angle = 0;
    const RunResult r = run_frcrange_pendulum(xml, engine, angle);
    EXPECT_NEAR(angle, sag, 0.01) << engine;
    EXPECT_EQ(r.metrics["torque_limit"]["limit"], 5.0) << engine;
    EXPECT_LE(r.metrics["max_abs_torque"].get<double>(), 5.0) << engine;
  }
}

}  // namespace
}  // namespace stance
