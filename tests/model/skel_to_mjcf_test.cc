#include "model/skel_to_mjcf.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "core/error.h"

namespace stance {
namespace {

namespace fs = std::filesystem;
using Eigen::AngleAxisd;
using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr const char* kFullbody = "/usr/share/doc/dart/data/skel/fullbody1.skel";
constexpr const char* kSkateboard = "/usr/share/doc/dart/data/skel/skateboard.skel";

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// a fresh directory per test, removed afterwards
class SkelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           (std::string("stance_skel_") + info->name() + "_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) const {
    std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }

  // loads MJCF text in MuJoCo; fails the test on any compiler error or warning
  ModelPtr load(const std::string& mjcf) const {
    std::string path = write("model.xml", mjcf);
    char error[1000] = "";
    ModelPtr m(mj_loadXML(path.c_str(), nullptr, error, sizeof(error)));
    EXPECT_NE(m, nullptr) << error;
    EXPECT_STREQ(error, "");
    return m;
  }

  fs::path dir_;
};

int joint_id(const mjModel* m, const char* name) {
  return mj_name2id(m, mjOBJ_JOINT, name);
}
int body_id(const mjModel* m, const char* name) {
  return mj_name2id(m, mjOBJ_BODY, name);
}
int geom_id(const mjModel* m, const char* name) {
  return mj_name2id(m, mjOBJ_GEOM, name);
}

// x y z roll pitch yaw, as DART reads <transformation>: R = Rx Ry Rz
Isometry3d xyz_rpy(double x, double y, double z, double r, double p, double yaw) {
  Isometry3d t = Isometry3d::Identity();
  t.linear() = (AngleAxisd(r, Vector3d::UnitX()) * AngleAxisd(p, Vector3d::UnitY()) *
                AngleAxisd(yaw, Vector3d::UnitZ()))
                   .toRotationMatrix();
  t.translation() = Vector3d(x, y, z);
  return t;
}

Isometry3d body_pose(const mjData* d, int id) {
  Isometry3d t = Isometry3d::Identity();
  t.translation() = Vector3d(d->xpos[3 * id], d->xpos[3 * id + 1], d->xpos[3 * id + 2]);
  t.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->xmat + 9 * id);
  return t;
}

TEST_F(SkelTest, Fullbody1TranslatesAndLoads) {
  if (!fs::exists(kFullbody)) GTEST_SKIP() << "dart-doc not installed";
  SkelTranslation t = skel_to_mjcf({SkelInput{"dart://sample/skel/fullbody1.skel"}});
  EXPECT_DOUBLE_EQ(t.timestep, 0.001);
  EXPECT_EQ(t.gravity, Vector3d(0, -9.81, 0));
  ASSERT_EQ(t.immobile_skeletons, std::vector<std::string>{"ground skeleton"});
  ModelPtr m = load(t.mjcf);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->nv, 37);
  EXPECT_EQ(m->nq, 38);
  EXPECT_DOUBLE_EQ(m->opt.timestep, 0.001);
  EXPECT_EQ(Vector3d(m->opt.gravity[0], m->opt.gravity[1], m->opt.gravity[2]),
            Vector3d(0, -9.81, 0));

  // mass of the moving bodies: the ground is static
  double mass = 0;
  for (int b = 1; b < m->nbody; ++b) {
    if (m->body_weldid[b] != 0) mass += m->body_mass[b];
  }
  EXPECT_NEAR(mass, 47.9028, 1e-6);
  EXPECT_EQ(m->body_weldid[body_id(m.get(), "ground")], 0);

  int pelvis = joint_id(m.get(), "j_pelvis");
  ASSERT_GE(pelvis, 0);
  EXPECT_EQ(m->jnt_type[pelvis], mjJNT_FREE);
  for (const char* name : {"j_thigh_left_z", "j_thigh_left_y", "j_thigh_left_x", "j_heel_left_1",
                           "j_heel_left_2", "j_shin_left"}) {
    int j = joint_id(m.get(), name);
    ASSERT_GE(j, 0) << name;
    EXPECT_EQ(m->jnt_type[j], mjJNT_HINGE) << name;
  }
  // euler zyx: the z hinge comes first in the body, then y, then x
  int z = joint_id(m.get(), "j_thigh_left_z");
  EXPECT_EQ(joint_id(m.get(), "j_thigh_left_y"), z + 1);
  EXPECT_EQ(joint_id(m.get(), "j_thigh_left_x"), z + 2);
  EXPECT_EQ(Vector3d(m->jnt_axis + 3 * z), Vector3d::UnitZ());

  // the 20 bodies of fullbody1 never collide with each other
  EXPECT_EQ(m->nexclude, 20 * 19 / 2);
  // DART's initial state (<init_pos>) is the "init" keyframe, q = 0 stays the reference
  int key = mj_name2id(m.get(), mjOBJ_KEY, "init");
  ASSERT_GE(key, 0);
  int shin = joint_id(m.get(), "j_shin_left");
  EXPECT_DOUBLE_EQ(m->key_qpos[key * m->nq + m->jnt_qposadr[shin]], -0.17);
  EXPECT_DOUBLE_EQ(m->qpos0[m->jnt_qposadr[shin]], 0.0);
}

