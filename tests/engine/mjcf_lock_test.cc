// lock_joints on MJCF models (model/mjcf_lock.h, issue 45): MuJoCo's humanoid with its ankle rolls
// locked is models/humanoid_pitch_ankles.xml (the hand-made one-axis-ankle copy), and a chain
// locked in the middle is the same on both engines; what names a locked joint (actuators,
// sensors, keyframe entries) goes with it; names the file lacks and free joints are refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> load(const std::string& engine, const std::string& file,
                             const std::vector<std::string>& lock) {
  WorldSpec spec;
  ModelFile mf{file};
  mf.robot.lock_joints = lock;
  spec.models.push_back(mf);
  return make_engine(engine, spec);
}

// every body's pose at the same random hinge angles (by dof name) agrees to `tolerance`
void expect_same_bodies(Engine& a, Engine& b, double tolerance) {
  ASSERT_EQ(a.nbody(), b.nbody());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-0.5, 0.5);
  for (int trial = 0; trial < 5; ++trial) {
    for (int d = 0; d < a.nv(); ++d) {
      const JointInfo& j = a.joint(a.dof_joint(d));
      if (j.type != JointType::kHinge) continue;
      const double value = angle(rng);
      a.set_dof_position(d, value);
      b.set_dof_position(b.dof_index(a.dof_name(d)), value);
    }
    a.forward();
    b.forward();
    for (int i = 0; i < a.nbody(); ++i) {
      const int k = b.body_index(a.body_name(i));
      ASSERT_GE(k, 0) << a.body_name(i);
      EXPECT_LT((a.body_pose(i).pos - b.body_pose(k).pos).norm(), tolerance) << a.body_name(i);
      EXPECT_LT(a.body_pose(i).quat.angularDistance(b.body_pose(k).quat), tolerance)
          << a.body_name(i);
    }
  }
}

TEST(MjcfLock, HumanoidWithAnkleRollsLockedIsThePitchAnklesModel) {
  if (!std::filesystem::exists(test::kHumanoidXml)) GTEST_SKIP() << "humanoid.xml missing";
  const auto locked = load("mujoco", test::kHumanoidXml, {"right_ankle_x", "left_ankle_x"});
  const auto made = load("mujoco", test::source_dir() + "/models/humanoid_pitch_ankles.xml", {});
  const auto full = load("mujoco", test::kHumanoidXml, {});
  EXPECT_EQ(locked->nv(), full->nv() - 2);
  EXPECT_EQ(locked->nv(), made->nv());
  EXPECT_EQ(locked->nu(), made->nu()) << "the locked joints' motors go too";
  EXPECT_EQ(locked->dof_index("right_ankle_x"), -1);
  EXPECT_GE(locked->dof_index("right_ankle_y"), 0);
  EXPECT_NEAR(locked->total_mass(), full->total_mass(), 1e-12);
  for (int d = 0; d < made->nv(); ++d) EXPECT_EQ(locked->dof_name(d), made->dof_name(d));
  for (int a = 0; a < made->nu(); ++a) EXPECT_EQ(locked->actuator_name(a), made->actuator_name(a));
  expect_same_bodies(*locked, *made, 1e-12);
  Eigen::MatrixXd m_locked(locked->nv(), locked->nv()), m_made(made->nv(), made->nv());
  locked->mass_matrix(m_locked);
  made->mass_matrix(m_made);
  EXPECT_LT((m_locked - m_made).cwiseAbs().maxCoeff(), 1e-12);
}

