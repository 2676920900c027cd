// The CLI commands that need OpenGL (apps/stance_main.cc calls them when the viewer is built).
// Each returns the process exit code, as in app/commands.h.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "app/commands.h"
#include "viz/recorder.h"

namespace stance {

// `stance run SCENARIO --record out.mp4 / --screenshot out.png --at T`
// (the video in the run that writes summary.json and log.csv; the screenshot in one of its own)
int record_command(const RunCommand& cmd);

// the video options of `stance run --record` and `stance bvh track --record`, with their shared
// defaults: small enough that rendering in software (llvmpipe) adds under a third to the run's
// time
struct VideoOptions {
  std::string video;  // .mp4 or .gif
  // side or front: beside or in front of a clip's heading (clip_heading_world), following the
  // root (bvh track only: its default is side); follow: the scenario's camera angles (camera.*),
  // following the root; free: those angles from where the camera starts; empty: the command's
  // default (run: the scenario's camera.mode)
  std::string camera;
  std::string size = "640x360";
  std::string debug_draw = "off";  // on: the COM ball, contacts, markers, planner path, ghost
  double fps = 30;                 // frames per simulated second
};
using TrackVideoOptions = VideoOptions;
// the recording options of that video: the quick look (no shadows, no multisampling, x264's
// quickest preset). clip_heading: where the tracked clip heads (side and front need it; null:
// no clip). Throws InputError naming the option.
RecordOptions video_record_options(const VideoOptions& video,
                                   const std::function<Eigen::Vector3d()>& clip_heading = {});
// the recording options of bvh track's video (the camera from the clip's heading)
RecordOptions track_record_options(const BvhTrackCommand& cmd, const TrackVideoOptions& video);

// `stance bvh track CLIP --record out.mp4`: the tracking run with its video rendered as it goes
int record_track_command(const BvhTrackCommand& cmd, const TrackVideoOptions& video);

// `stance bvh track CLIP --view`: the viewer on the tracking scenario that bvh track writes
// (quit_after_s: as ViewCommand's)
int view_track_command(const BvhTrackCommand& cmd, double quit_after_s = 0);

// `stance view SCENARIO [--engine E]` (ViewCommand is in app/commands.h)
int view_command(const ViewCommand& cmd);

// `stance screenshots [--dir scenarios] [--out docs/img] [--at T]`: one PNG per scenario
int screenshots_command(const std::string& scenario_dir, const std::string& out_dir, double at,
                        const std::string& size);

// `stance screenshots --gif [--dir scenarios] [--out docs/img] [--size 480x300]`: a short
// looping GIF of each seed system (gif_clips()) found in the folder
int gifs_command(const std::string& scenario_dir, const std::string& out_dir,
                 const std::string& size);

// one GIF of the README: a scenario, the simulated time it shows and how fast it plays
struct GifClip {
  const char* scenario;  // file stem in the scenario folder
  double start_s;        // simulated
  double length_s;       // simulated
  double slow_motion;    // playback speed: 1 real time, 0.5 half speed
  const char* caption;
};
const std::vector<GifClip>& gif_clips();

}  // namespace stance
