#include "viz/recorder.h"

#include <fmt/format.h>
#include <stb/stb_image_write.h>

#include <fcntl.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "motion/bvh_measure.h"
#include "viz/gl_context.h"

namespace stance {

namespace {
// the folder an output file goes in, created if missing; a path that cannot be one is bad input
void make_parent_folder(const std::string& path) {
  std::filesystem::path p(path);
  if (!p.has_parent_path()) return;
  std::error_code ec;
  std::filesystem::create_directories(p.parent_path(), ec);
  if (ec) throw InputError(fmt::format("{}: cannot create its folder ({})", path, ec.message()));
}

// the camera and what is drawn, as the options ask
void apply_view_options(SceneView& view, const RecordOptions& o) {
  if (o.camera) view.options.camera = *o.camera;
  if (o.azimuth_deg && std::isfinite(*o.azimuth_deg)) view.camera().azimuth = *o.azimuth_deg;
  view.options.com = view.options.contacts = view.options.markers = o.debug_draw;
  // the ghost too: its second pose costs a third of a software-rendered frame
  view.options.ghost = o.debug_draw;
}

// a file-axes direction turned as bvh track turns the clip: its up axis to +z
Eigen::Vector3d file_to_z_up(const Eigen::Vector3d& v, char up_axis) {
  if (up_axis != 'y') return v;
  // +90 deg about x (motion/reference_motion.h): y -> z, z -> -y
  return {v.x(), -v.z(), v.y()};
}
}  // namespace

double side_view_azimuth_deg(const Eigen::Vector3d& heading) {
  // the camera looks along d = (cos a, sin a, 0); the picture's right is d x up =
  // (sin a, -cos a, 0), which is to be the heading
  if (heading.head<2>().norm() < 1e-9) return std::nan("");
  return std::atan2(heading.x(), -heading.y()) * 180 / M_PI;
}

double front_view_azimuth_deg(const Eigen::Vector3d& heading) {
  if (heading.head<2>().norm() < 1e-9) return std::nan("");
  return std::atan2(-heading.y(), -heading.x()) * 180 / M_PI;
}

Eigen::Vector3d clip_heading_world(const BvhClip& clip, double scale_to_meters) {
  const BvhCharacterMeasures m = measure_bvh_character(clip, scale_to_meters);
  constexpr double kTravelsM = 0.2;
  Eigen::Vector3d file = m.travel.norm() * m.scale_to_meters > kTravelsM ? m.travel : m.facing;
  Eigen::Vector3d world = file_to_z_up(file, m.up_axis);
  world.z() = 0;
  return world.norm() > 1e-9 ? Eigen::Vector3d(world.normalized()) : Eigen::Vector3d::Zero();
}

void parse_frame_size(const std::string& text, int& width, int& height) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') ||
      w < 16 || h < 16 || w > 7680 || h > 4320)
    throw InputError(
        fmt::format("--size '{}': expected WxH, e.g. 1280x720 (16..7680 x 16..4320)", text));
  width = w;
  height = h;
}

void write_png(const std::string& path, int width, int height, const unsigned char* rgb) {
  make_parent_folder(path);
  // to the hidden temporary, then renamed into place: never half a picture
  const std::filesystem::path tmp = temporary_path_for(path);
  if (!stbi_write_png(tmp.c_str(), width, height, 3, rgb, width * 3)) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw InputError(path + ": cannot write");
  }
  rename_into_place(tmp, path);
}

