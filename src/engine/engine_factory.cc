// The engine factory: resolves model paths and translates what a backend cannot read, then
// hands the backend its input (engine/backend_world.h).
#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <mutex>
#include <set>

#include "core/error.h"
#include "engine/backend_world.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "model/skel_to_mjcf.h"

namespace stance {

namespace {

BackendWorld world_options(const WorldSpec& spec) {
  if (spec.models.empty()) throw InputError("no model given");
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

}  // namespace

std::unique_ptr<Engine> make_mujoco_engine(const WorldSpec& spec) {
  BackendWorld world = world_options(spec);
  std::vector<SkelInput> skel_inputs;
  std::vector<RobotInput> robot_inputs;
  for (const auto& mf : spec.models) {
    std::string path = resolve_model_path(mf.path);
    const ModelFormat format = model_format(path);
    if (format == ModelFormat::kSkel) skel_inputs.push_back({path, mf.offset});
    if (is_robot_format(format)) robot_inputs.push_back({mf.path, path, mf.offset, mf.robot});
  }
  if (!robot_inputs.empty()) {
    // URDF and SDF through stance's translation, composed into one world
    if (robot_inputs.size() != spec.models.size())
      throw InputError(
          "composing URDF/SDF files with MJCF/SKEL files is not supported on MuJoCo; "
          "compose URDF and SDF files only");
    RobotTranslation t = robots_to_mjcf(robot_inputs);
    for (const std::string& w : t.warnings) warn_once(w);
    world.models.push_back({spec.models.front().path, "", t.mjcf, ModelFormat::kMjcf, {}});
    return open_mujoco_engine(world);
  }
  if (!skel_inputs.empty()) {
    // SKEL through its MJCF translation, which keeps DART's initial state (<init_pos>) in
    // keyframe "init": start there, as DART does
    if (skel_inputs.size() != spec.models.size())
      throw InputError(
          "composing SKEL files with MJCF/URDF files is not supported on MuJoCo; "
          "convert the SKEL files first with `stance convert`");
    SkelTranslation t = skel_to_mjcf(skel_inputs);
    world.models.push_back({spec.models.front().path, "", t.mjcf, ModelFormat::kMjcf, {}});
    world.start_keyframe = "init";
    return open_mujoco_engine(world);
  }
  if (spec.models.size() != 1)
    throw InputError("MuJoCo loads one MJCF/URDF file per world; use <include> to compose");
  const ModelFile& mf = spec.models.front();
  const std::string path = resolve_model_path(mf.path);
  check_mjcf_root(mf.path, path);
  world.models.push_back({path, path, "", model_format(path), mf.offset});
  return open_mujoco_engine(world);
}

std::unique_ptr<Engine> make_dart_engine(const WorldSpec& spec) {
#ifdef STANCE_HAVE_DART
  BackendWorld world = world_options(spec);
  for (const auto& mf : spec.models) {
    const std::string path = resolve_model_path(mf.path);
    BackendModel model{mf.path, path, "", model_format(path), mf.offset};
    // DART's parsers assert or crash on bad values: stance's own checks go first, located
    if (model.format == ModelFormat::kSkel) check_skel_for_dart(path);
    if (model.format == ModelFormat::kMjcf) {
      check_mjcf_root(mf.path, path);
      check_mujoco_compiles(model);
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
  return open_dart_engine(world);
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
