// Servo actuators (biastype affine: <position>, <velocity>, a <general> servo) on a robot that
// stance drives by torque become torque motors within their forcerange
// (engine/mujoco/mujoco_engine.cc): at ctrl 0 a servo would pull every joint to zero, against
// the controller. tests/models/pitch_ankle_robot_servo.xml is pitch_ankle_robot.xml with
// position servos (kp, kv and inheritrange in a class; forcerange = the motors' ctrlrange).
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <cstring>
#include <string>

#include "engine/engine.h"
#include "engine/mujoco/mujoco_engine.h"
#include "engine/world_spec.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::string robot_file(const char* name) {
  return test::source_dir() + "/tests/models/" + name;
}

// the atlas_stand pattern: stable PD from the pose stand_pose: auto finds
LoadedScenario stand_scenario(const std::string& xml, double seconds) {
  const std::string yaml =
      "name: servo_stand\nmodel:\n  - {file: " + xml +
      "}\ntimestep: 0.002\nduration: " + std::to_string(seconds) +
      "\nstand_pose: auto\ncontrollers:\n  - {type: stable_pd, kp: 6000, kd: 300}\n"
      "fall: {com_height_fraction: 0.8, ground_height: 0, "
      "allowed_contacts: [left_sole_link, right_sole_link]}\n";
  return parse_scenario(YAML::Load(yaml), "servo_stand.yaml", "");
}

RunResult stand(const std::string& xml, Eigen::VectorXd& q_end) {
  RunOptions options;
  options.engine = "mujoco";
  Simulation run(stand_scenario(xml, 3), options);
  RunResult result = run.run();
  q_end.resize(run.engine().nq());
  run.engine().get_positions(q_end);
  return result;
}

