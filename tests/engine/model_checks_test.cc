// What every model passes before an engine sees it, on both engines: masses the joints can move
// (issue 46: DART aborted on a floating URDF of mass 0 and on a massless child link), a time
// step a run can take, a model path that is a file; and DART loading a user's MJCF quietly.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>

#include <unistd.h>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

const char* const kEngines[] = {"mujoco", "dart"};

// a link's <inertial>: mass 0 with no inertia, or 1 kg with 0.01 kg m^2 about each axis
std::string inertial(bool massive) {
  return massive ? R"(<inertial><origin xyz="0 0 -0.2"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>)"
                 : R"(<inertial><mass value="0"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>)";
}

// a floating base (line 2), a link "mid" (line 7) on hinge "hip" (line 19) about `hip_axis`, a
// link "leg" (line 11) on hinge "knee" (line 23) about y, and a link "imu" (line 15) fixed to the
// base
std::string robot(bool base, bool mid, bool leg, bool imu, const std::string& hip_axis = "1 0 0") {
  return "<robot name=\"r\">\n<link name=\"base\">\n  " + inertial(base) +
         "\n  <collision><geometry><box size=\"0.2 0.1 0.05\"/></geometry></collision>\n"
         "</link>\n<link name=\"mid\">\n  " +
         inertial(mid) + "\n</link>\n<link name=\"leg\">\n  " + inertial(leg) +
         "\n</link>\n<link name=\"imu\">\n  " + inertial(imu) +
         "\n</link>\n<joint name=\"hip\" type=\"revolute\">\n"
         "  <origin xyz=\"0 0 -0.1\"/><parent link=\"base\"/><child link=\"mid\"/>\n"
         "  <axis xyz=\"" +
         hip_axis +
         "\"/><limit lower=\"-1\" upper=\"1\" effort=\"50\" velocity=\"3\"/>\n</joint>\n"
         "<joint name=\"knee\" type=\"revolute\">\n"
         "  <parent link=\"mid\"/><child link=\"leg\"/>\n"
         "  <axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"50\" velocity=\"3\"/>\n"
         "</joint>\n<joint name=\"imu_mount\" type=\"fixed\">\n"
         "  <parent link=\"base\"/><child link=\"imu\"/>\n</joint>\n</robot>\n";
}

std::unique_ptr<Engine> load(const std::string& engine, const std::string& path,
                             std::optional<double> timestep = {}) {
  WorldSpec spec;
  spec.models.push_back({path});
  spec.timestep = timestep;
  return make_engine(engine, spec);
}

