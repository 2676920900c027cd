// A scenario: model(s), engine, timestep, gravity, initial pose, controllers, timed pushes,
// duration and fall criterion. Loaded from YAML through the parameter visit.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "params/param_list.h"
#include "params/params.h"
#include "sim/expectation.h"
#include "sim/planner_params.h"

namespace stance {

struct ModelEntry {
  std::string file;  // MJCF/URDF/SDF/SKEL path; "dart://sample/..." allowed; relative to the YAML
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  // URDF and SDF only (model/robot_model.h)
  bool fixed_base = false;
  std::vector<std::string> package_path;  // relative to the YAML
  std::string mesh_collision = "box";
  std::vector<std::string> lock_joints;  // welded at their zero position (URDF, SDF, MJCF)

  template <class V>
  void visit(V& v) {
    v("file", file, {.help = "model file"});
    v("offset", offset, {.unit = "m", .help = "translation of the whole file"});
    v("fixed_base", fixed_base, {.help = "URDF/SDF: weld the root link to the world"});
    v("package_path", package_path,
      {.help = "URDF/SDF: folders searched for package:// meshes (then STANCE_PACKAGE_PATH)"});
    v("mesh_collision", mesh_collision,
      {.help = "URDF/SDF: box (collide with each mesh's bounding box) or mesh"});
    v("lock_joints", lock_joints,
      {.help = "URDF/SDF/MJCF: joints welded at their zero position (ankle rolls: one-axis "
               "ankles)"});
  }
};

// a force on a body for a while (the seed's pushes)
struct Perturbation {
  std::string body;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  // N, world frame
  double start = 0;                                 // s
  double duration = 0.1;                            // s
  // where the force acts: "com" (the body's centre of mass) or "origin" (its frame's origin, as
  // DART's addExtForce does), plus `offset` in the body frame (point: origin with an offset is
  // any point fixed to the body)
  std::string point = "com";
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // m, body frame

  template <class V>
  void visit(V& v) {
    v("body", body, {.help = "body to push"});
    v("force", force, {.unit = "N", .help = "force in the world frame"});
    v("start", start, {.unit = "s", .min = 0});
    v("duration", duration, {.unit = "s", .min = 0});
    v("point", point, {.help = "where the force acts: com or origin (plus offset)"});
    v("offset", offset, {.unit = "m", .help = "added to the point, in the body frame"});
  }
  bool active_at(double t) const { return t >= start && t < start + duration; }
};

struct FallCriterion {
  bool enabled = true;
  // fell when the COM height above ground_height drops below this fraction of its start
  double com_height_fraction = 0.5;
  double ground_height = 0;  // m, along the up axis (-gravity)
  // bodies allowed to touch the ground; any other body touching it is a fall. Empty: no check.
  std::vector<std::string> allowed_contacts;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled);
    v("com_height_fraction", com_height_fraction, {.min = 0, .max = 1});
    v("ground_height", ground_height, {.unit = "m"});
    v("allowed_contacts", allowed_contacts, {.help = "bodies that may touch the ground"});
  }
};

struct LogOptions {
  double rate_hz = 100;

  template <class V>
  void visit(V& v) {
    v("rate_hz", rate_hz, {.unit = "Hz", .min = 0.001, .max = 1e6});
  }
};

// how the viewer and the recorder frame the character (scenario key `camera`)
struct CameraParams {
  double distance = 0;          // m; 0: from the character's size
  double azimuth = 90;          // deg; 90 looks along +y, at the sagittal plane
  double elevation = -12;       // deg; negative looks down
  std::string mode = "follow";  // follow: tracks the root; fixed: stays where it starts

  template <class V>
  void visit(V& v) {
    v("distance", distance,
      {.unit = "m", .min = 0, .max = 1000, .help = "0: from the character's size"});
    v("azimuth", azimuth, {.unit = "deg", .min = -360, .max = 360});
    v("elevation", elevation, {.unit = "deg", .min = -89, .max = 89});
    v("mode", mode, {.help = "follow (tracks the root) or fixed"});
  }
};

struct Scenario {
  std::string name;
  std::string engine = "mujoco";
  std::vector<ModelEntry> model;
  double timestep = 0;          // s; 0: the model file's own
  std::vector<double> gravity;  // m/s^2; empty: the model file's own
  double slope_rad = 0;         // tilts gravity about y: g = |g| (sin a, 0, -cos a)
  NamedValues initial_pose;     // dof -> value
  std::string keyframe;         // MuJoCo keyframe name (MuJoCo only)
  // "auto": lean the legs so that the COM is over the feet (control/standing_pose.h); "" or off
  std::string stand_pose;
  double duration = 10;  // s
  int seed = 0;
  double torque_scale = 1;  // multiplies the summed controller torques (seed: 0.8)
  // clamp the summed generalised forces to the model's limits (engine.h: force_limit): "auto"
  // wherever the model gives a limit (URDF/SDF effort, MJCF actuator ranges), "on", "off"
  std::string torque_limits = "auto";
  std::vector<Perturbation> perturbations;
  FallCriterion fall;
  LogOptions log;
  PlannerParams planner;
  CameraParams camera;
  Expectation expect;  // what the scenario shows (scenario/expectation.h)

  template <class V>
  void visit(V& v) {
    v("name", name);
    v("engine", engine, {.help = "mujoco or dart"});
    v("model", model, {.help = "model file(s)"});
    v("timestep", timestep, {.unit = "s", .min = 0, .max = 1});
    v("gravity", gravity, {.unit = "m/s^2"});
    v("slope_rad", slope_rad,
      {.unit = "rad",
       .min = -1.5,
       .max = 1.5,
       .help = "downhill slope along +x, applied by tilting gravity"});
    v("initial_pose", initial_pose, {.help = "dof name: value"});
    v("keyframe", keyframe, {.help = "MuJoCo keyframe to start from"});
    v("stand_pose", stand_pose,
      {.help = "auto: lean the legs at hips and ankles until the COM is over the feet (after "
               "initial_pose; the feet: fall.allowed_contacts if two); empty or off: as given"});
    v("duration", duration, {.unit = "s", .min = 0});
    v("seed", seed, {.min = 0});
    v("torque_scale", torque_scale, {.min = 0, .max = 10});
    v("torque_limits", torque_limits,
      {.help = "clamp torques to the model's limits: auto (where the model has any), on or off"});
    v("perturbations", perturbations);
    v("fall", fall);
    v("log", log);
    v("planner", planner);
    v("camera", camera);
    v("expect", expect, {.help = "what a run shows: fell, metric bounds (checked after a run)"});
  }
};

// a scenario with its controller blocks, as loaded
struct LoadedScenario {
  Scenario scenario;
  std::vector<YAML::Node> controllers;  // each a mapping with "type"
  std::string source;                   // file name for messages
  YAML::Node document;                  // the whole YAML (after overrides), for saving
};

// load and validate (types, ranges, unknown keys, finite numbers). Overrides are "a.b=value".
// Relative model paths are resolved against the YAML file's folder.
LoadedScenario load_scenario(const std::string& path,
                             const std::vector<std::string>& overrides = {});
LoadedScenario parse_scenario(const YAML::Node& doc, const std::string& source,
                              const std::string& base_dir);
// the numeric parameters of controller `index`, defaults filled in, read from its block by its
// type's parameter struct as the loader checked it (no engine); none for a Python controller
std::vector<ParamEntry> controller_params(const LoadedScenario& loaded, size_t index);

}  // namespace stance
