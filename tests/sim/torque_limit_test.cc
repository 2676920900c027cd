// Torque limits: a pendulum held horizontal by joint PD against gravity (9.81 N m) with a 5 N m
// limit sags until gravity's torque is the limit, cos(theta) = 5 / 9.81, on both engines; the
// metrics report the peak against the limit. Ball joints clamp alike on both engines.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "model/bvh_to_mjcf.h"
#include "motion/bvh.h"
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

// a three-link arm held horizontal, its elbow's motor weak (gear 1 x 3 N m against gravity's
// 9.8 N m), the shoulder's and the wrist's strong: only the elbow ever reaches its limit
constexpr const char* kWeakElbowMjcf = R"(<mujoco model="weak_elbow">
  <option timestep="0.001"/>
  <default><joint type="hinge" axis="0 1 0" damping="2"/></default>
  <worldbody>
    <body name="upper">
      <joint name="shoulder"/>
      <inertial pos="0.25 0 0" mass="1" diaginertia="0.001 0.02 0.02"/>
      <body name="fore" pos="0.5 0 0">
        <joint name="elbow"/>
        <inertial pos="0.25 0 0" mass="1" diaginertia="0.001 0.02 0.02"/>
        <body name="hand" pos="0.5 0 0">
          <joint name="wrist"/>
          <inertial pos="0.25 0 0" mass="1" diaginertia="0.001 0.02 0.02"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="shoulder" gear="100" ctrllimited="true" ctrlrange="-2 2"/>
    <motor joint="elbow" gear="1" ctrllimited="true" ctrlrange="-3 3"/>
    <motor joint="wrist" gear="25" ctrllimited="true" ctrlrange="-2 2"/>
  </actuator>
</mujoco>
)";

// summary.json's per-dof block names the weak joint, and its numbers are those of the steps'
// requests: unclamped (off) the record is the requests themselves; clamped (on) a request at or
// over the limit leaves the dof exactly at it
TEST(TorqueLimit, PerDofShareNamesTheWeakJoint) {
  const std::string xml = test::write_temp_file("weak_elbow.xml", kWeakElbowMjcf);
  for (const char* limits : {"off", "on"}) {
    SCOPED_TRACE(limits);
    const std::string yaml = "name: weak_elbow\nmodel: " + xml +
                             "\nduration: 1\ntimestep: 0.001\ntorque_limits: " + limits +
                             "\nfall: {enabled: false}\ncontrollers:\n  - {type: pd, kp: 200, "
                             "kd: 20}\n";
    RunOptions opt;
    opt.quiet = true;
    Simulation run(parse_scenario(YAML::Load(yaml), "weak_elbow.yaml", ""), opt);
    const Engine& e = run.engine();
    ASSERT_EQ(e.nv(), 3);
    std::map<std::string, long> at_limit;
    std::map<std::string, double> peak;
    const int steps = 1000;
    for (int i = 0; i < steps; ++i) {
      ASSERT_TRUE(run.step());
      for (int d = 0; d < e.nv(); ++d) {
        const double ratio =
            std::abs(run.last_output().tau[d]) / e.joint(e.dof_joint(d)).force_limit;
        if (ratio >= 1) ++at_limit[e.dof_name(d)];
        peak[e.dof_name(d)] = std::max(peak[e.dof_name(d)], ratio);
      }
    }
    const nlohmann::json tl = run.result().metrics.at("torque_limit");
    const nlohmann::json& per_dof = tl.at("per_dof");
    ASSERT_EQ(per_dof.size(), 1u) << tl.dump();
    EXPECT_EQ(at_limit.count("shoulder") + at_limit.count("wrist"), 0u);
    const nlohmann::json& elbow = per_dof.at("elbow");
    EXPECT_GT(at_limit.at("elbow"), steps / 2) << "the elbow sags against its limit";
    EXPECT_DOUBLE_EQ(elbow.at("share_at_limit").get<double>(),
                     double(at_limit.at("elbow")) / steps);
    EXPECT_EQ(tl.at("most_at_limit"), nlohmann::json::array({"elbow"}));
    EXPECT_EQ(tl.at("steps_at_limit").get<long>(), at_limit.at("elbow"));
    if (std::string(limits) == "off") {
      EXPECT_DOUBLE_EQ(elbow.at("peak_request_ratio").get<double>(), peak.at("elbow"));
      EXPECT_DOUBLE_EQ(tl.at("peak_ratio").get<double>(), peak.at("elbow"));
    } else {
      // the requests over the limit were clamped: their peak is over the applied ones' 1
      EXPECT_GT(elbow.at("peak_request_ratio").get<double>(), 1.5);
      EXPECT_EQ(peak.at("elbow"), 1.0);
    }
    EXPECT_LT(peak.at("shoulder"), 1.0);
    EXPECT_LT(peak.at("wrist"), 1.0);
  }
}