std::string error_of(const std::string& engine, const std::string& path,
                     std::optional<double> timestep = {}) {
  try {
    load(engine, path, timestep);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

// the line of the first text that starts with `what` in the file
void expect_line(const std::string& path, int line, const std::string& what) {
  std::istringstream in(test::read_file(path));
  std::string text;
  for (int i = 1; i <= line && std::getline(in, text); ++i) {
  }
  EXPECT_NE(text.find(what), std::string::npos) << path << ":" << line << " is '" << text << "'";
}

TEST(ModelChecks, FloatingUrdfOfMassZeroIsRefusedWithTheUrdfLine) {
  const std::string path = test::write_temp_file("checks_massless.urdf", robot(0, 0, 0, 0));
  expect_line(path, 2, "<link name=\"base\">");
  for (const char* engine : kEngines)
    EXPECT_EQ(error_of(engine, path),
              path +
                  ":2: link 'base': a floating base whose links all weigh 0 kg cannot move: "
                  "give the links <inertial> masses, or weld the base to the world")
        << engine;
}

TEST(ModelChecks, HingeThatMovesNoMassIsRefusedWithItsLine) {
  // DART asserted !isNan(PI) on the first step
  const std::string path = test::write_temp_file("checks_massless_leg.urdf", robot(1, 1, 0, 1));
  expect_line(path, 23, "<joint name=\"knee\"");
  expect_line(path, 11, "<link name=\"leg\">");
  for (const char* engine : kEngines)
    EXPECT_EQ(error_of(engine, path),
              path +
                  ":23: joint 'knee' moves nothing with inertia: link 'leg' (line 11) and the "
                  "links below it weigh 0 kg; give them <inertial> mass and inertia, or make "
                  "the joint fixed")
        << engine;
}

TEST(ModelChecks, MasslessLinkBetweenTwoParallelHingesIsRefused) {
  // the knee turns the leg freely about the hip's own axis: the hip moves no inertia
  const std::string path =
      test::write_temp_file("checks_parallel.urdf", robot(1, 0, 1, 1, "0 1 0"));
  for (const char* engine : kEngines)
    EXPECT_NE(error_of(engine, path)
                  .find(":19: joint 'hip' moves nothing with inertia: link 'mid' (line 7) and "
                        "the links below it have no inertia about the joint's axis"),
              std::string::npos)
        << engine;
}

TEST(ModelChecks, MasslessFixedLinkLoadsOnBothEngines) {
  // a massless "imu" link fixed to the base, as URDFs attach sensors
  const std::string path = test::write_temp_file("checks_massless_imu.urdf", robot(1, 1, 1, 0));
  for (const char* engine : kEngines) {
    auto e = load(engine, path);
    EXPECT_NEAR(e->total_mass(), 3, 1e-12) << engine;
    for (int i = 0; i < 100; ++i) e->step();
    EXPECT_TRUE(e->state_is_finite()) << engine;
  }
}

TEST(ModelChecks, MasslessLinkBetweenCrossedHingesRunsOnDartAndIsLocatedOnMujoco) {
  // a universal joint of two hinges: DART moves it; MuJoCo's compiler refuses every moving body
  // without mass, which stance reports at the URDF's line, not its MJCF translation's
  const std::string path = test::write_temp_file("checks_universal.urdf", robot(1, 0, 1, 1));
  auto dart = load("dart", path);
  for (int i = 0; i < 200; ++i) dart->step();
  EXPECT_TRUE(dart->state_is_finite());
  EXPECT_EQ(error_of("mujoco", path),
            path +
                ":7: link 'mid': MuJoCo needs a moving link's mass and every principal "
                "inertia (with the links welded to it) above 1e-15 (mjMINVAL); DART loads it "
                "(--engine dart)");
}

std::string mjcf_with_timestep(const std::string& timestep) {
  return "<mujoco>\n<compiler angle=\"radian\"/>\n<option timestep=\"" + timestep +
         "\"/>\n<worldbody>\n<body name=\"b\">\n<joint name=\"j\" type=\"hinge\"/>\n"
         "<geom type=\"sphere\" size=\"0.1\" pos=\"0 0 -0.5\"/>\n</body>\n</worldbody>\n"
         "</mujoco>\n";
}

TEST(ModelChecks, MjcfTimestepIsCheckedWithItsLine) {
  const std::string zero = test::write_temp_file("checks_dt0.xml", mjcf_with_timestep("0"));
  const std::string tiny = test::write_temp_file("checks_dt_tiny.xml", mjcf_with_timestep("1e-9"));
  for (const char* engine : kEngines) {
    EXPECT_EQ(error_of(engine, zero),
              zero + ":3: <option> timestep: 0 s: a time step must be positive (at least 1e-05 s)")
        << engine;
    EXPECT_EQ(error_of(engine, tiny),
              tiny +
                  ":3: <option> timestep: 1e-09 s is below the smallest time step, 1e-05 s (a "
                  "simulated second would take 1e+09 steps)")
        << engine;
    // the world's own time step replaces the file's and is checked alike
    EXPECT_EQ(error_of(engine, test::source_dir() + "/models/arm3.xml", 0.0),
              "timestep: 0 s: a time step must be positive (at least 1e-05 s)")
        << engine;
  }
  EXPECT_EQ(load("mujoco", zero, 0.001)->timestep(), 0.001);
}

TEST(ModelChecks, ModelPathThatIsNoFileSaysWhatItIs) {
  const std::string folder =
      (std::filesystem::temp_directory_path() / ("stance_checks_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(folder + "/model.xml");
  for (const char* engine : kEngines) {
    EXPECT_EQ(error_of(engine, folder + "/model.xml"), folder + "/model.xml: a folder, not a file")
        << engine;
    EXPECT_EQ(error_of(engine, "/dev/zero"), "/dev/zero: not a regular file (a character device)")
        << engine;
    EXPECT_EQ(error_of(engine, folder + "/none.xml"), folder + "/none.xml: no such file") << engine;
  }
  std::filesystem::remove_all(folder);
}

TEST(ModelChecks, DartRefusesAnMjcfBodyLeftWithoutMass) {
  // DART 6.12's MJCF reader takes a body's mass from its first geom: a massless visual geom first
  // left the free body with none, and DART asserted mTotalMass != 0 in the first step
  const std::string path = test::write_temp_file("checks_first_geom.xml", R"(<mujoco>
  <worldbody>
    <body name="a" pos="0 0 1">
      <freejoint/>
      <geom type="sphere" size="0.05" mass="0" contype="0" conaffinity="0"/>
      <geom type="box" size="0.1 0.1 0.1" mass="2"/>
    </body>
  </worldbody>
</mujoco>
)");
  EXPECT_NEAR(load("mujoco", path)->total_mass(), 2, 1e-12);
  EXPECT_EQ(error_of("dart", path),
            path +
                ":3: body 'a': joint 'joint0' moves no mass on DART (DART 6.12's MJCF reader "
                "takes a body's mass from its first geom): give the body an <inertial> (or a "
                "first geom with mass)");
}

// what DART prints to std::cout (its dtmsg) and std::cerr (dtwarn, dterr) while `body` runs
template <class F>
std::string printed_by(F body) {
  std::ostringstream out, err;
  std::streambuf* old_out = std::cout.rdbuf(out.rdbuf());
  std::streambuf* old_err = std::cerr.rdbuf(err.rdbuf());
  body();
  std::cout.rdbuf(old_out);
  std::cerr.rdbuf(old_err);
  return out.str() + err.str();
}

TEST(ModelChecks, DartLoadsAnMjcfWithUnnamedGeomsQuietly) {
  // DART's NameManager printed "The name [default] is a duplicate" per unnamed geom
  const std::string path = test::write_temp_file("checks_unnamed_geoms.xml", R"(<mujoco>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="torso" pos="0 0 1">
      <freejoint/>
      <geom type="box" size="0.1 0.1 0.2" mass="5"/>
      <geom type="sphere" size="0.05" pos="0 0 0.3" mass="1"/>
      <geom name="geom2" type="sphere" size="0.05" pos="0 0 -0.3" mass="1"/>
      <body name="thigh" pos="0 0 -0.2">
        <joint name="hip" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.04" mass="2"/>
        <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
)");
  std::unique_ptr<Engine> e;
  const std::string printed = printed_by([&] {
    e = load("dart", path);
    for (int i = 0; i < 50; ++i) e->step();
  });
  EXPECT_EQ(printed, "");
  ASSERT_TRUE(e);
  EXPECT_EQ(e->nbody(), 2);
  EXPECT_TRUE(e->state_is_finite());
}

}  // namespace
}  // namespace stance