TEST_F(SkelTest, SkateboardTranslatesAndLoads) {
  if (!fs::exists(kSkateboard)) GTEST_SKIP() << "dart-doc not installed";
  SkelTranslation t = skel_to_mjcf({SkelInput{kSkateboard}});
  ModelPtr m = load(t.mjcf);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->nq, 7 + 2 + 2 + 1 + 1);
  EXPECT_EQ(m->nv, 6 + 2 + 2 + 1 + 1);
  EXPECT_TRUE(t.immobile_skeletons.empty());
  // skeleton <transformation> 0 -0.3 0 moves the board
  EXPECT_DOUBLE_EQ(m->body_pos[3 * body_id(m.get(), "main_body") + 1], -0.3);
  // wheel collision: ellipsoid of diameters 0.08 -> semi-axes 0.04; visual cylinder r 0.05 h 0.03
  int wheel = geom_id(m.get(), "wheel_front_left/collision0");
  ASSERT_GE(wheel, 0);
  EXPECT_EQ(m->geom_type[wheel], mjGEOM_ELLIPSOID);
  EXPECT_NEAR(m->geom_size[3 * wheel], 0.04, 1e-15);
  int rim = geom_id(m.get(), "wheel_front_left/visual0");
  EXPECT_EQ(m->geom_type[rim], mjGEOM_CYLINDER);
  EXPECT_NEAR(m->geom_size[3 * rim], 0.05, 1e-15);
  EXPECT_NEAR(m->geom_size[3 * rim + 1], 0.015, 1e-15);
}

TEST_F(SkelTest, SkaterComposesWithOffsetAndRejectsDuplicateNames) {
  if (!fs::exists(kFullbody) || !fs::exists(kSkateboard)) GTEST_SKIP() << "no dart-doc";
  SkelTranslation t = skel_to_mjcf({SkelInput{kFullbody}, SkelInput{kSkateboard, {0, 0, 2}}});
  ModelPtr m = load(t.mjcf);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->nq, 38 + 13);
  EXPECT_DOUBLE_EQ(m->body_pos[3 * body_id(m.get(), "main_body") + 2], 2.0);
  // excluded pairs stay within a skeleton: feet can touch the board
  EXPECT_EQ(m->nexclude, 20 * 19 / 2 + 5 * 4 / 2);
  try {
    skel_to_mjcf({SkelInput{kFullbody}, SkelInput{kFullbody}});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'ground' is used twice"), std::string::npos) << e.what();
  }
}

