// The CLI's commands, as library functions: apps/stance_main.cc only parses arguments.
// Each returns the process exit code: 0 done (a fall is a result), 2 bad input, 3 simulation
// diverged, 4 (run --check) the scenario's expectation did not hold, 70 internal error (a bug),
// 71 the machine lacks something (memory, display, ffmpeg).
#pragma once

#include <atomic>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "batch/batch_options.h"
#include "params/option_meta.h"

namespace stance {

class Simulation;
class StepObserver;

// makes an observer of a command's one run once its Simulation exists (the recorder:
// viz/viz_commands.h); it watches every step and is gone before the command returns
using RunObserverMaker = std::function<std::unique_ptr<StepObserver>(Simulation&)>;

inline constexpr int kExitOk = 0;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitDiverged = 3;
// `stance run --check`: the scenario's `expect` did not hold (scenario/expectation.h)
inline constexpr int kExitExpectationNotHeld = 4;
inline constexpr int kExitInternalError = 70;  // BSD's EX_SOFTWARE
inline constexpr int kExitEnvironment = 71;    // BSD's EX_OSERR
inline constexpr int kExitInterrupted = 130;   // 128 + SIGINT, as a shell reports it

struct RunCommand {
  std::string scenario;
  std::string engine;
  std::optional<double> duration;
  std::vector<std::string> sets;
  std::vector<std::string> pushes;
  std::string out_dir = "out";
  bool quiet = false;
  bool past_fall = false;  // go on to the end after a fall (default: stop 1 s after it)
  bool check = false;      // exit kExitExpectationNotHeld when the expectation does not hold
  // offscreen recording (src/viz/viz_commands.h): a video and/or one frame at screenshot_at
  std::string record;        // .mp4
  std::string screenshot;    // .png
  double screenshot_at = 0;  // s
  // the video's options, with bvh track --record's defaults (viz/viz_commands.h: VideoOptions)
  double fps = 30;
  std::string size;                // WxH; empty: 640x360 for a video, 1280x720 for a screenshot
  std::string camera;              // follow or free (fixed); empty: the scenario's (camera.mode)
  std::string debug_draw = "off";  // on: COM ball, contacts, markers, planner path, ghost
  // mocap_tracker / mocap_retarget (controllers[0]): write the simulated motion as BVH here
  // (the CLI turns it into the override controllers.0.export_bvh=<absolute path>)
  std::string export_bvh;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("scenario", scenario,
      OptionMeta{.help = "scenario YAML", .names = "scenario", .required = true});
    v("engine", engine, OptionMeta{.help = "mujoco or dart (default: the scenario's)"});
    v("duration", duration, OptionMeta{.help = "simulated seconds", .unit = "s", .min = 0});
    v("sets", sets, OptionMeta{.help = "override a parameter: key.path=value", .names = "--set"});
    v("pushes", pushes,
      OptionMeta{.help = "body,fx,fy,fz,start,duration (repeatable)", .names = "--push"});
    v("out_dir", out_dir,
      OptionMeta{.help = "output folder (summary.json, log.csv)", .names = "--out"});
    v("quiet", quiet, OptionMeta{.help = "no summary on stdout"});
    v("past_fall", past_fall,
      OptionMeta{.help = "go on to the end after a fall (default: stop 1 s after it)"});
    v("record", record, OptionMeta{.help = "render an MP4 offscreen (ffmpeg)"});
    v("screenshot", screenshot, OptionMeta{.help = "render one PNG frame at --at"});
    v("check", check, OptionMeta{.help = "exit 4 when the scenario's expect block does not hold"});
    v("screenshot_at", screenshot_at,
      OptionMeta{.help = "screenshot time, s", .names = "--at", .unit = "s", .min = 0});
    v("fps", fps, OptionMeta{.help = "video frames per simulated second (default 30)", .min = 0});
    v("size", size, OptionMeta{.help = "frame size WxH (default 640x360; a screenshot 1280x720)"});
    v("camera", camera, OptionMeta{.help = "follow or free (default: the scenario's)"});
    v("debug_draw", debug_draw,
      OptionMeta{.help = "on draws the COM, contacts, markers, planner path and reference ghost "
                         "(default off)"});
    v("export_bvh", export_bvh,
      OptionMeta{.help = "mocap_tracker / mocap_retarget: write the simulated motion"});
  }
};
int run_command(const RunCommand& cmd, const RunObserverMaker& observe = {});
// the Simulation run_command runs: the scenario with cmd.sets (named after its file when it has
// no name) and cmd's options; throws InputError. For callers that want the result, not the exit
// code (the Python module's track)
std::unique_ptr<Simulation> make_run_simulation(const RunCommand& cmd,
                                                const std::atomic<bool>* interrupt = nullptr);
