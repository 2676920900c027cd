// What the viewer and the recorder draw for controllers: SIMBICON's circles (Controller::markers)
// and the tracking ghost's pose (Controller::reference_qpos). No display needed.
#include <gtest/gtest.h>

#include "control/marker.h"
#include "control/mocap_retarget_tracker.h"
#include "control/simbicon.h"
#include "motion/reference_motion.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

const Marker* find_label(const std::vector<Marker>& markers, const std::string& prefix) {
  for (const auto& m : markers)
    if (m.label.rfind(prefix, 0) == 0) return &m;
  return nullptr;
}

TEST(SimbiconMarkers, CirclesOnTheStanceAnkleAndTheHip) {
  Simulation run(load_scenario(test::scenario_path("simbicon_walk.yaml")), test::quiet());
  Engine& e = run.engine();
  const auto& simbicon = dynamic_cast<const Simbicon&>(*run.controllers()[0]);
  const Simbicon::State& state = run.state_as<Simbicon::State>(0);
  // over a few steps, so that both legs take the stance
  bool seen[2] = {false, false};
  while (e.time() < 2.0) {
    ASSERT_TRUE(run.step());
    e.forward();
    std::vector<Marker> markers;
    simbicon.markers(run.controller_state(0), e, markers);
    const int stance = state.fsm < 2 ? Simbicon::kRight : Simbicon::kLeft;
    seen[stance] = true;
    const Marker* ankle = find_label(markers, "stance ankle");
    ASSERT_NE(ankle, nullptr);
    EXPECT_EQ(ankle->shape, Marker::Shape::kCircle);
    // planar: in the sagittal plane (normal y), moved sideways only (along y)
    Eigen::Vector3d foot = e.body_pose(simbicon.model().foot[stance]).pos;
    EXPECT_LT((ankle->pos - foot).head<1>().norm() + std::abs((ankle->pos - foot).z()), 1e-12);
    EXPECT_LT(std::abs(ankle->normal.dot(Eigen::Vector3d::UnitX())), 1e-12);
    EXPECT_GT(ankle->radius, 0);
    // the hip circle sits midway between the hip joints
    const Marker* hip = find_label(markers, "hip");
    ASSERT_NE(hip, nullptr);
    Eigen::Vector3d centre = 0.5 * (e.body_pose(simbicon.model().thigh[0]).pos +
                                    e.body_pose(simbicon.model().thigh[1]).pos);
    EXPECT_LT((hip->pos - centre - (ankle->pos - foot)).norm(), 1e-12);
    // the swing target arrow leaves the hip at the target angle from vertical
    const Marker* arrow = nullptr;
    for (const auto& m : markers)
      if (m.shape == Marker::Shape::kArrow) arrow = &m;
    ASSERT_NE(arrow, nullptr);
    EXPECT_LT((arrow->pos - hip->pos).norm(), 1e-12);
    Eigen::Vector3d dir = (arrow->end - arrow->pos).normalized();
    double th = state.swing_hip_target;
    EXPECT_NEAR(dir.x(), std::sin(th), 1e-9);
    EXPECT_NEAR(dir.z(), -std::cos(th), 1e-9);
    EXPECT_NE(find_label(markers, "swing target"), nullptr);
  }
  EXPECT_TRUE(seen[0] && seen[1]);
}

TEST(MocapMarkers, ReferenceQposIsTheReferenceSample) {
  Simulation run(load_scenario(test::scenario_path("mocap_track.yaml")), test::quiet());
  Engine& e = run.engine();
  const auto* tracker = dynamic_cast<const MocapRetargetTracker*>(run.controllers().at(0).get());
  ASSERT_NE(tracker, nullptr);
  while (e.time() < 0.7) ASSERT_TRUE(run.step());
  Eigen::VectorXd q;
  ASSERT_TRUE(tracker->reference_qpos(run.controller_state(0), e, q));
  ASSERT_EQ(q.size(), e.nq());
  // the identity map's table is the reference: each body where the clip's segment is
  const RetargetedMotion& motion = tracker->motion();
  std::vector<Eigen::Quaterniond> local(motion.bodies().size());
  std::vector<Eigen::Vector3d> pos(motion.bodies().size());
  motion.sample_bodies(e.time(), local, pos);
  auto probe = run.model().make_engine();
  probe->set_positions(q);
  probe->forward();
  for (size_t i = 0; i < motion.bodies().size(); ++i)
    EXPECT_LT((probe->body_pose(motion.bodies()[i].body).pos - pos[i]).norm(), 1e-9)
        << motion.bodies()[i].name;
  // the reference moves on with time: a later sample is another pose
  while (e.time() < 1.0) ASSERT_TRUE(run.step());
  Eigen::VectorXd later;
  tracker->reference_qpos(run.controller_state(0), e, later);
  EXPECT_GT((later - q).norm(), 1e-3);
  // controllers that track no pose offer no reference
  Simulation stand(load_scenario(test::scenario_path("biped_stand.yaml")), test::quiet());
  EXPECT_EQ(stand.controllers().at(0)->as<Tracking>(), nullptr);
}

}  // namespace
}  // namespace stance