TEST(ServoActuators, ARobotOnPositionServosStandsAsOnItsMotorsToTheBit) {
  Eigen::VectorXd q_motor, q_servo;
  const RunResult motor = stand(robot_file("pitch_ankle_robot_scene.xml"), q_motor);
  const RunResult servo = stand(robot_file("pitch_ankle_robot_servo_scene.xml"), q_servo);
  EXPECT_FALSE(motor.fell) << motor.fall_reason;
  EXPECT_FALSE(servo.fell) << servo.fall_reason;  // the servos as springs: fell at 2.2 s
  ASSERT_EQ(q_servo.size(), q_motor.size());
  EXPECT_EQ((q_servo - q_motor).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(servo.metrics["torque_limit"], motor.metrics["torque_limit"]);
}

TEST(ServoActuators, TheLimitsAreTheForcerangesOnBothEnginesAndKeyTargetsNoTorque) {
  const LoadedScenario motor = stand_scenario(robot_file("pitch_ankle_robot_scene.xml"), 1);
  const LoadedScenario servo = stand_scenario(robot_file("pitch_ankle_robot_servo_scene.xml"), 1);
  std::unique_ptr<Engine> m = make_scenario_engine(motor.scenario, "mujoco", &motor);
  for (const char* engine : {"mujoco", "dart"}) {
    std::unique_ptr<Engine> s = make_scenario_engine(servo.scenario, engine, &servo);
    ASSERT_EQ(s->nv(), m->nv()) << engine;
    int limited = 0;
    for (int j = 0; j < m->njoint(); ++j) {
      const JointInfo& mj = m->joint(j);
      if (mj.type == JointType::kFree) continue;  // named apart on DART; no limit
      const JointInfo& sj = s->joint(s->require_joint(mj.name));
      EXPECT_EQ(sj.force_limit, mj.force_limit) << engine << " " << mj.name;
      limited += std::isfinite(sj.force_limit);
    }
    EXPECT_EQ(limited, 17) << engine;
    EXPECT_EQ(s->joint(s->require_joint("left_knee")).force_limit, 220) << engine;
    EXPECT_EQ(s->joint(s->require_joint("right_elbow")).force_limit, 15) << engine;
  }
  // the keyframe's ctrl are the servos' position targets: no torque once they are motors
  std::unique_ptr<Engine> s = make_scenario_engine(servo.scenario, "mujoco", &servo);
  s->apply_keyframe("home");
  Eigen::VectorXd ctrl(s->nu());
  s->get_controls(ctrl);
  EXPECT_EQ(ctrl.cwiseAbs().maxCoeff(), 0.0);
}

// LQR designs on the controls: on the servo robot they are its joints' torques, as on the motor
// robot, and its request (moment^T ctrl) is measured against the limits (it read 0 before)
TEST(ServoActuators, LqrHoldsTheServoRobotOnTwoFeetAndItsRequestIsMeasured) {
  const std::string yaml =
      "name: servo_lqr\nmodel: " + robot_file("pitch_ankle_robot_servo_scene.xml") +
      "\nkeyframe: home\ntimestep: 0.002\nduration: 2\ncontrollers:\n"
      "  - {type: lqr, root_body: base, stance_foot: both, "
      "balance_cost: 1.0e+6, balance_joint_cost: 3000, other_joint_cost: 300,"
      " balance_dofs: [\"waist_yaw\", \"(left|right)_(hip_.*|knee|ankle)\"]}\n"
      "fall: {com_height_fraction: 0.8, "
      "allowed_contacts: [left_sole_link, right_sole_link]}\n";
  RunOptions options;
  options.engine = "mujoco";
  const RunResult r = Simulation(parse_scenario(YAML::Load(yaml), "lqr.yaml", ""), options).run();
  EXPECT_FALSE(r.fell) << r.fall_reason;
  EXPECT_LT(r.metrics["com_displacement_m"].get<double>(), 0.02);
  const nlohmann::json& limit = r.metrics["torque_limit"];
  EXPECT_GT(limit["peak_ratio"].get<double>(), 0.05) << limit;  // the ankles hold the lean
  EXPECT_LT(limit["peak_ratio"].get<double>(), 1.0) << limit;
  EXPECT_EQ(limit["limit"].get<double>(), 35) << limit;  // an ankle's forcerange
}

// four arms, each on its own hinge to the world, no gravity: a servo of each kind and a motor
constexpr const char* kServoKinds = R"(<mujoco model="servo_kinds">
  <compiler autolimits="true"/>
  <option gravity="0 0 0" timestep="0.001"/>
  <worldbody>
    <body pos="0 0 0"><joint name="position" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
    <body pos="0 1 0"><joint name="velocity" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
    <body pos="0 2 0"><joint name="general" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
    <body pos="0 3 0"><joint name="motor" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
  </worldbody>
  <actuator>
    <position joint="position" kp="100" forcerange="-5 5"/>
    <velocity joint="velocity" kv="10" forcerange="-3 3" gear="2"/>
    <general joint="general" biastype="affine" gainprm="50" biasprm="0 -50 -2"/>
    <motor joint="motor" gear="7" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
)";

TEST(ServoActuators, EveryKindOfServoPullsNoMoreAtCtrlZeroAndMotorsStayAsCompiled) {
  const std::string xml = test::write_temp_file("servo_kinds.xml", kServoKinds);
  std::unique_ptr<Engine> e = make_mujoco_engine(WorldSpec{{{xml}}, {}, {}});
  auto limit = [&](const char* joint) { return e->joint(e->require_joint(joint)).force_limit; };
  EXPECT_EQ(limit("position"), 5);
  EXPECT_EQ(limit("velocity"), 6);  // gear x forcerange
  EXPECT_TRUE(std::isinf(limit("general")));
  EXPECT_EQ(limit("motor"), 7);
  // away from zero and moving, ctrl 0: no servo force, so each arm keeps its speed
  e->set_positions(Eigen::VectorXd::Constant(4, 0.3));
  e->set_velocities(Eigen::VectorXd::Constant(4, 1.0));
  e->set_controls(Eigen::VectorXd::Zero(4));
  e->forward();
  e->step();
  Eigen::VectorXd v(4);
  e->get_velocities(v);
  EXPECT_EQ(v, Eigen::VectorXd::Constant(4, 1.0));
  // the motor's compiled fields are MuJoCo's own, to the bit
  char err[512] = "";
  mjModel* raw = mj_loadXML(xml.c_str(), nullptr, err, sizeof(err));
  ASSERT_NE(raw, nullptr) << err;
  const mjModel* loaded = dynamic_cast<MujocoEngine&>(*e).model();
  const int motor = 3;
  EXPECT_EQ(std::memcmp(loaded->actuator_gainprm + mjNGAIN * motor,
                        raw->actuator_gainprm + mjNGAIN * motor, sizeof(mjtNum) * mjNGAIN),
            0);
  EXPECT_EQ(std::memcmp(loaded->actuator_ctrlrange + 2 * motor, raw->actuator_ctrlrange + 2 * motor,
                        sizeof(mjtNum) * 2),
            0);
  EXPECT_EQ(loaded->actuator_biastype[motor], raw->actuator_biastype[motor]);
  mj_deleteModel(raw);
}

