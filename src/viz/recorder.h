// Offscreen recording of a scenario run: MP4 through ffmpeg, or one PNG frame. Needs no display
// (EGL; a hidden GLFW window under Xvfb as the fallback). The physics steps exactly as in
// `stance run`, and frames are taken at fixed simulated times, so the same run gives the same
// frames.
#pragma once

#include <optional>
#include <string>

#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "viz/scene_view.h"

namespace stance {

struct RecordOptions {
  std::string video;           // .mp4 to write; empty: none
  std::string screenshot;      // .png to write; empty: none
  double screenshot_time = 0;  // s, simulated
  double fps = 60;
  int width = 1280;  // even (the H.264 encoder's 4:2:0 chroma needs it)
  int height = 720;
  CameraMode camera = CameraMode::kFollow;
};

struct RecordResult {
  long frames = 0;
  double sim_time = 0;
  bool diverged = false;
  std::string divergence;
  std::optional<double> fall_time;  // s, when the character fell
  bool stopped_after_fall = false;  // ended stop_after_fall_s past the fall, before the end
  std::string gl_backend;           // "egl" or "glfw"
};

// step `loaded` as `stance run` does and write the video and/or screenshot.
// Throws InputError on bad options, EnvironmentError when ffmpeg or OpenGL fail.
RecordResult record_scenario(const LoadedScenario& loaded, const RunOptions& run_options,
                             const RecordOptions& options);

// "1280x720" -> width, height; throws InputError
void parse_frame_size(const std::string& text, int& width, int& height);

// write rgb (dim width*height*3, top row first) as a PNG; throws InputError
void write_png(const std::string& path, int width, int height, const unsigned char* rgb);

}  // namespace stance