// the options' values checked as the parameters they set (--duration as the scenario's
// duration); throws InputError. run_command checks them; the recorder's callers call this first
void check_run_command(const RunCommand& cmd);
// the same, as an exit code (0, or 2 after the one-line message)
int check_run_options(const RunCommand& cmd);
// `stance screenshots`: --at a time >= 0, --dir a folder (0, or 2 after the message)
int check_screenshots_options(const std::string& scenario_dir, double at);

// `stance view SCENARIO [--engine E]`: runs in src/viz (viz/viz_commands.h)
struct ViewCommand {
  std::string scenario;
  std::string engine;
  std::vector<std::string> sets;
  int width = 1400, height = 900;
  double quit_after_s = 0;  // wall s; then prints the simulated time over the wall time

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("scenario", scenario,
      OptionMeta{.help = "scenario YAML", .names = "scenario", .required = true});
    v("engine", engine, OptionMeta{.help = "mujoco or dart (default: the scenario's)"});
    v("quit_after_s", quit_after_s,
      OptionMeta{.help = "close after S s of wall time and print the pace (benchmarks)",
                 .names = "--quit-after",
                 .unit = "s"});
    v("sets", sets, OptionMeta{.help = "override a parameter: key.path=value", .names = "--set"});
  }
};

// `stance screenshots [--dir D] [--out O] [--gif]`: runs in src/viz (viz/viz_commands.h)
struct ScreenshotsCommand {
  std::string dir = "scenarios";
  std::string out = "docs/img";
  double at = 2.0;  // s
  std::string size = "800x500";
  bool gif = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("dir", dir, OptionMeta{.help = "scenario folder"});
    v("out", out, OptionMeta{.help = "image folder"});
    v("at", at, OptionMeta{.help = "simulated time of each picture, s", .unit = "s", .min = 0});
    v("size", size, OptionMeta{.help = "WxH (GIFs: default 480x300)"});
    v("gif", gif, OptionMeta{.help = "short looping GIFs of the seed systems instead"});
  }
};

struct InfoCommand {
  std::string model;
  std::string engine = "mujoco";
  bool json = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("model", model,
      OptionMeta{.help = "MJCF, URDF or SKEL file", .names = "model", .required = true});
    v("engine", engine, OptionMeta{.help = "mujoco or dart"});
    v("json", json, OptionMeta{.help = "print JSON"});
  }
};
int info_command(const InfoCommand& cmd);

// `stance convert IN.skel OUT.xml`
struct ConvertCommand {
  std::string input, output;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("input", input, OptionMeta{.help = ".skel file", .names = "input", .required = true});
    v("output", output,
      OptionMeta{.help = "MJCF file to write", .names = "output", .required = true});
  }
};
int convert_command(const std::string& in_path, const std::string& out_path);

// `stance bvh info FILE [--json]`: bvh_info_text/json, and what the tracker makes of the file:
// the root body and the joints that carry it, and the legs (JSON: root_body, root_carriers,
// legs {left, right: {thigh, foot}})
struct BvhInfoCommand {
  std::string file;
  bool json = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("file", file, OptionMeta{.help = "BVH file", .names = "file", .required = true});
    v("json", json, OptionMeta{.help = "print JSON"});
  }
};
int bvh_info_command(const std::string& path, bool json);

