// The URDF and SDF reader: what it keeps, the MJCF it writes, the text DART gets, and its
// located errors.
#include "model/robot_model.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "test_support.h"

namespace stance {
namespace {

// a floating two-link URDF: a rotated inertial, a link without one, a box and a mesh
std::string two_link_urdf(const std::string& mesh = "foot.stl") {
  return R"(<robot name="two">
  <link name="base">
    <inertial>
      <origin xyz="0 0 0.1" rpy="0 0 1.5707963267948966"/>
      <mass value="2"/>
      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.25"/>
    </inertial>
    <collision><geometry><box size="0.2 0.1 0.05"/></geometry></collision>
  </link>
  <link name="foot">
    <collision>
      <origin xyz="0 0 -0.5"/>
      <geometry><mesh filename=")" +
         mesh + R"(" scale="2 1 1"/></geometry>
    </collision>
    <visual><geometry><mesh filename="foot.dae"/></geometry></visual>
  </link>
  <joint name="hinge" type="revolute">
    <origin xyz="0 0 -0.3"/>
    <parent link="base"/>
    <child link="foot"/>
    <axis xyz="0 2 0"/>
    <limit lower="-1" upper="1" effort="50" velocity="3"/>
    <dynamics damping="0.5"/>
  </joint>
</robot>
)";
}

// a binary STL of one triangle
void write_stl(const std::string& path, const float v[9]) {
  std::ofstream out(path, std::ios::binary);
  char header[80] = {};
  out.write(header, 80);
  const uint32_t count = 1;
  out.write(reinterpret_cast<const char*>(&count), 4);
  const float normal[3] = {0, 0, 1};
  out.write(reinterpret_cast<const char*>(normal), 12);
  out.write(reinterpret_cast<const char*>(v), 36);
  const uint16_t attribute = 0;
  out.write(reinterpret_cast<const char*>(&attribute), 2);
}

// a folder of this process's own: ctest runs these tests as parallel processes, and a file
// one of them rewrites (foot.stl, two.urdf) must not change under another's reader
struct PrivateFolder {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("stance_robot_tests_" + std::to_string(::getpid()));
  PrivateFolder() { std::filesystem::create_directories(path); }
  ~PrivateFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

std::string temp_dir() {
  static const PrivateFolder folder;
  return folder.path.string();
}

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = temp_dir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string write_robot(const std::string& name, const std::string& text) {
  const float tri[9] = {-0.1f, -0.05f, -0.02f, 0.2f, 0.05f, -0.02f, 0.0f, 0.0f, 0.03f};
  write_stl(temp_dir() + "/foot.stl", tri);
  write_file("foot.dae", "<COLLADA/>");
  return write_file(name, text);
}

std::string error_of(const std::string& name, const std::string& text,
                     const RobotOptions& options = {}) {
  const std::string path = write_robot(name, text);
  try {
    read_robot(name, path, options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(RobotModel, ReadsLinksJointsAndDartsDefaults) {
  const std::string path = write_robot("two.urdf", two_link_urdf());
  const RobotModel m = read_robot("two.urdf", path, {});
  ASSERT_EQ(m.links.size(), 2u);
  EXPECT_EQ(m.root, "base");
  EXPECT_EQ(m.root_joint, "rootJoint");
  // the inertial's rotation about z by 90 degrees swaps ixx and iyy
  EXPECT_NEAR(m.links[0].inertia(0, 0), 0.2, 1e-12);
  EXPECT_NEAR(m.links[0].inertia(1, 1), 0.1, 1e-12);
  EXPECT_NEAR(m.links[0].com.z(), 0.1, 1e-15);
  // no <inertial>: DART's 1 kg and unit moment
  EXPECT_EQ(m.links[1].mass, 1.0);
  EXPECT_TRUE(m.links[1].inertia.isIdentity(0.0));
  const RobotJoint& j = m.joints[0];
  EXPECT_EQ(j.axis, Eigen::Vector3d::UnitY());
  EXPECT_EQ(j.effort, 50);
  EXPECT_EQ(j.damping, 0.5);
  EXPECT_TRUE(j.has_limits);
  EXPECT_EQ(read_robot("two.urdf", path, {.fixed_base = true}).root_joint, "");
}

TEST(RobotModel, MeshBoundsOfBinaryAndAsciiStl) {
  const float tri[9] = {-0.1f, -0.05f, -0.02f, 0.2f, 0.05f, -0.02f, 0.0f, 0.0f, 0.03f};
  const std::string bin = temp_dir() + "/tri.stl";
  write_stl(bin, tri);
  const Eigen::AlignedBox3d b = mesh_bounds("m", 1, bin, Eigen::Vector3d(2, 1, 1));
  EXPECT_NEAR(b.min().x(), -0.2, 1e-7);
  EXPECT_NEAR(b.max().x(), 0.4, 1e-7);
  EXPECT_NEAR(b.max().z(), 0.03, 1e-7);
  const std::string ascii = write_file(
      "tri_ascii.stl",
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 2 3\nvertex -1 0 0\n"
      "endloop\nendfacet\nendsolid t\n");
  const Eigen::AlignedBox3d a = mesh_bounds("m", 1, ascii, Eigen::Vector3d::Ones());
  EXPECT_EQ(a.min(), Eigen::Vector3d(-1, 0, 0));
  EXPECT_EQ(a.max(), Eigen::Vector3d(1, 2, 3));
  const std::string bad = write_file("bad.stl", "not a mesh");
  try {
    mesh_bounds("robot.urdf", 7, bad, Eigen::Vector3d::Ones());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "robot.urdf:7: mesh '" + bad +
                  "': neither a binary STL (84 + 50 bytes per triangle) nor an ASCII one "
                  "('solid')");
  }
}

TEST(RobotModel, MjcfHasFreeRootMotorsBoxesAndDropsDaeVisuals) {
  const std::string path = write_robot("two.urdf", two_link_urdf());
  RobotTranslation t = robots_to_mjcf({{"two.urdf", path, Eigen::Vector3d(0, 0, 1), {}}});
  EXPECT_NE(t.mjcf.find(R"(<joint type="free" name="rootJoint"/>)"), std::string::npos);
  EXPECT_NE(t.mjcf.find(R"(<body name="base" pos="0 0 1">)"), std::string::npos);
  EXPECT_NE(t.mjcf.find(R"(<motor name="hinge" joint="hinge" gear="1" ctrllimited="true" )"
                        R"(ctrlrange="-50 50"/>)"),
            std::string::npos);
  // the mesh's bounding box, scaled by 2 in x: x in [-0.2, 0.4] -> half 0.3, centre 0.1
  EXPECT_NE(t.mjcf.find(R"(type="box" size="0.30000000447034836 0.05000000074505806 )"),
            std::string::npos)
      << t.mjcf;
  EXPECT_EQ(t.mjcf.find("foot.dae"), std::string::npos);
  ASSERT_EQ(t.warnings.size(), 1u);
  EXPECT_EQ(t.warnings[0],
            "two.urdf: 1 visual mesh MuJoCo cannot read (not STL or OBJ) dropped; collision "
            "shapes are kept");
  // mesh collision keeps the STL as a mesh asset
  t = robots_to_mjcf({{"two.urdf", path, {}, {.mesh_collision = "mesh"}}});
  EXPECT_NE(t.mjcf.find(R"(type="mesh" mesh="mesh0")"), std::string::npos);
}

TEST(RobotModel, DartTextGetsBoxesAndAbsoluteMeshPaths) {
  const std::string path = write_robot("two.urdf", two_link_urdf());
  const std::string text = robot_text_for_dart("two.urdf", path, {});
  EXPECT_NE(text.find(R"(<origin xyz="0.10000000149011612 0 -0.49500000011175871"/>)"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find(R"(<box size="0.60000000894069672 0.10000000149011612 )"), std::string::npos);
  EXPECT_NE(text.find("filename=\"" + temp_dir() + "/foot.dae\""), std::string::npos);
}

TEST(RobotModel, PackagePathsResolveFromOptionsThenTheEnvironment) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(temp_dir()) / "pkgroot";
  fs::create_directories(root / "my_robot" / "meshes");
  const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  write_stl((root / "my_robot" / "meshes" / "foot.stl").string(), tri);
  const std::string urdf = two_link_urdf("package://my_robot/meshes/foot.stl");
  EXPECT_EQ(read_robot("p.urdf", write_robot("p.urdf", urdf), {.package_path = {root.string()}})
                .links[1]
                .collisions[0]
                .mesh,
            (root / "my_robot" / "meshes" / "foot.stl").string());
  ::setenv("STANCE_PACKAGE_PATH", ("/nonexistent:" + root.string()).c_str(), 1);
  EXPECT_NO_THROW(read_robot("p.urdf", write_robot("p.urdf", urdf), {}));
  ::unsetenv("STANCE_PACKAGE_PATH");
  EXPECT_EQ(error_of("p.urdf", urdf),
            "p.urdf:13: mesh 'package://my_robot/meshes/foot.stl': not found in the package path "
            "(empty; set the model's package_path or STANCE_PACKAGE_PATH to folders holding "
            "'my_robot')");
}

// each malformed robot: the exact message with its line
TEST(RobotModel, MalformedFilesGiveLocatedErrors) {
  const std::string good = two_link_urdf();
  auto edit = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    const size_t at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return s.replace(at, from.size(), to);
  };
  EXPECT_EQ(error_of("e.urdf", edit("</robot>", "")),
            "e.urdf:1: malformed XML (XML_ERROR_PARSING)");
  // a declaration and a comment, no element (fuzz_model: the reader dereferenced a null root)
  for (const char* name : {"e.urdf", "e.sdf"})
    EXPECT_EQ(error_of(name, "<?xml version=\"1.0\"?>\n<!-- nothing -->\n"),
              std::string(name) + ":1: no XML element in the file");
  EXPECT_EQ(error_of("e.urdf", edit("<mass value=\"2\"/>", "<mass value=\"2kg\"/>")),
            "e.urdf:5: <mass> value: '2kg' is not a finite number");
  EXPECT_EQ(error_of("e.urdf", edit("<mass value=\"2\"/>", "<mass value=\"-2\"/>")),
            "e.urdf:5: link 'base': mass must be >= 0");
  EXPECT_EQ(error_of("e.urdf", edit("izz=\"0.25\"", "izz=\"0.5\"")),
            "e.urdf:6: link 'base': the inertia is not a body's (principal moments 0.1 0.2 0.5 "
            "must be >= 0, and any two add up to at least the third)");
  EXPECT_EQ(error_of("e.urdf", edit("<child link=\"foot\"/>", "<child link=\"fot\"/>")),
            "e.urdf:17: joint 'hinge': unknown link 'fot' (did you mean 'foot'?)");
  EXPECT_EQ(error_of("e.urdf", edit("type=\"revolute\"", "type=\"revolut\"")),
            "e.urdf:17: joint 'hinge': unsupported joint type 'revolut' (supported: fixed, "
            "revolute, continuous, prismatic, floating)");
  EXPECT_EQ(error_of("e.urdf", edit("<axis xyz=\"0 2 0\"/>", "<axis xyz=\"0 0\"/>")),
            "e.urdf:21: <axis> xyz: expected 3 numbers, found 2 in '0 0'");
  EXPECT_EQ(error_of("e.urdf", edit("<axis xyz=\"0 2 0\"/>", "<axis xyz=\"0 0 0\"/>")),
            "e.urdf:21: the joint axis must not be zero");
  EXPECT_EQ(error_of("e.urdf",
                     edit("<limit lower=\"-1\" upper=\"1\" effort=\"50\" velocity=\"3\"/>", "")),
            "e.urdf:17: joint 'hinge': a revolute joint needs <limit>");
  EXPECT_EQ(error_of("e.urdf", edit("<parent link=\"base\"/>", "<parent link=\"foot\"/>")),
            "e.urdf:17: joint 'hinge': link 'foot' is its own parent");
  EXPECT_EQ(error_of("e.urdf", edit("</robot>",
                                    "<joint name=\"back\" type=\"fixed\"><parent link=\"foot\"/>"
                                    "<child link=\"base\"/></joint></robot>")),
            "e.urdf:1: the joints form a cycle: no link is the root");
  EXPECT_EQ(error_of("e.urdf", edit("foot.stl", "missing.stl")),
            "e.urdf:13: mesh 'missing.stl': no such file (" + temp_dir() + "/missing.stl)");
}

TEST(RobotModel, SdfReadsPosesInTheModelFrame) {
  const std::string sdf = R"(<sdf version="1.4">
  <model name="m">
    <pose>0 0 1 0 0 0</pose>
    <link name="a"><inertial><mass>3</mass><inertia><ixx>1</ixx><ixy>0</ixy><ixz>0</ixz>
      <iyy>1</iyy><iyz>0</iyz><izz>1</izz></inertia></inertial></link>
    <link name="b"><pose>0.5 0 0 0 0 1.5707963267948966</pose></link>
    <joint name="j" type="revolute"><parent>a</parent><child>b</child>
      <pose>0 0.1 0 0 0 0</pose><axis><xyz>1 0 0</xyz><limit><lower>-1</lower><upper>1</upper>
      <effort>30</effort></limit></axis></joint>
  </model>
</sdf>
)";
  const RobotModel m = read_robot("m.sdf", write_file("m.sdf", sdf), {});
  EXPECT_EQ(m.root_joint, "root");
  EXPECT_NEAR(m.pose.translation().z(), 1, 1e-15);
  EXPECT_TRUE(m.joints[0].parent_to_child.translation().isApprox(Eigen::Vector3d(0.5, 0, 0)));
  EXPECT_NEAR(m.joints[0].child_to_joint.translation().y(), 0.1, 1e-15);
  EXPECT_EQ(m.joints[0].effort, 30);
  EXPECT_EQ(m.links[1].mass, 1.0);
  const std::string world = "<sdf version=\"1.4\">\n<world name=\"w\"/>\n</sdf>\n";
  EXPECT_EQ(error_of("w.sdf", world),
            "w.sdf:2: SDF <world> files are not supported: give a file with one <model>");
  std::string screw = sdf;
  screw.replace(screw.find("type=\"revolute\""), 15, "type=\"screw\"");
  EXPECT_EQ(error_of("s.sdf", screw),
            "s.sdf:7: joint 'j': unsupported joint type 'screw' (supported: fixed, revolute, "
            "prismatic, ball)");
}

// a joint must move something with inertia (DART asserted on a massless child link); a massless
// link passes where mass hangs below it or is welded to it
TEST(RobotModel, JointsMustMoveInertia) {
  const std::string sdf = R"(<sdf version="1.4">
  <model name="m">
    <link name="a"/>
    <link name="b"><inertial><mass>0</mass><inertia><ixx>0</ixx><ixy>0</ixy><ixz>0</ixz>
      <iyy>0</iyy><iyz>0</iyz><izz>0</izz></inertia></inertial></link>
    <joint name="j" type="revolute"><parent>a</parent><child>b</child>
      <axis><xyz>1 0 0</xyz></axis></joint>
  </model>
</sdf>
)";
  EXPECT_EQ(error_of("z.sdf", sdf),
            "z.sdf:6: joint 'j' moves nothing with inertia: link 'b' (line 4) and the links "
            "below it weigh 0 kg; give them <inertial> mass and inertia, or make the joint fixed");
  // the same link with a link of mass welded below it, or moving a slide: fine
  std::string welded = sdf;
  welded.replace(welded.find("  </model>"), 0,
                 "    <link name=\"c\"><pose>0 0 -1 0 0 0</pose></link>\n"
                 "    <joint name=\"w\" type=\"fixed\"><parent>b</parent><child>c</child>"
                 "</joint>\n");
  EXPECT_EQ(error_of("w.sdf", welded), "no error");
  // a point mass on the hinge's own axis turns with no inertia about it
  std::string point = sdf;
  point.replace(point.find("<mass>0</mass>"), 14, "<mass>2</mass>");
  EXPECT_EQ(error_of("p.sdf", point),
            "p.sdf:6: joint 'j' moves nothing with inertia: link 'b' (line 4) and the links "
            "below it have no inertia about the joint's axis; give them <inertial> mass and "
            "inertia, or make the joint fixed");
  std::string slide = point;
  slide.replace(slide.find("revolute"), 8, "prismatic");
  EXPECT_EQ(error_of("s.sdf", slide), "no error");
  // a fixed robot whose links all weigh 0 moves nothing: nothing to refuse
  const std::string urdf = "<robot name=\"r\">\n<link name=\"a\">\n" +
                           std::string(R"(<inertial><mass value="0"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>)") +
                           "\n</link>\n</robot>\n";
  EXPECT_EQ(error_of("f.urdf", urdf, {.fixed_base = true}), "no error");
  EXPECT_EQ(error_of("f.urdf", urdf),
            "f.urdf:2: link 'a': a floating base whose links all weigh 0 kg cannot move: give "
            "the links <inertial> masses, or weld the base to the world");
}

// a ground is a robot nothing of which moves, with a collision shape: models/ground.urdf's text
// is one; a floating robot, the same welded to the world (a hinge still moves) or a shapeless
// weld are not, and only a floating robot without a ground needs one
TEST(RobotModel, GroundIsAShapedRobotWeldedWhole) {
  const RobotModel ground =
      read_robot("ground.urdf", write_file("ground.urdf", ground_urdf_text()), {});
  const RobotModel floating = read_robot("two.urdf", write_robot("two.urdf", two_link_urdf()), {});
  RobotOptions fixed;
  fixed.fixed_base = true;
  const RobotModel arm = read_robot("two.urdf", write_robot("two.urdf", two_link_urdf()), fixed);
  const RobotModel shapeless = read_robot(
      "weld.urdf",
      write_file("weld.urdf", R"(<robot name="weld"><link name="world"/><link name="post"/>
  <joint name="w" type="fixed"><parent link="world"/><child link="post"/></joint></robot>)"),
      {});
  EXPECT_TRUE(robot_is_ground(ground));
  const std::string shipped = std::string(STANCE_SOURCE_DIR) + "/models/ground.urdf";
  EXPECT_TRUE(robot_is_ground(read_robot("models/ground.urdf", shipped, {})));
  EXPECT_FALSE(robot_is_ground(floating));
  EXPECT_FALSE(robot_is_ground(arm));
  EXPECT_FALSE(robot_is_ground(shapeless));
  EXPECT_TRUE(robots_need_ground({floating}));
  EXPECT_TRUE(robots_need_ground({floating, shapeless}));
  EXPECT_FALSE(robots_need_ground({floating, ground}));
  EXPECT_FALSE(robots_need_ground({arm}));
}

}  // namespace
}  // namespace stance