VideoWriter::VideoWriter(const std::string& path, int width, int height, double fps, bool quick)
    : path_(path),
      tmp_(temporary_path_for(path)),
      frame_bytes_(static_cast<size_t>(width) * height * 3) {
  make_parent_folder(path);
  remove_stale_temporaries(tmp_.parent_path());
  // ffmpeg writes the hidden temporary beside the target, which close() renames into place, so
  // a killed recording never leaves half a video
  std::string input =
      fmt::format("ffmpeg -loglevel error -y -f rawvideo -pix_fmt rgb24 -s {}x{} -r {} -i - ",
                  width, height, fps);
  std::string ext = std::filesystem::path(path).extension().string();
  std::string cmd;
  if (ext == ".gif") {
    // one palette for the whole clip (stats from every frame), dithered; loops forever
    cmd = input + fmt::format(
                      "-filter_complex \"split[a][b];[a]palettegen=stats_mode=full[p];"
                      "[b][p]paletteuse=dither=bayer:bayer_scale=3\" -loop 0 -threads 1 "
                      "-f gif '{}'",
                      tmp_.string());
  } else {
    // one encoder thread and bitexact flags: the same frames give the same file
    cmd = input + fmt::format(
                      "-c:v libx264 -preset {} -crf 20 -pix_fmt yuv420p -threads 1 "
                      "-fflags +bitexact -flags:v +bitexact -movflags +faststart -f mp4 '{}'",
                      quick ? "ultrafast" : "veryfast", tmp_.string());
  }
  pipe_ = popen(cmd.c_str(), "w");
  if (!pipe_) throw EnvironmentError("cannot start ffmpeg (is it installed?)");
  // room for a whole frame or two in the pipe (the default is 64 KiB): write() then returns while
  // ffmpeg encodes the frame before, and the encoding overlaps the simulation; best effort (the
  // system's pipe-max-size caps it)
  fcntl(fileno(pipe_), F_SETPIPE_SZ, static_cast<int>(std::min<size_t>(2 * frame_bytes_, 1 << 20)));
}

VideoWriter::~VideoWriter() {
  if (!pipe_) return;
  pclose(pipe_);
  std::error_code ignored;
  std::filesystem::remove(tmp_, ignored);
}

void VideoWriter::write(const unsigned char* rgb) {
  if (std::fwrite(rgb, 1, frame_bytes_, pipe_) != frame_bytes_)
    throw EnvironmentError("ffmpeg stopped reading frames");
  ++frames_;
}

void VideoWriter::close() {
  if (!pipe_) return;
  int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status != 0) {
    std::error_code ignored;
    std::filesystem::remove(tmp_, ignored);
    throw EnvironmentError(fmt::format("ffmpeg failed writing {} (status {})", path_, status));
  }
  rename_into_place(tmp_, path_);
}

void check_video_options(const RecordOptions& o) {
  if (!(o.fps > 0 && o.fps <= 1000))
    throw InputError(fmt::format("--fps {}: expected 0 < fps <= 1000", o.fps));
  if (!o.video.empty() && (o.width % 2 || o.height % 2))
    throw InputError(fmt::format("--size {}x{}: video sizes must be even", o.width, o.height));
}

VideoRecorder::VideoRecorder(Simulation& run, const RecordOptions& o) : run_(run), options_(o) {
  check_video_options(o);
  const double duration = run.scenario().duration;
  if (!(o.video_start >= 0 && o.video_start < duration))
    throw InputError(
        fmt::format("video start {} s: expected a time in 0..{} s", o.video_start, duration));
  gl_ = std::make_unique<OffscreenGlContext>();
  gl_backend_ = gl_->backend();
  view_ = std::make_unique<SceneView>(run, o.width, o.height, o.scene_look, o.draft_look);
  apply_view_options(*view_, o);
  video_ = std::make_unique<VideoWriter>(o.video, o.width, o.height,
                                         o.playback_fps > 0 ? o.playback_fps : o.fps, o.draft_look);
  // frames at k / fps for video_start <= k / fps < duration
  next_frame_ = std::lround(std::ceil(o.video_start * o.fps - 1e-9));
  end_frame_ = std::lround(std::floor(duration * o.fps + 1e-9));
}

VideoRecorder::~VideoRecorder() = default;

void VideoRecorder::on_start(const Simulation&) {
  render_due_frames();
}

void VideoRecorder::on_step(const Simulation&) {
  render_due_frames();
}

void VideoRecorder::render_due_frames() {
  const Engine& engine = run_.engine();
  // half a step of tolerance: times are sums of the timestep
  const double now = engine.time() + 0.5 * engine.timestep();
  while (next_frame_ < end_frame_ && now >= next_frame_ / options_.fps) {
    view_->update(run_);
    view_->render_offscreen(options_.width, options_.height, rgb_,
                            fmt::format("t = {:.2f} s", engine.time()));
    video_->write(rgb_.data());
    ++next_frame_;
  }
}