// `stance bvh2mjcf IN.bvh OUT.xml [--mass KG] [--first-frame N] [--timestep S]`: a character
// for the clip (model/bvh_to_mjcf.h) whose "start" keyframe is the clip at first_frame
struct Bvh2MjcfCommand {
  std::string bvh, mjcf;
  double mass_kg = 70;
  int first_frame = 0;  // 0: the first frame of the motion (detect_bvh_first_motion_frame)
  double timestep_s = 0.002;
  double scale_to_meters = 0;  // metres per file unit; 0: detect from the legs
  bool human_limits = false;   // human-like torque limits on the joints (docs/mocap.md)

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("bvh", bvh, OptionMeta{.help = "BVH file", .names = "input", .required = true});
    v("mjcf", mjcf, OptionMeta{.help = "MJCF file to write", .names = "output", .required = true});
    v("mass_kg", mass_kg,
      OptionMeta{.help = "total mass, kg", .names = "--mass", .unit = "kg", .min = 0});
    v("first_frame", first_frame,
      OptionMeta{.help = "frame of the start keyframe (default: after a leading T-pose)",
                 .min = 0});
    v("timestep_s", timestep_s,
      OptionMeta{.help = "simulation timestep, s", .names = "--timestep", .unit = "s", .min = 0});
    v("human_limits", human_limits,
      OptionMeta{.help = "human-like joint torque limits, scaled by --mass (docs/mocap.md)"});
    v("scale_to_meters", scale_to_meters,
      OptionMeta{
          .help = "metres per file unit (default: detected from the legs)", .unit = "m", .min = 0});
  }
};
int bvh2mjcf_command(const Bvh2MjcfCommand& cmd);

// `bvh synth-walk` / `bvh synth-run`: the synthetic clip (run: synthetic_run_options())
struct BvhSynthCommand {
  std::string output;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("output", output,
      OptionMeta{.help = "BVH file to write", .names = "output", .required = true});
  }
};
int bvh_synth_command(const std::string& out_path, bool run);

// `stance bvh retarget IN.bvh --map MAP.yaml --model MODEL OUT.csv`: the clip mapped onto a
// model (control/retarget.h), written as a table of the model's positions and velocities at the
// clip's frame rate, for tools that want a reference in the robot's own coordinates
struct BvhRetargetCommand {
  std::string bvh, map, model, out;
  std::string engine = "mujoco";
  double duration_s = 0;  // > 0 with loop: that long; otherwise one pass of the clip range
  bool loop = false;
  int first_frame = 0;
  int last_frame = -1;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("bvh", bvh, OptionMeta{.help = "BVH file", .names = "input", .required = true});
    v("out", out, OptionMeta{.help = "CSV file to write", .names = "output", .required = true});
    v("map", map, OptionMeta{.help = "YAML joint map", .required = true});
    v("model", model, OptionMeta{.help = "model file (MJCF, URDF, SKEL)", .required = true});
    v("engine", engine, OptionMeta{.help = "mujoco or dart"});
    v("loop", loop, OptionMeta{.help = "repeat the clip for --duration"});
    v("duration_s", duration_s,
      OptionMeta{.help = "seconds to write", .names = "--duration", .unit = "s", .min = 0});
    v("first_frame", first_frame, OptionMeta{.help = "first frame of the range", .min = 0});
    v("last_frame", last_frame, OptionMeta{.help = "last frame (-1: the end)", .min = -1});
  }
};
int bvh_retarget_command(const BvhRetargetCommand& cmd);

