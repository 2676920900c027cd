// tracked.bvh in the clip's own frame (issue 43): its first frame's root is where the source's
// is, turned as the source's, in the same units and at the same frame rate, so that it overlays
// the source; export_origin_centred keeps the old output, above the origin and on the ground.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <numbers>

#include "control/mocap_clip.h"
#include "control/mocap_retarget_tracker.h"
#include "control/retarget.h"
#include "engine/world_spec.h"
#include "math/rotations.h"
#include "model/bvh_to_mjcf.h"
#include "motion/clip_conventions.h"
#include "test_support.h"

namespace stance {
namespace {

std::unique_ptr<Engine> engine_of(const std::string& xml) {
  WorldSpec spec;
  spec.models.push_back({xml});
  return make_engine("mujoco", spec);
}

// `clip` tracked kinematically for `seconds` on its own character; the exported clip, read back
BvhClip tracked_bvh(const BvhClip& clip, const std::string& tag, bool origin_centred,
                    double seconds = 0.1) {
  const std::string bvh = test::write_temp_file(tag + ".bvh", format_bvh(clip));
  BvhCharacterOptions o;
  o.reference.first_frame = detect_bvh_first_motion_frame(clip);
  const std::string xml = test::write_temp_file(tag + ".xml", make_bvh_character(clip, o).mjcf);
  MocapRetargetParams p;
  p.bvh = bvh;
  p.mode = "kinematic";
  p.export_bvh = "tracked.bvh";
  p.export_origin_centred = origin_centred;
  std::unique_ptr<Engine> engine = engine_of(xml);
  ControllerContext ctx;
  ctx.duration_s = seconds;
  ctx.scratch_engine = [xml] { return engine_of(xml); };
  MocapRetargetTracker tracker(p, ctx, *engine);
  Eigen::VectorXd q, v;
  EXPECT_TRUE(tracker.initial_state(*engine, q, v));
  engine->set_positions(q);
  engine->set_velocities(v);
  std::unique_ptr<ControllerState> state = tracker.make_state(*engine);
  ControlOutput out;
  out.resize(engine->nv(), engine->nu());
  for (long k = 0; k < std::lround(seconds / engine->timestep()); ++k) {
    engine->forward();
    out.clear();
    tracker.compute(*state, *engine, out);
    engine->set_generalized_forces(out.tau);
    engine->step();
  }
  const auto dir = std::filesystem::temp_directory_path() / "stance_tests" / tag;
  std::filesystem::create_directories(dir);
  tracker.write_outputs(*state, dir.string());
  return read_bvh((dir / "tracked.bvh").string());
}

// the body root's world pose at `frame`, in the file's frame and units
struct RootPose {
  Eigen::Vector3d position;
  Eigen::Quaterniond rotation;
};
RootPose root_pose(const BvhClip& clip, int frame) {
  const MotionSkeleton sk = make_motion_skeleton(clip, {});
  const RootCarriers carriers = root_carriers(clip, sk, frame);
  return {root_chain_translation(clip, sk, frame),
          carriers.rotation * clip.rotation(frame, sk.segments[0].bvh_joint)};
}

// the heading of a rotation about the file's +Y: where it turns the +Z axis, in the ground plane
double heading_deg(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d z = q * Eigen::Vector3d::UnitZ();
  return std::atan2(z.x(), z.z()) * 180 / std::numbers::pi;
}

void expect_overlays(const BvhClip& source, const BvhClip& tracked, double meters_per_unit) {
  EXPECT_EQ(tracked.frame_time_s, source.frame_time_s);
  EXPECT_EQ(detect_bvh_scale_to_meters(tracked), detect_bvh_scale_to_meters(source));
  const int first = detect_bvh_first_motion_frame(source);
  const RootPose want = root_pose(source, first), got = root_pose(tracked, 0);
  EXPECT_LT(meters_per_unit * (got.position - want.position).norm(), 0.01)
      << "source " << want.position.transpose() << ", tracked " << got.position.transpose();
  EXPECT_LT(std::abs(heading_deg(got.rotation) - heading_deg(want.rotation)), 1.0);
  EXPECT_LT(geodesic_angle(got.rotation, want.rotation), std::numbers::pi / 180);
}

// the synthetic walk placed away from the origin and turned, plain and under a moving carrier
// root (Bandai Namco's), and with a leading T-pose: the first tracked frame is the source's
TEST(MocapExport, TrackedBvhOverlaysItsSource) {
  BvhClip away = make_synthetic_walk_clip();
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()));
  for (int f = 0; f < away.frame_count; ++f) {
    away.rotation(f, 0) = yaw * away.rotation(f, 0);
    Eigen::Vector3d& root = away.positions[static_cast<size_t>(f) * away.position_joint_count];
    root = yaw * root + Eigen::Vector3d(-30.5, 9.0, -237.4);
  }
  const std::vector<std::pair<std::string, BvhClip>> clips = {
      {"export_away", away},
      {"export_carried", test::with_carrier_root(away, "joint_Root")},
      {"export_t_posed", test::with_leading_t_pose(away, 1, {0, 95, 0})}};
  for (const auto& [tag, clip] : clips) {
    SCOPED_TRACE(tag);
    const BvhClip source = parse_bvh(format_bvh(clip), tag);
    expect_overlays(source, tracked_bvh(source, tag, false), 0.01);
    // the old output: the root starts above the origin, on the ground
    const BvhClip centred = tracked_bvh(source, tag + "_centred", true);
    const RootPose start = root_pose(centred, 0);
    EXPECT_LT(std::hypot(start.position.x(), start.position.z()), 1e-6);
    EXPECT_GT(std::abs(start.position.y() - root_pose(source, 0).position.y()), 1.0);
  }
}

