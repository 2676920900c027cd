// What to load into an engine: one or more model files composed into one world.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "model/robot_model.h"

namespace stance {

class Engine;

struct ModelFile {
  std::string path;  // .xml (MJCF), .urdf, .sdf, .skel; "dart://sample/..." is resolved
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // translation of the whole file's content
  RobotOptions robot;  // URDF and SDF only: fixed base, package path, mesh collision
};

struct WorldSpec {
  std::vector<ModelFile> models;
  std::optional<double> timestep;          // s; default: the model file's own
  std::optional<Eigen::Vector3d> gravity;  // m/s^2; default: the model file's own
};

// backends. Throw stance::InputError (see core/error.h) for bad files.
std::unique_ptr<Engine> make_mujoco_engine(const WorldSpec& spec);
std::unique_ptr<Engine> make_dart_engine(const WorldSpec& spec);  // throws if built without DART
// engine_name: "mujoco" or "dart"
std::unique_ptr<Engine> make_engine(const std::string& engine_name, const WorldSpec& spec);

}  // namespace stance
