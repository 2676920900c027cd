// MJCF of a newer MuJoCo: a joint's actuatorfrcrange (on the joint, through default classes, in
// an included file) read as its torque limit and removed from the text MuJoCo 2.2.2 parses.
#include "model/mjcf_newer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>

#include "core/error.h"
#include "test_support.h"

namespace stance {
namespace {

// classes as current model collections write them: the main class bounds every joint, a class
// its own, a nested class turns the bound off; a body's childclass and a joint's own attribute
constexpr const char* kClassedRobot = R"(<mujoco model="classed">
  <default>
    <joint actuatorfrcrange="-100 100"/>
    <default class="arm">
      <joint actuatorfrcrange="-3 4"/>
      <default class="free_wrist">
        <joint actuatorfrclimited="false"/>
      </default>
    </default>
  </default>
  <worldbody>
    <body name="torso">
      <freejoint name="root"/>
      <joint name="waist" axis="0 0 1"/>
      <body name="upper_arm" childclass="arm">
        <joint name="shoulder" axis="0 1 0"/>
        <joint name="shoulder_own" axis="1 0 0"
               actuatorfrcrange="-7 2"/>
        <body name="hand">
          <joint name="wrist" class="free_wrist" axis="0 1 0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
)";

std::map<std::string, double> by_name(const NewerMjcf& n) {
  return {n.joint_force_limits.begin(), n.joint_force_limits.end()};
}

TEST(MjcfNewer, ActuatorfrcrangeFromJointsAndDefaultClasses) {
  const std::string xml = test::write_temp_file("newer_classed.xml", kClassedRobot);
  const NewerMjcf n = read_newer_mjcf("classed.xml", xml);
  const std::map<std::string, double> expected = {
      {"waist", 100}, {"shoulder", 4}, {"shoulder_own", 7}};
  EXPECT_EQ(by_name(n), expected);  // the free joint has none; the wrist's is off
  ASSERT_EQ(n.patched.size(), 1u);
  EXPECT_EQ(n.patched[0].path, xml);
  const std::string& text = n.patched[0].text;
  EXPECT_EQ(text.find("actuatorfrc"), std::string::npos);
  // line breaks kept: MuJoCo's later messages keep their lines
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'),
            std::count(kClassedRobot, kClassedRobot + std::char_traits<char>::length(kClassedRobot),
                       '\n'));
  EXPECT_NE(n.note.find("3 joints"), std::string::npos) << n.note;
}

TEST(MjcfNewer, IncludedFileIsPatchedInItsOwnPlace) {
  const std::string robot =
      test::write_temp_file("newer_included_robot.xml",
                            "<mujoco><worldbody><body name=\"b\"><joint name=\"hinge\" "
                            "actuatorfrcrange='-12 12'/></body></worldbody></mujoco>\n");
  const std::string scene = test::write_temp_file(
      "newer_scene.xml", "<mujoco>\n  <include file=\"newer_included_robot.xml\"/>\n</mujoco>\n");
  const NewerMjcf n = read_newer_mjcf("scene.xml", scene);
  EXPECT_EQ(by_name(n), (std::map<std::string, double>{{"hinge", 12}}));
  ASSERT_EQ(n.patched.size(), 1u);  // the scene itself needs no patch
  EXPECT_EQ(n.patched[0].path, robot);
}

TEST(MjcfNewer, ModelWithoutThemIsLeftAlone) {
  const std::string xml = test::write_temp_file(
      "newer_none.xml", "<mujoco><worldbody><body><joint name=\"j\"/></body></worldbody></mujoco>");
  const NewerMjcf n = read_newer_mjcf("none.xml", xml);
  EXPECT_TRUE(n.patched.empty());
  EXPECT_TRUE(n.joint_force_limits.empty());
  EXPECT_TRUE(n.note.empty());
}

// a <position>'s kv and inheritrange (T1's class default) go, its line breaks kept; a
// <velocity>'s kv is its gain, known to 2.2.2, and stays
TEST(MjcfNewer, PositionKvAndInheritrangeAreRemovedAndVelocityKvStays) {
  constexpr const char* kServos = R"(<mujoco>
  <default>
    <position kp="75" kv="5"
              inheritrange="1"/>
  </default>
  <worldbody><body><joint name="a"/><joint name="b"/></body></worldbody>
  <actuator>
    <position joint="a" kv='2'/>
    <velocity joint="b" kv="10"/>
  </actuator>
</mujoco>
)";
  const std::string xml = test::write_temp_file("newer_servos.xml", kServos);
  const NewerMjcf n = read_newer_mjcf("servos.xml", xml);
  ASSERT_EQ(n.patched.size(), 1u);
  const std::string& text = n.patched[0].text;
  EXPECT_EQ(text.find("inheritrange"), std::string::npos) << text;
  EXPECT_NE(text.find("<position kp=\"75\""), std::string::npos) << text;
  EXPECT_NE(text.find("<position joint=\"a\" />"), std::string::npos) << text;
  EXPECT_NE(text.find("<velocity joint=\"b\" kv=\"10\"/>"), std::string::npos) << text;
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'),
            std::count(kServos, kServos + std::char_traits<char>::length(kServos), '\n'));
  EXPECT_NE(n.note.find("kv and inheritrange of <position>"), std::string::npos) << n.note;
  EXPECT_TRUE(n.joint_force_limits.empty());
}

TEST(MjcfNewer, MalformedRangeIsRefusedAtItsLine) {
  const std::string xml = test::write_temp_file(
      "newer_bad_range.xml",
      "<mujoco>\n<worldbody>\n<body>\n<joint name=\"j\" actuatorfrcrange=\"5 10\"/>\n"
      "</body></worldbody></mujoco>\n");
  try {
    read_newer_mjcf("bad_range.xml", xml);
    FAIL() << "accepted a range that excludes zero";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad_range.xml:4: joint 'j': actuatorfrcrange"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace stance