// every joint type and shape type the translation supports, in three skeletons
constexpr const char* kSynthetic = R"(<?xml version="1.0" ?>
<skel version="1.0">
  <world name="synthetic">
    <physics>
      <time_step>0.002</time_step>
      <gravity>0 0 -9.81</gravity>
    </physics>
    <skeleton name="floor">
      <mobile>false</mobile>
      <body name="floor">
        <transformation>0 0 -1 0 0 0</transformation>
        <collision_shape>
          <geometry><box><size>4 4 0.1</size></box></geometry>
        </collision_shape>
      </body>
      <joint type="weld" name="j_floor">
        <parent>world</parent>
        <child>floor</child>
      </joint>
    </skeleton>
    <skeleton name="fixed_arm">
      <mobile>0</mobile>
      <transformation>1 0 0 0 0 0.5</transformation>
      <body name="arm_base">
        <transformation>0 0 0.2 0 0 0</transformation>
        <collision_shape>
          <geometry><sphere><radius>0.1</radius></sphere></geometry>
        </collision_shape>
      </body>
      <body name="arm_link">
        <transformation>0 0 0.5 0.1 0.2 0.3</transformation>
        <collision_shape>
          <geometry><capsule><radius>0.05</radius><height>0.3</height></capsule></geometry>
        </collision_shape>
      </body>
      <joint type="free" name="j_arm_base">
        <parent>world</parent>
        <child>arm_base</child>
      </joint>
      <joint type="revolute" name="j_arm">
        <transformation>0 0 -0.1 0 0 0</transformation>
        <parent>arm_base</parent>
        <child>arm_link</child>
        <axis><xyz>0 1 0</xyz></axis>
        <init_pos>0.7</init_pos>
      </joint>
    </skeleton>
    <skeleton name="synth">
      <transformation>0.1 0.2 0.3 0.3 -0.2 0.5</transformation>
      <body name="base">
        <transformation>0 0 1 0.1 0.2 -0.3</transformation>
        <inertia>
          <mass>3.0</mass>
          <offset>0.01 -0.02 0.03</offset>
          <moment_of_inertia>
            <ixx>0.05</ixx><iyy>0.06</iyy><izz>0.07</izz>
            <ixy>0.001</ixy><ixz>-0.002</ixz><iyz>0.003</iyz>
          </moment_of_inertia>
        </inertia>
        <visualization_shape>
          <transformation>0 0 0.1 0 0 0</transformation>
          <geometry><box><size>0.2 0.3 0.4</size></box></geometry>
          <color>0.1 0.2 0.3</color>
        </visualization_shape>
        <collision_shape>
          <geometry><sphere><radius>0.15</radius></sphere></geometry>
        </collision_shape>
      </body>
      <body name="b_rev">
        <transformation>0.2 0 1 0 0.3 0</transformation>
        <inertia><mass>1.5</mass><offset>0 0.05 0</offset></inertia>
        <visualization_shape>
          <geometry><ellipsoid><size>0.2 0.4 0.6</size></ellipsoid></geometry>
        </visualization_shape>
        <collision_shape>
          <transformation>0.01 0.02 0.03 0.5 0 0</transformation>
          <geometry><ellipsoid><size>0.2 0.4 0.6</size></ellipsoid></geometry>
        </collision_shape>
      </body>
      <body name="b_pri">
        <transformation>0.4 0.1 1 0 0 0.2</transformation>
        <inertia><mass>0.7</mass></inertia>
        <collision_shape>
          <geometry><cylinder><radius>0.05</radius><height>0.3</height></cylinder></geometry>
        </collision_shape>
      </body>
      <body name="b_uni">
        <transformation>-0.2 0 0.9 0.2 0 0</transformation>
        <inertia><mass>0.9</mass><offset>0 0 -0.1</offset></inertia>
        <visualization_shape>
          <geometry><capsule><radius>0.04</radius><height>0.2</height></capsule></geometry>
        </visualization_shape>
      </body>
      <body name="b_exyz">
        <transformation>-0.3 0.1 0.7 0 0 0</transformation>
        <inertia><mass>0.4</mass></inertia>
        <collision_shape>
          <geometry><sphere><radius>0.07</radius></sphere></geometry>
        </collision_shape>
      </body>
      <body name="b_ezyx">
        <transformation>-0.35 0.15 0.5 0.3 0.3 0.3</transformation>
        <inertia><mass>0.3</mass></inertia>
        <collision_shape><geometry><box><size>0.1 0.1 0.1</size></box></geometry></collision_shape>
      </body>
      <body name="b_ball">
        <transformation>0.3 -0.1 1.2 0 0.5 0</transformation>
        <inertia><mass>0.6</mass></inertia>
        <collision_shape>
          <geometry><sphere><radius>0.05</radius></sphere></geometry>
        </collision_shape>
      </body>
      <body name="b_weld">
        <transformation>0.35 -0.1 1.4 0 0 0</transformation>
        <inertia><mass>0.2</mass></inertia>
        <collision_shape>
          <geometry><box><size>0.05 0.05 0.05</size></box></geometry>
        </collision_shape>
      </body>
      <body name="b_trans">
        <transformation>0.4 -0.1 1.5 0 0 0.4</transformation>
        <inertia><mass>0.25</mass></inertia>
        <collision_shape>
          <geometry><box><size>0.05 0.05 0.05</size></box></geometry>
        </collision_shape>
      </body>
      <joint type="free" name="j_base">
        <parent>world</parent>
        <child>base</child>
        <init_pos>0.1 -0.2 0.3 0.01 0.02 0.03</init_pos>
        <init_vel>0.5 -0.4 0.3 0.2 -0.1 0.6</init_vel>
      </joint>
      <joint type="revolute" name="j_rev">
        <transformation>0.05 0.1 -0.02 0.4 0.1 -0.3</transformation>
        <parent>base</parent>
        <child>b_rev</child>
        <axis>
          <xyz>1 1 0</xyz>
          <limit><lower>-1</lower><upper>1.5</upper></limit>
          <dynamics><damping>0.2</damping></dynamics>
        </axis>
        <init_pos>0.3</init_pos>
      </joint>
      <joint type="prismatic" name="j_pri">
        <transformation>0 0 0.1 0 0.2 0</transformation>
        <parent>b_rev</parent>
        <child>b_pri</child>
        <axis><xyz>0 0 1</xyz><limit><lower>-0.1</lower><upper>0.2</upper></limit></axis>
        <init_pos>0.05</init_pos>
      </joint>
      <joint type="universal" name="j_uni">
        <transformation>0 0.02 0.05 0.2 -0.1 0.4</transformation>
        <parent>base</parent>
        <child>b_uni</child>
        <axis><xyz>1 0 0</xyz><limit><lower>-0.5</lower><upper>0.5</upper></limit></axis>
        <axis2><xyz>0 1 0</xyz><limit><lower>-0.6</lower><upper>0.6</upper></limit></axis2>
        <init_pos>0.1 -0.2</init_pos>
      </joint>
      <joint type="euler" name="j_exyz">
        <transformation>0.01 0 0.02 0 0.3 0</transformation>
        <parent>b_uni</parent>
        <child>b_exyz</child>
        <axis_order>xyz</axis_order>
        <init_pos>0.1 0.2 0.3</init_pos>
      </joint>
      <joint type="euler" name="j_ezyx">
        <transformation>0 0 0 -1.2423 0 0</transformation>
        <parent>b_exyz</parent>
        <child>b_ezyx</child>
        <axis_order>zyx</axis_order>
        <axis><limit><lower>-0.1</lower><upper>0.1</upper></limit></axis>
      </joint>
      <joint type="ball" name="j_ball">
        <transformation>0.02 0.03 0.04 0.5 -0.4 0.3</transformation>
        <parent>b_rev</parent>
        <child>b_ball</child>
        <init_pos>0.2 0.1 -0.3</init_pos>
        <init_vel>1 2 3</init_vel>
      </joint>
      <joint type="weld" name="j_weld">
        <parent>b_ball</parent>
        <child>b_weld</child>
      </joint>
      <joint type="translational" name="j_trans">
        <transformation>0 0 0 0.3 0 0</transformation>
        <parent>b_weld</parent>
        <child>b_trans</child>
        <init_pos>0.01 0.02 0.03</init_pos>
      </joint>
    </skeleton>
  </world>
