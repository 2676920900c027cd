#include "model/skel_to_mjcf.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

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

// MuJoCo's contype/conaffinity filter: true when geoms g1 and g2 may touch
bool may_collide(const mjModel* m, int g1, int g2) {
  return (m->geom_contype[g1] & m->geom_conaffinity[g2]) != 0 ||
         (m->geom_contype[g2] & m->geom_conaffinity[g1]) != 0;
}

// DART never collides a skeleton with itself, and collides different skeletons: every two
// colliding geoms of different bodies are filtered exactly when they share a mobile root body.
// Returns the number of pairs checked.
int expect_skeletons_never_self_collide(const mjModel* m) {
  int pairs = 0;
  for (int g1 = 0; g1 < m->ngeom; ++g1) {
    for (int g2 = g1 + 1; g2 < m->ngeom; ++g2) {
      const int b1 = m->geom_bodyid[g1];
      const int b2 = m->geom_bodyid[g2];
      const bool colliding = (m->geom_contype[g1] | m->geom_conaffinity[g1]) != 0 &&
                             (m->geom_contype[g2] | m->geom_conaffinity[g2]) != 0;
      // MuJoCo itself skips pairs within one body and pairs of static bodies
      if (!colliding || b1 == b2 || (m->body_weldid[b1] == 0 && m->body_weldid[b2] == 0)) continue;
      const bool same_skeleton = m->body_rootid[b1] == m->body_rootid[b2];
      EXPECT_EQ(may_collide(m, g1, g2), !same_skeleton)
          << mj_id2name(m, mjOBJ_GEOM, g1) << " and " << mj_id2name(m, mjOBJ_GEOM, g2);
      ++pairs;
    }
  }
  return pairs;
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

  // the 20 bodies of fullbody1 never collide with each other, and do collide with the ground,
  // by contype bits (no quadratic list of excluded pairs)
  EXPECT_EQ(m->nexclude, 0);
  EXPECT_GT(expect_skeletons_never_self_collide(m.get()), 20);
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
  // filtered pairs stay within a skeleton: feet can touch the board
  EXPECT_EQ(m->nexclude, 0);
  expect_skeletons_never_self_collide(m.get());
  const int foot = geom_id(m.get(), "h_toe_left/collision0");
  const int board = geom_id(m.get(), "main_body/collision0");
  ASSERT_GE(foot, 0);
  ASSERT_GE(board, 0);
  EXPECT_TRUE(may_collide(m.get(), foot, board));
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
  // visual geoms never collide; collision geoms do, with a default geom (contype and
  // conaffinity 1) of another model; no geom carries mass
  int visual = geom_id(m.get(), "base/visual0");
  int collision = geom_id(m.get(), "base/collision0");
  EXPECT_EQ(m->geom_contype[visual] | m->geom_conaffinity[visual], 0);
  EXPECT_NE((m->geom_contype[collision] | m->geom_conaffinity[collision]) & 1, 0);
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

  // bodies of the mobile skeleton never collide with each other
  EXPECT_EQ(m->nexclude, 0);
  expect_skeletons_never_self_collide(m.get());
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

// ---------------------------------------------------------------------------------------------
// the checks that run before DART's parser (check_skel_for_dart): each case once crashed DART

// a one-body world; the body's extra elements are on line 5, the joint's on line 8
std::string one_body_skel(const std::string& body_extra, const std::string& joint_type = "free",
                          const std::string& joint_extra = "",
                          const std::string& physics = "<time_step>0.001</time_step>") {
  return "<skel><world>\n"  // 1
         "<physics>" +
         physics +
         "</physics>\n"             // 2
         "<skeleton name=\"s\">\n"  // 3
         "<body name=\"a\">\n"      // 4
         + body_extra +
         "\n"         // 5
         "</body>\n"  // 6
         "<joint type=\"" +
         joint_type + "\" name=\"j\">\n"  // 7
         + joint_extra +
         "\n"                                        // 8
         "<parent>world</parent><child>a</child>\n"  // 9
         "</joint>\n"                                // 10
         "</skeleton></world></skel>\n";
}

// the message of the InputError that check_skel_for_dart throws for `path`
std::string dart_check_error(const std::string& path) {
  try {
    check_skel_for_dart(path);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected InputError for " << path;
  return "";
}

struct BadSkel {
  const char* name;
  std::string text;
  int line;
  const char* says;
};

TEST_F(SkelTest, DartChecksRejectWhatCrashedDartWithFileAndLine) {
  const std::string box =
      "<collision_shape><geometry><box><size>{}</size></box></geometry>"
      "</collision_shape>";
  const std::vector<BadSkel> cases = {
      {"box_size_zero", one_body_skel(fmt::format(fmt::runtime(box), "0 1 1")), 5,
       "every number must be positive"},
      {"sphere_radius_negative",
       one_body_skel("<visualization_shape><geometry><sphere><radius>-1</radius></sphere>"
                     "</geometry></visualization_shape>"),
       5, "<radius> must be positive, found -1"},
      {"cylinder_height_zero",
       one_body_skel("<collision_shape><geometry><cylinder><radius>1</radius><height>0</height>"
                     "</cylinder></geometry></collision_shape>"),
       5, "<height> must be positive"},
      {"transformation_five_numbers", one_body_skel("<transformation>0 0 0 0 0</transformation>"),
       5, "expected 6 numbers, found 5"},
      {"vector_two_numbers", one_body_skel("<inertia><mass>1</mass><offset>0 0</offset></inertia>"),
       5, "expected 3 numbers, found 2"},
      {"unknown_joint_type", one_body_skel("", "hinge2"), 7, "unsupported joint type 'hinge2'"},
      {"nan_time_step", one_body_skel("", "free", "", "<time_step>nan</time_step>"), 2,
       "'nan' is not a number"},
      {"zero_time_step", one_body_skel("", "free", "", "<time_step>0</time_step>"), 2,
       "<time_step>: 0 s: a time step must be positive (at least 1e-05 s)"},
      // a simulated second in 10^9 steps (core/timestep.h)
      {"tiny_time_step", one_body_skel("", "free", "", "<time_step>1e-9</time_step>"), 2,
       "<time_step>: 1e-09 s is below the smallest time step, 1e-05 s"},
      {"bad_boolean", one_body_skel("<gravity>yes</gravity>"), 5, "expected true/false/1/0"},
      {"init_pos_size", one_body_skel("", "ball", "<init_pos>0 0</init_pos>"), 8,
       "expected 3 numbers, found 2"},
      {"damping_index",
       one_body_skel("", "revolute",
                     "<axis><xyz>0 0 1</xyz></axis><dof local_index=\"3\"><damping>1</damping>"
                     "</dof>"),
       8, "needs local_index in [0, 1)"},
      {"euler_axis_order", one_body_skel("", "euler", "<axis_order>xzy</axis_order>"), 8,
       "axis_order 'xzy'"},
      {"mesh_without_uri",
       one_body_skel("<visualization_shape><geometry><mesh/></geometry></visualization_shape>"), 5,
       "<mesh> is missing <file_name>"},
      {"mesh_missing_file",
       one_body_skel("<visualization_shape><geometry><mesh><file_name>none.dae</file_name>"
                     "<scale>1 1 1</scale></mesh></geometry></visualization_shape>"),
       5, "no such file"},
      {"soft_frags_nan",
       one_body_skel("<soft_shape><total_mass>1</total_mass><geometry><box><size>1 1 1</size>"
                     "<frags>nan 2 2</frags></box></geometry></soft_shape>"),
       5, "'nan' is not a number"},
      {"soft_frags_huge",
       one_body_skel("<soft_shape><total_mass>1</total_mass><geometry><box><size>1 1 1</size>"
                     "<frags>1000 1000 1000</frags></box></geometry></soft_shape>"),
       5, "whole numbers in [2, 100]"},
      {"negative_mass", one_body_skel("<inertia><mass>-1</mass></inertia>"), 5,
       "<mass> must be positive, found -1"},
      {"moment_negative",
       one_body_skel("<inertia><mass>1</mass><moment_of_inertia><ixx>1</ixx><iyy>1</iyy>"
                     "<izz>-1</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></moment_of_inertia>"
                     "</inertia>"),
       5, "<moment_of_inertia> needs ixx, iyy and izz > 0"},
      {"soft_box_without_frags",
       one_body_skel("<soft_shape><total_mass>1</total_mass><geometry><box><size>1 1 1</size>"
                     "</box></geometry></soft_shape>"),
       5, "<box> is missing <frags>"},
  };
  for (const BadSkel& c : cases) {
    std::string path = write(std::string(c.name) + ".skel", c.text);
    std::string message = dart_check_error(path);
    EXPECT_NE(message.find(fmt::format("{}.skel:{}: ", c.name, c.line)), std::string::npos)
        << c.name << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.name << ": " << message;
    // the MuJoCo path reads the same way
    EXPECT_EQ(error_of(path), message) << c.name;
  }
}

TEST_F(SkelTest, DartChecksRejectSkeletonsDartCannotAssemble) {
  std::string no_joint = write("no_joint.skel", R"(<skel><world>
<skeleton name="s">
  <body name="a"/>
</skeleton></world></skel>)");
  std::string message = dart_check_error(no_joint);
  EXPECT_NE(message.find("no_joint.skel:2: skeleton 's' has no joint"), std::string::npos)
      << message;

  std::string cycle = write("cycle.skel", R"(<skel><world>
<skeleton name="s">
  <body name="r"/>
  <body name="a"/>
  <body name="b"/>
  <joint type="free" name="j0"><parent>world</parent><child>r</child></joint>
  <joint type="weld" name="j1"><parent>a</parent><child>b</child></joint>
  <joint type="weld" name="j2"><parent>b</parent><child>a</child></joint>
</skeleton></world></skel>)");
  message = dart_check_error(cycle);
  EXPECT_NE(message.find("cycle.skel:4: body 'a' is in a joint cycle"), std::string::npos)
      << message;
}

// a chain of `bodies` bodies joined by weld joints, under one free root
std::string weld_chain(int bodies) {
  std::string text = "<skel><world>\n<skeleton name=\"chain\">\n";
  for (int i = 0; i < bodies; ++i) {
    text += fmt::format(
        "<body name=\"b{}\"><collision_shape><geometry><sphere><radius>0.1"
        "</radius></sphere></geometry></collision_shape></body>\n",
        i);
  }
  text += "<joint type=\"free\" name=\"j0\"><parent>world</parent><child>b0</child></joint>\n";
  for (int i = 1; i < bodies; ++i) {
    text += fmt::format(
        "<joint type=\"weld\" name=\"j{}\"><parent>b{}</parent><child>b{}</child>"
        "</joint>\n",
        i, i - 1, i);
  }
  return text + "</skeleton></world></skel>\n";
}

TEST_F(SkelTest, DeepChainsStopAtTheBodyLimitAndAtMujocosNesting) {
  // as many bodies as the limit allows pass the checks of the DART path
  std::string deepest = write("deepest.skel", weld_chain(static_cast<int>(kMaxSkelBodies)));
  EXPECT_NO_THROW(check_skel_for_dart(deepest));
  std::string too_many = write("too_many.skel", weld_chain(static_cast<int>(kMaxSkelBodies) + 1));
  std::string message = dart_check_error(too_many);
  EXPECT_NE(message.find(fmt::format("too_many.skel:{}: more than {} bodies in one file",
                                     kMaxSkelBodies + 3, kMaxSkelBodies)),
            std::string::npos)
      << message;
  EXPECT_EQ(error_of(too_many), message);

  // MuJoCo reads 96 nested bodies: translated (without recursion, no pair list) and loaded
  SkelTranslation t = skel_to_mjcf({SkelInput{write("chain96.skel", weld_chain(96))}});
  EXPECT_EQ(t.mjcf.find("<exclude"), std::string::npos);
  ModelPtr m = load(t.mjcf);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->nbody, 97);
  // the 97th is refused where it is in the .skel file, not in the translated text
  message = error_of(write("chain97.skel", weld_chain(97)));
  EXPECT_NE(message.find("chain97.skel:99: body 'b96' is nested 97 bodies deep: MuJoCo reads at "
                         "most 96"),
            std::string::npos)
      << message;
}

TEST_F(SkelTest, WhatOnlyDartSimulatesPassesDartChecksAndNotTheMujocoTranslation) {
  write("part.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::vector<BadSkel> cases = {
      {"soft_body",
       one_body_skel("<soft_shape><total_mass>1</total_mass><geometry><box><size>1 1 1</size>"
                     "<frags>2 2 2</frags></box></geometry><kv>50</kv></soft_shape>"),
       5, "soft bodies are not supported by the MuJoCo translation"},
      {"mesh",
       one_body_skel("<visualization_shape><geometry><mesh><file_name>part.obj</file_name>"
                     "<scale>1 1 1</scale></mesh></geometry></visualization_shape>"),
       5, "shape <mesh> is not supported by the MuJoCo translation"},
      {"cone",
       one_body_skel("<collision_shape><geometry><cone><radius>1</radius><height>1</height>"
                     "</cone></geometry></collision_shape>"),
       5, "shape <cone> is not supported"},
      {"planar", one_body_skel("", "planar", "<plane type=\"xy\"/>"), 7,
       "planar joints are not supported by the MuJoCo translation"},
      {"gravity_off", one_body_skel("<gravity>false</gravity>"), 4,
       "<gravity>false</gravity> is not supported by the MuJoCo translation"},
  };
  for (const BadSkel& c : cases) {
    std::string path = write(std::string(c.name) + ".skel", c.text);
    EXPECT_NO_THROW(check_skel_for_dart(path)) << c.name;
    std::string message = error_of(path);
    EXPECT_NE(message.find(fmt::format("{}.skel:{}: ", c.name, c.line)), std::string::npos)
        << c.name << ": " << message;
    EXPECT_NE(message.find(c.says), std::string::npos) << c.name << ": " << message;
  }
}

// the .skel files dart-doc ships pass the checks, but for those DART itself cannot load
// correctly: a soft box without <frags> (DART 6.12 dereferences the missing element) and a box
// of negative size (DART's BoxShape asserts on it in a debug build)
TEST_F(SkelTest, DartChecksPassTheSkelFilesDartDocShips) {
  const fs::path root = "/usr/share/doc/dart/data/skel";
  if (!fs::exists(root)) GTEST_SKIP() << "dart-doc not installed";
  const std::map<std::string, std::string> rejected = {
      {"test_single_body.skel", ":19: <box> is missing <frags>"},
      {"test_single_pendulum.skel", ":19: <box> is missing <frags>"},
      {"test_double_pendulum.skel", ":54: <box> is missing <frags>"},
      {"kima_human_left_leg.skel", ":119: <size>: every number must be positive"},
  };
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (entry.path().extension() != ".skel") continue;
    ++files;
    auto it = rejected.find(entry.path().filename().string());
    if (it == rejected.end()) {
      EXPECT_NO_THROW(check_skel_for_dart(entry.path().string())) << entry.path();
    } else {
      std::string message = dart_check_error(entry.path().string());
      EXPECT_NE(message.find(it->second), std::string::npos) << message;
    }
  }
  EXPECT_GE(files, 70);
}

}  // namespace
}  // namespace stance
