// lock_joints for MJCF models (issue 45): the named joints of a model file welded where the file
// places their body (the joint at its reference position), so that a one-axis-ankle model can be
// made from any model without writing a new file. On MuJoCo the joints go from the text it
// parses, with what names them: their actuators, sensors, fixed-tendon entries, joint equalities
// and their entries in keyframes. DART welds them after parsing (engine/dart).
#pragma once

#include <set>
#include <string>
#include <vector>

namespace stance {

// the entries of the locked joints (and of their actuators) in MuJoCo's state vectors, which go
// from the model's keyframes
struct KeyframeEntries {
  std::set<int> qpos, qvel, ctrl;
};

// `text` (the model file `shown_name`) with `names` locked and `dropped` removed from its
// keyframes. Throws InputError "<shown_name>: lock_joints: ..." for a name that is no hinge,
// slide or ball joint of the file (a free joint cannot be locked), naming the joints it has.
std::string mjcf_with_joints_locked(const std::string& shown_name, const std::string& text,
                                    const std::vector<std::string>& names,
                                    const KeyframeEntries& dropped);

}  // namespace stance
