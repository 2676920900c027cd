// stance: the command-line front end. Argument parsing only; the work is in the library.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "app/commands.h"
#include "app/track_batch.h"
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

int main(int argc, char** argv) {
  CLI::App app{"stance: physics-based biped balance and locomotion control"};
  app.require_subcommand(1);

  stance::RunCommand run;
  auto* run_cmd = app.add_subcommand("run", "run a scenario headless");
  run_cmd->add_option("scenario", run.scenario, "scenario YAML")->required();
  run_cmd->add_option("--engine", run.engine, "mujoco or dart (default: the scenario's)");
  run_cmd->add_option("--duration", run.duration, "simulated seconds");
  run_cmd->add_option("--set", run.sets, "override a parameter: key.path=value")
      ->allow_extra_args(false);
  run_cmd->add_option("--push", run.pushes, "body,fx,fy,fz,start,duration (repeatable)")
      ->allow_extra_args(false);
  run_cmd->add_option("--out", run.out_dir, "output folder (summary.json, log.csv)");
  run_cmd->add_flag("--quiet", run.quiet, "no summary on stdout");
  run_cmd->add_flag("--past-fall", run.past_fall,
                    "go on to the end after a fall (default: stop 1 s after it)");
  run_cmd->add_option("--record", run.record, "render an MP4 offscreen (ffmpeg)");
  run_cmd->add_option("--screenshot", run.screenshot, "render one PNG frame at --at");
  run_cmd->add_flag("--check", run.check, "exit 4 when the scenario's expect block does not hold")
      ->excludes("--record")
      ->excludes("--screenshot");
  run_cmd->add_option("--at", run.screenshot_at, "screenshot time, s");
  run_cmd->add_option("--fps", run.fps, "video frames per simulated second");
  run_cmd->add_option("--size", run.size, "frame size WxH");
  run_cmd->add_option("--camera", run.camera, "follow or free (default: the scenario's)");

  stance::ViewCommand view;
  auto* view_cmd = app.add_subcommand("view", "watch, push and tune a scenario in a window");
  view_cmd->add_option("scenario", view.scenario, "scenario YAML")->required();
  view_cmd->add_option("--engine", view.engine, "mujoco or dart (default: the scenario's)");
  view_cmd->add_option("--quit-after", view.quit_after_s,
                       "close after S s of wall time and print the pace (benchmarks)");
  view_cmd->add_option("--set", view.sets, "override a parameter: key.path=value")
      ->allow_extra_args(false);

  std::string shots_dir = "scenarios", shots_out = "docs/img", shots_size = "800x500";
  double shots_at = 2.0;
  auto* shots_cmd = app.add_subcommand("screenshots", "one PNG per scenario (README images)");
  shots_cmd->add_option("--dir", shots_dir, "scenario folder");
  shots_cmd->add_option("--out", shots_out, "image folder");
  shots_cmd->add_option("--at", shots_at, "simulated time of each picture, s");
  shots_cmd->add_option("--size", shots_size, "WxH (GIFs: default 480x300)");
  bool shots_gif = false;
  shots_cmd->add_flag("--gif", shots_gif, "short looping GIFs of the seed systems instead");

  stance::InfoCommand info;
  auto* info_cmd = app.add_subcommand("info", "model sizes and mass");
  info_cmd->add_option("model", info.model, "MJCF, URDF or SKEL file")->required();
  info_cmd->add_option("--engine", info.engine, "mujoco or dart");
  info_cmd->add_flag("--json", info.json, "print JSON");

  std::string convert_in, convert_out;
  auto* convert_cmd = app.add_subcommand("convert", "translate a DART .skel to MJCF");
  convert_cmd->add_option("input", convert_in, ".skel file")->required();
  convert_cmd->add_option("output", convert_out, "MJCF file to write")->required();

  std::string bvh_file;
  bool bvh_json = false;
  auto* bvh_cmd = app.add_subcommand("bvh", "motion-capture files");
  bvh_cmd->require_subcommand(1);
  auto* bvh_info_cmd = bvh_cmd->add_subcommand("info", "frames, joints, channels, orders, units");
  bvh_info_cmd->add_option("file", bvh_file, "BVH file")->required();
  bvh_info_cmd->add_flag("--json", bvh_json, "print JSON");

  std::string synth_out;
  auto* bvh_synth_cmd = bvh_cmd->add_subcommand("synth-walk", "write the synthetic walking clip");
  bvh_synth_cmd->add_option("output", synth_out, "BVH file to write")->required();
  auto* bvh_synth_run_cmd =
      bvh_cmd->add_subcommand("synth-run", "write the synthetic running clip (a flight phase)");
  bvh_synth_run_cmd->add_option("output", synth_out, "BVH file to write")->required();

  stance::BvhRetargetCommand retarget;
  auto* bvh_retarget_cmd =
      bvh_cmd->add_subcommand("retarget", "a clip mapped onto a model, as a table of its q and v");
  bvh_retarget_cmd->add_option("input", retarget.bvh, "BVH file")->required();
  bvh_retarget_cmd->add_option("output", retarget.out, "CSV file to write")->required();
  bvh_retarget_cmd->add_option("--map", retarget.map, "YAML joint map")->required();
  bvh_retarget_cmd->add_option("--model", retarget.model, "model file (MJCF, URDF, SKEL)")
      ->required();
  bvh_retarget_cmd->add_option("--engine", retarget.engine, "mujoco or dart");
  bvh_retarget_cmd->add_flag("--loop", retarget.loop, "repeat the clip for --duration");
  bvh_retarget_cmd->add_option("--duration", retarget.duration_s, "seconds to write");
  bvh_retarget_cmd->add_option("--first-frame", retarget.first_frame, "first frame of the range");
  bvh_retarget_cmd->add_option("--last-frame", retarget.last_frame, "last frame (-1: the end)");
  stance::BvhTrackCommand track;
  std::string track_record;
  stance::BvhTrackBatchCommand track_batch;  // several clips, a folder or a glob
  auto* bvh_track_cmd = bvh_cmd->add_subcommand(
      "track", "track clips in free mode with the sampling planner (no per-clip tuning)");
  bvh_track_cmd
      ->add_option("input", track_batch.inputs,
                   "BVH files, folders or quoted globs (more than one: OUT/<clip>/ each, and "
                   "OUT/results.csv)")
      ->required();
  bvh_track_cmd->add_option("--out", track.out_dir,
                            "output folder (track.yaml, summary.json, log.csv, tracked.bvh)");
  bvh_track_cmd->add_option("--jobs", track_batch.jobs,
                            "several clips: clips at once per process (default: one per thread)");
  bvh_track_cmd->add_flag("--resume", track_batch.resume,
                          "several clips: keep --out's finished clips, track the rest");
  bvh_track_cmd->add_flag("--plot,!--no-plot", track_batch.plot,
                          "several clips: OUT/results.png (gnuplot; default on)");
  bvh_track_cmd->add_option("--duration", track.duration, "seconds (default: the clip once)");
  bvh_track_cmd->add_flag("--loop", track.loop, "repeat the clip, root carried forward");
  bvh_track_cmd->add_option("--first-frame", track.first_frame,
                            "first frame of the range (default: after a leading T-pose)");
  bvh_track_cmd->add_option("--last-frame", track.last_frame, "last frame (-1: the end)");
  bvh_track_cmd->add_option(
      "--map", track.map,
      "YAML joint map onto --model (default: found from its tree, written to --out/map.yaml)");
  bvh_track_cmd->add_option("--model", track.model, "model file (MJCF, URDF, SKEL)");
  bvh_track_cmd->add_option("--engine", track.engine, "mujoco or dart");
  bvh_track_cmd->add_option("--threads", track.threads, "rollout threads (default: all cores)");
  bvh_track_cmd->add_option("--scale-to-meters", track.scale_to_meters,
                            "metres per file unit (default: detected from the legs)");
  bvh_track_cmd->add_option("--set", track.sets, "override: key.path=value")
      ->allow_extra_args(false);
  bvh_track_cmd->add_option("--record", track_record, "also render the run as an MP4");
  std::string track_camera = "side", track_size = "640x360", track_debug_draw = "off";
  bool track_view = false;
  bvh_track_cmd->add_option("--camera", track_camera,
                            "--record: side, front (of the clip's heading), follow or free "
                            "(the scenario's camera.*; default side)");
  bvh_track_cmd->add_option("--size", track_size, "--record: frame size WxH (default 640x360)");
  bvh_track_cmd->add_option("--debug-draw", track_debug_draw,
                            "--record: on draws the COM, contacts, planner path and reference "
                            "ghost (default off)");
  bvh_track_cmd->add_flag("--view", track_view, "watch the tracking run in the viewer instead");
  double track_quit_after = 0;
  bvh_track_cmd->add_option("--quit-after", track_quit_after,
                            "--view: close after S s of wall time and print the pace");
  bvh_track_cmd->add_flag("--quiet", track.quiet, "no summary on stdout");
  bvh_track_cmd->add_flag("--origin-centred", track.origin_centred,
                          "tracked.bvh starts above the origin, on the ground (the default: "
                          "where the clip starts, to overlay it)");

  stance::Bvh2MjcfCommand bvh2mjcf;
  auto* bvh2mjcf_cmd = app.add_subcommand("bvh2mjcf", "a simulated character from a BVH skeleton");
  bvh2mjcf_cmd->add_option("input", bvh2mjcf.bvh, "BVH file")->required();
  bvh2mjcf_cmd->add_option("output", bvh2mjcf.mjcf, "MJCF file to write")->required();
  bvh2mjcf_cmd->add_option("--mass", bvh2mjcf.mass_kg, "total mass, kg");
  bvh2mjcf_cmd->add_option("--first-frame", bvh2mjcf.first_frame,
                           "frame of the start keyframe (default: after a leading T-pose)");
  bvh2mjcf_cmd->add_option("--timestep", bvh2mjcf.timestep_s, "simulation timestep, s");
  bvh2mjcf_cmd->add_flag("--human-limits", bvh2mjcf.human_limits,
                         "human-like joint torque limits, scaled by --mass (docs/mocap.md)");
  bvh2mjcf_cmd->add_option("--scale-to-meters", bvh2mjcf.scale_to_meters,
                           "metres per file unit (default: detected from the legs)");
  // `run --export-bvh`: the mocap_tracker (controllers[0]) writes the simulated motion
  std::string export_bvh;
  run_cmd->add_option("--export-bvh", export_bvh,
                      "mocap_tracker / mocap_retarget: write the simulated motion");

  std::string list_what;
  auto* list_cmd =
      app.add_subcommand("list", "controllers and scenarios; a controller's parameters");
  list_cmd->add_option("what", list_what,
                       "a scenario folder (default scenarios), 'controllers' or a controller "
                       "type: its parameters with unit, range and help");

  // `sweep`: any key path; `sweep-gain`: the slope walker's hip kp, 2..12, plotted
  stance::SweepCommand sweep, sweep_gain;
  sweep_gain.param = "controllers.0.hip_kp";
  sweep_gain.from = 2;
  sweep_gain.to = 12;
  sweep_gain.plot = true;
  sweep_gain.out_dir = "out/sweep_gain";
  auto add_sweep_options = [](CLI::App* c, stance::SweepCommand& s) {
    c->add_option("scenario", s.scenario, "scenario YAML")->required();
    c->add_option("--param", s.param, "key path to sweep, as in --set");
    c->add_option("--from", s.from, "first value");
    c->add_option("--to", s.to, "last value");
    c->add_option("--steps", s.steps, "number of values from..to");
    c->add_option("--values", s.values, "comma-separated values instead of from/to/steps");
    c->add_option("--threads", s.threads, "worker threads (default: all cores)");
    c->add_option("--engine", s.engine, "mujoco or dart (default: the scenario's)");
    c->add_option("--duration", s.duration, "simulated seconds per run");
    c->add_option("--set", s.sets, "override for every run: key.path=value")
        ->allow_extra_args(false);
    c->add_option("--out", s.out_dir, "output folder (sweep.csv, points.csv, PNG)");
    c->add_flag("--plot,!--no-plot", s.plot, "plot a list metric against the value (gnuplot)");
    c->add_option("--plot-metric", s.plot_metric, "list metric to plot");
    c->add_flag("--quiet", s.quiet, "no progress lines");
    c->add_option("--resume", s.resume,
                  "finish an interrupted sweep in this folder (same options)");
  };
  auto* sweep_cmd = app.add_subcommand("sweep", "run a scenario over a range of one parameter");
  add_sweep_options(sweep_cmd, sweep);
  auto* sweep_gain_cmd =
      app.add_subcommand("sweep-gain", "slope walker bifurcation diagram over hip_kp");
  add_sweep_options(sweep_gain_cmd, sweep_gain);

  stance::PushThresholdCommand push_threshold;
  auto* push_threshold_cmd = app.add_subcommand(
      "push-threshold", "largest push survived along +axis and -axis, by bisection");
  push_threshold_cmd->add_option("scenario", push_threshold.scenario, "scenario YAML")->required();
  push_threshold_cmd->add_option("--body", push_threshold.body, "body to push")->required();
  push_threshold_cmd->add_option("--axis", push_threshold.axis, "x, y or z (world)");
  push_threshold_cmd->add_option("--engine", push_threshold.engine, "mujoco or dart");
  push_threshold_cmd->add_option("--duration", push_threshold.duration, "seconds per run");
  push_threshold_cmd->add_option("--set", push_threshold.sets, "override: key.path=value")
      ->allow_extra_args(false);
  push_threshold_cmd->add_option("--max", push_threshold.max_force, "largest force tried, N");
  push_threshold_cmd->add_option("--push-duration,--duration-push", push_threshold.push_duration,
                                 "push, s");
  push_threshold_cmd->add_option("--point", push_threshold.point,
                                 "where the push acts: com, origin or x,y,z (body frame, m)");
  push_threshold_cmd->add_option("--at", push_threshold.at, "push start, s");
  push_threshold_cmd->add_option("--tolerance", push_threshold.tolerance, "bracket width, N");
  push_threshold_cmd->add_option("--threads", push_threshold.threads,
                                 "2: both directions at once, 1: one after the other");
  push_threshold_cmd->add_flag("--quiet", push_threshold.quiet, "no line per trial");

  stance::RobustnessCommand robustness;
  auto* robustness_cmd = app.add_subcommand(
      "robustness", "push thresholds per direction and gait phase, with outcome codes");
  robustness_cmd->add_option("scenario", robustness.scenario, "scenario YAML")->required();
  robustness_cmd->add_option("--body", robustness.body, "body to push")->required();
  robustness_cmd->add_option("--directions", robustness.directions,
                             "directions in the horizontal plane");
  robustness_cmd->add_option("--phases", robustness.phases,
                             "gait phases (walkers) or push start times (standing)");
  robustness_cmd->add_option("--push-duration,--duration-push", robustness.push_duration,
                             "push, s");
  robustness_cmd->add_option("--max", robustness.max_force, "largest force tried, N");
  robustness_cmd->add_option("--tolerance", robustness.tolerance, "bracket width, N");
  robustness_cmd->add_option("--at", robustness.at,
                             "s: first push start (standing) or warm-up (walkers)");
  robustness_cmd->add_option("--phase-spacing", robustness.phase_spacing,
                             "s between a standing scenario's push starts");
  robustness_cmd->add_option("--recovery-window", robustness.recovery_window,
                             "s after the push in which steps are counted");
  robustness_cmd->add_option("--max-steps", robustness.max_steps,
                             "recovery steps allowed before outcome 3");
  robustness_cmd->add_option("--point", robustness.point,
                             "where the push acts: com, origin or x,y,z (body frame, m)");
  robustness_cmd->add_option("--engine", robustness.engine, "mujoco or dart");
  robustness_cmd->add_option("--duration", robustness.duration, "seconds per run");
  robustness_cmd->add_option("--set", robustness.sets, "override: key.path=value")
      ->allow_extra_args(false);
  robustness_cmd->add_option("--threads", robustness.threads,
                             "worker threads (default: all cores)");
  robustness_cmd->add_option("--out", robustness.out_dir,
                             "output folder (robustness.csv, thresholds.csv, summary.json, PNG)");
  robustness_cmd->add_option("--resume", robustness.resume,
                             "finish an interrupted run in this folder (same options)");
  robustness_cmd->add_flag("--plot,!--no-plot", robustness.plot, "the polar plot (gnuplot)");
  robustness_cmd->add_flag("--quiet", robustness.quiet, "no line per direction and phase");

  stance::TuneCommand tune;
  auto* tune_cmd = app.add_subcommand("tune", "robust search of several parameters of a scenario");
  tune_cmd->add_option("scenario", tune.scenario, "scenario YAML")->required();
  tune_cmd->add_option("--param", tune.params, "searched parameter: key.path=lo:hi[:log]")
      ->allow_extra_args(false);
  tune_cmd
      ->add_option("--neighbour,--neighbor", tune.neighbours,
                   "a perturbed run scored too: \"k*=0.85,k2=0.001\" (repeatable)")
      ->allow_extra_args(false);
  tune_cmd->add_option("--budget", tune.budget, "candidates in all");
  tune_cmd->add_option("--population", tune.population, "candidates per generation");
  tune_cmd->add_option("--seed", tune.seed, "random seed of the search");
  tune_cmd->add_option("--threads", tune.threads, "worker threads (default: all cores)");
  tune_cmd->add_option("--engine", tune.engine, "mujoco or dart (default: the scenario's)");
  tune_cmd->add_option("--duration", tune.duration, "simulated seconds per run");
  tune_cmd->add_option("--metric", tune.metric,
                       "summary metric added to the score, e.g. mocap.mean_joint_error_deg");
  tune_cmd->add_option("--fall-penalty", tune.fall_penalty,
                       "score per second of the duration not stayed up");
  tune_cmd->add_option("--set", tune.sets, "override for every run: key.path=value")
      ->allow_extra_args(false);
  tune_cmd->add_option("--method", tune.method, "search: cem (default) or cmaes");
  tune_cmd->add_option("--out", tune.out_dir, "output folder (tune.csv, best.yaml)");
  tune_cmd->add_option("--resume", tune.resume,
                       "folder of an interrupted tune: go on from its last finished generation");
  tune_cmd->add_flag("--quiet", tune.quiet, "no progress lines");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version print and exit 0; every other parse error is one line, exit 2
    if (e.get_exit_code() == 0) return app.exit(e);
    if (!report_command_word(app, argc, argv))
      std::cerr << "error: " << e.what() << " (see --help)\n";
    return stance::kExitBadInput;
  }
  if (*run_cmd && (!run.record.empty() || !run.screenshot.empty())) {
#ifdef STANCE_HAVE_VIEWER
    if (int code = stance::check_run_options(run); code != stance::kExitOk) return code;
    return stance::record_command(run);
#else
    std::cerr << "error: --record/--screenshot need the viewer build (STANCE_WITH_VIEWER)\n";
    return stance::kExitBadInput;
#endif
  }
  if (*run_cmd && !export_bvh.empty())
    run.sets.push_back("controllers.0.export_bvh=" +
                       std::filesystem::absolute(export_bvh).string());
  if (*run_cmd) return stance::run_command(run);
  if (*view_cmd || *shots_cmd) {
#ifdef STANCE_HAVE_VIEWER
    if (*view_cmd) return stance::view_command(view);
    if (int code = stance::check_screenshots_options(shots_dir, shots_at); code != stance::kExitOk)
      return code;
    if (shots_gif)
      return stance::gifs_command(shots_dir, shots_out,
                                  shots_cmd->count("--size") ? shots_size : "480x300");
    return stance::screenshots_command(shots_dir, shots_out, shots_at, shots_size);
#else
    std::cerr << "error: this stance was built without the viewer (STANCE_WITH_VIEWER)\n";
    return stance::kExitBadInput;
#endif
  }
  if (*info_cmd) return stance::info_command(info);
  if (*convert_cmd) return stance::convert_command(convert_in, convert_out);
  if (*bvh_info_cmd) return stance::bvh_info_command(bvh_file, bvh_json);
  if (*bvh2mjcf_cmd) return stance::bvh2mjcf_command(bvh2mjcf);
  if (*bvh_synth_cmd) return stance::bvh_synth_command(synth_out, false);
  if (*bvh_synth_run_cmd) return stance::bvh_synth_command(synth_out, true);
  if (*bvh_retarget_cmd) return stance::bvh_retarget_command(retarget);
  if (*bvh_track_cmd) {
    if (stance::is_track_batch(track_batch.inputs) || track_batch.resume) {
      track_batch.track = track;
      track_batch.record = track_record;
      track_batch.view = track_view;
      return stance::bvh_track_batch_command(track_batch);
    }
    track.bvh = track_batch.inputs.front();
    if (track_record.empty() && !track_view) return stance::bvh_track_command(track);
#ifdef STANCE_HAVE_VIEWER
    if (track_view) return stance::view_track_command(track, track_quit_after);
    return stance::record_track_command(track, {.video = track_record,
                                                .camera = track_camera,
                                                .size = track_size,
                                                .debug_draw = track_debug_draw});
#else
    std::cerr << "error: --record and --view need the viewer build (STANCE_WITH_VIEWER)\n";
    return stance::kExitBadInput;
#endif
  }
  if (*list_cmd) return stance::list_command(list_what);
  if (*sweep_cmd) return stance::sweep_command(sweep);
  if (*sweep_gain_cmd) return stance::sweep_command(sweep_gain);
  if (*push_threshold_cmd) return stance::push_threshold_command(push_threshold);
  if (*robustness_cmd) return stance::robustness_command(robustness);
  if (*tune_cmd) return stance::tune_command(tune);
  return stance::kExitBadInput;
}