TEST(TorqueLimit, MjcfGearTimesCtrlrange) {
  const std::string xml = test::write_temp_file("pendulum_limit.xml", kPendulumMjcf);
  const double sag = std::acos(5 / (2 * 9.81 * 0.5));
  // auto: an MJCF motor's gear x ctrlrange clamps as a URDF effort does, on both engines
  // (DART's limits from the factory); off: reported only
  for (const char* engine : {"mujoco", "dart"}) {
    const Held reported = hold(xml, engine, "off");
    EXPECT_NEAR(reported.angle, 9.81 / 200, 0.005) << engine;
    EXPECT_EQ(reported.result.metrics["torque_limit"]["limit"], 5.0) << engine;
    EXPECT_EQ(reported.result.metrics["torque_limit"]["clamping"], false) << engine;
    for (const char* limits : {"auto", "on"}) {
      const Held clamped = hold(xml, engine, limits);
      EXPECT_NEAR(clamped.angle, sag, 0.01) << engine << " " << limits;
      EXPECT_EQ(clamped.result.metrics["torque_limit"]["clamping"], true) << engine;
    }
  }
}

// a ball-jointed character (bvh2mjcf --human-limits: each ball joint's actuatorfrcrange): both
// engines read the same limit per joint, and clamp every dof of a ball joint to it (DART's MJCF
// reader leaves ball joints without; the backend reads the limits set on their dofs)
TEST(TorqueLimit, BallJointsClampedAlikeOnBothEngines) {
  BvhCharacterOptions o;
  o.human_limits = true;
  const std::string character = test::write_temp_file(
      "ball_limits.xml",
      make_bvh_character(read_bvh(test::source_dir() + "/models/synthetic_walk.bvh"), o).mjcf);
  // stable PD holds the pose against 1000 N on the head for 0.1 s: far beyond the neck's 28 N m
  const std::string yaml =
      "name: ball_limits\nmodel: " + character +
      "\nduration: 0.3\ntorque_limits: on\nfall: {enabled: false}\nperturbations: [{body: Head, "
      "force: [0, 1000, 0], start: 0.02, duration: 0.1}]\ncontrollers:\n  - {type: stable_pd, "
      "kp: 2000, kd: 50}\n";
  std::map<std::string, double> limits[2];
  const char* engines[] = {"mujoco", "dart"};
  for (int k = 0; k < 2; ++k) {
    SCOPED_TRACE(engines[k]);
    RunOptions opt;
    opt.engine = engines[k];
    opt.quiet = true;
    Simulation run(parse_scenario(YAML::Load(yaml), "ball_limits.yaml", ""), opt);
    const Engine& e = run.engine();
    for (int j = 0; j < e.njoint(); ++j)
      if (e.joint(j).type == JointType::kBall) limits[k][e.joint(j).name] = e.joint(j).force_limit;
    long clamped = 0;
    for (int i = 0; i < 150; ++i) {  // 0.3 s
      ASSERT_TRUE(run.step());
      const Eigen::VectorXd& tau = run.last_output().tau;
      for (int d = 0; d < e.nv(); ++d) {
        const double limit = e.joint(e.dof_joint(d)).force_limit;
        ASSERT_LE(std::abs(tau[d]), limit + 1e-9) << e.dof_name(d);
        if (e.joint(e.dof_joint(d)).type == JointType::kBall && std::abs(tau[d]) == limit)
          ++clamped;
      }
    }
    EXPECT_GT(clamped, 10) << "the push asks the ball joints for more than their limits";
  }
  ASSERT_FALSE(limits[0].empty());
  EXPECT_EQ(limits[0], limits[1]);
  // a hip: 3.5 N m per kg of the character's 70 kg
  EXPECT_NEAR(limits[1].at("LeftUpLeg"), 3.5 * 70, 1e-9);
}

}  // namespace
}  // namespace stance
