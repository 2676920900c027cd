// Offscreen recording of a scenario run: MP4 through ffmpeg, or one PNG frame. Needs no display
// (EGL; a hidden GLFW window under Xvfb as the fallback). The physics steps exactly as in
// `stance run`, and frames are taken at fixed simulated times, so the same run gives the same
// frames.
#pragma once

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "motion/bvh.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "viz/scene_view.h"

namespace stance {

struct RecordOptions {
  std::string video;           // .mp4 (H.264) or .gif (palette, looping) to write; empty: none
  double video_start = 0;      // s, simulated: the video's first frame (the run starts at 0)
  std::string screenshot;      // .png to write; empty: none
  double screenshot_time = 0;  // s, simulated
  double fps = 60;             // frames per simulated second
  double playback_fps = 0;     // frames per second of the video; 0: fps (real time)
  int width = 1280;            // even (the H.264 encoder's 4:2:0 chroma needs it)
  int height = 720;
  std::optional<CameraMode> camera;  // empty: the scenario's (camera.mode)
  // deg, the camera's azimuth instead of the scenario's (side_view_azimuth_deg); empty: its
  std::optional<double> azimuth_deg;
  bool scene_look = true;  // stance's sky, floor and shadows (viz/scene_look.h)
  // no shadows and no multisampling, and x264's quickest preset: a third of a frame's time in
  // software rendering
  bool draft_look = false;
  // the COM ball, the contacts and their forces, the controllers' markers, the planner's path and
  // the reference's ghost (the pushes are drawn either way)
  bool debug_draw = true;
};

// the azimuth (deg, MuJoCo's: the camera looks along (cos a, sin a, 0)) of a camera beside a
// character heading along `heading` (horizontal, Z-up world), who then goes from the left of
// the picture to the right; NaN for a heading with no horizontal part
double side_view_azimuth_deg(const Eigen::Vector3d& heading);
// the camera in front of that character, looking at its face; NaN as above
double front_view_azimuth_deg(const Eigen::Vector3d& heading);
// where a clip's character heads in the Z-up world that stance tracks it in (unit, horizontal):
// where its root travels from the first motion frame to the last, or, when it stays within
// 0.2 m, where it faces (motion/bvh_measure.h); zero when nothing tells.
// scale_to_meters: 0 detects it
Eigen::Vector3d clip_heading_world(const BvhClip& clip, double scale_to_meters = 0);

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

class OffscreenGlContext;
class VideoWriter;

// the video of the run it observes, rendered as the run goes: a frame at each k / fps of
// simulated time from video_start (RecordOptions' video, fps, size, camera, look; no screenshot).
// Rendering reads the state only, so the run's outputs are those of the run without it. Make it
// after the run's Simulation (it needs one for the scene) and add it as an observer.
class VideoRecorder final : public StepObserver {
 public:
  // throws InputError on bad options, EnvironmentError when ffmpeg or OpenGL fail
  VideoRecorder(Simulation& run, const RecordOptions& options);
  ~VideoRecorder() override;
  void on_start(const Simulation& sim) override;
  void on_step(const Simulation& sim) override;
  // a diverged run's video keeps its full length (the last frame repeated); closes the file.
  // Does not throw (the run's own files are still to be written): see error()
  void on_finish(const Simulation& sim, const RunResult& result) override;
  long frames() const { return written_; }
  const std::string& gl_backend() const { return gl_backend_; }
  // the camera the frames are drawn from (azimuth and elevation in deg, distance in m)
  const mjvCamera& camera() const { return view_->camera(); }
  // why the video could not be finished; empty when it was written
  const std::string& error() const { return error_; }

 private:
  void render_due_frames();

  Simulation& run_;
  RecordOptions options_;
  std::unique_ptr<OffscreenGlContext> gl_;  // made first, outlives the view
  std::unique_ptr<SceneView> view_;
  std::unique_ptr<VideoWriter> video_;
  std::vector<unsigned char> rgb_;
  long next_frame_ = 0, end_frame_ = 0, written_ = 0;
  std::string gl_backend_, error_;
};

// fps and size as a video needs them; throws InputError naming the option
void check_video_options(const RecordOptions& options);

// an ffmpeg process that turns raw rgb frames into a video: H.264 MP4 (yuv420p, bitexact), or
// for a .gif a looping GIF with a palette made from all its frames
class VideoWriter {
 public:
  // throws EnvironmentError when ffmpeg cannot be started, InputError for a bad path.
  // quick: x264's ultrafast preset (a larger file) instead of veryfast
  VideoWriter(const std::string& path, int width, int height, double fps, bool quick = false);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;
  // rgb, dim width*height*3, top row first
  void write(const unsigned char* rgb);
  // waits for ffmpeg to finish the file; throws EnvironmentError when it failed
  void close();
  long frames() const { return frames_; }
  const std::string& path() const { return path_; }

 private:
  FILE* pipe_ = nullptr;
  std::string path_;
  std::filesystem::path tmp_;  // ffmpeg's output, renamed to path_ when complete
  size_t frame_bytes_ = 0;
  long frames_ = 0;
};

// "1280x720" -> width, height; throws InputError
void parse_frame_size(const std::string& text, int& width, int& height);

// write rgb (dim width*height*3, top row first) as a PNG; throws InputError
void write_png(const std::string& path, int width, int height, const unsigned char* rgb);

}  // namespace stance
