// The bvh commands: bvh info, bvh2mjcf, bvh retarget, bvh track and bvh synth.
#include "app/command_support.h"
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

#include "batch/batch_ranks.h"
#include "batch/push_threshold.h"
#include "batch/robustness.h"
#include "batch/sweep.h"
#include "batch/tune.h"
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
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace stance {

using namespace command_support;

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
  std::string ground;           // a robot's floor, which its file does not bring
};

// true for a URDF/SDF robot with a floating base (an MJCF free joint) and no floor: alone it
// falls through at once
bool model_needs_ground(const std::string& model) {
  const std::string path = resolve_model_path(model);
  const ModelFormat format = model_format(path);
  if (format == ModelFormat::kMjcf) {
    const MjcfGroundFacts facts = mjcf_ground_facts(path);
    return facts.floats && !facts.has_floor;
  }
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
  if (cmd.human_limits && !cmd.model.empty())
    throw InputError(
        "bvh track: --human-limits is for the clip's own character (without --model); "
        "a model's limits are its own");
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
    o.human_limits = cmd.human_limits;
    files.character = make_bvh_character(clip, o).mjcf;
    doc["model"].push_back(YAML::Node(YAML::NodeType::Map));
    doc["model"][0]["file"] = "character.xml";
    if (cmd.human_limits) doc["torque_limits"] = "on";  // a person's strength, not only reported
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
// --out as it was. Messages name the files where they will be, in --out. Returns whether the
// model gives any dof a torque limit.
bool check_bvh_track_files(const BvhTrackFiles& files, const BvhTrackCommand& cmd) {
  ScratchFolder scratch;
  const std::string scenario = write_bvh_track_files(files, scratch.path());
  try {
    RunOptions opt;
    opt.engine = cmd.engine;
    opt.quiet = true;
    const auto model = make_simulation_model(load_scenario(scenario, cmd.sets), opt);
    return model->force_limit.array().isFinite().any();
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
  // a model without limits (a SKEL file, an MJCF without actuator ranges) is tracked unclamped:
  // its torques are not a robot's, and summary.json has no torque_limit to report
  if (!check_bvh_track_files(files, cmd) && !cmd.model.empty())
    std::cout << cmd.model << " gives no torque limits: nothing is clamped (torque_limits: auto "
              << "clamps only where the model gives a limit)\n";
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

}  // namespace stance
