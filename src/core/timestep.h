// The time steps and run lengths stance accepts: one rule for every source of a time step (a
// scenario's `timestep`, a model file's own: MJCF <option timestep>, SKEL <time_step>; the
// planner's, `bvh2mjcf --timestep`, the Python API). Callers put the source in front of the
// problem: "file:line: <option> timestep: 0 s: a time step must be positive ...".
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <string>

namespace stance {

// s. Below the smallest, one simulated second takes more than 100,000 steps (MuJoCo's and
// DART's defaults are 2 ms and 1 ms); above the largest, no contact or joint is resolved.
constexpr double kMinTimestep = 1e-5;
constexpr double kMaxTimestep = 1;
// the most steps one run may take (10 ms of compute a step would be 11 days)
constexpr double kMaxRunSteps = 1e8;

// why `dt` (s) cannot be a time step, or "" when it can
inline std::string timestep_problem(double dt) {
  if (!std::isfinite(dt)) return fmt::format("'{}' is not a finite number of seconds", dt);
  if (dt <= 0)
    return fmt::format("{:g} s: a time step must be positive (at least {:g} s)", dt, kMinTimestep);
  if (dt < kMinTimestep)
    return fmt::format(
        "{:g} s is below the smallest time step, {:g} s (a simulated second would "
        "take {:.3g} steps)",
        dt, kMinTimestep, 1 / dt);
  if (dt > kMaxTimestep)
    return fmt::format("{:g} s is above the largest time step, {:g} s", dt, kMaxTimestep);
  return "";
}

// why a run of `duration_s` at `dt` is too long to start, or "" when it is not
inline std::string step_count_problem(double duration_s, double dt) {
  const double steps = duration_s / dt;
  if (!(steps > kMaxRunSteps)) return "";
  return fmt::format(
      "duration {:g} s at timestep {:g} s is {:.3g} steps, more than {:.3g}: "
      "shorten the duration or raise the timestep",
      duration_s, dt, steps, kMaxRunSteps);
}

}  // namespace stance
