// `stance bvh track CLIP --record`: the camera stands beside the clip's heading by default (the
// gait seen from the side whichever way the clip walks), and --size gives the video's size.
// `stance run --record` makes its video through the same options, with the same defaults.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <string>

#include "app/commands.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"
#include "test_support.h"
#include "viz/gl_context.h"
#include "viz/recorder.h"
#include "viz/viz_commands.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

fs::path scratch_dir() {
  fs::path d = fs::temp_directory_path() / "stance_track_video_test";
  fs::create_directories(d);
  return d;
}

// the synthetic walk (along +Z, Y-up) written as a file; along_x: the whole clip turned a
// quarter about the up axis, so that it walks and faces along +X
std::string synthetic_walk_file(bool along_x) {
  BvhClip clip = make_synthetic_walk_clip(SyntheticWalkOptions{});
  if (along_x) {
    const Eigen::Quaterniond quarter(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()));
    const BvhJoint& root = clip.joints[0];
    for (int f = 0; f < clip.frame_count; ++f) {
      Eigen::Quaterniond& q = clip.rotations[static_cast<size_t>(f) * clip.joints.size()];
      q = quarter * q;
      Eigen::Vector3d& p = clip.positions[f * clip.position_joint_count + root.position_slot];
      p = quarter * p;
    }
  }
  const fs::path path = scratch_dir() / (along_x ? "walk_x.bvh" : "walk_z.bvh");
  write_bvh(clip, path.string());
  return path.string();
}

// the camera's horizontal viewing direction at MuJoCo azimuth a (deg)
Eigen::Vector3d looking_along(double azimuth_deg) {
  const double a = azimuth_deg * M_PI / 180;
  return {std::cos(a), std::sin(a), 0};
}

TEST(TrackVideoTest, TrackingCameraStandsBesideTheClipsHeading) {
  for (bool along_x : {false, true}) {
    SCOPED_TRACE(along_x ? "walking along +X" : "walking along +Z");
    BvhTrackCommand cmd;
    cmd.bvh = synthetic_walk_file(along_x);
    // Y-up files turn +Z into -y and keep +X as +x (motion/reference_motion.h)
    const Eigen::Vector3d heading = along_x ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, -1, 0);
    EXPECT_TRUE(clip_heading_world(read_bvh(cmd.bvh)).isApprox(heading, 1e-6))
        << clip_heading_world(read_bvh(cmd.bvh)).transpose();

    TrackVideoOptions video;
    video.video = (scratch_dir() / "unused.mp4").string();
    const RecordOptions side = track_record_options(cmd, video);
    ASSERT_TRUE(side.azimuth_deg.has_value());
    const Eigen::Vector3d side_look = looking_along(*side.azimuth_deg);
    // across the path, with the walker going from the left of the picture to the right
    EXPECT_NEAR(side_look.dot(heading), 0, 1e-9);
    EXPECT_NEAR(side_look.cross(Eigen::Vector3d::UnitZ()).dot(heading), 1, 1e-9);
    EXPECT_FALSE(side.debug_draw);

    video.camera = "front";
    const RecordOptions front = track_record_options(cmd, video);
    ASSERT_TRUE(front.azimuth_deg.has_value());
    EXPECT_NEAR(looking_along(*front.azimuth_deg).dot(heading), -1, 1e-9);

    // follow and free keep the scenario's angles
    video.camera = "follow";
    EXPECT_FALSE(track_record_options(cmd, video).azimuth_deg.has_value());
  }
  // the two clips' side cameras differ by the quarter turn between their paths
  BvhTrackCommand z, x;
  z.bvh = synthetic_walk_file(false);
  x.bvh = synthetic_walk_file(true);
  TrackVideoOptions video;
  video.video = (scratch_dir() / "unused.mp4").string();
  EXPECT_NEAR(*track_record_options(z, video).azimuth_deg, 0, 1e-9);
  EXPECT_NEAR(*track_record_options(x, video).azimuth_deg, 90, 1e-9);
}

TEST(TrackVideoTest, TrackVideoOptionsRejectBadValues) {
  BvhTrackCommand cmd;
  cmd.bvh = synthetic_walk_file(false);
  TrackVideoOptions video;
  video.video = (scratch_dir() / "unused.mp4").string();
  video.camera = "top";
  EXPECT_THROW(track_record_options(cmd, video), InputError);
  video.camera = "side";
  video.debug_draw = "maybe";
  EXPECT_THROW(track_record_options(cmd, video), InputError);
  video.debug_draw = "on";
  video.size = "321x240";  // odd: H.264 needs even sizes
  EXPECT_THROW(track_record_options(cmd, video), InputError);
}

