#include "viz/viz_commands.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>

#include "app/guarded.h"
#include "core/error.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "viz/recorder.h"
#include "viz/viewer.h"

namespace stance {

namespace {
constexpr const char* kScreenshotSize = "1280x720";  // `run --screenshot` without --size

LoadedScenario load_named(const std::string& path, const std::vector<std::string>& sets) {
  LoadedScenario loaded = load_scenario(path, sets);
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(path).stem().string();
  return loaded;
}

// `run --record`'s video options and `--screenshot`'s: the screenshot keeps the full look and
// a larger default size. Throws InputError
RecordOptions record_options(const RunCommand& cmd) {
  VideoOptions video;
  video.video = cmd.record;
  // "fixed" as a scenario's camera.mode says it
  video.camera = cmd.camera == "fixed" ? "free" : cmd.camera;
  video.debug_draw = cmd.debug_draw;
  video.fps = cmd.fps;
  if (!cmd.size.empty()) video.size = cmd.size;
  RecordOptions ro = video_record_options(video);
  ro.screenshot = cmd.screenshot;
  ro.screenshot_time = cmd.screenshot_at;
  return ro;
}

// runs `run` (run_command or bvh_track_command) with the video rendered as it goes
int run_recorded(const RecordOptions& ro, bool quiet,
                 const std::function<int(const RunObserverMaker&)>& run) {
  std::string error;
  long frames = 0;
  std::string backend;
  // the recorder lives inside the run; what the report needs is copied out as it ends
  struct Reporting final : public StepObserver {
    std::unique_ptr<VideoRecorder> recorder;
    std::string *error, *backend;
    long* frames;
    void on_start(const Simulation& sim) override { recorder->on_start(sim); }
    void on_step(const Simulation& sim) override { recorder->on_step(sim); }
    void on_finish(const Simulation& sim, const RunResult& r) override {
      recorder->on_finish(sim, r);
      *error = recorder->error();
      *frames = recorder->frames();
      *backend = recorder->gl_backend();
    }
  };
  bool finished = false;
  int code = run([&](Simulation& sim) -> std::unique_ptr<StepObserver> {
    auto reporting = std::make_unique<Reporting>();
    reporting->recorder = std::make_unique<VideoRecorder>(sim, ro);
    reporting->error = &error;
    reporting->backend = &backend;
    reporting->frames = &frames;
    finished = true;
    return reporting;
  });
  if (!finished) return code;  // the run never started: its message is out
  if (!error.empty()) {
    std::cerr << "error: " << error << "\n";
    return kExitEnvironment;
  }
  if (!quiet && frames > 0)
    std::cout << fmt::format("wrote {}: {} frames at {} fps, {}x{} ({})\n", ro.video, frames,
                             ro.fps, ro.width, ro.height, backend);
  return code;
}

// the screenshot of `run --screenshot` (a run of its own that stops at --at)
int screenshot_command(const RunCommand& cmd, RecordOptions ro) {
  return guarded([&] {
    LoadedScenario loaded = load_named(cmd.scenario, cmd.sets);
    RunOptions opt;
    opt.engine = cmd.engine;
    opt.duration = cmd.duration;
    opt.quiet = true;
    if (cmd.past_fall) opt.stop_after_fall_s = -1;
    for (const auto& p : cmd.pushes) opt.extra_pushes.push_back(parse_push(p));
    ro.video.clear();
    ro.draft_look = false;  // one frame: the full look costs little
    if (cmd.size.empty()) parse_frame_size(kScreenshotSize, ro.width, ro.height);
    RecordResult r = record_scenario(loaded, opt, ro);
    if (!cmd.quiet)
      std::cout << fmt::format("wrote {} at t={:.3f} s\n", ro.screenshot, ro.screenshot_time);
    if (r.diverged) {
      std::cerr << "error: simulation diverged: " << r.divergence << "\n";
      return kExitDiverged;
    }
    return kExitOk;
  });
}
}  // namespace

int record_command(const RunCommand& cmd) {
  RecordOptions ro;
  if (int code = guarded([&] {
        ro = record_options(cmd);
        return kExitOk;
      });
      code != kExitOk)
    return code;
  if (!ro.video.empty()) {
    int code = run_recorded(
        ro, cmd.quiet, [&](const RunObserverMaker& observe) { return run_command(cmd, observe); });
    if (code != kExitOk || ro.screenshot.empty()) return code;
  }
  return screenshot_command(cmd, ro);
}

RecordOptions video_record_options(const VideoOptions& video,
                                   const std::function<Eigen::Vector3d()>& clip_heading) {
  RecordOptions ro;
  ro.video = video.video;
  ro.fps = video.fps;
  parse_frame_size(video.size, ro.width, ro.height);
  ro.draft_look = true;
  if (video.debug_draw != "on" && video.debug_draw != "off")
    throw InputError(fmt::format("--debug-draw '{}': expected on or off", video.debug_draw));
  ro.debug_draw = video.debug_draw == "on";
  const std::string& camera = video.camera;
  const bool of_clip = camera == "side" || camera == "front";
  if (!of_clip && !camera.empty() && camera != "follow" && camera != "free")
    throw InputError(fmt::format("--camera '{}': expected {}", camera,
                                 clip_heading ? "side, front, follow or free" : "follow or free"));
  if (of_clip && !clip_heading)
    throw InputError(fmt::format(
        "--camera {}: a clip's heading is needed (stance bvh track); expected follow or free",
        camera));
  if (camera == "free") ro.camera = CameraMode::kFree;
  if (camera == "follow" || of_clip) ro.camera = CameraMode::kFollow;
  if (of_clip) {
    const Eigen::Vector3d heading = clip_heading();
    double azimuth =
        camera == "side" ? side_view_azimuth_deg(heading) : front_view_azimuth_deg(heading);
    // a clip that neither travels nor faces anywhere keeps the scenario's angles
    if (std::isfinite(azimuth)) ro.azimuth_deg = azimuth;
  }
  check_video_options(ro);
  return ro;
}

RecordOptions track_record_options(const BvhTrackCommand& cmd, const TrackVideoOptions& video) {
  VideoOptions with_default = video;
  if (with_default.camera.empty()) with_default.camera = "side";
  return video_record_options(
      with_default, [&] { return clip_heading_world(read_bvh(cmd.bvh), cmd.scale_to_meters); });
}

int record_track_command(const BvhTrackCommand& cmd, const TrackVideoOptions& video) {
  RecordOptions ro;
  if (int code = guarded([&] {
        ro = track_record_options(cmd, video);
        return kExitOk;
      });
      code != kExitOk)
    return code;
  return run_recorded(ro, cmd.quiet, [&](const RunObserverMaker& observe) {
    return bvh_track_command(cmd, observe);
  });
}

int view_track_command(const BvhTrackCommand& cmd, double quit_after_s) {
  std::string scenario;
  if (int code = guarded([&] {
        scenario = write_bvh_track_scenario(cmd);
        return kExitOk;
      });
      code != kExitOk)
    return code;
  ViewCommand view;
  view.quit_after_s = quit_after_s;
  view.scenario = scenario;
  view.engine = cmd.engine;
  // the camera beside the clip's heading, as the video's; a --set camera.azimuth comes after
  if (int code = guarded([&] {
        const double azimuth =
            side_view_azimuth_deg(clip_heading_world(read_bvh(cmd.bvh), cmd.scale_to_meters));
        if (std::isfinite(azimuth)) view.sets.push_back(fmt::format("camera.azimuth={}", azimuth));
        return kExitOk;
      });
      code != kExitOk)
    return code;
  view.sets.insert(view.sets.end(), cmd.sets.begin(), cmd.sets.end());
  return view_command(view);
}

int view_command(const ViewCommand& cmd) {
  return guarded([&] {
    LoadedScenario loaded = load_named(cmd.scenario, cmd.sets);
    ViewerOptions vo;
    vo.engine = cmd.engine;
    vo.width = cmd.width;
    vo.height = cmd.height;
    vo.save_path = cmd.scenario;
    vo.quit_after_s = cmd.quit_after_s;
    Viewer viewer(loaded, vo);
    const double sim0 = viewer.sim_time();
    const auto wall0 = std::chrono::steady_clock::now();
    viewer.run();
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    // how the viewer kept pace (bench/): simulated time over wall time
    if (cmd.quit_after_s > 0)
      std::cout << fmt::format(
          "viewed {:.2f} s of wall time: {:.3f} s simulated, {:.3f}x real time\n", wall,
          viewer.sim_time() - sim0, (viewer.sim_time() - sim0) / wall);
    return kExitOk;
  });
}

int screenshots_command(const std::string& scenario_dir, const std::string& out_dir, double at,
                        const std::string& size) {
  return guarded([&] {
    std::vector<std::filesystem::path> files;
    for (const auto& f : std::filesystem::directory_iterator(scenario_dir))
      // skip the viewer's saved "<name>_tuned.yaml" copies
      if (f.path().extension() == ".yaml" && !f.path().stem().string().ends_with("_tuned"))
        files.push_back(f.path());
    std::sort(files.begin(), files.end());
    if (files.empty()) throw InputError("no scenarios in " + scenario_dir);
    for (const auto& f : files) {
      LoadedScenario loaded = load_named(f.string(), {});
      RunOptions opt;
      opt.quiet = true;
      RecordOptions ro;
      parse_frame_size(size, ro.width, ro.height);
      ro.screenshot = (std::filesystem::path(out_dir) / (f.stem().string() + ".png")).string();
      ro.screenshot_time = std::min(at, loaded.scenario.duration);
      RecordResult r = record_scenario(loaded, opt, ro);
      std::cout << fmt::format("wrote {} (t={:.2f} s{})\n", ro.screenshot, ro.screenshot_time,
                               r.diverged ? ", diverged" : "");
    }
    return kExitOk;
  });
}

const std::vector<GifClip>& gif_clips() {
  // a few seconds each: the README's moving pictures stay small
  static const std::vector<GifClip> clips = {
      {"biped_push", 1.7, 1.6, 0.5, "standing biped taking a 50 N push (red arrow), half speed"},
      {"simbicon_walk", 3.0, 3.0, 1.0, "SIMBICON walk, planar biped"},
      {"simbicon_walk_3d", 3.0, 3.0, 1.0, "SIMBICON walk in 3D"},
      {"lqr_noise", 1.0, 3.0, 1.0, "LQR balance under force noise"},
      {"slope_walk", 6.0, 3.0, 1.0, "passive-dynamic walker on a slope"},
      {"mocap_track", 1.0, 3.0, 1.0, "mocap tracking with its reference ghost"},
  };
  return clips;
}

int gifs_command(const std::string& scenario_dir, const std::string& out_dir,
                 const std::string& size) {
  return guarded([&] {
    constexpr double kGifFps = 15;
    int made = 0;
    for (const GifClip& clip : gif_clips()) {
      std::filesystem::path file =
          std::filesystem::path(scenario_dir) / (std::string(clip.scenario) + ".yaml");
      if (!std::filesystem::exists(file)) continue;
      LoadedScenario loaded = load_named(file.string(), {});
      RunOptions opt;
      opt.quiet = true;
      opt.duration = clip.start_s + clip.length_s;
      RecordOptions ro;
      parse_frame_size(size, ro.width, ro.height);
      if (ro.width % 2 || ro.height % 2)
        throw InputError(fmt::format("--size {}: GIF sizes must be even", size));
      ro.video = (std::filesystem::path(out_dir) / (std::string(clip.scenario) + ".gif")).string();
      ro.video_start = clip.start_s;
      ro.playback_fps = kGifFps;
      ro.fps = kGifFps / clip.slow_motion;
      RecordResult r = record_scenario(loaded, opt, ro);
      std::cout << fmt::format("wrote {}: {} frames, {:.1f}..{:.1f} s{}\n", ro.video, r.frames,
                               clip.start_s, r.sim_time, r.diverged ? ", diverged" : "");
      ++made;
    }
    if (made == 0) throw InputError("none of the README's GIF scenarios is in " + scenario_dir);
    return kExitOk;
  });
}

}  // namespace stance