// a floating trunk with two three-link legs (DART's MJCF reader needs a joint on every body)
constexpr const char* kLegs = R"(<mujoco model="legs">
  <worldbody>
    <body name="trunk" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="box" size="0.1 0.15 0.1" mass="10"/>
      <body name="l_thigh" pos="0 0.1 -0.1">
        <joint name="l_hip" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04" mass="3"/>
        <body name="l_shin" pos="0 0 -0.4">
          <joint name="l_knee" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03" mass="2"/>
          <body name="l_foot" pos="0.05 0 -0.4">
            <joint name="l_ankle_roll" type="hinge" axis="1 0 0"/>
            <geom type="box" size="0.1 0.04 0.02" mass="1"/>
          </body>
        </body>
      </body>
      <body name="r_thigh" pos="0 -0.1 -0.1">
        <joint name="r_hip" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04" mass="3"/>
        <body name="r_shin" pos="0 0 -0.4">
          <joint name="r_knee" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03" mass="2"/>
          <body name="r_foot" pos="0.05 0 -0.4">
            <joint name="r_ankle_roll" type="hinge" axis="1 0 0"/>
            <geom type="box" size="0.1 0.04 0.02" mass="1"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="m_l_hip" joint="l_hip" gear="50" ctrllimited="true" ctrlrange="-1 1"/>
    <motor name="m_l_knee" joint="l_knee" gear="40" ctrllimited="true" ctrlrange="-1 1"/>
    <motor name="m_r_knee" joint="r_knee" gear="40" ctrllimited="true" ctrlrange="-1 1"/>
  </actuator>
  <sensor>
    <jointpos name="s_l_knee" joint="l_knee"/>
    <actuatorfrc name="s_m_l_knee" actuator="m_l_knee"/>
    <jointpos name="s_r_hip" joint="r_hip"/>
  </sensor>
  <keyframe>
    <key name="crouch" qpos="0 0 0.9 1 0 0 0  0.3 -0.6 0.01  0.3 -0.6 0.02"
         qvel="0 0 0 0 0 0  1 2 3  4 5 6" ctrl="0.1 0.2 0.3"/>
  </keyframe>
</mujoco>
)";

TEST(MjcfLock, TheSameOnBothEngines) {
  const std::string xml = test::write_temp_file("mjcf_lock_legs.xml", kLegs);
  const std::vector<std::string> lock = {"l_knee", "l_ankle_roll", "r_ankle_roll"};
  const auto mj = load("mujoco", xml, lock);
  const auto mj_full = load("mujoco", xml, {});
  EXPECT_EQ(mj->nv(), mj_full->nv() - 3);
  EXPECT_EQ(mj->nu(), 2);
  EXPECT_EQ(mj->actuator_index("m_l_knee"), -1);
  EXPECT_NEAR(mj->joint(mj->dof_joint(mj->dof_index("r_knee"))).force_limit, 40, 1e-12);
#ifdef STANCE_HAVE_DART
  const auto dart = load("dart", xml, lock);
  EXPECT_EQ(dart->nv(), mj->nv());
  EXPECT_EQ(dart->dof_index("l_knee"), -1);
  EXPECT_EQ(dart->dof_index("r_ankle_roll"), -1);
  EXPECT_NEAR(dart->total_mass(), mj->total_mass(), 1e-12);
  EXPECT_NEAR(dart->joint(dart->dof_joint(dart->dof_index("r_knee"))).force_limit, 40, 1e-12);
  expect_same_bodies(*mj, *dart, 1e-9);
  // the whole-body COM at the last random pose (each engine computes a capsule's inertia its
  // own way, so the mass matrices differ with or without the lock)
  EXPECT_LT((mj->com() - dart->com()).norm(), 1e-9);
#endif
}

TEST(MjcfLock, KeyframesKeepTheEntriesOfTheJointsLeft) {
  const std::string xml = test::write_temp_file("mjcf_lock_legs.xml", kLegs);
  const auto mj = load("mujoco", xml, {"l_knee", "l_ankle_roll"});
  mj->apply_keyframe("crouch");
  EXPECT_NEAR(mj->dof_position(mj->dof_index("l_hip")), 0.3, 1e-12);
  EXPECT_NEAR(mj->dof_position(mj->dof_index("r_knee")), -0.6, 1e-12);
  EXPECT_NEAR(mj->dof_position(mj->dof_index("r_ankle_roll")), 0.02, 1e-12);
  EXPECT_NEAR(mj->dof_velocity(mj->dof_index("l_hip")), 1, 1e-12);
  EXPECT_NEAR(mj->dof_velocity(mj->dof_index("r_hip")), 4, 1e-12);
  Eigen::VectorXd ctrl(mj->nu());
  mj->get_controls(ctrl);
  ASSERT_EQ(ctrl.size(), 2);
  EXPECT_NEAR(ctrl[0], 0.1, 1e-12);  // m_l_hip
  EXPECT_NEAR(ctrl[1], 0.3, 1e-12);  // m_r_knee
}

