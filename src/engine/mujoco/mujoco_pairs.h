// The broadphase skipped where it only costs.
// MuJoCo's broadphase (a covariance frame, an eigen-solve and two sorts every step) costs several
// times the narrowphase on a character whose geoms touch only the floor. Where the geom pairs
// the filters let through are few, named and share their contact parameters, the model is
// compiled again with them predefined, in the order mj_collision visits them (body pairs by
// index, then each body's geoms), and collides those alone: the same contacts in the same order.
#pragma once

#include <mujoco/mujoco.h>

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace stance {

// compiles MJCF texts (file name, text), the main one `name`; throws InputError
using MjcfReload = mjModel* (*)(const std::vector<std::pair<std::string, std::string>>& files,
                                const std::string& name);

// `m` with its dynamic pairs predefined (collision="predefined"), or `m` itself where that does
// not apply; `files[main]` is the main file's MJCF, compiled again by `reload` as `name` with the
// other files beside it. Takes `m` over: deletes it when it returns another model.
mjModel* with_predefined_pairs(mjModel* m, std::vector<std::pair<std::string, std::string>> files,
                               size_t main, const std::string& name, MjcfReload reload);

}  // namespace stance
