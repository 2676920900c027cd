// A model of a newer MuJoCo on both engines: a joint's actuatorfrcrange is its torque limit (the
// tighter of it and its actuators'); an attribute stance cannot apply is refused at its line.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/mjcf_newer.h"
#include "test_support.h"

namespace stance {
namespace {

// a scene that includes its robot, as model collections ship them; DART's MJCF reader needs a
// joint on every body
constexpr const char* kFrcrangeRobot = R"(<mujoco model="frcrange_robot">
  <default>
    <default class="leg">
      <joint actuatorfrcrange="-40 40"/>
    </default>
  </default>
  <worldbody>
    <body name="thigh" childclass="leg">
      <joint name="hip" type="hinge" axis="0 1 0"/>
      <geom type="sphere" size="0.05" mass="1"/>
      <body name="shin" pos="0 0 -0.3">
        <joint name="knee" type="hinge" axis="0 1 0" actuatorfrcrange="-25 30"/>
        <geom type="sphere" size="0.05" mass="1"/>
        <body name="foot" pos="0 0 -0.3">
          <joint name="ankle" type="hinge" axis="0 1 0"/>
          <geom type="sphere" size="0.05" mass="1"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="ankle" gear="10" ctrllimited="true" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
)";

TEST(MjcfNewer, ActuatorfrcrangeIsTheTorqueLimitOnBothEngines) {
  const std::string robot = test::write_temp_file("frcrange_robot.xml", kFrcrangeRobot);
  const std::string scene =
      test::write_temp_file("frcrange_scene.xml",
                            "<mujoco model=\"scene\">\n  <include file=\"frcrange_robot.xml\"/>\n"
                            "</mujoco>\n");
  // DART 6.12's MJCF reader finds no default class of an included file: the robot itself there
  const std::pair<const char*, std::string> cases[] = {
      {"mujoco", scene}, {"mujoco", robot}, {"dart", robot}};
  for (const auto& [engine, model] : cases) {
    WorldSpec spec;
    spec.models.push_back({model});
    const auto e = make_engine(engine, spec);
    const auto limit = [&](const char* joint) {
      return e->joint(e->require_joint(joint)).force_limit;
    };
    EXPECT_DOUBLE_EQ(limit("hip"), 40) << engine;    // its class's
    EXPECT_DOUBLE_EQ(limit("knee"), 30) << engine;   // its own
    EXPECT_DOUBLE_EQ(limit("ankle"), 10) << engine;  // its motor's, tighter than the class's
  }
}

TEST(MjcfNewer, AnAttributeOfANewerMujocoIsNamedAtItsLine) {
  const std::string xml = test::write_temp_file(
      "newer_gravcomp.xml",
      "<mujoco>\n<worldbody>\n<body name=\"b\" gravcomp=\"1\">\n<joint name=\"j\"/>\n"
      "<geom type=\"sphere\" size=\"0.1\" mass=\"1\"/>\n</body>\n</worldbody>\n</mujoco>\n");
  for (const char* engine : {"mujoco", "dart"}) {
    WorldSpec spec;
    spec.models.push_back({xml});
    try {
      make_engine(engine, spec);
      FAIL() << engine << " loaded a gravcomp that it cannot apply";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("newer_gravcomp.xml:3: <body> attribute 'gravcomp'"), std::string::npos)
          << what;
      EXPECT_NE(what.find("needs a newer MuJoCo"), std::string::npos) << what;
    }
  }
}

// integrator="implicitfast" (current collections' robots) runs as 2.2.2's implicit, with a note;
// 2.2.2's parser refused the keyword ("invalid keyword")
TEST(MjcfNewer, ImplicitFastRunsAsImplicit) {
  auto pendulum = [](const std::string& name, const std::string& integrator) {
    return test::write_temp_file(
        name, "<mujoco>\n<option integrator=\"" + integrator +
                  "\"/>\n<worldbody>\n<body name=\"b\">\n"
                  "<joint name=\"j\" axis=\"0 1 0\" damping=\"3\"/>\n"
                  "<geom type=\"capsule\" fromto=\"0 0 0 0.3 0 0\" size=\"0.05\" mass=\"1\"/>\n"
                  "</body>\n</worldbody>\n</mujoco>\n");
  };
  const std::string fast = pendulum("newer_implicitfast.xml", "implicitfast");
  const std::string implicit = pendulum("newer_implicit.xml", "implicit");
  EXPECT_NE(read_newer_mjcf(fast, fast).note.find("implicitfast"), std::string::npos);
  WorldSpec a, b;
  a.models.push_back({fast});
  b.models.push_back({implicit});
  std::unique_ptr<Engine> run_fast = make_engine("mujoco", a);
  std::unique_ptr<Engine> run_implicit = make_engine("mujoco", b);
  for (int k = 0; k < 200; ++k) {
    run_fast->step();
    run_implicit->step();
  }
  EXPECT_EQ(run_fast->dof_position(0), run_implicit->dof_position(0));
  EXPECT_GT(std::abs(run_fast->dof_position(0)), 0.1);  // it swung down
}

}  // namespace
}  // namespace stance
