// What an engine backend loads, as the factory (engine/engine_factory.cc) hands it over: model
// paths already resolved ("dart://", "mujoco://") and formats a backend cannot read already
// translated (SKEL -> MJCF for MuJoCo). Backends open files or text and nothing else; model
// loading and path resolution stay above them, in the factory and src/model.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/model_format.h"

namespace stance {

class Engine;

struct BackendModel {
  std::string name;  // as the scenario gave it, for messages
  std::string file;  // the resolved path to open; empty when `text` holds the model
  std::string text;  // the model itself (a translation), in `format`
  ModelFormat format = ModelFormat::kMjcf;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // translation of the whole model
  // URDF and SDF on DART: `file` is the path DART resolves against, `text` the checked and
  // patched content (model/robot_model.h); the root welded to the world; the joints' effort
  // limits (DART's SdfParser does not read them; nor does its MJCF parser read actuators), by
  // joint name
  bool fixed_base = false;
  std::vector<std::pair<std::string, double>> effort_limits;
  // MJCF: files read in place of the ones on disk, as (path, text): the model and its includes
  // with the attributes of a newer MuJoCo that stance applies itself removed
  // (model/mjcf_newer.h); their joint limits are in `effort_limits`, on both engines
  std::vector<std::pair<std::string, std::string>> patched_files;
  // MJCF on DART: joints welded after parsing (on MuJoCo the factory removes them from the text)
  std::vector<std::string> lock_joints;
};

struct BackendWorld {
  std::vector<BackendModel> models;
  std::optional<double> timestep;          // s; default: the model file's own
  std::optional<Eigen::Vector3d> gravity;  // m/s^2; default: the model file's own
  // a keyframe to start from when the model has one (a translated SKEL's initial state)
  std::string start_keyframe;
  // a MuJoCo engine of the same world that only draws (Engine::render_model on DART); empty: none
  std::function<std::unique_ptr<Engine>()> make_drawing_world;
};

// the backends; throw InputError for files they cannot load
std::unique_ptr<Engine> open_mujoco_engine(const BackendWorld& world);
std::unique_ptr<Engine> open_dart_engine(const BackendWorld& world);
// compiles a model file with MuJoCo's compiler (its error thrown, located: MJCF meant for DART
// goes through it first, as DART's MJCF parser asserts on values MuJoCo rejects) and returns its
// torque limits by joint name: its actuators' forcerange, a motor's ctrlrange x gain, times gear,
// summed per joint (DART's MJCF parser reads no actuators), each the tighter of that and the
// model's `effort_limits`
std::vector<std::pair<std::string, double>> mjcf_joint_force_limits(const BackendModel& model);
// where a model's joints and actuators sit in MuJoCo's state vectors
struct MjcfJointSlots {
  std::string name;
  int qpos_adr = 0, nq = 0, dof_adr = 0, nv = 0;
};
struct MjcfLayout {
  std::vector<MjcfJointSlots> joints;
  std::vector<std::string> actuator_joints;  // per actuator, its joint's name ("" if none)
};
// compiles a model file with MuJoCo's compiler (its error thrown, located) and returns its layout
MjcfLayout mjcf_layout(const BackendModel& model);

}  // namespace stance