// `stance bvh track IN.bvh --out DIR ...`: the clip tracked in free mode with the sampling
// planner, on a character built from the clip (as bvh2mjcf does) or, with a map, on a model.
// Writes DIR/track.yaml (the scenario it runs; DIR/character.xml without a map), then runs it:
// DIR/summary.json, DIR/log.csv and DIR/tracked.bvh (the simulated motion on the clip's skeleton)
struct BvhTrackCommand {
  std::string bvh;
  std::string out_dir = "out/track";
  std::optional<double> duration;  // s; default: the clip range once
  bool loop = false;
  int first_frame = 0;  // 0: the first frame of the motion (detect_bvh_first_motion_frame)
  int last_frame = -1;
  std::string map, model;  // both or neither
  std::string engine = "mujoco";
  int threads = 0;                // rollout threads, 0: every core
  std::vector<std::string> sets;  // overrides on the generated scenario
  bool quiet = false;
  bool origin_centred = false;  // tracked.bvh above the origin, not in the clip's own frame
  double scale_to_meters = 0;   // m per file unit, for the character and the tracker; 0: detect
  bool human_limits = false;    // the character's joints get human torque limits, clamped
};
// writes the scenario (and the character) into cmd.out_dir once all of it has loaded (the clip,
// --set, the model, the engine and the controllers): bad input leaves cmd.out_dir untouched.
// Returns the scenario's path.
std::string write_bvh_track_scenario(const BvhTrackCommand& cmd);
// the run options bvh track uses on that scenario (for the recorder too)
RunCommand bvh_track_run(const BvhTrackCommand& cmd, const std::string& scenario);
int bvh_track_command(const BvhTrackCommand& cmd, const RunObserverMaker& observe = {});

// `stance list [WHAT]`: the registered controllers and the scenarios in a folder (WHAT, default
// scenarios); WHAT "controllers" or a controller type: their parameters with default, unit,
// range and help. Anything else is bad input (exit 2).
struct ListCommand {
  std::string what;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("what", what,
      OptionMeta{
          .help = "a scenario folder (default scenarios), 'controllers' or a controller type: its "
                  "parameters with unit, range and help",
          .names = "what"});
  }
};
int list_command(const std::string& what);

// `stance sweep SCENARIO --param key.path (--from A --to B --steps N | --values a,b,c)`:
// one run per value on `threads` threads; sweep.csv and points.csv in out_dir, and with
// `plot` a PNG of a list metric (default: the first, e.g. steady_step_lengths_m) against it.
// The options that reach the sweep itself are its SweepOptions' fields.
struct SweepCommand {
  SweepOptions options;  // scenario, param, threads, engine, duration, sets
  std::optional<double> from, to;
  int steps = 41;
  std::string values;  // "1,2,3": instead of from/to/steps
  std::string out_dir = "out/sweep";
  std::string resume;  // the folder of an interrupted sweep: its finished runs are kept
  bool plot = false;
  std::string plot_metric;
  bool quiet = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("scenario", options.scenario,
      OptionMeta{.help = "scenario YAML", .names = "scenario", .required = true});
    v("param", options.param, OptionMeta{.help = "key path to sweep, as in --set"});
    v("from", from, OptionMeta{.help = "first value"});
    v("to", to, OptionMeta{.help = "last value"});
    v("steps", steps, OptionMeta{.help = "number of values from..to", .min = 1});
    v("values", values, OptionMeta{.help = "comma-separated values instead of from/to/steps"});
    v("threads", options.threads,
      OptionMeta{.help = "worker threads (default: all cores)", .min = 0});
    v("engine", options.engine, OptionMeta{.help = "mujoco or dart (default: the scenario's)"});
    v("duration", options.duration,
      OptionMeta{.help = "simulated seconds per run", .unit = "s", .min = 0});
    v("sets", options.sets,
      OptionMeta{.help = "override for every run: key.path=value", .names = "--set"});
    v("out_dir", out_dir,
      OptionMeta{.help = "output folder (sweep.csv, points.csv, PNG)", .names = "--out"});
    v("plot", plot,
      OptionMeta{.help = "plot a list metric against the value (gnuplot)",
                 .names = "--plot,!--no-plot"});
    v("plot_metric", plot_metric, OptionMeta{.help = "list metric to plot"});
    v("quiet", quiet, OptionMeta{.help = "no progress lines"});
    v("resume", resume,
      OptionMeta{.help = "finish an interrupted sweep in this folder (same options)"});
  }
};
int sweep_command(const SweepCommand& cmd);