void VideoRecorder::on_finish(const Simulation&, const RunResult& result) {
  try {
    if (result.diverged && !rgb_.empty())
      for (; next_frame_ < end_frame_; ++next_frame_) video_->write(rgb_.data());
    video_->close();
    written_ = video_->frames();
  } catch (const std::exception& e) {
    error_ = e.what();
  }
}

RecordResult record_scenario(const LoadedScenario& loaded, const RunOptions& run_options,
                             const RecordOptions& o) {
  if (o.video.empty() && o.screenshot.empty())
    throw InputError("recording: give --record FILE.mp4 and/or --screenshot FILE.png");
  check_video_options(o);

  RecordResult result;
  OffscreenGlContext gl;
  result.gl_backend = gl.backend();
  Simulation run(loaded, run_options);
  SceneView view(run, o.width, o.height, o.scene_look, o.draft_look);
  apply_view_options(view, o);
  Engine& engine = run.engine();
  double duration = run.scenario().duration;
  if (!o.screenshot.empty() && (o.screenshot_time < 0 || o.screenshot_time > duration))
    throw InputError(
        fmt::format("--at {}: expected a time in 0..{} s", o.screenshot_time, duration));

  if (!o.video.empty() && !(o.video_start >= 0 && o.video_start < duration))
    throw InputError(
        fmt::format("video start {} s: expected a time in 0..{} s", o.video_start, duration));
  std::unique_ptr<VideoWriter> ffmpeg;
  if (!o.video.empty())
    ffmpeg = std::make_unique<VideoWriter>(o.video, o.width, o.height,
                                           o.playback_fps > 0 ? o.playback_fps : o.fps);
  // frames at video_start + k / fps until the end
  long first_frame = std::lround(std::ceil(o.video_start * o.fps - 1e-9));
  long frames = o.video.empty() ? 0 : std::lround(std::floor(duration * o.fps + 1e-9));
  double end = o.video.empty() ? o.screenshot_time : duration;
  bool shot_taken = o.screenshot.empty();
  std::vector<unsigned char> rgb;
  double dt = engine.timestep();
  long frame = first_frame;
  // step to each frame's time (half a step of tolerance: times are sums of dt)
  auto reached = [&](double t) { return engine.time() >= t - 0.5 * dt; };
  while (true) {
    if (!shot_taken && reached(o.screenshot_time)) {
      view.update(run);
      view.render_offscreen(o.width, o.height, rgb, fmt::format("t = {:.2f} s", engine.time()));
      write_png(o.screenshot, o.width, o.height, rgb.data());
      shot_taken = true;
    }
    while (frame < frames && reached(frame / o.fps)) {
      view.update(run);
      view.render_offscreen(o.width, o.height, rgb, fmt::format("t = {:.2f} s", engine.time()));
      ffmpeg->write(rgb.data());
      ++frame;
    }
    if ((frame >= frames && shot_taken) || engine.time() >= end + 0.5 * dt) break;
    // as `stance run` does, a recording ends a while after a fall (RunOptions::stop_after_fall_s)
    if (!result.diverged && run.done() && run.progress().fell) {
      result.stopped_after_fall = true;
      if (!shot_taken) {
        view.update(run);
        view.render_offscreen(o.width, o.height, rgb, fmt::format("t = {:.2f} s", engine.time()));
        write_png(o.screenshot, o.width, o.height, rgb.data());
        shot_taken = true;
      }
      break;
    }
    if (result.diverged) {
      // keep the video at its full length: repeat the last frame after a divergence
      ffmpeg->write(rgb.data());
      ++frame;
      continue;
    }
    if (!run.step()) {
      result.diverged = true;
      result.divergence = run.progress().divergence;
      if (rgb.empty()) {
        view.update(run);
        view.render_offscreen(o.width, o.height, rgb);
      }
      if (!shot_taken) {
        write_png(o.screenshot, o.width, o.height, rgb.data());
        shot_taken = true;
      }
      if (!ffmpeg) break;
    }
  }
  if (ffmpeg) ffmpeg->close();
  result.frames = ffmpeg ? ffmpeg->frames() : 0;
  result.sim_time = engine.time();
  if (run.progress().fell) result.fall_time = run.progress().fall_time;
  return result;
}

}  // namespace stance
