// MJCF torque limits, read the same on both engines: DART's MJCF parser reads no actuators, so
// the factory takes them from MuJoCo's compile of the file (engine/backend_world.h).
#include <gtest/gtest.h>

#include <cmath>

#include "engine/engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

// one hinge per actuator kind, chained (DART's MJCF reader needs a joint on every body)
constexpr const char* kActuatedChain = R"(<mujoco model="limits">
  <worldbody>
    <body name="b1">
      <joint name="motor_gear100" type="hinge" axis="0 1 0"/>
      <geom type="sphere" size="0.05" mass="1"/>
      <body name="b2" pos="0 0 -0.2">
        <joint name="forcerange_gear2" type="hinge" axis="0 1 0"/>
        <geom type="sphere" size="0.05" mass="1"/>
        <body name="b3" pos="0 0 -0.2">
          <joint name="motor_and_forcerange" type="hinge" axis="0 1 0"/>
          <geom type="sphere" size="0.05" mass="1"/>
          <body name="b4" pos="0 0 -0.2">
            <joint name="position_servo" type="hinge" axis="0 1 0"/>
            <geom type="sphere" size="0.05" mass="1"/>
            <body name="b5" pos="0 0 -0.2">
              <joint name="two_motors" type="hinge" axis="0 1 0"/>
              <geom type="sphere" size="0.05" mass="1"/>
              <body name="b6" pos="0 0 -0.2">
                <joint name="unlimited_motor" type="hinge" axis="0 1 0"/>
                <geom type="sphere" size="0.05" mass="1"/>
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="motor_gear100" gear="100" ctrllimited="true" ctrlrange="-1 1"/>
    <general joint="forcerange_gear2" gear="2" forcelimited="true" forcerange="-30 20"/>
    <motor joint="motor_and_forcerange" gear="100" ctrllimited="true" ctrlrange="-1 1"
           forcelimited="true" forcerange="-0.5 0.5"/>
    <position joint="position_servo" kp="10" forcelimited="true" forcerange="-7 7"/>
    <motor joint="two_motors" gear="10" ctrllimited="true" ctrlrange="-1 1"/>
    <motor joint="two_motors" gear="5" ctrllimited="true" ctrlrange="-2 1"/>
    <motor joint="unlimited_motor" gear="100" ctrllimited="false"/>
  </actuator>
</mujoco>
)";

TEST(MjcfLimits, ForcerangeAndCtrlrangeTimesGearOnBothEngines) {
  const std::string xml = test::write_temp_file("mjcf_limits.xml", kActuatedChain);
  for (const char* engine : {"mujoco", "dart"}) {
    WorldSpec spec;
    spec.models.push_back({xml});
    const auto e = make_engine(engine, spec);
    const auto limit = [&](const char* joint) {
      return e->joint(e->require_joint(joint)).force_limit;
    };
    EXPECT_DOUBLE_EQ(limit("motor_gear100"), 100) << engine;        // gear x ctrlrange
    EXPECT_DOUBLE_EQ(limit("forcerange_gear2"), 60) << engine;      // gear x max |forcerange|
    EXPECT_DOUBLE_EQ(limit("motor_and_forcerange"), 50) << engine;  // the tighter of the two
    EXPECT_DOUBLE_EQ(limit("position_servo"), 7) << engine;         // a servo's forcerange
    EXPECT_DOUBLE_EQ(limit("two_motors"), 10 + 5 * 2) << engine;    // summed
    EXPECT_TRUE(std::isinf(limit("unlimited_motor"))) << engine;
  }
}

}  // namespace
}  // namespace stance
