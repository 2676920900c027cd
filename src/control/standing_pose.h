// A standing pose found from the model instead of by trial and error (issue 45): the legs lean
// forward or back at the hips, with the ankles turned back by the same angle so that the feet
// stay flat and the torso upright, until the whole-body COM is over the centre of the feet along
// the character's forward axis. A robot whose zero pose has its COM ahead of or behind its feet
// (MuJoCo's humanoid.xml falls at 1.4 s in it) then starts, and is held, balanced.
//
// The feet are two named bodies, or the two lowest bodies (frame origins along up) of which
// neither hangs from the other. The centre of the feet is the mean of their centres of mass, a
// box or capsule foot's middle. On each leg the hip is the pitch hinge nearest the root and the
// ankle the one nearest the foot, a pitch hinge turning about the character's lateral axis
// (left = up x forward) within 45 degrees. Sideways the same with the roll hinges (about forward
// within 45 degrees): the legs lean left or right at the hips, the ankles turn back by as much,
// until the COM is over the feet's centre along left as well. A leg without a roll hinge at both
// hip and ankle (one-axis ankles) is not leaned sideways (`roll_searched` false).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "engine/engine.h"

namespace stance {

struct StandingPoseOptions {
  std::vector<std::string> feet;                       // 2 bodies, or empty: the lowest two
  Eigen::Vector3d forward = Eigen::Vector3d::UnitX();  // world; made normal to up
  double max_lean_rad = 0.4;                           // the search interval's half width
  double tolerance_m = 1e-5;                           // COM offset accepted
};

struct StandingPose {
  std::array<std::string, 2> feet;
  std::array<int, 2> hip{{-1, -1}}, ankle{{-1, -1}};  // dofs, per foot
  // +1 where the hinge turns its child about the character's left axis, -1 about right
  std::array<double, 2> hip_sign{{1, 1}}, ankle_sign{{1, 1}};
  double lean_rad = 0;         // the legs' forward lean (the hips turn by it, the ankles back)
  double offset_before_m = 0;  // COM ahead of the feet's centre, along forward, in the given pose
  double offset_m = 0;         // the same in the found pose
  // sideways: the roll hinges (dofs, -1 when a leg has none), +1 where the hinge turns its child
  // about +forward; the legs' lean about forward (the hips turn by it, the ankles back); the COM
  // left of the feet's centre before and after
  std::array<int, 2> hip_roll{{-1, -1}}, ankle_roll{{-1, -1}};
  std::array<double, 2> hip_roll_sign{{1, 1}}, ankle_roll_sign{{1, 1}};
  bool roll_searched = false;
  double roll_rad = 0;
  double lateral_before_m = 0;
  double lateral_m = 0;
};

// COM ahead of the feet's centre along forward (m) at lean `lean_rad` from the pose q0 (dim nq).
// Leaves the engine in that pose, forwarded.
double standing_com_offset(Engine& engine, const StandingPose& pose, const Eigen::Vector3d& forward,
                           const Eigen::VectorXd& q0, double lean_rad);
// the COM's offset from the feet's centre (along forward, along left; m) at lean `lean_rad` and
// sideways lean `roll_rad` (used where pose.roll_searched) from q0. Leaves the engine there.
Eigen::Vector2d standing_com_offsets(Engine& engine, const StandingPose& pose,
                                     const Eigen::Vector3d& forward, const Eigen::VectorXd& q0,
                                     double lean_rad, double roll_rad);

// Finds the lean from the engine's current pose and leaves the engine in it (forwarded).
// Throws InputError when the feet, hips or ankles cannot be found, or when no lean within
// max_lean_rad puts the COM over the feet.
StandingPose find_standing_pose(Engine& engine, const StandingPoseOptions& options);

// one line: the feet, the leans and the COM offsets before and after
std::string describe_standing_pose(const StandingPose& pose, const Engine& engine);

}  // namespace stance
