// The parameter panel's layout, without any GUI: readable labels from the parameter visit, the
// groups the key paths make (a controller's structs, the FSM states), and the filter. The viewer
// draws this tree with imgui tree nodes; tests check it without OpenGL.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "params/param_list.h"

namespace stance {

// the label an entry is shown with: the last part of its key path plus its unit,
// "gait.states.0.swh" -> "swh", "kp" with unit "N m/rad" -> "kp (N m/rad)"; a vector's
// component "heel_point.1" -> "heel_point[1]"
std::string param_label(const ParamEntry& entry);

// the full key path, the help, the unit and the range, for the hover text
std::string param_tooltip(const ParamEntry& entry);

// true when `filter` (case-insensitive, spaces separate words that must all match) is found in
// the entry's key path, label or help; an empty filter matches everything
bool param_matches(const ParamEntry& entry, std::string_view filter);

// a group of the panel: the entries directly in it (indices into the list) and its subgroups,
// in the visit's order. "states.0.swh" sits in group "states" > "states 0".
struct ParamGroup {
  std::string name;  // "" for the root
  std::vector<int> entries;
  std::vector<ParamGroup> groups;
  // entries in this group and all its subgroups
  int size() const;
};

// the tree of the entries that match `filter`; groups left empty by the filter are dropped
ParamGroup build_param_tree(const std::vector<ParamEntry>& entries, std::string_view filter = "");

}  // namespace stance
