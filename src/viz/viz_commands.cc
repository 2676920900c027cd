#include "viz/viz_commands.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>

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

CameraMode parse_camera(const std::string& text) {
  if (text == "follow") return CameraMode::kFollow;
  if (text == "free") return CameraMode::kFree;
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

}  // namespace stance
