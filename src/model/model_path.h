// Model file names: "dart://sample/..." and "mujoco://model/..." resolution; the format by
// extension comes from core/model_format.h.
#pragma once

#include <string>

#include "core/model_format.h"  // ModelFormat, model_format()

namespace stance {

// "dart://sample/X" -> "$STANCE_DART_DATA/X" or, when the variable is unset or empty,
// "/usr/share/doc/dart/data/X" (where Debian's dart-doc installs DART's sample data).
// "mujoco://model/X" -> "$STANCE_MUJOCO_MODELS/X" or "/usr/share/mujoco/model/X" (Debian's
// libmujoco-samples: humanoid/humanoid.xml and friends).
// Other paths, relative ones included, are returned unchanged.
// Throws InputError "<path>: no such file" when the resolved file does not exist, and says what
// it is when it is no regular file: "a folder, not a file", "not a regular file (a character
// device)".
std::string resolve_model_path(const std::string& path);

// An MJCF file's root element must be <mujoco>: MuJoCo's mj_loadXML would hand a <robot> root to
// its own URDF importer (which crashed on fuzzed input and differs from stance's URDF reader).
// Throws InputError "<name>:<line>: root element <x>: ..." otherwise; a file that is not
// well-formed XML is left to MuJoCo, whose message has the line.
void check_mjcf_root(const std::string& name, const std::string& path);

// the line of an MJCF file's <option> element; 0 when it has none (or only in an included file)
int mjcf_option_line(const std::string& path);

}  // namespace stance
