#include "viz/viz_commands.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>

#include "app/guarded.h"
#include "core/error.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "viz/recorder.h"
#include "viz/viewer.h"

namespace stance {

namespace {
LoadedScenario load_named(const std::string& path, const std::vector<std::string>& sets) {
  LoadedScenario loaded = load_scenario(path, sets);
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(path).stem().string();
  return loaded;
}

std::optional<CameraMode> parse_camera(const std::string& text) {
  if (text.empty()) return std::nullopt;
  if (text == "follow") return CameraMode::kFollow;
  // free: the camera stays where it starts, as a scenario's "fixed"
  if (text == "free" || text == "fixed") return CameraMode::kFree;
  throw InputError(fmt::format("--camera '{}': expected follow or free", text));
}
}  // namespace

int record_command(const RunCommand& cmd) {
  return guarded([&] {
    LoadedScenario loaded = load_named(cmd.scenario, cmd.sets);
    RunOptions opt;
    opt.engine = cmd.engine;
    opt.duration = cmd.duration;
    opt.quiet = true;
    if (cmd.past_fall) opt.stop_after_fall_s = -1;
    for (const auto& p : cmd.pushes) opt.extra_pushes.push_back(parse_push(p));
    RecordOptions ro;
    ro.video = cmd.record;
    ro.screenshot = cmd.screenshot;
    ro.screenshot_time = cmd.screenshot_at;
    ro.fps = cmd.fps;
    parse_frame_size(cmd.size, ro.width, ro.height);
    ro.camera = parse_camera(cmd.camera);
    RecordResult r = record_scenario(loaded, opt, ro);
    if (!cmd.quiet) {
      if (!ro.video.empty())
        std::cout << fmt::format("wrote {}: {} frames at {} fps, {}x{} ({})\n", ro.video, r.frames,
                                 ro.fps, ro.width, ro.height, r.gl_backend);
      if (!ro.screenshot.empty())
        std::cout << fmt::format("wrote {} at t={:.3f} s\n", ro.screenshot, ro.screenshot_time);
      if (r.stopped_after_fall)
        std::cout << fmt::format(
            "fell at t={:.3f} s: the recording ends at {:.3f} s (--past-fall "
            "records to the end)\n",
            *r.fall_time, r.sim_time);
    }
    if (r.diverged) {
      std::cerr << "error: simulation diverged: " << r.divergence << "\n";
      return kExitDiverged;
    }
    return kExitOk;
  });
}

int view_command(const ViewCommand& cmd) {
  return guarded([&] {
    LoadedScenario loaded = load_named(cmd.scenario, cmd.sets);
    ViewerOptions vo;
    vo.engine = cmd.engine;
    vo.width = cmd.width;
    vo.height = cmd.height;
    vo.save_path = cmd.scenario;
    Viewer viewer(loaded, vo);
    viewer.run();
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
