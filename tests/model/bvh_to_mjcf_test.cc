// BVH -> MJCF characters: they load, weigh the total mass, and their "start" keyframe puts the
// bodies where the reference motion's forward kinematics does.
#include "model/bvh_to_mjcf.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/mujoco/mujoco_engine.h"
#include "engine/world_spec.h"
#include "test_support.h"

namespace stance {
namespace {

std::string shared_bvh(const std::string& file) {
  return std::string(STANCE_SOURCE_DIR) + "/../shared/data/bvh/" + file;
}

// loads the character, applies its start keyframe and checks it against the reference
void check_character(const BvhClip& clip, const BvhCharacterOptions& o, const std::string& tag) {
  BvhCharacter ch = make_bvh_character(clip, o);
  std::string path = test::write_temp_file(tag + ".xml", ch.mjcf);
  WorldSpec spec;
  spec.models.push_back({path});
  auto engine = make_mujoco_engine(spec);
  const MotionSkeleton& sk = ch.skeleton;
  EXPECT_EQ(engine->nbody(), sk.segment_count());
  EXPECT_EQ(engine->nv(), 3 * sk.segment_count() + 3);
  EXPECT_NEAR(engine->total_mass(), o.total_mass_kg, 1e-6 * o.total_mass_kg);
  EXPECT_NEAR(engine->timestep(), o.timestep_s, 1e-15);
  for (const auto& seg : sk.segments) EXPECT_GE(engine->body_index(seg.name), 0) << seg.name;

  auto* mj = dynamic_cast<MujocoEngine*>(engine.get());
  ASSERT_NE(mj, nullptr);
  int key = mj_name2id(mj->model(), mjOBJ_KEY, "start");
  ASSERT_GE(key, 0);
  mj_resetDataKeyframe(mj->model(), mj->data(), key);
  mj->invalidate();
  engine->forward();
  ReferenceMotion ref(clip, sk, o.reference);
  ReferencePose pose = ref.make_pose();
  ref.sample(0, pose);
  std::vector<Eigen::Vector3d> pos;
  std::vector<Eigen::Quaterniond> rot;
  ref.forward_kinematics(pose, pos, rot);
  for (int k = 0; k < sk.segment_count(); ++k) {
    BodyPose b = engine->body_pose(engine->body_index(sk.segments[k].name));
    EXPECT_NEAR((b.pos - pos[k]).norm(), 0, 1e-6) << sk.segments[k].name;
    EXPECT_LT(b.quat.angularDistance(rot[k]), 1e-6) << sk.segments[k].name;
  }
  // nothing starts inside the floor (ground alignment): contacts are at most touching
  for (int i = 0; i < engine->num_contacts(); ++i) EXPECT_GT(engine->contact(i).pos.z(), -0.01);
}

TEST(BvhToMjcf, SyntheticWalkCharacter) {
  BvhClip clip = make_synthetic_walk_clip();
  BvhCharacterOptions o;
  check_character(clip, o, "synthetic_walk");
  o.total_mass_kg = 55;
  o.reference.first_frame = 20;
  check_character(clip, o, "synthetic_walk_55");
  BvhCharacter ch = make_bvh_character(clip, o);
  EXPECT_NE(ch.mjcf.find("type=\"box\""), std::string::npos);      // feet
  EXPECT_NE(ch.mjcf.find("type=\"capsule\""), std::string::npos);  // limbs
  EXPECT_NE(ch.mjcf.find("<freejoint name=\"root\"/>"), std::string::npos);
  o.total_mass_kg = 0;
  EXPECT_THROW(make_bvh_character(clip, o), InputError);
}

TEST(BvhToMjcf, FootSegmentNames) {
  EXPECT_TRUE(is_foot_segment_name("Character1_LeftFoot"));
  EXPECT_TRUE(is_foot_segment_name("LeftToe"));
  EXPECT_TRUE(is_foot_segment_name("RightAnkle"));
  EXPECT_FALSE(is_foot_segment_name("LeftKnee"));
}

TEST(BvhToMjcf, SharedFilesBuildLoadableCharacters) {
  for (const char* file : {"mass_walk.bvh", "cmu_131_01.bvh"}) {
    const std::string path = shared_bvh(file);
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
    SCOPED_TRACE(file);
    BvhClip clip = read_bvh(path);
    BvhCharacterOptions o;
    if (std::string(file) == "cmu_131_01.bvh") o.reference.first_frame = 540;
    check_character(clip, o, std::string(file) + "_char");
  }
}

TEST(BvhToMjcf, WritesTheFile) {
  BvhClip clip = make_synthetic_walk_clip();
  std::string bvh = test::write_temp_file("walk_for_cli.bvh", format_bvh(clip));
  std::string xml =
      (std::filesystem::temp_directory_path() / "stance_tests" / "walk_cli.xml").string();
  write_bvh_character(bvh, xml, {});
  EXPECT_TRUE(std::filesystem::exists(xml));
  EXPECT_THROW(write_bvh_character(bvh + ".missing", xml, {}), InputError);
}

}  // namespace
}  // namespace stance