TEST(TrackVideoTest, TrackVideoHasTheSizeAskedAndTheSideCamera) {
  try {
    OffscreenGlContext gl;
  } catch (const std::exception& e) {
    GTEST_SKIP() << "no offscreen OpenGL: " << e.what();
  }
  if (!test::have_tool("ffprobe")) GTEST_SKIP() << "no ffprobe";
  BvhTrackCommand cmd;
  cmd.bvh = synthetic_walk_file(true);
  cmd.out_dir = (scratch_dir() / "track").string();
  cmd.duration = 0.2;
  cmd.loop = true;
  cmd.quiet = true;
  // the video is the point here, not the tracking: the planner stays off
  cmd.sets = {"planner.enabled=false"};
  TrackVideoOptions video;
  video.video = (scratch_dir() / "track" / "walk.mp4").string();
  video.size = "320x240";
  ASSERT_EQ(record_track_command(cmd, video), kExitOk);
  const std::string probe = test::run_capture(
      "ffprobe -v error -count_frames -select_streams v:0 "
      "-show_entries stream=width,height,nb_read_frames -of csv=p=0 '" +
      video.video + "'");
  EXPECT_EQ(probe.substr(0, probe.find_last_not_of("\n") + 1), "320,240,6");

  // the recorder draws from the side camera chosen for the clip
  const RecordOptions ro = track_record_options(cmd, video);
  LoadedScenario loaded = load_scenario(cmd.out_dir + "/track.yaml", cmd.sets);
  RunOptions run_options;
  run_options.quiet = true;
  Simulation run(loaded, run_options);
  RecordOptions again = ro;
  again.video = (scratch_dir() / "track" / "again.mp4").string();
  VideoRecorder recorder(run, again);
  EXPECT_NEAR(recorder.camera().azimuth, 90, 1e-6);
  EXPECT_NEAR(recorder.camera().elevation, loaded.scenario.camera.elevation, 1e-6);
}

// ffprobe's "width,height,frames,rate" of a video's first stream
std::string probe_video(const std::string& path) {
  const std::string probe = test::run_capture(
      "ffprobe -v error -count_frames -select_streams v:0 "
      "-show_entries stream=width,height,nb_read_frames,r_frame_rate -of "
      "csv=p=0:nk=1 '" +
      path + "'");
  return probe.substr(0, probe.find_last_not_of("\n") + 1);
}

TEST(TrackVideoTest, RunVideoHasTheTrackVideosDefaults) {
  // one set of options and defaults for both commands: size, fps, the quick look, no debug drawing
  RunCommand run;
  run.record = "run.mp4";
  EXPECT_TRUE(run.size.empty());  // a video's default size: VideoOptions'
  EXPECT_EQ(run.debug_draw, "off");
  const RecordOptions from_run = video_record_options({.video = "run.mp4", .fps = run.fps});
  BvhTrackCommand track;
  track.bvh = synthetic_walk_file(false);
  VideoOptions defaults;
  defaults.video = "track.mp4";
  const RecordOptions from_track = track_record_options(track, defaults);
  EXPECT_EQ(from_run.width, 640);
  EXPECT_EQ(from_run.height, 360);
  EXPECT_EQ(from_track.width, from_run.width);
  EXPECT_EQ(from_track.height, from_run.height);
  EXPECT_EQ(run.fps, defaults.fps);
  EXPECT_EQ(from_track.fps, 30);
  EXPECT_TRUE(from_run.draft_look && from_track.draft_look);
  EXPECT_FALSE(from_run.debug_draw || from_track.debug_draw);
  // a run has no clip to stand beside: side and front are refused, follow and free kept
  EXPECT_THROW(video_record_options({.video = "v.mp4", .camera = "side"}), InputError);
  EXPECT_EQ(video_record_options({.video = "v.mp4", .camera = "free"}).camera, CameraMode::kFree);
  EXPECT_FALSE(video_record_options({.video = "v.mp4"}).camera.has_value());
  EXPECT_TRUE(video_record_options({.video = "v.mp4", .debug_draw = "on"}).debug_draw);

  try {
    OffscreenGlContext gl;
  } catch (const std::exception& e) {
    GTEST_SKIP() << "no offscreen OpenGL: " << e.what();
  }
  if (!test::have_tool("ffprobe")) GTEST_SKIP() << "no ffprobe";
  // `stance run --record` with no video option: 640x360 at 30 frames per simulated second
  run.scenario = test::source_dir() + "/scenarios/pd_hold.yaml";
  run.duration = 0.2;
  run.quiet = true;
  run.out_dir = (scratch_dir() / "run").string();
  run.record = (scratch_dir() / "run" / "run.mp4").string();
  ASSERT_EQ(record_command(run), kExitOk);
  EXPECT_EQ(probe_video(run.record), "640,360,30/1,6");
  run.size = "320x240";
  run.fps = 20;
  ASSERT_EQ(record_command(run), kExitOk);
  EXPECT_EQ(probe_video(run.record), "320,240,20/1,4");
}

}  // namespace
}  // namespace stance