</skel>
)";

TEST_F(SkelTest, SyntheticJointAndShapeTypes) {
  SkelTranslation t = skel_to_mjcf({SkelInput{write("synth.skel", kSynthetic)}});
  EXPECT_DOUBLE_EQ(t.timestep, 0.002);
  EXPECT_EQ(t.immobile_skeletons, (std::vector<std::string>{"floor", "fixed_arm"}));
  ModelPtr m = load(t.mjcf);
  ASSERT_NE(m, nullptr);
  // free 7/6, revolute 1, prismatic 1, universal 2, euler 3 + 3, ball 4/3, weld 0, translational 3
  EXPECT_EQ(m->nq, 7 + 1 + 1 + 2 + 3 + 3 + 4 + 3);
  EXPECT_EQ(m->nv, 6 + 1 + 1 + 2 + 3 + 3 + 3 + 3);
  const std::pair<const char*, int> types[] = {
      {"j_base", mjJNT_FREE},     {"j_rev", mjJNT_HINGE},     {"j_pri", mjJNT_SLIDE},
      {"j_uni_1", mjJNT_HINGE},   {"j_uni_2", mjJNT_HINGE},   {"j_exyz_x", mjJNT_HINGE},
      {"j_exyz_y", mjJNT_HINGE},  {"j_exyz_z", mjJNT_HINGE},  {"j_ezyx_z", mjJNT_HINGE},
      {"j_ezyx_y", mjJNT_HINGE},  {"j_ezyx_x", mjJNT_HINGE},  {"j_ball", mjJNT_BALL},
      {"j_trans_x", mjJNT_SLIDE}, {"j_trans_y", mjJNT_SLIDE}, {"j_trans_z", mjJNT_SLIDE}};
  for (const auto& [name, type] : types) {
    int j = joint_id(m.get(), name);
    ASSERT_GE(j, 0) << name;
    EXPECT_EQ(m->jnt_type[j], type) << name;
  }
  EXPECT_EQ(m->njnt, 15);  // the immobile skeletons have no joints

  // ranges are kept, but not enforced, as in DART
  int rev = joint_id(m.get(), "j_rev");
  EXPECT_EQ(m->jnt_range[2 * rev], -1.0);
  EXPECT_EQ(m->jnt_range[2 * rev + 1], 1.5);
  EXPECT_EQ(m->jnt_limited[rev], 0);
  EXPECT_DOUBLE_EQ(m->dof_damping[m->jnt_dofadr[rev]], 0.2);
  int uni2 = joint_id(m.get(), "j_uni_2");
  EXPECT_EQ(m->jnt_range[2 * uni2 + 1], 0.6);
  // the revolute axis (1 1 0) is normalized and rotated into the body by the joint frame
  Vector3d axis = xyz_rpy(0, 0, 0, 0.4, 0.1, -0.3).linear() * Vector3d(1, 1, 0).normalized();
  EXPECT_LT((Vector3d(m->jnt_axis + 3 * rev) - axis).norm(), 1e-12);
  EXPECT_LT((Vector3d(m->jnt_pos + 3 * rev) - Vector3d(0.05, 0.1, -0.02)).norm(), 1e-15);

  // shape sizes: box half sizes, ellipsoid diameters -> semi-axes, cylinder and capsule half
  // heights (capsule height is the cylindrical part in DART and MuJoCo alike)
  auto size = [&](const char* name) {
    int g = geom_id(m.get(), name);
    EXPECT_GE(g, 0) << name;
    return Vector3d(m->geom_size + 3 * g);
  };
  EXPECT_EQ(m->geom_type[geom_id(m.get(), "b_rev/collision0")], mjGEOM_ELLIPSOID);
  EXPECT_LT((size("b_rev/collision0") - Vector3d(0.1, 0.2, 0.3)).norm(), 1e-15);
  EXPECT_LT((size("base/visual0") - Vector3d(0.1, 0.15, 0.2)).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(size("base/collision0").x(), 0.15);
  EXPECT_EQ(m->geom_type[geom_id(m.get(), "b_pri/collision0")], mjGEOM_CYLINDER);
  EXPECT_LT((size("b_pri/collision0").head<2>() - Eigen::Vector2d(0.05, 0.15)).norm(), 1e-15);
  EXPECT_EQ(m->geom_type[geom_id(m.get(), "b_uni/visual0")], mjGEOM_CAPSULE);
  EXPECT_LT((size("b_uni/visual0").head<2>() - Eigen::Vector2d(0.04, 0.1)).norm(), 1e-15);
  // visual geoms never collide; collision geoms do; no geom carries mass
  int visual = geom_id(m.get(), "base/visual0");
  int collision = geom_id(m.get(), "base/collision0");
  EXPECT_EQ(m->geom_contype[visual] | m->geom_conaffinity[visual], 0);
  EXPECT_EQ(m->geom_contype[collision] & m->geom_conaffinity[collision], 1);
  // the collision shape's own <transformation> is kept relative to the body
  int shifted = geom_id(m.get(), "b_rev/collision0");
  EXPECT_LT((Vector3d(m->geom_pos + 3 * shifted) - Vector3d(0.01, 0.02, 0.03)).norm(), 1e-15);

  // inertia: given moment kept; missing moment -> first shape's moment for the body mass
  int base = body_id(m.get(), "base");
  EXPECT_DOUBLE_EQ(m->body_mass[base], 3.0);
  EXPECT_LT((Vector3d(m->body_ipos + 3 * base) - Vector3d(0.01, -0.02, 0.03)).norm(), 1e-15);
  int ell = body_id(m.get(), "b_rev");  // ellipsoid 0.2 0.4 0.6, mass 1.5: m/20 (b^2 + c^2)..
  Vector3d ell_inertia(1.5 / 20 * (0.16 + 0.36), 1.5 / 20 * (0.04 + 0.36),
                       1.5 / 20 * (0.04 + 0.16));
  Vector3d got(m->body_inertia + 3 * ell);
  std::sort(got.data(), got.data() + 3);
  std::sort(ell_inertia.data(), ell_inertia.data() + 3);
  EXPECT_LT((got - ell_inertia).norm(), 1e-12);
  // capsule r 0.04 h 0.2, mass 0.9: the value DART 6.12 reports for this body
  int cap = body_id(m.get(), "b_uni");
  EXPECT_NEAR(m->body_inertia[3 * cap], 0.0052370526315789487, 1e-15);
  EXPECT_NEAR(m->body_inertia[3 * cap + 2], 0.00068968421052631576, 1e-15);
  // no <inertia>: DART's defaults, mass 1 and unit moment
  EXPECT_DOUBLE_EQ(m->body_mass[body_id(m.get(), "floor")], 1.0);

  // immobile skeletons: static bodies at DART's initial configuration (j_arm at 0.7)
  DataPtr d(mj_makeData(m.get()));
  mj_kinematics(m.get(), d.get());
  int link = body_id(m.get(), "arm_link");
  EXPECT_EQ(m->body_weldid[link], 0);
  EXPECT_EQ(m->body_parentid[link], 0);
  Isometry3d skeleton = xyz_rpy(1, 0, 0, 0, 0, 0.5);
  Isometry3d link0 = skeleton * xyz_rpy(0, 0, 0.5, 0.1, 0.2, 0.3);
  Isometry3d joint = xyz_rpy(0, 0, -0.1, 0, 0, 0);
  Isometry3d rot = Isometry3d::Identity();
  rot.linear() = AngleAxisd(0.7, Vector3d::UnitY()).toRotationMatrix();
  Isometry3d expected = link0 * joint * rot * joint.inverse();
  EXPECT_LT((body_pose(d.get(), link).matrix() - expected.matrix()).norm(), 1e-12);

  // bodies of the mobile skeleton exclude each other: 9 bodies
  EXPECT_EQ(m->nexclude, 9 * 8 / 2);
}

// a chain world -> (weld) -> parent -> (revolute, rotated joint frame) -> child
constexpr const char* kChain = R"(<skel version="1.0"><world name="w">
  <skeleton name="chain">
    <transformation>0.3 -0.2 0.1 0.2 0.1 -0.4</transformation>
    <body name="parent">
      <transformation>0 0 1 0.5 -0.3 0.2</transformation>
      <inertia><mass>2</mass></inertia>
    </body>
    <body name="child">
      <transformation>0.2 0.1 0.7 -0.1 0.6 0.3</transformation>
      <inertia><mass>1</mass><offset>0 0 -0.1</offset></inertia>
    </body>
    <joint type="weld" name="fix"><parent>world</parent><child>parent</child></joint>
    <joint type="revolute" name="hinge">
      <transformation>0.05 -0.02 0.1 0.3 -0.7 1.1</transformation>
      <parent>parent</parent><child>child</child>
      <axis><xyz>0 0.6 0.8</xyz></axis>
    </joint>
  </skeleton>
</world></skel>)";

