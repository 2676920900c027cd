#include "app/commands.h"
#include "app/guarded.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>

#include "control/auto_joint_map.h"
#include "control/controller.h"
#include "control/mocap_clip.h"
#include "control/mocap_retarget_tracker.h"
#include "control/retarget.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/model_format.h"
#include "core/text_check.h"
#include "core/timestep.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/bvh_to_mjcf.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "model/skel_to_mjcf.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"
#include "params/option_check.h"
#include "scenario/batch_ranks.h"
#include "scenario/push_threshold.h"
#include "scenario/robustness.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "scenario/sweep.h"
#include "scenario/tune.h"

namespace stance {

namespace {
std::atomic<bool> g_interrupt{false};

extern "C" void request_interrupt(int) {
  g_interrupt.store(true);
}

// while a run writes its outputs, SIGINT and SIGTERM end it cleanly: the log is flushed and
// summary.json says "interrupted": true. The handler is reset on its first call, so a second
// Ctrl-C kills at once.
class InterruptHandler {
 public:
  InterruptHandler() {
    g_interrupt.store(false);
    struct sigaction sa {};
    sa.sa_handler = request_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptHandler() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};
}  // namespace

// the ranges of the numeric options: those of the parameters they set, where there is one
namespace {
ParamMeta duration_range() {
  return param_meta<Scenario>("duration");
}
ParamMeta threads_range() {
  return param_meta<PlannerParams>("threads");
}
constexpr ParamMeta kFirstFrameRange{.min = 0};
constexpr ParamMeta kLastFrameRange{.min = -1};  // -1: the clip's end
constexpr ParamMeta kTimeRange{.min = 0};        // s from the start of a run
constexpr ParamMeta kScaleRange{.min = 0};       // m per file unit; 0: detected from the legs

// a resume file's JSON, its nesting bounded while it is parsed: nlohmann's dump and comparisons
// recurse once per level, so a file nested 100,000 deep would overflow the stack
nlohmann::json parse_resume_json(std::istream& in, const std::string& path) {
  constexpr int kMaxDepth = 64;
  return nlohmann::json::parse(in, [&](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
    if (depth > kMaxDepth)
      throw InputError(fmt::format("{}: nested more than {} deep: not a resume file of stance",
                                   path, kMaxDepth));
    return true;
  });
}

// a file name that goes into JSON (a resume file's options, a name made from it) must be UTF-8,
// as JSON is
void check_utf8_file_name(const std::string& path) {
  const size_t bad = invalid_utf8_offset(path);
  if (bad == std::string::npos) return;
  throw InputError(
      fmt::format("{}: the file name is not UTF-8 (byte 0x{:02X} at character {}): "
                  "rename the file",
                  printable_text(path), static_cast<unsigned char>(path[bad]), bad + 1));
}
}  // namespace

void check_run_command(const RunCommand& cmd) {
  check_option_number("--duration", cmd.duration, duration_range());
  check_option_number("--at", cmd.screenshot_at, kTimeRange);
}

int check_run_options(const RunCommand& cmd) {
  return guarded([&] {
    check_run_command(cmd);
    return kExitOk;
  });
}

int check_screenshots_options(const std::string& scenario_dir, double at) {
  return guarded([&] {
    check_option_number("--at", at, kTimeRange);
    if (!std::filesystem::is_directory(scenario_dir))
      throw InputError(fmt::format("--dir {}: no such folder", scenario_dir));
    return kExitOk;
  });
}

std::unique_ptr<Simulation> make_run_simulation(const RunCommand& cmd) {
  check_run_command(cmd);
  LoadedScenario loaded = load_scenario(cmd.scenario, cmd.sets);
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(cmd.scenario).stem().string();
  RunOptions opt;
  opt.engine = cmd.engine;
  opt.duration = cmd.duration;
  opt.out_dir = cmd.out_dir;
  opt.quiet = cmd.quiet;
  opt.progress = !cmd.quiet;
  if (cmd.past_fall) opt.stop_after_fall_s = -1;
  for (const auto& p : cmd.pushes) opt.extra_pushes.push_back(parse_push(p));
  opt.interrupt = &g_interrupt;
  opt.check_expect_names = true;
  if (cmd.check && !loaded.scenario.expect.given)
    throw InputError(cmd.scenario + ": --check: the scenario has no 'expect' block to check");
  return std::make_unique<Simulation>(loaded, opt);
}

int run_command(const RunCommand& cmd, const RunObserverMaker& observe) {
  return guarded([&] {
    const std::unique_ptr<Simulation> simulation = make_run_simulation(cmd);
    Simulation& run = *simulation;
    std::unique_ptr<StepObserver> observer = observe ? observe(run) : nullptr;
    if (observer) run.add_observer(observer.get());
    InterruptHandler interrupt_handler;
    RunResult r = run.run();
    if (!cmd.quiet) {
      std::cout << fmt::format(
          "{} on {}: {:.3f} s simulated in {:.3f} s wall ({:.1f}x real time)\n", r.scenario,
          r.engine, r.sim_time, r.wall_time_s,
          r.wall_time_s > 0 ? r.sim_time / r.wall_time_s : 0.0);
      if (r.diverged)
        std::cout << "  DIVERGED: " << r.divergence << "\n";
      else if (r.fell)
        std::cout << fmt::format("  fell at t={:.3f} s: {}\n", *r.fall_time, r.fall_reason);
      else
        std::cout << "  did not fall\n";
      for (auto it = r.metrics.begin(); it != r.metrics.end(); ++it)
        std::cout << "  " << it.key() << ": " << it.value().dump() << "\n";
      if (!cmd.out_dir.empty())
        std::cout << "  wrote " << (std::filesystem::path(cmd.out_dir) / "summary.json").string()
                  << " and log.csv\n";
    }
    // one line: on stderr when --check turns a miss into the exit code
    const bool missed = !r.expectation.is_null() && !r.expectation.at("held").get<bool>();
    if (cmd.check && missed)
      std::cerr << expectation_line(r.expectation) << "\n";
    else if (!cmd.quiet && !r.expectation.is_null())
      std::cout << "  " << expectation_line(r.expectation) << "\n";
    if (r.diverged) {
      std::cerr << "error: simulation diverged: " << r.divergence << "\n";
      return kExitDiverged;
    }
    if (r.interrupted) {
      std::cerr << fmt::format("interrupted at t={:.6f} s{}\n", r.sim_time,
                               cmd.out_dir.empty() ? "" : "; summary.json and log.csv written");
      return kExitInterrupted;
    }
    if (cmd.check && missed) return kExitExpectationNotHeld;
    return kExitOk;
  });
}

int info_command(const InfoCommand& cmd) {
  return guarded([&] {
    WorldSpec spec;
    spec.models.push_back({cmd.model, Eigen::Vector3d::Zero()});
    std::unique_ptr<Engine> e = make_engine(cmd.engine, spec);
    nlohmann::json j;
    j["nbody"] = e->nbody();
    j["nq"] = e->nq();
    j["nv"] = e->nv();
    j["nu"] = e->nu();
    j["mass"] = e->total_mass();
    if (cmd.json) {
      std::cout << j.dump() << "\n";
    } else {
      std::cout << fmt::format("{} on {}: {} mobile bodies, nq {}, nv {}, nu {}, mass {:.6f} kg\n",
                               cmd.model, cmd.engine, e->nbody(), e->nq(), e->nv(), e->nu(),
                               e->total_mass());
      std::cout << "dofs:";
      for (int i = 0; i < e->nv(); ++i) std::cout << ' ' << e->dof_name(i);
      std::cout << "\nbodies:";
      for (int i = 0; i < e->nbody(); ++i) std::cout << ' ' << e->body_name(i);
      std::cout << "\n";
    }
    return kExitOk;
  });
}

int convert_command(const std::string& in_path, const std::string& out_path) {
  return guarded([&] {
    write_mjcf_file(in_path, out_path);
    std::cout << "wrote " << out_path << "\n";
    return kExitOk;
  });
}

int bvh_info_command(const std::string& path, bool json) {
  return guarded([&] {
    BvhClip clip = read_bvh(path);
    // what the tracker makes of it: the root body (and the joints that carry it) and the legs
    const MotionSkeleton sk = make_motion_skeleton(clip, {});
    int hip[2], foot[2];
    find_mocap_legs(sk, {"", "", "", ""}, hip, foot);
    auto name = [&](int k) { return k >= 0 ? sk.segments[k].name : std::string("-"); };
    std::vector<std::string> carriers;
    for (size_t i = 0; i + 1 < sk.segments[0].rotation_chain.size(); ++i)
      carriers.push_back(clip.joints[sk.segments[0].rotation_chain[i]].name);
    if (json) {
      nlohmann::json info = bvh_info_json(clip);
      info["root_body"] = sk.segments[0].name;
      info["root_carriers"] = carriers;
      info["legs"] = {{"left", {{"thigh", name(hip[0])}, {"foot", name(foot[0])}}},
                      {"right", {{"thigh", name(hip[1])}, {"foot", name(foot[1])}}}};
      std::cout << info.dump(2) << "\n";
    } else {
      std::cout << bvh_info_text(clip);
      std::cout << fmt::format(
          "root body:   {}{}\n", sk.segments[0].name,
          carriers.empty() ? "" : fmt::format(" (carried by {})", fmt::join(carriers, ", ")));
      std::cout << fmt::format("legs:        left {} .. {}, right {} .. {}\n", name(hip[0]),
                               name(foot[0]), name(hip[1]), name(foot[1]));
    }
    return kExitOk;
  });
}

int bvh2mjcf_command(const Bvh2MjcfCommand& cmd) {
  return guarded([&] {
    if (const std::string problem = timestep_problem(cmd.timestep_s); !problem.empty())
      throw InputError("--timestep: " + problem);
    check_option_number("--first-frame", cmd.first_frame, kFirstFrameRange);
    BvhCharacterOptions o;
    o.total_mass_kg = cmd.mass_kg;
    o.timestep_s = cmd.timestep_s;
    o.human_limits = cmd.human_limits;
    check_option_number("--scale-to-meters", cmd.scale_to_meters, kScaleRange);
    o.skeleton.scale_to_meters = cmd.scale_to_meters;
    BvhClip clip = read_bvh(cmd.bvh);
    o.reference.first_frame =
        cmd.first_frame > 0 ? cmd.first_frame : detect_bvh_first_motion_frame(clip);
    BvhCharacter ch = make_bvh_character(clip, o);
    write_file_atomically(cmd.mjcf, ch.mjcf);
    std::cout << fmt::format("wrote {}: {} bodies, {:.6g} kg, {:.6g} m per file unit\n", cmd.mjcf,
                             ch.skeleton.segment_count(), cmd.mass_kg, ch.skeleton.scale_to_meters);
    for (const std::string& w : ch.skeleton.warnings) std::cerr << "warning: " << w << "\n";
    return kExitOk;
  });
}

// the names of q's coordinates in the engine's layout, and of v's
std::vector<std::string> position_names(const Engine& engine) {
  std::vector<std::string> names(engine.nq());
  for (int j = 0; j < engine.njoint(); ++j) {
    const JointInfo& info = engine.joint(j);
    std::vector<std::string> parts;
    if (info.nq == 7) parts = {"pos_x", "pos_y", "pos_z", "qw", "qx", "qy", "qz"};  // MuJoCo free
    if (info.nq == 6) parts = {"rot_x", "rot_y", "rot_z", "pos_x", "pos_y", "pos_z"};  // DART free
    if (info.nq == 4) parts = {"qw", "qx", "qy", "qz"};  // MuJoCo ball
    if (info.nq == 3) parts = {"x", "y", "z"};           // DART ball
    if (info.nq == 1) {
      names[info.qpos_adr] = info.name;
      continue;
    }
    for (size_t k = 0; k < parts.size(); ++k) names[info.qpos_adr + k] = info.name + "_" + parts[k];
  }
  return names;
}

int bvh_retarget_command(const BvhRetargetCommand& cmd) {
  return guarded([&] {
    check_option_number("--duration", cmd.duration_s, duration_range());
    check_option_number("--first-frame", cmd.first_frame, kFirstFrameRange);
    check_option_number("--last-frame", cmd.last_frame, kLastFrameRange);
    MocapClipParams clip_params;
    clip_params.bvh = cmd.bvh;
    clip_params.loop = cmd.loop;
    clip_params.first_frame = cmd.first_frame;
    clip_params.last_frame = cmd.last_frame;
    MocapClip clip = load_mocap_clip(clip_params, "");
    JointMap map = read_joint_map(cmd.map);
    WorldSpec spec;
    spec.models.push_back({cmd.model});
    std::unique_ptr<Engine> engine = make_engine(cmd.engine, spec);
    RetargetedMotion motion(*clip.reference, map, *engine, cmd.loop ? cmd.duration_s : 0);
    const int frames = cmd.loop || cmd.duration_s <= 0
                           ? motion.frame_count()
                           : std::min(motion.frame_count(),
                                      static_cast<int>(cmd.duration_s / motion.frame_time_s()) + 1);
    // written beside the target and renamed into place: a failed run leaves the old file whole
    {
      AtomicFile file(cmd.out);
      std::ostream& f = file.stream();
      f << "time";
      for (const auto& n : position_names(*engine)) f << ',' << n;
      for (int i = 0; i < engine->nv(); ++i) f << ",v_" << engine->dof_name(i);
      f << '\n';
      Eigen::VectorXd q(engine->nq()), v(engine->nv()), scratch(engine->nv());
      for (int fr = 0; fr < frames; ++fr) {
        const double t = fr * motion.frame_time_s();
        motion.sample(*engine, t, q, v, scratch);
        f << fmt::format("{:.9g}", t);
        for (int i = 0; i < q.size(); ++i) f << fmt::format(",{:.9g}", q[i]);
        for (int i = 0; i < v.size(); ++i) f << fmt::format(",{:.9g}", v[i]);
        f << '\n';
      }
      file.commit();
    }
    std::cout << fmt::format(
        "wrote {}: {} frames at {:.6g} Hz, {} positions and {} velocities per row; yaw {:.1f} "
        "deg, scale {:.4g}, height offset {:.4g} m, fit error {:.2f} deg mean\n",
        cmd.out, frames, 1 / motion.frame_time_s(), engine->nq(), engine->nv(),
        motion.yaw_rad() * 180 / std::numbers::pi, motion.scale(), motion.height_offset_m(),
        motion.mean_fit_error_deg());
    return kExitOk;
  });
}

namespace {

// bvh track's scenario text and, without --map, the clip's character (MJCF text)
struct BvhTrackFiles {
  std::string scenario;
  std::string character;
  std::string map, map_report;  // --model without --map: the map found (auto_joint_map.h)
  std::string ground;           // a URDF/SDF robot's floor, which it does not bring
};

// true for a URDF/SDF robot with a floating base and no floor: alone it falls through at once
bool model_needs_ground(const std::string& model) {
  const std::string path = resolve_model_path(model);
  const ModelFormat format = model_format(path);
  if (format != ModelFormat::kUrdf && format != ModelFormat::kSdf) return false;
  return robots_need_ground({read_robot(model, path, {})});
}

BvhTrackFiles make_bvh_track_files(const BvhTrackCommand& cmd) {
  namespace fs = std::filesystem;
  if (!cmd.map.empty() && cmd.model.empty())
    throw InputError("bvh track: --map needs --model (the model it maps the clip onto)");
  check_option_number("--duration", cmd.duration, duration_range());
  if (cmd.duration && !(*cmd.duration > 0))
    throw InputError("--duration: expected a positive number of seconds");
  check_option_number("--first-frame", cmd.first_frame, kFirstFrameRange);
  check_option_number("--last-frame", cmd.last_frame, kLastFrameRange);
  check_option_number("--threads", cmd.threads, threads_range());
  check_option_number("--scale-to-meters", cmd.scale_to_meters, kScaleRange);
  check_utf8_file_name(cmd.bvh);
  const BvhClip clip = read_bvh(cmd.bvh);
  const int last = cmd.last_frame < 0 ? clip.frame_count - 1 : cmd.last_frame;
  if (cmd.first_frame < 0 || cmd.first_frame >= clip.frame_count || last <= cmd.first_frame ||
      last >= clip.frame_count)
    throw InputError(
        clip.frame_count < 2
            ? located(cmd.bvh, clip.frames_line,
                      fmt::format("'Frames: {}': bvh track needs at least two", clip.frame_count))
            : fmt::format("{}: frames {}..{} are not a range of its {} frames", cmd.bvh,
                          cmd.first_frame, last, clip.frame_count));
  // without --first-frame, after leading frames that jump to the motion (a T-pose)
  const int first = cmd.first_frame > 0 ? cmd.first_frame
                                        : std::min(detect_bvh_first_motion_frame(clip), last - 1);
  BvhTrackFiles files;
  YAML::Node doc;
  doc["name"] = "bvh_track_" + fs::path(cmd.bvh).stem().string();
  doc["engine"] = cmd.engine;
  YAML::Node tracker;
  tracker["type"] = "mocap_retarget";
  tracker["bvh"] = fs::absolute(cmd.bvh).string();
  tracker["mode"] = "free";
  tracker["loop"] = cmd.loop;
  tracker["first_frame"] = first;
  tracker["last_frame"] = last;
  tracker["export_bvh"] = "tracked.bvh";
  if (cmd.origin_centred) tracker["export_origin_centred"] = true;
  if (cmd.scale_to_meters > 0) tracker["scale_to_meters"] = cmd.scale_to_meters;
  // the shared defaults, spelled out so that the scenario shows what it runs
  const MocapRetargetParams defaults;
  tracker["kp"] = defaults.kp;
  tracker["kd"] = defaults.kd;
  if (cmd.model.empty()) {
    // the clip's own character, starting on the range's first frame
    BvhCharacterOptions o;
    o.reference.first_frame = first;
    o.skeleton.scale_to_meters = cmd.scale_to_meters;
    files.character = make_bvh_character(clip, o).mjcf;
    doc["model"].push_back(YAML::Node(YAML::NodeType::Map));
    doc["model"][0]["file"] = "character.xml";
  } else {
    doc["model"].push_back(YAML::Node(YAML::NodeType::Map));
    const std::string model =
        cmd.model.find("://") != std::string::npos ? cmd.model : fs::absolute(cmd.model).string();
    doc["model"][0]["file"] = model;
    if (cmd.map.empty()) {
      // no --map: found from the model's tree, written beside the scenario to edit and pass back
      // (its engine loads the model under the lock every load takes: a batch tracks clips at once)
      std::unique_lock<std::mutex> load_lock(model_load_mutex());
      const AutoJointMap found =
          find_joint_map_of_files(cmd.bvh, cmd.model, cmd.engine, cmd.scale_to_meters);
      load_lock.unlock();
      files.map = joint_map_yaml(found, cmd.bvh, cmd.model);
      files.map_report = joint_map_report(found);
      tracker["joint_map"] = "map.yaml";
    } else {
      tracker["joint_map"] = fs::absolute(cmd.map).string();
    }
    if (model_needs_ground(cmd.model)) {
      files.ground = ground_urdf_text();
      doc["model"].push_back(YAML::Node(YAML::NodeType::Map));
      doc["model"][1]["file"] = "ground.urdf";
    }
  }
  doc["duration"] = cmd.duration ? *cmd.duration : (last - first) * clip.frame_time_s;
  doc["controllers"].push_back(tracker);
  doc["planner"]["enabled"] = true;
  // the planner's own coarser model: rollouts at 4 ms halve its compute for a few mm of G-MPJPE
  // (docs/planner.md#compute); the run itself keeps the character's step
  doc["planner"]["timestep"] = 0.004;
  doc["planner"]["threads"] = cmd.threads;
  YAML::Emitter out;
  out << doc;
  files.scenario = std::string("# written by stance bvh track\n") + out.c_str() + "\n";
  return files;
}

// writes the files into `dir`; returns the scenario's path
std::string write_bvh_track_files(const BvhTrackFiles& files, const std::filesystem::path& dir) {
  if (!files.character.empty()) write_file_atomically(dir / "character.xml", files.character);
  if (!files.map.empty()) write_file_atomically(dir / "map.yaml", files.map);
  if (!files.ground.empty()) write_file_atomically(dir / "ground.urdf", files.ground);
  write_file_atomically(dir / "track.yaml", files.scenario);
  return (dir / "track.yaml").string();
}

// a fresh folder under the system's temporary folder, removed with its files when it goes
class ScratchFolder {
 public:
  ScratchFolder() {
    std::string pattern = (std::filesystem::temp_directory_path() / "stance-XXXXXX").string();
    if (!mkdtemp(pattern.data()))
      throw EnvironmentError(fmt::format("cannot make a scratch folder {}", pattern));
    path_ = pattern;
  }
  ~ScratchFolder() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// everything the run loads (the scenario with --set, the character, the joint map, the engine
// and the controllers), loaded from a scratch copy before --out is touched: bad input leaves
// --out as it was. Messages name the files where they will be, in --out.
void check_bvh_track_files(const BvhTrackFiles& files, const BvhTrackCommand& cmd) {
  ScratchFolder scratch;
  const std::string scenario = write_bvh_track_files(files, scratch.path());
  try {
    RunOptions opt;
    opt.engine = cmd.engine;
    opt.quiet = true;
    make_simulation_model(load_scenario(scenario, cmd.sets), opt);
  } catch (const InputError& e) {
    std::string message = e.what();
    const std::string from = scratch.path().string();
    const std::string to = std::filesystem::path(cmd.out_dir).lexically_normal().string();
    for (size_t at; (at = message.find(from)) != std::string::npos;)
      message.replace(at, from.size(), to);
    throw InputError(message);
  }
}

}  // namespace

std::string write_bvh_track_scenario(const BvhTrackCommand& cmd) {
  const BvhTrackFiles files = make_bvh_track_files(cmd);
  if (!files.map_report.empty())
    std::cout << files.map_report
              << "the map: " << (std::filesystem::path(cmd.out_dir) / "map.yaml").string()
              << " (edit it and pass it back with --map)\n";
  if (!files.ground.empty())
    std::cout << cmd.model << " brings no ground: track.yaml adds ground.urdf (a Z-up floor, its "
              << "top at z = 0)\n";
  check_bvh_track_files(files, cmd);
  std::filesystem::create_directories(cmd.out_dir);
  return write_bvh_track_files(files, std::filesystem::absolute(cmd.out_dir));
}

RunCommand bvh_track_run(const BvhTrackCommand& cmd, const std::string& scenario) {
  RunCommand run;
  run.scenario = scenario;
  run.engine = cmd.engine;
  run.sets = cmd.sets;
  run.out_dir = cmd.out_dir;
  run.quiet = cmd.quiet;
  return run;
}

int bvh_track_command(const BvhTrackCommand& cmd, const RunObserverMaker& observe) {
  std::string scenario;
  int code = guarded([&] {
    scenario = write_bvh_track_scenario(cmd);
    return kExitOk;
  });
  if (code != kExitOk) return code;
  return run_command(bvh_track_run(cmd, scenario), observe);
}

int bvh_synth_command(const std::string& out_path, bool run) {
  return guarded([&] {
    BvhClip clip = make_synthetic_walk_clip(run ? synthetic_run_options() : SyntheticWalkOptions{});
    write_bvh(clip, out_path);
    std::cout << fmt::format("wrote {}: {} frames at {:.6g} s\n", out_path, clip.frame_count,
                             clip.frame_time_s);
    return kExitOk;
  });
}

namespace {
// a controller type's parameters, one line each: path, default, unit, range, help
void print_controller_params(const ControllerType& type) {
  std::cout << fmt::format("{}: {}\n", type.name, type.summary);
  const std::vector<ParamDoc> docs = type.params ? type.params() : std::vector<ParamDoc>{};
  if (docs.empty()) {
    std::cout << "  (no parameters)\n";
    return;
  }
  // long defaults (lists, tables) are cut: the column is for the value a user would change
  auto shown = [](const std::string& text) {
    return text.size() <= 16 ? text : text.substr(0, 13) + "...";
  };
  size_t path_width = 9, value_width = 7, unit_width = 4, range_width = 5;
  for (const auto& d : docs) {
    path_width = std::max(path_width, d.path.size());
    value_width = std::max(value_width, shown(d.default_value).size());
    unit_width = std::max(unit_width, d.meta.unit.size());
    range_width = std::max(range_width, range_text(d.meta).size());
  }
  auto line = [&](std::string_view path, std::string_view value, std::string_view unit,
                  std::string_view range, std::string_view help) {
    std::string text = fmt::format("  {:<{}}  {:<{}}  {:<{}}  {:<{}}  {}", path, path_width, value,
                                   value_width, unit, unit_width, range, range_width, help);
    text.erase(text.find_last_not_of(' ') + 1);
    std::cout << text << "\n";
  };
  line("parameter", "default", "unit", "range", "help");
  for (const auto& d : docs)
    line(d.path, shown(d.default_value), d.meta.unit, range_text(d.meta), d.meta.help);
}
}  // namespace

int list_command(const std::string& what) {
  return guarded([&] {
    // "controllers", or one controller type: their parameters
    if (what == "controllers") {
      for (const auto& t : controller_registry()) {
        print_controller_params(t);
        std::cout << "\n";
      }
      return kExitOk;
    }
    std::vector<std::string> names;
    for (const auto& t : controller_registry()) {
      if (t.name == what) {
        print_controller_params(t);
        return kExitOk;
      }
      names.push_back(t.name);
    }
    // else a scenario folder (the default: scenarios)
    const std::string scenario_dir = what.empty() ? "scenarios" : what;
    if (!what.empty() && !std::filesystem::is_directory(what)) {
      names.push_back("controllers");
      std::string hint = did_you_mean(what, names);
      if (hint.empty()) hint = " (`stance list` shows the types)";
      throw InputError(fmt::format(
          "list: '{}' is neither a controller type nor a scenario folder{}", what, hint));
    }
    std::cout << "controllers (stance list NAME prints one's parameters, with units and "
                 "ranges):\n";
    for (const auto& t : controller_registry())
      std::cout << fmt::format("  {:<16} {}\n", t.name, t.summary);
    std::cout << "scenarios in " << scenario_dir << ":\n";
    std::vector<std::string> files;
    if (std::filesystem::is_directory(scenario_dir))
      for (const auto& f : std::filesystem::directory_iterator(scenario_dir))
        if (f.path().extension() == ".yaml") files.push_back(f.path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) std::cout << "  " << f << "\n";
    return kExitOk;
  });
}

namespace {
// what a resumed sweep must share with the interrupted one
nlohmann::json sweep_fingerprint(const SweepCommand& c, const std::vector<double>& values) {
  return {{"scenario", std::filesystem::absolute(c.scenario).lexically_normal().string()},
          {"param", c.param},
          {"values", values},
          {"engine", c.engine},
          {"duration", c.duration ? nlohmann::json(*c.duration) : nlohmann::json(nullptr)},
          {"sets", c.sets}};
}
constexpr const char* kSweepPartial = "sweep.partial.json";

// the finished entries of an interrupted batch (DIR/<partial>), checked against `fingerprint`:
// saved["done"] maps an index to its JSON; a differing option is bad input naming it
nlohmann::json read_partial(const std::string& dir, const char* partial_name,
                            const nlohmann::json& fingerprint) {
  const std::filesystem::path partial = std::filesystem::path(dir) / partial_name;
  std::ifstream in(partial);
  if (!in)
    throw InputError(
        fmt::format("--resume {}: no {} there (nothing to resume)", dir, partial_name));
  nlohmann::json saved;
  try {
    saved = parse_resume_json(in, partial.string());
    for (auto it = fingerprint.begin(); it != fingerprint.end(); ++it)
      if (saved.at("options").at(it.key()) != it.value())
        throw InputError(
            fmt::format("--resume {}: option '{}' was {} in the interrupted run, now {}", dir,
                        it.key(), saved.at("options").at(it.key()).dump(), it.value().dump()));
    (void)saved.at("done");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(
        fmt::format("{}: not a resume file of this command ({})", partial.string(), e.what()));
  }
  return saved;
}
}  // namespace

int sweep_command(const SweepCommand& command) {
  return guarded([&] {
    SweepCommand cmd = command;
    if (!cmd.resume.empty()) cmd.out_dir = cmd.resume;
    SweepOptions o;
    o.scenario = cmd.scenario;
    o.param = cmd.param;
    o.sets = cmd.sets;
    o.threads = cmd.threads;
    o.engine = cmd.engine;
    o.duration = cmd.duration;
    o.interrupt = &g_interrupt;
    check_option_number("--duration", cmd.duration, duration_range());
    check_option_number("--threads", cmd.threads, threads_range());
    check_utf8_file_name(cmd.scenario);
    if (!cmd.values.empty()) {
      o.values = parse_value_list(cmd.values);
    } else {
      if (!cmd.from || !cmd.to) throw InputError("sweep: give --from and --to, or --values");
      o.values = linspace(*cmd.from, *cmd.to, cmd.steps);
    }
    const std::filesystem::path partial = std::filesystem::path(cmd.out_dir) / kSweepPartial;
    nlohmann::json saved = {{"options", sweep_fingerprint(cmd, o.values)},
                            {"done", nlohmann::json::object()}};
    std::map<int, SweepPoint> finished;
    if (!cmd.resume.empty()) {
      saved = read_partial(cmd.resume, kSweepPartial, saved["options"]);
      try {
        for (auto it = saved["done"].begin(); it != saved["done"].end(); ++it)
          finished[std::stoi(it.key())] = sweep_point_from_json(it.value());
      } catch (const std::exception& e) {
        throw InputError(
            fmt::format("{}: a point does not read back ({})", partial.string(), e.what()));
      }
    }
    auto wall0 = std::chrono::steady_clock::now();
    InterruptHandler interrupt_handler;
    std::vector<SweepPoint> points = run_sweep(
        o,
        [&](const SweepPoint& p, int index, int done, int total) {
          // every finished run is kept, for --resume
          saved["done"][std::to_string(index)] = sweep_point_to_json(p);
          std::filesystem::create_directories(cmd.out_dir);
          write_file_atomically(partial, saved.dump() + "\n");
          if (cmd.quiet) return;
          std::string what = !p.error.empty()    ? "error: " + p.error
                             : p.result.diverged ? "diverged"
                             : p.result.fell     ? "fell"
                                                 : "ok";
          std::cout << fmt::format("  [{}/{}] {}={} {}\n", done, total, cmd.param,
                                   format_sweep_value(p.value), what)
                    << std::flush;
        },
        finished);
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    // under mpirun, rank 0 gathered every result and writes; the others are done
    if (!BatchRanks::get().root()) return kExitOk;
    const long unfinished =
        std::count_if(points.begin(), points.end(), [](const SweepPoint& p) { return !p.done; });
    if (unfinished > 0) {
      std::cerr << fmt::format(
          "interrupted: {} of {} runs done, kept in {}; finish them with the same command and "
          "--resume {}\n",
          points.size() - unfinished, points.size(), partial.string(), cmd.out_dir);
      return kExitInterrupted;
    }
    write_sweep_outputs(cmd.out_dir, cmd.param, points);
    std::error_code ec;
    std::filesystem::remove(partial, ec);
    std::cout << fmt::format(
        "swept {} over {} values in {:.2f} s wall; wrote {}/sweep.csv and "
        "points.csv\n",
        cmd.param, points.size(), wall, cmd.out_dir);
    if (cmd.plot) {
      std::string metric = cmd.plot_metric;
      std::vector<std::string> lists = sweep_list_metrics(points);
      if (metric.empty()) {
        // the slope walker's bifurcation points when present, else the first list metric
        auto it = std::find(lists.begin(), lists.end(), "steady_step_lengths_m");
        if (it != lists.end())
          metric = *it;
        else if (!lists.empty())
          metric = lists.front();
        else
          throw InputError("--plot: the runs report no list metric to plot");
      }
      std::string title = fmt::format(
          "{}: {} vs {}",
          points.front().result.scenario.empty() ? cmd.scenario : points.front().result.scenario,
          metric, cmd.param);
      std::string png = plot_sweep(cmd.out_dir, cmd.param, metric, title, metric + ".png");
      std::cout << "wrote " << png << "\n";
    }
    for (const auto& p : points)
      if (!p.error.empty()) {
        std::cerr << fmt::format("error: {}={}: {}\n", cmd.param, format_sweep_value(p.value),
                                 p.error);
        return kExitBadInput;
      }
    return kExitOk;
  });
}

int push_threshold_command(const PushThresholdCommand& cmd) {
  return guarded([&] {
    PushThresholdOptions o;
    if (cmd.axis == "x")
      o.axis = 0;
    else if (cmd.axis == "y")
      o.axis = 1;
    else if (cmd.axis == "z")
      o.axis = 2;
    else
      throw InputError(fmt::format("--axis '{}': use x, y or z", cmd.axis));
    check_option_number("--duration", cmd.duration, duration_range());
    check_option_number("--at", cmd.at, kTimeRange);
    check_option_number("--threads", cmd.threads, threads_range());
    o.body = cmd.body;
    o.engine = cmd.engine;
    o.duration = cmd.duration;
    o.max_force = cmd.max_force;
    o.push_duration = cmd.push_duration;
    o.at = cmd.at;
    o.tolerance = cmd.tolerance;
    o.threads = cmd.threads;
    parse_push_point(cmd.point, o.point, o.offset);
    LoadedScenario loaded = load_scenario(cmd.scenario, cmd.sets);
    auto wall0 = std::chrono::steady_clock::now();
    PushThresholdResult r = find_push_threshold(loaded, o, [&](double f, bool survived) {
      if (!cmd.quiet)
        std::cout << fmt::format("  {:+.1f} N along {}: {}\n", f, cmd.axis,
                                 survived ? "survived" : "fell")
                  << std::flush;
    });
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    std::string engine = cmd.engine.empty() ? loaded.scenario.engine : cmd.engine;
    std::cout << fmt::format("{} on {}: {} s push on {} at t = {} s, bisection on 0..{} N\n",
                             loaded.scenario.name, engine, o.push_duration, o.body, o.at,
                             o.max_force);
    for (const PushBracket* b : {&r.positive, &r.negative}) {
      std::string dir = fmt::format("{}{}", b->sign > 0 ? '+' : '-', cmd.axis);
      if (b->falls_unpushed)
        std::cout << fmt::format("  {}: falls without the push\n", dir);
      else if (!b->fell)
        std::cout << fmt::format("  {}: survives the maximum, {:.1f} N\n", dir, b->survived);
      else
        std::cout << fmt::format("  {}: survives {:.1f} N, falls at {:.1f} N ({} trials)\n", dir,
                                 b->survived, *b->fell, b->trials);
    }
    std::cout << fmt::format("{} trials in {:.2f} s wall\n", r.positive.trials + r.negative.trials,
                             wall);
    return kExitOk;
  });
}

namespace {
// what a resumed robustness run must share with the interrupted one (not threads, nor where
// and how it reports)
nlohmann::json robustness_fingerprint(const RobustnessCommand& c) {
  return {{"scenario", std::filesystem::absolute(c.scenario).lexically_normal().string()},
          {"sets", c.sets},
          {"body", c.body},
          {"directions", c.directions},
          {"phases", c.phases},
          {"push_duration", c.push_duration},
          {"max", c.max_force},
          {"tolerance", c.tolerance},
          {"at", c.at},
          {"phase_spacing", c.phase_spacing},
          {"recovery_window", c.recovery_window},
          {"max_steps", c.max_steps},
          {"point", c.point},
          {"engine", c.engine},
          {"duration", c.duration ? nlohmann::json(*c.duration) : nlohmann::json(nullptr)}};
}
constexpr const char* kRobustnessPartial = "robustness.partial.json";
}  // namespace

int robustness_command(const RobustnessCommand& command) {
  return guarded([&] {
    RobustnessCommand cmd = command;
    if (!cmd.resume.empty()) cmd.out_dir = cmd.resume;
    check_option_number("--duration", cmd.duration, duration_range());
    check_option_number("--threads", cmd.threads, threads_range());
    check_utf8_file_name(cmd.scenario);
    RobustnessOptions o;
    o.body = cmd.body;
    o.directions = cmd.directions;
    o.phases = cmd.phases;
    o.push_duration = cmd.push_duration;
    o.max_force = cmd.max_force;
    o.tolerance = cmd.tolerance;
    o.at = cmd.at;
    o.phase_spacing_s = cmd.phase_spacing;
    o.recovery_window_s = cmd.recovery_window;
    o.max_recovery_steps = cmd.max_steps;
    parse_push_point(cmd.point, o.point, o.offset);
    o.engine = cmd.engine;
    o.duration = cmd.duration;
    o.threads = cmd.threads;
    o.interrupt = &g_interrupt;
    if (cmd.out_dir.empty()) throw InputError("--out: give an output folder");
    const std::filesystem::path partial = std::filesystem::path(cmd.out_dir) / kRobustnessPartial;
    const nlohmann::json fingerprint = robustness_fingerprint(cmd);
    nlohmann::json saved = {{"options", fingerprint}, {"done", nlohmann::json::array()}};
    std::vector<RobustnessCell> finished;
    if (!cmd.resume.empty()) {
      saved = read_partial(cmd.resume, kRobustnessPartial, fingerprint);
      try {
        for (const auto& c : saved.at("done")) finished.push_back(cell_from_json(c));
      } catch (const std::exception& e) {
        throw InputError(fmt::format("{}: a direction and phase do not read back ({})",
                                     partial.string(), e.what()));
      }
    }
    LoadedScenario loaded = load_scenario(cmd.scenario, cmd.sets);
    auto wall0 = std::chrono::steady_clock::now();
    InterruptHandler interrupt_handler;
    RobustnessResult r = run_robustness(
        loaded, o,
        [&](const RobustnessCell& c, int done, int total) {
          // every finished direction and phase is kept, for --resume
          saved["done"].push_back(cell_to_json(c));
          std::filesystem::create_directories(cmd.out_dir);
          write_file_atomically(partial, saved.dump() + "\n");
          if (cmd.quiet) return;
          std::cout << fmt::format(
                           "  [{}/{}] direction {} phase {}: {} N ({} trials, outcome {} at it)\n",
                           done, total, c.direction, c.phase, c.threshold, c.trials.size(),
                           c.outcome_at_threshold)
                    << std::flush;
        },
        finished);
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    // under mpirun, rank 0 gathered every result and writes; the others are done
    if (!BatchRanks::get().root()) return kExitOk;
    if (r.interrupted) {
      int done = 0;
      for (const auto& c : r.cells) done += c.done;
      std::cerr << fmt::format(
          "interrupted: {} of {} directions x phases done, kept in {}; finish them with the same "
          "command and --resume {}\n",
          done, r.cells.size(), partial.string(), cmd.out_dir);
      return kExitInterrupted;
    }
    for (const auto& note : r.notes) std::cout << "note: " << note << "\n";
    write_robustness_outputs(cmd.out_dir, o, r);
    const nlohmann::json s = r.summary();
    int trials = 0;
    for (const auto& c : r.cells) trials += static_cast<int>(c.trials.size());
    std::cout << fmt::format(
        "{} on {} ({}{}): {} directions x {} phases, {} s pushes on {}; {} trials in {:.1f} s "
        "wall\n",
        r.scenario, r.engine, r.walker ? "walker" : "standing", r.planar ? ", planar" : "",
        r.directions.size(), r.phase_fractions.size(), o.push_duration, o.body, trials, wall);
    std::cout << fmt::format(
        "threshold min {} N, mean {:.1f} N, max {} N; weakest: {} degrees at phase {}\n",
        s["threshold_n"]["min"].get<double>(), s["threshold_n"]["mean"].get<double>(),
        s["threshold_n"]["max"].get<double>(), s["weakest"]["angle_deg"].get<double>(),
        s["weakest"]["phase"].get<int>());
    std::cout << fmt::format("wrote {}/robustness.csv, thresholds.csv and summary.json\n",
                             cmd.out_dir);
    if (cmd.plot) std::cout << "wrote " << plot_robustness(cmd.out_dir, r) << "\n";
    std::error_code ec;
    std::filesystem::remove(partial, ec);
    return kExitOk;
  });
}

namespace {
constexpr const char* kTunePartial = "tune.partial.json";
}  // namespace

int tune_command(const TuneCommand& command) {
  return guarded([&] {
    TuneCommand cmd = command;
    if (!cmd.resume.empty()) cmd.out_dir = cmd.resume;
    check_option_number("--duration", cmd.duration, duration_range());
    check_option_number("--threads", cmd.threads, threads_range());
    check_option_number("--seed", static_cast<double>(cmd.seed), {.min = 0});
    check_utf8_file_name(cmd.scenario);
    TuneOptions o;
    o.scenario = cmd.scenario;
    o.sets = cmd.sets;
    for (const auto& p : cmd.params) o.params.push_back(parse_tune_param(p));
    for (const auto& n : cmd.neighbours) o.neighbours.push_back(parse_neighbour(n));
    o.budget = cmd.budget;
    o.population = cmd.population;
    o.seed = static_cast<unsigned long long>(cmd.seed);
    o.threads = cmd.threads;
    o.engine = cmd.engine;
    o.duration = cmd.duration;
    o.metric = cmd.metric;
    o.fall_penalty = cmd.fall_penalty;
    o.method = cmd.method;
    o.interrupt = &g_interrupt;
    if (cmd.out_dir.empty()) throw InputError("--out: give an output folder");
    // a resumed tune: the checkpoint of the interrupted one, made with the same options
    const std::filesystem::path partial = std::filesystem::path(cmd.out_dir) / kTunePartial;
    nlohmann::json saved;
    if (!cmd.resume.empty()) {
      std::ifstream in(partial);
      if (!in)
        throw InputError(
            fmt::format("--resume {}: no {} there (nothing to resume)", cmd.resume, kTunePartial));
      try {
        saved = parse_resume_json(in, partial.string());
      } catch (const nlohmann::json::exception& e) {
        throw InputError(
            fmt::format("{}: not a stance tune resume file ({})", partial.string(), e.what()));
      }
      check_tune_resume(o, saved, "--resume " + cmd.resume);
    }
    auto wall0 = std::chrono::steady_clock::now();
    InterruptHandler interrupt_handler;
    bool notes_shown = false;
    TuneResult r = run_tune(
        o,
        [&](const TuneResult& so_far, int g) {
          // under mpirun every rank holds the same result; rank 0 writes and reports
          if (!BatchRanks::get().root()) return;
          // every finished generation is kept: the outputs so far, then the state to resume
          write_tune_outputs(cmd.out_dir, o, so_far);
          write_file_atomically(partial, so_far.checkpoint.dump() + "\n");
          if (cmd.quiet) return;
          if (!notes_shown)
            for (const auto& note : so_far.notes) std::cout << "note: " << note << "\n";
          notes_shown = true;
          const TuneCandidate& best = so_far.candidates[so_far.best];
          double gen_best = std::numeric_limits<double>::infinity();
          for (const auto& c : so_far.candidates)
            if (c.generation == g) gen_best = std::min(gen_best, c.robust_score);
          std::string metric =
              o.metric.empty() ? "" : fmt::format(", mean {} {:.4g}", o.metric, best.mean_metric);
          std::cout << fmt::format(
                           "generation {}/{}: {} candidates; best robust score {:.6g} (worst time "
                           "up {:.3f} of {:.3f} s{}); this generation's best {:.6g}\n",
                           g + 1, so_far.generations, so_far.candidates.size(), best.robust_score,
                           best.worst_time_up, so_far.duration, metric, gen_best)
                    << std::flush;
        },
        cmd.resume.empty() ? nullptr : &saved);
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    if (!BatchRanks::get().root()) return r.interrupted ? kExitInterrupted : kExitOk;
    if (r.interrupted) {
      if (r.finished_generations == 0)
        std::cerr << "interrupted before the first generation finished; nothing kept\n";
      else
        std::cerr << fmt::format(
            "interrupted: {} of {} generations done, kept in {}; finish them with the same "
            "command and --resume {}\n",
            r.finished_generations, r.generations, partial.string(), cmd.out_dir);
      return kExitInterrupted;
    }
    write_tune_outputs(cmd.out_dir, o, r);
    const TuneCandidate& start = r.candidates.front();
    const TuneCandidate& best = r.candidates[r.best];
    int failed = 0;
    for (const auto& c : r.candidates) failed += c.failed_runs;
    std::cout << fmt::format(
        "tuned {} parameters over {} candidates x {} runs in {:.1f} s wall; wrote "
        "{}/tune.csv, best.yaml and best_scenario.yaml\n",
        o.params.size(), r.candidates.size(), 1 + o.neighbours.size(), wall, cmd.out_dir);
    std::cout << fmt::format("start: robust score {:.6g}, worst time up {:.3f} s\n",
                             start.robust_score, start.worst_time_up);
    std::cout << fmt::format("best:  robust score {:.6g}, worst time up {:.3f} s",
                             best.robust_score, best.worst_time_up);
    if (!o.metric.empty()) std::cout << fmt::format(", mean {} {:.4g}", o.metric, best.mean_metric);
    std::cout << "\n";
    if (failed > 0)
      std::cout << fmt::format("{} runs diverged or failed (counted as down at t = 0)\n", failed);
    for (const auto& a : tune_assignments(o, best)) std::cout << "  --set " << a << "\n";
    std::error_code ec;
    std::filesystem::remove(partial, ec);
    return kExitOk;
  });
}

}  // namespace stance