// `stance push-threshold SCENARIO --body B [--axis x|y|z] ...`: the largest push survived along
// +axis and -axis, by bisection (scenario/push_threshold.h)
// The options that reach the bisection itself are its PushThresholdOptions' fields.
struct PushThresholdCommand {
  std::string scenario;
  PushThresholdOptions options;  // body, engine, duration, force, push, point, threads
  std::string axis = "x";
  std::vector<std::string> sets;
  bool quiet = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("scenario", scenario,
      OptionMeta{.help = "scenario YAML", .names = "scenario", .required = true});
    v("body", options.body, OptionMeta{.help = "body to push", .required = true});
    v("axis", axis, OptionMeta{.help = "x, y or z (world)"});
    v("engine", options.engine, OptionMeta{.help = "mujoco or dart"});
    v("duration", options.duration, OptionMeta{.help = "seconds per run", .unit = "s", .min = 0});
    v("sets", sets, OptionMeta{.help = "override: key.path=value", .names = "--set"});
    v("max_force", options.max_force,
      OptionMeta{.help = "largest force tried, N", .names = "--max", .unit = "N"});
    v("push_duration", options.push_duration,
      OptionMeta{.help = "push, s", .names = "--push-duration,--duration-push", .unit = "s"});
    v("point", options.point,
      OptionMeta{.help = "where the push acts: com, origin or x,y,z (body frame, m)"});
    v("at", options.at, OptionMeta{.help = "push start, s", .unit = "s", .min = 0});
    v("tolerance", options.tolerance, OptionMeta{.help = "bracket width, N", .unit = "N"});
    v("threads", options.threads,
      OptionMeta{.help = "2: both directions at once, 1: one after the other"});
    v("quiet", quiet, OptionMeta{.help = "no line per trial"});
  }
};
int push_threshold_command(const PushThresholdCommand& cmd);

// `stance robustness SCENARIO --body B [--directions 8] [--phases 4] ...`: the largest push
// survived per direction and gait phase, with outcome codes (scenario/robustness.h);
// robustness.csv, thresholds.csv, summary.json and robustness.png in out_dir
// The options that reach the map itself are its RobustnessOptions' fields.
struct RobustnessCommand {
  std::string scenario;
  RobustnessOptions options;  // body, directions, phases, pushes, recovery, engine, threads
  std::vector<std::string> sets;
  std::string out_dir = "out/robustness";
  std::string resume;  // the folder of an interrupted run: its finished cells are kept
  bool plot = true;
  bool quiet = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("scenario", scenario,
      OptionMeta{.help = "scenario YAML", .names = "scenario", .required = true});
    v("body", options.body, OptionMeta{.help = "body to push", .required = true});
    v("directions", options.directions,
      OptionMeta{.help = "directions in the horizontal plane", .min = 1});
    v("phases", options.phases,
      OptionMeta{.help = "gait phases (walkers) or push start times (standing)", .min = 1});
    v("push_duration", options.push_duration,
      OptionMeta{.help = "push, s", .names = "--push-duration,--duration-push", .unit = "s"});
    v("max_force", options.max_force,
      OptionMeta{.help = "largest force tried, N", .names = "--max", .unit = "N"});
    v("tolerance", options.tolerance, OptionMeta{.help = "bracket width, N", .unit = "N"});
    v("at", options.at,
      OptionMeta{.help = "s: first push start (standing) or warm-up (walkers)", .unit = "s"});
    v("phase_spacing", options.phase_spacing_s,
      OptionMeta{.help = "s between a standing scenario's push starts", .unit = "s"});
    v("recovery_window", options.recovery_window_s,
      OptionMeta{.help = "s after the push in which steps are counted", .unit = "s"});
    v("max_steps", options.max_recovery_steps,
      OptionMeta{.help = "recovery steps allowed before outcome 3", .min = 0});
    v("point", options.point,
      OptionMeta{.help = "where the push acts: com, origin or x,y,z (body frame, m)"});
    v("engine", options.engine, OptionMeta{.help = "mujoco or dart"});
    v("duration", options.duration, OptionMeta{.help = "seconds per run", .unit = "s", .min = 0});
    v("sets", sets, OptionMeta{.help = "override: key.path=value", .names = "--set"});
    v("threads", options.threads,
      OptionMeta{.help = "worker threads (default: all cores)", .min = 0});
    v("out_dir", out_dir,
      OptionMeta{.help = "output folder (robustness.csv, thresholds.csv, summary.json, PNG)",
                 .names = "--out"});
    v("resume", resume,
      OptionMeta{.help = "finish an interrupted run in this folder (same options)"});
    v("plot", plot, OptionMeta{.help = "the polar plot (gnuplot)", .names = "--plot,!--no-plot"});
    v("quiet", quiet, OptionMeta{.help = "no line per direction and phase"});
  }
};
int robustness_command(const RobustnessCommand& cmd);

