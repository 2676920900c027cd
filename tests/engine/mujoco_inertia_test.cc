#include "engine/mujoco/mujoco_inertia.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <string>

#include "test_support.h"

namespace stance {
namespace {

// a free box and a slide on the world (MuJoCo's "simple" dofs, whose qM is a constant) beside a
// hinge chain, so that both kinds of row are compared
const char* kSimpleAndChain = R"(
<mujoco>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.2 0.3"/></body>
    <body pos="1 0 1"><joint type="slide" axis="1 0 0"/><geom type="sphere" size="0.1"/></body>
    <body pos="0 1 1">
      <joint type="ball"/><geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.05"/>
      <body pos="0 0 -0.4">
        <joint type="hinge" axis="0 1 0" armature="0.01"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 -0.3" size="0.04"/>
        <body pos="0.3 0 -0.3"><joint type="hinge" axis="1 0 0"/>
          <geom type="box" size="0.05 0.1 0.02" pos="0.02 0.03 0"/></body>
      </body>
    </body>
  </worldbody>
</mujoco>)";

mjModel* load_file(const std::string& file) {
  char err[1000] = "";
  mjModel* m = mj_loadXML(file.c_str(), nullptr, err, sizeof(err));
  EXPECT_NE(m, nullptr) << file << ": " << err;
  return m;
}

mjModel* load_text(const char* xml) {
  return load_file(test::write_temp_file("simple_and_chain.xml", xml));
}

// a random pose (unit quaternions) and velocity, the same in a and b
void randomize(const mjModel* m, mjData* a, mjData* b, std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  mj_resetData(m, a);
  for (int i = 0; i < m->nq; ++i) a->qpos[i] += 0.5 * n(rng);
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_type[j] == mjJNT_BALL || m->jnt_type[j] == mjJNT_FREE)
      mju_normalize4(a->qpos + m->jnt_qposadr[j] + (m->jnt_type[j] == mjJNT_FREE ? 3 : 0));
  for (int i = 0; i < m->nv; ++i) a->qvel[i] = 2 * n(rng);
  mj_resetData(m, b);
  std::copy(a->qpos, a->qpos + m->nq, b->qpos);
  std::copy(a->qvel, a->qvel + m->nv, b->qvel);
}

bool same_bits(const mjtNum* x, const mjtNum* y, int n) {
  return std::memcmp(x, y, sizeof(mjtNum) * n) == 0;
}

// from random states, the half-step with the inertia stages inlined gives mj_step1's inertia,
// factor and bias forces to the bit, and the steps after it the same states
void expect_step1_to_the_bit(mjModel* m, int trials) {
  ASSERT_NE(m, nullptr);
  mjData* a = mj_makeData(m);
  mjData* b = mj_makeData(m);
  std::mt19937 rng(11);
  for (int trial = 0; trial < trials; ++trial) {
    randomize(m, a, b, rng);
    for (int k = 0; k < 3; ++k) {
      mj_step1(m, a);
      step_positions_and_velocities(m, b);
      ASSERT_TRUE(same_bits(a->crb, b->crb, 10 * m->nbody)) << "trial " << trial;
      ASSERT_TRUE(same_bits(a->qM, b->qM, m->nM)) << "trial " << trial;
      ASSERT_TRUE(same_bits(a->qLD, b->qLD, m->nM)) << "trial " << trial;
      ASSERT_TRUE(same_bits(a->qLDiagInv, b->qLDiagInv, m->nv)) << "trial " << trial;
      ASSERT_TRUE(same_bits(a->qLDiagSqrtInv, b->qLDiagSqrtInv, m->nv)) << "trial " << trial;
      ASSERT_TRUE(same_bits(a->qfrc_bias, b->qfrc_bias, m->nv)) << "trial " << trial;
      ASSERT_EQ(a->ncon, b->ncon);
      mj_step2(m, a);
      mj_step2(m, b);
    }
    EXPECT_TRUE(same_bits(a->qpos, b->qpos, m->nq)) << "trial " << trial;
    EXPECT_TRUE(same_bits(a->qvel, b->qvel, m->nv)) << "trial " << trial;
  }
  mj_deleteData(a);
  mj_deleteData(b);
  mj_deleteModel(m);
}

TEST(MujocoInertia, TrackedCharacterStepsAsMujocosHalfStepToTheBit) {
  expect_step1_to_the_bit(load_file(test::source_dir() + "/models/synthetic_walk.xml"), 100);
}

TEST(MujocoInertia, HingeRobotStepsAsMujocosHalfStepToTheBit) {
  expect_step1_to_the_bit(load_file(test::source_dir() + "/models/humanoid_pitch_ankles.xml"), 100);
}

TEST(MujocoInertia, SimpleDofsAndArmatureAsMujocosHalfStepToTheBit) {
  mjModel* m = load_text(kSimpleAndChain);
  ASSERT_NE(m, nullptr);
  EXPECT_GT(std::count_if(m->dof_simplenum, m->dof_simplenum + m->nv, [](int s) { return s; }), 0);
  EXPECT_LT(std::count_if(m->dof_simplenum, m->dof_simplenum + m->nv, [](int s) { return s; }),
            m->nv);
  expect_step1_to_the_bit(m, 100);
}

}  // namespace
}  // namespace stance
