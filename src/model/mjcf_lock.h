// lock_joints for MJCF models (issue 45): the named joints of a model file welded where the file
// places their body (the joint at its reference position), so that a one-axis-ankle model can be
// made from any model without writing a new file. On MuJoCo the joints go from the text it
// parses, with what names them: their actuators, sensors, fixed-tendon entries, joint equalities
// and their entries in keyframes. DART welds them after parsing (engine/dart).
#pragma once

#include <functional>
#include <set>
#include <string>
#include <vector>

namespace stance {

// the entries of the locked joints (and of their actuators) in MuJoCo's state vectors, which go
// from the model's keyframes
struct KeyframeEntries {
  std::set<int> qpos, qvel, ctrl;
};

// a model file's text, read in place of the file at `path`
struct MjcfFileText {
  std::string path;
  std::string text;
};

// the MJCF file at `main_path` (first) and every file it <include>s, at any depth, resolved as
// MuJoCo 2.2.2 does (against the main file's folder); `text_of` reads a file
std::vector<std::string> mjcf_include_paths(
    const std::string& main_path, const std::function<std::string(const std::string&)>& text_of);

// `files` (a model file `shown_name` and the files it includes) with `names` locked wherever
// they are and `dropped` removed from the keyframes: the new texts, in `files`' order. Throws
// InputError "<shown_name>: lock_joints: ..." for a name that is no hinge, slide or ball joint
// of the files (a free joint cannot be locked), naming the joints they have.
std::vector<std::string> mjcf_with_joints_locked(const std::string& shown_name,
                                                 const std::vector<MjcfFileText>& files,
                                                 const std::vector<std::string>& names,
                                                 const KeyframeEntries& dropped);

}  // namespace stance