// `stance tune SCENARIO --param key=lo:hi[:log] ... [--neighbour "k*=0.85,k2=v" ...]`: a
// robust parameter search (scenario/tune.h); tune.csv, best.yaml and best_scenario.yaml in out_dir
// The options that reach the search itself are its TuneOptions' fields; the parameters and
// neighbours are parsed from their text, the seed checked.
struct TuneCommand {
  TuneOptions options;  // scenario, sets, budget, population, threads, engine, metric, method
  std::vector<std::string> params;      // "key=lo:hi[:log]"
  std::vector<std::string> neighbours;  // "k*=0.85,k2=0.001"
  long long seed = 1;  // >= 0 (signed, so that a negative one is refused, not wrapped)
  std::string out_dir;
  // the folder of an interrupted tune (its tune.partial.json): the search goes on from its last
  // finished generation, into that folder
  std::string resume;
  bool quiet = false;

  // the command-line options, in --help's order (app/cli_options.h)
  template <class V>
  void visit(V& v) {
    v("scenario", options.scenario,
      OptionMeta{.help = "scenario YAML", .names = "scenario", .required = true});
    v("params", params,
      OptionMeta{.help = "searched parameter: key.path=lo:hi[:log]", .names = "--param"});
    v("neighbours", neighbours,
      OptionMeta{.help = "a perturbed run scored too: \"k*=0.85,k2=0.001\" (repeatable)",
                 .names = "--neighbour,--neighbor"});
    v("budget", options.budget, OptionMeta{.help = "candidates in all", .min = 1});
    v("population", options.population, OptionMeta{.help = "candidates per generation", .min = 2});
    v("seed", seed, OptionMeta{.help = "random seed of the search", .min = 0});
    v("threads", options.threads,
      OptionMeta{.help = "worker threads (default: all cores)", .min = 0});
    v("engine", options.engine, OptionMeta{.help = "mujoco or dart (default: the scenario's)"});
    v("duration", options.duration,
      OptionMeta{.help = "simulated seconds per run", .unit = "s", .min = 0});
    v("metric", options.metric,
      OptionMeta{.help = "summary metric added to the score, e.g. mocap.mean_joint_error_deg"});
    v("fall_penalty", options.fall_penalty,
      OptionMeta{.help = "score per second of the duration not stayed up"});
    v("sets", options.sets,
      OptionMeta{.help = "override for every run: key.path=value", .names = "--set"});
    v("method", options.method, OptionMeta{.help = "search: cem (default) or cmaes"});
    v("out_dir", out_dir,
      OptionMeta{.help = "output folder (tune.csv, best.yaml)", .names = "--out"});
    v("resume", resume,
      OptionMeta{.help = "folder of an interrupted tune: go on from its last finished generation"});
    v("quiet", quiet, OptionMeta{.help = "no progress lines"});
  }
};
int tune_command(const TuneCommand& cmd);

}  // namespace stance
