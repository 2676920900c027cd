// The engine factory: resolves model paths and translates what a backend cannot read, then
// hands the backend its input (engine/backend_world.h).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <set>

#include "core/error.h"
#include "core/timestep.h"
#include "engine/backend_world.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/mjcf_lock.h"
#include "model/mjcf_newer.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "model/skel_to_mjcf.h"

namespace stance {

namespace {

BackendWorld world_options(const WorldSpec& spec) {
  if (spec.models.empty()) throw InputError("no model given");
  if (spec.timestep && !timestep_problem(*spec.timestep).empty())
    throw InputError("timestep: " + timestep_problem(*spec.timestep));
  BackendWorld world;
  world.timestep = spec.timestep;
  world.gravity = spec.gravity;
  return world;
}

bool is_robot_format(ModelFormat f) {
  return f == ModelFormat::kUrdf || f == ModelFormat::kSdf;
}

// a load warning, printed once per process and message (a sweep loads the model many times)
void warn_once(const std::string& message) {
  static std::mutex mutex;
  static std::set<std::string> printed;
  std::lock_guard<std::mutex> lock(mutex);
  if (printed.insert(message).second) std::cerr << "warning: " << message << "\n";
}

// an MJCF file's attributes of a newer MuJoCo that stance applies itself: read (their joint
// limits join the model's) and removed from the text MuJoCo parses; returns the note to print
// once the model has loaded
std::string apply_newer_mjcf(const ModelFile& mf, BackendModel& model) {
  NewerMjcf newer = read_newer_mjcf(mf.path, model.file);
  for (PatchedModelFile& f : newer.patched)
    model.patched_files.emplace_back(std::move(f.path), std::move(f.text));
  model.effort_limits.insert(model.effort_limits.end(), newer.joint_force_limits.begin(),
                             newer.joint_force_limits.end());
  return newer.note;
}

// lock_joints reads URDF, SDF and MJCF files
void check_lockable(const ModelFile& mf, ModelFormat format) {
  if (format == ModelFormat::kSkel && !mf.robot.lock_joints.empty())
    throw InputError(mf.path +
                     ": lock_joints: not for SKEL files (URDF, SDF and MJCF only; "
                     "`stance convert` writes a SKEL file as MJCF)");
}

// lock_joints on an MJCF model (model/mjcf_lock.h): the texts of the main file and of the files
// it includes, without the joints, read by MuJoCo in place of the files; checked on DART too, so
// that both engines refuse alike
void lock_mjcf_joints(const ModelFile& mf, BackendModel& model) {
  if (mf.robot.lock_joints.empty()) return;
  auto patched_text = [&](const std::string& path) -> std::string* {
    for (auto& [p, text] : model.patched_files)
      if (p == path) return &text;
    return nullptr;
  };
  auto text_of = [&](const std::string& path) {
    if (const std::string* text = patched_text(path)) return *text;
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  std::vector<MjcfFileText> files;
  for (const std::string& path : mjcf_include_paths(model.file, text_of))
    files.push_back({path, text_of(path)});
  const MjcfLayout layout = mjcf_layout(model);  // compiles it unlocked: its errors, located
  const std::set<std::string> names(mf.robot.lock_joints.begin(), mf.robot.lock_joints.end());
  KeyframeEntries dropped;
  for (const MjcfJointSlots& j : layout.joints) {
    if (!names.count(j.name)) continue;
    for (int k = 0; k < j.nq; ++k) dropped.qpos.insert(j.qpos_adr + k);
    for (int k = 0; k < j.nv; ++k) dropped.qvel.insert(j.dof_adr + k);
  }
  for (size_t a = 0; a < layout.actuator_joints.size(); ++a)
    if (names.count(layout.actuator_joints[a])) dropped.ctrl.insert(static_cast<int>(a));
  std::vector<std::string> locked =
      mjcf_with_joints_locked(mf.path, files, mf.robot.lock_joints, dropped);
  for (size_t i = 0; i < files.size(); ++i) {
    if (std::string* text = patched_text(files[i].path))
      *text = std::move(locked[i]);
    else
      model.patched_files.emplace_back(files[i].path, std::move(locked[i]));
  }
}

// a load note, printed once per process and message
void note_once(const std::string& note) {
  static std::mutex mutex;
  static std::set<std::string> printed;
  std::lock_guard<std::mutex> lock(mutex);
  if (!note.empty() && printed.insert(note).second) std::cerr << "note: " << note << "\n";
}

// MuJoCo's compiler error about a body of a URDF/SDF translation ("x.urdf (translated to
// MJCF):9: Error: mass and inertia of moving bodies must be larger than mjMINVAL Object name =
// base, id = 1, line = 9, column = -1") located at the link's own file and line; unchanged when
// it names no link
std::string located_in_robot_file(const std::string& message, const RobotTranslation& t) {
  const std::string object = "Object name = ";
  const size_t at = message.find(object);
  const size_t error = message.find("Error: ");
  if (at == std::string::npos || error == std::string::npos || error > at) return message;
  const size_t name_at = at + object.size();
  const std::string name = message.substr(name_at, message.find(',', name_at) - name_at);
  const auto link = t.body_lines.find(name);
  if (link == t.body_lines.end()) return message;
  std::string why = message.substr(error + 7, at - error - 7);
  while (!why.empty() && why.back() == ' ') why.pop_back();
  // stance's own check (model/robot_model.h) passed: DART can move what MuJoCo refuses
  if (why.find("mass and inertia of moving bodies") != std::string::npos)
    why =
        "MuJoCo needs a moving link's mass and every principal inertia (with the links welded "
        "to it) above 1e-15 (mjMINVAL); DART loads it (--engine dart)";
  else
    why = "MuJoCo: " + why;
  return located(link->second.first, link->second.second, fmt::format("link '{}': {}", name, why));
}

// the model files' own time step (core/timestep.h's rule; the spec's is checked first), named
// with the file that gives it: the first MJCF or SKEL file (URDF/SDF get 1 ms)
std::unique_ptr<Engine> checked_timestep(std::unique_ptr<Engine> engine, const WorldSpec& spec) {
  const std::string problem = timestep_problem(engine->timestep());
  if (problem.empty()) return engine;
  for (const ModelFile& mf : spec.models) {
    const std::string path = resolve_model_path(mf.path);
    const ModelFormat format = model_format(path);
    if (format == ModelFormat::kMjcf)
      throw InputError(located(mf.path, mjcf_option_line(path), "<option> timestep: " + problem));
    if (format == ModelFormat::kSkel) throw InputError(mf.path + ": <time_step>: " + problem);
  }
  throw InputError(spec.models.front().path + ": timestep: " + problem);
}

// the one MJCF model of a world whose other models are URDF/SDF grounds (bvh track's
// ground.urdf beside a collection's robot file, which brings no floor); null otherwise
const ModelFile* mjcf_on_grounds(const WorldSpec& spec) {
  const ModelFile* mjcf = nullptr;
  std::vector<const ModelFile*> others;
  for (const auto& mf : spec.models) {
    const ModelFormat format = model_format(resolve_model_path(mf.path));
    if (format == ModelFormat::kMjcf && mjcf == nullptr) {
      mjcf = &mf;
    } else if (is_robot_format(format)) {
      others.push_back(&mf);
    } else {
      return nullptr;
    }
  }
  if (mjcf == nullptr || others.empty()) return nullptr;
  for (const ModelFile* mf : others)
    if (!robot_is_ground(read_robot(mf->path, resolve_model_path(mf->path), mf->robot)))
      return nullptr;
  return mjcf;
}

// MuJoCo loads one MJCF per world: the grounds become a floor in the model's own text, the box
// of models/ground.urdf (40 m x 40 m, its top at z = 0)
void add_mjcf_floor(BackendModel& model) {
  auto patched = std::find_if(model.patched_files.begin(), model.patched_files.end(),
                              [&](const auto& f) { return f.first == model.file; });
  if (patched == model.patched_files.end()) {
    std::ifstream in(model.file, std::ios::binary);
    model.patched_files.emplace_back(model.file, std::string(std::istreambuf_iterator<char>(in),
                                                             std::istreambuf_iterator<char>()));
    patched = std::prev(model.patched_files.end());
  }
  std::string& text = patched->second;
  const size_t end = text.rfind("</mujoco>");
  if (end == std::string::npos) return;  // not well-formed: MuJoCo's message says where
  text.insert(end,
              "<worldbody><geom name=\"stance_ground\" type=\"box\" size=\"20 20 0.5\" "
              "pos=\"0 0 -0.5\" contype=\"1\" conaffinity=\"1\"/></worldbody>\n");
}

std::unique_ptr<Engine> open_mujoco_world(const WorldSpec& spec) {
  BackendWorld world = world_options(spec);
  std::vector<SkelInput> skel_inputs;
  std::vector<RobotInput> robot_inputs;
  for (const auto& mf : spec.models) {
    std::string path = resolve_model_path(mf.path);
    const ModelFormat format = model_format(path);
    check_lockable(mf, format);
    if (format == ModelFormat::kSkel) skel_inputs.push_back({path, mf.offset});
    if (is_robot_format(format)) robot_inputs.push_back({mf.path, path, mf.offset, mf.robot});
  }
  const ModelFile* on_grounds = mjcf_on_grounds(spec);
  if (!robot_inputs.empty() && on_grounds == nullptr) {
    // URDF and SDF through stance's translation, composed into one world
    if (robot_inputs.size() != spec.models.size())
      throw InputError(
          "composing URDF/SDF files with MJCF/SKEL files is not supported on MuJoCo; "
          "compose URDF and SDF files only");
    RobotTranslation t = robots_to_mjcf(robot_inputs);
    for (const std::string& w : t.warnings) warn_once(w);
    world.models.push_back(
        {spec.models.front().path, "", t.mjcf, ModelFormat::kMjcf, Eigen::Vector3d::Zero()});
    try {
      return open_mujoco_engine(world);
    } catch (const InputError& e) {
      throw InputError(located_in_robot_file(e.what(), t));
    }
  }
  if (!skel_inputs.empty()) {
    // SKEL through its MJCF translation, which keeps DART's initial state (<init_pos>) in
    // keyframe "init": start there, as DART does
    if (skel_inputs.size() != spec.models.size())
      throw InputError(
          "composing SKEL files with MJCF/URDF files is not supported on MuJoCo; "
          "convert the SKEL files first with `stance convert`");
    SkelTranslation t = skel_to_mjcf(skel_inputs);
    world.models.push_back(
        {spec.models.front().path, "", t.mjcf, ModelFormat::kMjcf, Eigen::Vector3d::Zero()});
    world.start_keyframe = "init";
    return open_mujoco_engine(world);
  }
  if (spec.models.size() != 1 && on_grounds == nullptr)
    throw InputError("MuJoCo loads one MJCF/URDF file per world; use <include> to compose");
  const ModelFile& mf = on_grounds ? *on_grounds : spec.models.front();
  const std::string path = resolve_model_path(mf.path);
  check_mjcf_root(mf.path, path);
  world.models.push_back({path, path, "", model_format(path), mf.offset});
  const std::string note = apply_newer_mjcf(mf, world.models.back());
  lock_mjcf_joints(mf, world.models.back());
  if (on_grounds) add_mjcf_floor(world.models.back());
  std::unique_ptr<Engine> engine = open_mujoco_engine(world);
  note_once(note);
  note_once(engine->load_note());
  return engine;
}

}  // namespace

std::unique_ptr<Engine> make_mujoco_engine(const WorldSpec& spec) {
  return checked_timestep(open_mujoco_world(spec), spec);
}

std::unique_ptr<Engine> make_dart_engine(const WorldSpec& spec) {
#ifdef STANCE_HAVE_DART
  BackendWorld world = world_options(spec);
  std::vector<std::string> notes;
  for (const auto& mf : spec.models) {
    const std::string path = resolve_model_path(mf.path);
    BackendModel model{mf.path, path, "", model_format(path), mf.offset};
    // DART's parsers assert or crash on bad values: stance's own checks go first, located
    check_lockable(mf, model.format);
    if (model.format == ModelFormat::kSkel) check_skel_for_dart(path);
    if (model.format == ModelFormat::kMjcf) {
      check_mjcf_root(mf.path, path);
      notes.push_back(apply_newer_mjcf(mf, model));
      model.effort_limits = mjcf_joint_force_limits(model);  // compiles it: its errors, located
      BackendModel checked = model;
      lock_mjcf_joints(mf, checked);
      model.lock_joints = mf.robot.lock_joints;
    }
    if (is_robot_format(model.format)) {
      const RobotModel robot = read_robot(mf.path, path, mf.robot);
      model.text = robot_text_for_dart(mf.path, path, mf.robot);
      model.fixed_base = mf.robot.fixed_base;
      for (const RobotJoint& j : robot.joints)
        if (std::isfinite(j.effort)) model.effort_limits.emplace_back(j.name, j.effort);
    }
    world.models.push_back(std::move(model));
  }
  world.make_drawing_world = [spec] { return make_mujoco_engine(spec); };
  std::unique_ptr<Engine> engine = checked_timestep(open_dart_engine(world), spec);
  for (const std::string& note : notes) note_once(note);
  return engine;
#else
  throw InputError("this build of stance has no DART backend");
#endif
}

std::unique_ptr<Engine> make_engine(const std::string& engine_name, const WorldSpec& spec) {
  if (engine_name == "mujoco") return make_mujoco_engine(spec);
  if (engine_name == "dart") return make_dart_engine(spec);
  throw InputError(fmt::format("unknown engine '{}' (expected mujoco or dart)", engine_name));
}

}  // namespace stance
