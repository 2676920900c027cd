// stance: the command-line front end. Argument parsing only; the work is in the library.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "app/cli_options.h"
#include "app/commands.h"
#include "app/track_batch.h"
#include "app/track_command_line.h"
#include "core/error.h"
#ifdef STANCE_HAVE_VIEWER
#include "viz/viz_commands.h"
#endif

namespace {
// the parse error of a command word that names no command, at any level (`stance rnu`, `stance
// bvh inf`), or of a missing one (`stance bvh`), as one line with the nearest name; false when
// the error is another
bool report_command_word(CLI::App& app, int argc, char** argv) {
  CLI::App* level = &app;
  std::string path;  // "bvh"
  for (int i = 1;; ++i) {
    const auto all = [](CLI::App*) { return true; };
    std::vector<std::string> names;
    CLI::App* next = nullptr;
    for (CLI::App* sub : level->get_subcommands(all)) {
      names.push_back(sub->get_name());
      if (i < argc && sub->check_name(argv[i])) next = sub;
    }
    if (names.empty()) return false;  // the words from here on are arguments
    const std::string help = path.empty() ? "stance --help" : "stance " + path + " --help";
    const std::string prefix = path.empty() ? "" : path + " ";
    if (i >= argc || argv[i][0] == '-') {
      if (i < argc || level->get_require_subcommand_min() == 0) return false;
      std::string list;
      for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
      std::cerr << "error: '" << (path.empty() ? "stance" : "stance " + path)
                << "' needs a command: " << list << " (" << help << " lists them)\n";
      return true;
    }
    if (!next) {
      const std::string word = argv[i];
      const std::string nearest = stance::nearest_name(word, names);
      std::cerr << "error: unknown command '" << prefix << word << "'"
                << (nearest.empty() ? "" : " (did you mean '" + prefix + nearest + "'?)") << " ("
                << help << " lists them)\n";
      return true;
    }
    level = next;
    path = prefix + next->get_name();
  }
}
}  // namespace