// T1's pattern: servos without forcerange, each joint bounded by its actuatorfrcrange (a newer
// MuJoCo's); a motor whose ctrlrange reaches past it. Controls (LQR's) are held to the joint's
// bound, as MuJoCo 3 holds them.
constexpr const char* kJointBounded = R"(<mujoco model="joint_bounded">
  <compiler autolimits="true"/>
  <option gravity="0 0 0" timestep="0.001"/>
  <worldbody>
    <body pos="0 0 0"><joint name="servo" axis="0 1 0" actuatorfrcrange="-3 3"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
    <body pos="0 1 0"><joint name="motor" axis="0 1 0" actuatorfrcrange="-4 4"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
  </worldbody>
  <actuator>
    <position joint="servo" kp="100"/>
    <motor joint="motor" gear="2" ctrlrange="-10 10"/>
  </actuator>
</mujoco>
)";

TEST(ServoActuators, ControlsAreHeldToTheJointsActuatorfrcrange) {
  const std::string xml = test::write_temp_file("joint_bounded.xml", kJointBounded);
  std::unique_ptr<Engine> e = make_mujoco_engine(WorldSpec{{{xml}}, {}, {}});
  EXPECT_EQ(e->joint(e->require_joint("servo")).force_limit, 3);
  EXPECT_EQ(e->joint(e->require_joint("motor")).force_limit, 4);
  e->set_controls(Eigen::Vector2d(50, -10));
  e->forward();
  e->step();
  Eigen::VectorXd applied(2);
  ASSERT_TRUE(e->applied_joint_forces(applied));
  EXPECT_NEAR(applied[0], 3, 1e-12);
  EXPECT_NEAR(applied[1], -4, 1e-12);
}

// a model with motors only (the pitch-ankle robot's scene) compiles as MuJoCo compiles it
TEST(ServoActuators, AMotorRobotsActuatorsAndKeyframesAreMuJoCosToTheBit) {
  const std::string xml = robot_file("pitch_ankle_robot_scene.xml");
  std::unique_ptr<Engine> e = make_mujoco_engine(WorldSpec{{{xml}}, {}, {}});
  char err[512] = "";
  mjModel* raw = mj_loadXML(xml.c_str(), nullptr, err, sizeof(err));
  ASSERT_NE(raw, nullptr) << err;
  const mjModel* loaded = dynamic_cast<MujocoEngine&>(*e).model();
  ASSERT_EQ(loaded->nu, raw->nu);
  auto same = [](const void* a, const void* b, size_t bytes) {
    return std::memcmp(a, b, bytes) == 0;
  };
  const size_t nu = raw->nu;
  EXPECT_TRUE(same(loaded->actuator_gainprm, raw->actuator_gainprm, sizeof(mjtNum) * nu * mjNGAIN));
  EXPECT_TRUE(same(loaded->actuator_biasprm, raw->actuator_biasprm, sizeof(mjtNum) * nu * mjNBIAS));
  EXPECT_TRUE(same(loaded->actuator_ctrlrange, raw->actuator_ctrlrange, sizeof(mjtNum) * nu * 2));
  EXPECT_TRUE(same(loaded->actuator_ctrllimited, raw->actuator_ctrllimited, nu));
  EXPECT_TRUE(same(loaded->actuator_biastype, raw->actuator_biastype, sizeof(int) * nu));
  EXPECT_TRUE(same(loaded->key_ctrl, raw->key_ctrl, sizeof(mjtNum) * nu * raw->nkey));
  mj_deleteModel(raw);
}

}  // namespace
}  // namespace stance