TEST_F(SkelTest, RevoluteForwardKinematicsMatchesHandComputedTransform) {
  SkelTranslation t = skel_to_mjcf({SkelInput{write("chain.skel", kChain)}});
  ModelPtr m = load(t.mjcf);
  ASSERT_NE(m, nullptr);
  ASSERT_EQ(m->nq, 1);
  DataPtr d(mj_makeData(m.get()));
  const Isometry3d skeleton = xyz_rpy(0.3, -0.2, 0.1, 0.2, 0.1, -0.4);
  const Isometry3d child0 = skeleton * xyz_rpy(0.2, 0.1, 0.7, -0.1, 0.6, 0.3);
  const Isometry3d child_to_joint = xyz_rpy(0.05, -0.02, 0.1, 0.3, -0.7, 1.1);
  for (double q : {0.0, 0.4, -1.3, 2.9}) {
    d->qpos[0] = q;
    mj_kinematics(m.get(), d.get());
    // DART: T_world_child(q) = T_world_child(0) * T_CJ * R(axis, q) * T_CJ^-1
    Isometry3d motion = Isometry3d::Identity();
    motion.linear() = AngleAxisd(q, Vector3d(0, 0.6, 0.8)).toRotationMatrix();
    Isometry3d expected = child0 * child_to_joint * motion * child_to_joint.inverse();
    Isometry3d got = body_pose(d.get(), body_id(m.get(), "child"));
    EXPECT_LT((got.translation() - expected.translation()).norm(), 1e-12) << "q=" << q;
    EXPECT_LT((got.linear() - expected.linear()).norm(), 1e-12) << "q=" << q;
  }
}

