// What a BVH clip's character measures, taken the same way for every exporter: the legs and the
// standing height from the poses, the root's speed and the heading, and the warnings when these
// are not a person's (issue 43).
//
// The poses measured are the rest pose where it stands (its feet hang at least 2/3 as low below
// the root as in the posed frames do), and the posed frames: up to 64 spread over the clip, each
// joint at its keyed position where position channels replace its OFFSET. A rest pose that does
// not stand (Bandai Namco's bones all lie along X) is measured in the frames alone. Everything is
// measured below the body root (bvh_body_root), so that a carrier root on the floor does not
// count. Lengths are in file units unless named _m.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "motion/bvh.h"

namespace stance {

// whether a rest pose stands: it spans (along the up axis) at least 2/3 of what the posed frames
// span. Below that it lies (Bandai Namco's bones lie along X) and tells no height or facing.
inline bool rest_span_stands(double rest_span, double posed_span) {
  return rest_span >= posed_span * (2.0 / 3.0);
}

// the legs: the drop from the body root to its lowest leaf (end site or childless joint) along
// the up axis, in the rest pose, or in the posed frames (their largest) where the rest pose does
// not stand. File units; 0 when there is no leg. detect_bvh_scale_to_meters snaps it to a unit.
double bvh_leg_drop(const BvhClip& clip);

struct BvhCharacterMeasures {
  double scale_to_meters = 1;
  bool rest_pose_stands = true;  // the rest pose was measured with the frames
  double leg_m = 0;              // bvh_leg_drop in metres
  // the largest extent along the up axis, from the lowest joint or end site to the highest, over
  // the poses measured: the height the joints span standing (the head's end site, not its top)
  double standing_height_m = 0;
  // the body root's horizontal speed over 0.25 s windows, from the first motion frame: the mean
  // over the windows and the largest
  double mean_speed_mps = 0;
  double peak_speed_mps = 0;
  // at the first motion frame, where the character faces: across the line between its thighs,
  // towards where its toes point; horizontal, file axes; zero when nothing tells
  Eigen::Vector3d facing = Eigen::Vector3d::Zero();
  // the root's horizontal displacement from the first motion frame to the last, file axes
  Eigen::Vector3d travel = Eigen::Vector3d::Zero();
  char up_axis = 'y';  // the world's (detect_bvh_up_axis, posed)
};

// the measures at `scale_to_meters` (0: detect_bvh_scale_to_meters)
BvhCharacterMeasures measure_bvh_character(const BvhClip& clip, double scale_to_meters = 0);

// a horizontal direction's heading in degrees about the file's up axis, right-handed: from +Z
// towards +X for Y-up files, from +X towards +Y for Z-up files; NaN for a zero vector
double bvh_heading_deg(const Eigen::Vector3d& direction, char up_axis);

// what a person is: standing 1.0-2.3 m (the joints' span), the root at most 15 m/s
constexpr double kMinPersonHeightM = 1.0;
constexpr double kMaxPersonHeightM = 2.3;
constexpr double kMaxPersonSpeedMps = 15;

// one line per measure outside a person's range, naming the clip, the numbers and the setting
// that overrides the units (scale_to_meters); empty when the character is a person's size
std::vector<std::string> bvh_character_warnings(const BvhClip& clip, const BvhCharacterMeasures& m);

// the measures and warnings for `stance bvh info` ("character" in --json; lines of text)
nlohmann::json bvh_measures_json(const BvhClip& clip);
std::string bvh_measures_text(const BvhClip& clip);

}  // namespace stance
