// MJCF written for a MuJoCo newer than the 2.2.2 that stance links: the attributes of newer
// releases that stance applies itself are read here and removed before MuJoCo's parser sees the
// file (which would refuse them): joints' actuatorfrcrange, integrator implicitfast, and a
// <position>'s kv and inheritrange (its servo becomes a torque motor, engine/mujoco/
// mujoco_actuators.h). Others stay, and MuJoCo's refusal names them, located, as
// attributes of a newer MuJoCo (engine/mujoco).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace stance {

// a model file's text to read in place of the file on disk
struct PatchedModelFile {
  std::string path;  // as MuJoCo opens it: the main file's path, or an <include>'s resolved path
  std::string text;
};

struct NewerMjcf {
  // the main file and the included files that held such attributes, with them removed (line
  // breaks kept, so that MuJoCo's later messages keep their lines); empty when none did
  std::vector<PatchedModelFile> patched;
  // joints' actuatorfrcrange (the total actuator torque the joint takes), by joint name: the
  // largest magnitude of its range, the class defaults and actuatorfrclimited applied
  std::vector<std::pair<std::string, double>> joint_force_limits;
  // one line for the user (what was read and what was dropped); empty when nothing was
  std::string note;
};

// reads the MJCF file at `path` and the files it includes; `shown_name` names it in messages.
// Throws InputError "<file>:<line>: ..." for a malformed actuatorfrcrange. A file that is not
// well-formed XML is left to MuJoCo, whose message has the line.
NewerMjcf read_newer_mjcf(const std::string& shown_name, const std::string& path);

}  // namespace stance