// the legs split over three files: the scene includes the robot's body tree (inside
// <worldbody>) and, at the top, its actuators, sensors and keyframe; locked joints of the
// included files go as they do from one file
TEST(MjcfLock, JointsOfIncludedFilesAreLockedAsInOneFile) {
  const std::string legs = kLegs;
  const size_t body = legs.find("    <body name=\"trunk\"");
  const size_t bodies_end = legs.find("  </worldbody>");
  const size_t rest = legs.find("  <actuator>");
  const size_t end = legs.find("</mujoco>");
  test::write_temp_file("mjcf_lock_inc_tree.xml",
                        "<mujoco>\n" + legs.substr(body, bodies_end - body) + "</mujoco>\n");
  test::write_temp_file("mjcf_lock_inc_rest.xml",
                        "<mujoco>\n" + legs.substr(rest, end - rest) + "</mujoco>\n");
  const std::string scene = test::write_temp_file(
      "mjcf_lock_inc_scene.xml",
      "<mujoco model=\"legs\">\n  <worldbody>\n    <include file=\"mjcf_lock_inc_tree.xml\"/>\n"
      "  </worldbody>\n  <include file=\"mjcf_lock_inc_rest.xml\"/>\n</mujoco>\n");
  const std::string one = test::write_temp_file("mjcf_lock_legs.xml", kLegs);
  const std::vector<std::string> lock = {"l_knee", "l_ankle_roll"};
  const auto split = load("mujoco", scene, lock);
  const auto whole = load("mujoco", one, lock);
  ASSERT_EQ(split->nv(), whole->nv());
  EXPECT_EQ(split->nv(), load("mujoco", scene, {})->nv() - 2);
  EXPECT_EQ(split->dof_index("l_knee"), -1);
  EXPECT_EQ(split->actuator_index("m_l_knee"), -1) << "the motor in the other file goes too";
  ASSERT_EQ(split->nu(), whole->nu());
  split->apply_keyframe("crouch");
  whole->apply_keyframe("crouch");
  for (int d = 0; d < whole->nv(); ++d) {
    EXPECT_EQ(split->dof_name(d), whole->dof_name(d));
    EXPECT_EQ(split->dof_position(d), whole->dof_position(d)) << whole->dof_name(d);
  }
  expect_same_bodies(*split, *whole, 1e-12);
  try {
    load("mujoco", scene, {"l_kne"});
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no joint 'l_kne' in the file or its includes (it has: "
                                         "root, l_hip, l_knee"),
              std::string::npos)
        << e.what();
  }
}

TEST(MjcfLock, UnknownNamesAndFreeJointsAreRefusedOnBothEngines) {
  const std::string xml = test::write_temp_file("mjcf_lock_legs.xml", kLegs);
  std::vector<std::string> engines = {"mujoco"};
#ifdef STANCE_HAVE_DART
  engines.push_back("dart");
#endif
  for (const std::string& engine : engines) {
    SCOPED_TRACE(engine);
    try {
      load(engine, xml, {"l_kne"});
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("lock_joints: no joint 'l_kne' in the file (it has: "
                                           "root, l_hip, l_knee"),
                std::string::npos)
          << e.what();
    }
    try {
      load(engine, xml, {"root"});
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(":4: lock_joints: 'root' is a free joint"),
                std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace stance
