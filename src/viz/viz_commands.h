// The CLI commands that need OpenGL (apps/stance_main.cc calls them when the viewer is built).
// Each returns the process exit code, as in app/commands.h.
#pragma once

#include <string>
#include <vector>

#include "app/commands.h"

namespace stance {

// `stance run SCENARIO --record out.mp4 / --screenshot out.png --at T`
// (the video in the run that writes summary.json and log.csv; the screenshot in one of its own)
int record_command(const RunCommand& cmd);

// `stance bvh track CLIP --record out.mp4`: the tracking run with its video rendered as it goes
int record_track_command(const BvhTrackCommand& cmd, const std::string& video);

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