// the message of the InputError that translating the file at `path` throws
std::string error_of(const std::string& path) {
  try {
    skel_to_mjcf({SkelInput{path}});
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected InputError for " << path;
  return "";
}

TEST_F(SkelTest, MalformedXmlNamesFileAndLine) {
  std::string path = write("file.skel", "<skel>\n<world>\n<skeleton name=\"a\">\n<body name=a/>\n");
  std::string message = error_of(path);
  EXPECT_NE(message.find("file.skel:4"), std::string::npos) << message;
}

TEST_F(SkelTest, UnknownJointTypeNamesTypeAndLine) {
  std::string path = write("joint.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a"/>
  <joint type="hinge2" name="j">
    <parent>world</parent><child>a</child>
  </joint>
</skeleton></world></skel>)");
  std::string message = error_of(path);
  EXPECT_NE(message.find("joint.skel:4:"), std::string::npos) << message;
  EXPECT_NE(message.find("'hinge2'"), std::string::npos) << message;
}

TEST_F(SkelTest, BadReferencesAndNumbersNameTheLine) {
  std::string missing_child = write("child.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a"/>
  <joint type="free" name="j">
    <parent>world</parent>
    <child>b</child>
  </joint>
</skeleton></world></skel>)");
  std::string message = error_of(missing_child);
  EXPECT_NE(message.find("child.skel:6:"), std::string::npos) << message;
  EXPECT_NE(message.find("'b'"), std::string::npos) << message;

  std::string missing_parent = write("parent.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a"/>
  <joint type="revolute" name="j">
    <parent>nobody</parent>
    <child>a</child>
    <axis><xyz>0 0 1</xyz></axis>
  </joint>
</skeleton></world></skel>)");
  message = error_of(missing_parent);
  EXPECT_NE(message.find("parent.skel:5:"), std::string::npos) << message;
  EXPECT_NE(message.find("'nobody'"), std::string::npos) << message;

  std::string bad_number = write("number.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a">
    <transformation>0 0 1x 0 0 0</transformation>
  </body>
</skeleton></world></skel>)");
  message = error_of(bad_number);
  EXPECT_NE(message.find("number.skel:4:"), std::string::npos) << message;
  EXPECT_NE(message.find("'1x'"), std::string::npos) << message;

  std::string short_vector = write("short.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a">
    <inertia><mass>1</mass><offset>0 0</offset></inertia>
  </body>
</skeleton></world></skel>)");
  message = error_of(short_vector);
  EXPECT_NE(message.find("short.skel:4:"), std::string::npos) << message;
}

TEST_F(SkelTest, MissingFileNamesTheFile) {
  std::string path = (dir_ / "absent.skel").string();
  std::string message = error_of(path);
  EXPECT_NE(message.find(path), std::string::npos) << message;
}

TEST_F(SkelTest, FreeJointWithJointFrameIsRejected) {
  std::string path = write("free.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a"/>
  <joint type="free" name="j">
    <transformation>0 0 0.1 0 0 0</transformation>
    <parent>world</parent><child>a</child>
  </joint>
</skeleton></world></skel>)");
  std::string message = error_of(path);
  EXPECT_NE(message.find("free.skel:4:"), std::string::npos) << message;
}

TEST_F(SkelTest, WriteMjcfFileWritesLoadableModel) {
  std::string skel = write("chain.skel", kChain);
  std::string out = (dir_ / "chain.xml").string();
  write_mjcf_file(skel, out);
  char error[1000] = "";
  ModelPtr m(mj_loadXML(out.c_str(), nullptr, error, sizeof(error)));
  ASSERT_NE(m, nullptr) << error;
  EXPECT_EQ(m->nq, 1);
}

}  // namespace
}  // namespace stance