namespace {

// every command's options and its CLI::App: filled by the add_*_commands, read by dispatch()
struct Cli {
  stance::RunCommand run;
  stance::ViewCommand view;
  stance::ScreenshotsCommand shots;
  stance::InfoCommand info;
  stance::ConvertCommand convert;
  stance::BvhInfoCommand bvh_info;
  stance::BvhSynthCommand synth;
  stance::BvhRetargetCommand retarget;
  stance::BvhTrackCommandLine track;  // one clip, or several: a folder or a glob
  stance::Bvh2MjcfCommand bvh2mjcf;
  stance::ListCommand list;
  stance::SweepCommand sweep, sweep_gain;
  stance::PushThresholdCommand push_threshold;
  stance::RobustnessCommand robustness;
  stance::TuneCommand tune;
  CLI::App *run_cmd = nullptr, *view_cmd = nullptr, *shots_cmd = nullptr, *info_cmd = nullptr;
  CLI::App *convert_cmd = nullptr, *bvh_cmd = nullptr, *bvh_info_cmd = nullptr;
  CLI::App *bvh_synth_cmd = nullptr, *bvh_synth_run_cmd = nullptr, *bvh_retarget_cmd = nullptr;
  CLI::App *bvh_track_cmd = nullptr, *bvh2mjcf_cmd = nullptr, *list_cmd = nullptr;
  CLI::App *sweep_cmd = nullptr, *sweep_gain_cmd = nullptr, *push_threshold_cmd = nullptr;
  CLI::App *robustness_cmd = nullptr, *tune_cmd = nullptr;
};

// run, view, screenshots, info, convert
void add_run_commands(CLI::App& app, Cli& c) {
  c.run_cmd = app.add_subcommand("run", "run a scenario headless");
  stance::add_cli_options(*c.run_cmd, c.run);
  c.run_cmd->get_option("--check")->excludes("--record")->excludes("--screenshot");
  c.view_cmd = app.add_subcommand("view", "watch, push and tune a scenario in a window");
  stance::add_cli_options(*c.view_cmd, c.view);
  c.shots_cmd = app.add_subcommand("screenshots", "one PNG per scenario (README images)");
  stance::add_cli_options(*c.shots_cmd, c.shots);
  c.info_cmd = app.add_subcommand("info", "model sizes and mass");
  stance::add_cli_options(*c.info_cmd, c.info);
  c.convert_cmd = app.add_subcommand("convert", "translate a DART .skel to MJCF");
  stance::add_cli_options(*c.convert_cmd, c.convert);
}

// bvh info/synth/retarget/track, bvh2mjcf, list
void add_bvh_commands(CLI::App& app, Cli& c) {
  c.bvh_cmd = app.add_subcommand("bvh", "motion-capture files");
  c.bvh_cmd->require_subcommand(1);
  c.bvh_info_cmd = c.bvh_cmd->add_subcommand("info", "frames, joints, channels, orders, units");
  stance::add_cli_options(*c.bvh_info_cmd, c.bvh_info);
  c.bvh_synth_cmd = c.bvh_cmd->add_subcommand("synth-walk", "write the synthetic walking clip");
  stance::add_cli_options(*c.bvh_synth_cmd, c.synth);
  c.bvh_synth_run_cmd =
      c.bvh_cmd->add_subcommand("synth-run", "write the synthetic running clip (a flight phase)");
  stance::add_cli_options(*c.bvh_synth_run_cmd, c.synth);
  c.bvh_retarget_cmd = c.bvh_cmd->add_subcommand(
      "retarget", "a clip mapped onto a model, as a table of its q and v");
  stance::add_cli_options(*c.bvh_retarget_cmd, c.retarget);
  c.bvh_track_cmd = c.bvh_cmd->add_subcommand(
      "track", "track clips in free mode with the sampling planner (no per-clip tuning)");
  stance::add_cli_options(*c.bvh_track_cmd, c.track);

  c.bvh2mjcf_cmd = app.add_subcommand("bvh2mjcf", "a simulated character from a BVH skeleton");
  stance::add_cli_options(*c.bvh2mjcf_cmd, c.bvh2mjcf);

  c.list_cmd = app.add_subcommand("list", "controllers and scenarios; a controller's parameters");
  stance::add_cli_options(*c.list_cmd, c.list);
}

// sweep, sweep-gain, push-threshold, robustness, tune
void add_batch_commands(CLI::App& app, Cli& c) {
  // `sweep`: any key path; `sweep-gain`: the slope walker's hip kp, 2..12, plotted
  c.sweep_gain.options.param = "controllers.0.hip_kp";
  c.sweep_gain.from = 2;
  c.sweep_gain.to = 12;
  c.sweep_gain.plot = true;
  c.sweep_gain.out_dir = "out/sweep_gain";
  c.sweep_cmd = app.add_subcommand("sweep", "run a scenario over a range of one parameter");
  stance::add_cli_options(*c.sweep_cmd, c.sweep);
  c.sweep_gain_cmd =
      app.add_subcommand("sweep-gain", "slope walker bifurcation diagram over hip_kp");
  stance::add_cli_options(*c.sweep_gain_cmd, c.sweep_gain);
  c.push_threshold_cmd = app.add_subcommand(
      "push-threshold", "largest push survived along +axis and -axis, by bisection");
  stance::add_cli_options(*c.push_threshold_cmd, c.push_threshold);
  c.robustness_cmd = app.add_subcommand(
      "robustness", "push thresholds per direction and gait phase, with outcome codes");
  stance::add_cli_options(*c.robustness_cmd, c.robustness);
  c.tune_cmd = app.add_subcommand("tune", "robust search of several parameters of a scenario");
  stance::add_cli_options(*c.tune_cmd, c.tune);
}

// the chosen command's work, after a parse that succeeded
int dispatch(Cli& c) {
  if (*c.run_cmd && (!c.run.record.empty() || !c.run.screenshot.empty())) {
#ifdef STANCE_HAVE_VIEWER
    if (int code = stance::check_run_options(c.run); code != stance::kExitOk) return code;
    return stance::record_command(c.run);
#else
    std::cerr << "error: --record/--screenshot need the viewer build (STANCE_WITH_VIEWER)\n";
    return stance::kExitBadInput;
#endif
  }
  if (*c.run_cmd && !c.run.export_bvh.empty())
    c.run.sets.push_back("controllers.0.export_bvh=" +
                         std::filesystem::absolute(c.run.export_bvh).string());
  if (*c.run_cmd) return stance::run_command(c.run);
  if (*c.view_cmd || *c.shots_cmd) {
#ifdef STANCE_HAVE_VIEWER
    if (*c.view_cmd) return stance::view_command(c.view);
    if (int code = stance::check_screenshots_options(c.shots.dir, c.shots.at);
        code != stance::kExitOk)
      return code;
    if (c.shots.gif)
      return stance::gifs_command(c.shots.dir, c.shots.out,
                                  c.shots_cmd->count("--size") ? c.shots.size : "480x300");
    return stance::screenshots_command(c.shots.dir, c.shots.out, c.shots.at, c.shots.size);
#else
    std::cerr << "error: this stance was built without the viewer (STANCE_WITH_VIEWER)\n";
    return stance::kExitBadInput;
#endif
  }
  if (*c.info_cmd) return stance::info_command(c.info);
  if (*c.convert_cmd) return stance::convert_command(c.convert.input, c.convert.output);
  if (*c.bvh_info_cmd) return stance::bvh_info_command(c.bvh_info.file, c.bvh_info.json);
  if (*c.bvh2mjcf_cmd) return stance::bvh2mjcf_command(c.bvh2mjcf);
  if (*c.bvh_synth_cmd) return stance::bvh_synth_command(c.synth.output, false);
  if (*c.bvh_synth_run_cmd) return stance::bvh_synth_command(c.synth.output, true);
  if (*c.bvh_retarget_cmd) return stance::bvh_retarget_command(c.retarget);
  if (*c.bvh_track_cmd) {
    const stance::BvhTrackBatchCommand& batch = c.track.batch;
    if (stance::is_track_batch(batch.inputs) || batch.resume)
      return stance::bvh_track_batch_command(batch);
    stance::BvhTrackCommand one = batch.track;
    one.bvh = batch.inputs.front();
    if (batch.record.empty() && !batch.view) return stance::bvh_track_command(one);
#ifdef STANCE_HAVE_VIEWER
    if (batch.view) return stance::view_track_command(one, c.track.quit_after_s);
    return stance::record_track_command(one, {.video = batch.record,
                                              .camera = c.track.camera,
                                              .size = c.track.size,
                                              .debug_draw = c.track.debug_draw,
                                              .fps = c.track.fps});
#else
    std::cerr << "error: --record and --view need the viewer build (STANCE_WITH_VIEWER)\n";
    return stance::kExitBadInput;
#endif
  }
  if (*c.list_cmd) return stance::list_command(c.list.what);
  if (*c.sweep_cmd) return stance::sweep_command(c.sweep);
  if (*c.sweep_gain_cmd) return stance::sweep_command(c.sweep_gain);
  if (*c.push_threshold_cmd) return stance::push_threshold_command(c.push_threshold);
  if (*c.robustness_cmd) return stance::robustness_command(c.robustness);
  if (*c.tune_cmd) return stance::tune_command(c.tune);
  return stance::kExitBadInput;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"stance: physics-based biped balance and locomotion control"};
  app.require_subcommand(1);

  Cli c;
  add_run_commands(app, c);
  add_bvh_commands(app, c);
  add_batch_commands(app, c);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version print and exit 0; every other parse error is one line, exit 2
    if (e.get_exit_code() == 0) return app.exit(e);
    if (!report_command_word(app, argc, argv))
      std::cerr << "error: " << e.what() << " (see --help)\n";
    return stance::kExitBadInput;
  }
  return dispatch(c);
}