// mass_walk (CRLF, centimetres, _RIGMESH helpers), where ../shared is present
TEST(MocapExport, MassWalkTrackedBvhOverlaysItsSource) {
  const std::string path = test::shared_bvh("mass_walk.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared";
  const BvhClip source = read_bvh(path);
  expect_overlays(source, tracked_bvh(source, "export_mass_walk", false), 0.01);
}

// a character built from a clip whose rest pose lies along X, each frame rolled 90 deg about its
// bone (Bandai Namco's feet: their rest up is 90 deg off the sole's): levelling its planted feet
// turns each foot by about as little as on the plain clip's character, not by those 90 deg
// (before: the rest up was taken for the sole's)
TEST(MocapExport, PlantedFeetOfARestPoseAlongXStayNearTheClips) {
  const BvhClip plain = make_synthetic_walk_clip();
  const BvhClip along_x =
      parse_bvh(format_bvh(test::with_bones_along_x(
                    test::with_bones_in_position_channels(plain, 1.0), std::numbers::pi / 2)),
                "along_x.bvh");
  auto largest_turn_deg = [](const BvhClip& clip, const std::string& tag) {
    const std::string xml = test::write_temp_file(tag + ".xml", make_bvh_character(clip, {}).mjcf);
    std::unique_ptr<Engine> probe = engine_of(xml);
    const ReferenceMotion reference(clip, make_motion_skeleton(clip, {}), {});
    const MotionSkeleton& sk = reference.skeleton();
    const JointMap map = bvh_character_joint_map(sk, *probe);
    const std::vector<int> feet = {sk.find_segment("LeftFoot"), sk.find_segment("RightFoot")};
    const RetargetedMotion as_is(reference, map, *probe, 0);
    const RetargetedMotion level(reference, map, *probe, 0, feet);
    double largest = 0;
    for (int i = 0; i < static_cast<int>(level.bodies().size()); ++i) {
      if (std::find(feet.begin(), feet.end(), level.bodies()[i].segment) == feet.end()) continue;
      for (int f = 0; f < level.frame_count(); ++f) {
        const double t = f * level.frame_time_s();
        largest = std::max(largest, geodesic_angle(as_is.sample_body_pose(t, i).quat,
                                                   level.sample_body_pose(t, i).quat));
      }
    }
    return largest * 180 / std::numbers::pi;
  };
  const double plain_deg = largest_turn_deg(plain, "level_plain");
  const double along_x_deg = largest_turn_deg(along_x, "level_along_x");
  EXPECT_LT(plain_deg, 30);
  EXPECT_LT(along_x_deg, plain_deg + 10) << "plain " << plain_deg;
}

}  // namespace
}  // namespace stance
