// The planner's default objective: while a controller tracks a reference, its weighted squared
// errors (joint, root, body, root tilt); while nothing is tracked, balance where the run
// started (the capture point over the feet, COM velocity, uprightness, height lost).
#pragma once

#include <Eigen/Core>

#include <memory>

#include "plan/objective.h"

namespace stance {

std::unique_ptr<const PlannerObjective> make_track_or_balance(const PlannerParams& params,
                                                              const RunStart& start);

// x without its component along `up`
inline Eigen::Vector3d horizontal(const Eigen::Vector3d& x, const Eigen::Vector3d& up) {
  return x - up.dot(x) * up;
}
// the mean origin of the support bodies (the feet); start.support_bodies must not be empty
Eigen::Vector3d support_center(const RunStart& start, const Engine& e);
// the capture point (COM + v sqrt(h / g)) against the start, horizontal: where the COM would
// have to be to come to rest, so a push shows before the COM has moved
Eigen::Vector3d capture_offset(const RunStart& start, const Simulation& sim);

}  // namespace stance
