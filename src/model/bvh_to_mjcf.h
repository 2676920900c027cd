// A simulated character from a BVH skeleton (`stance bvh2mjcf IN.bvh OUT.xml`).
//
// One body per MotionSkeleton segment (see motion/reference_motion.h for which BVH joints are
// merged or skipped), named after its BVH joint, with a ball joint of the same name (the root
// gets a free joint "root"). Each bone is a capsule from the joint to the bone's end; segments
// named like a foot, toe or ankle get one box spanning their bones down to the sole. Masses
// come from a total mass shared by geometric volume (one density for every geom). Body frames
// are the BVH rest frames turned Z-up, so a ball joint's quaternion is the segment's local
// rotation from ReferenceMotion as is. A keyframe "start" holds the reference pose and
// velocity at t = 0 of the clip range.
#pragma once

#include <string>
#include <vector>

#include "motion/bvh.h"
#include "motion/reference_motion.h"

namespace stance {

struct BvhCharacterOptions {
  double total_mass_kg = 70;
  double timestep_s = 0.002;
  double limb_radius_fraction = 0.13;  // capsule radius per bone length
  double min_radius_m = 0.025;
  double max_radius_m = 0.07;
  double foot_half_width_m = 0.045;
  double heel_length_m = 0.05;  // foot box behind the ankle
  double armature = 0.01;       // kg m^2 on every ball-joint dof (numerical stiffness margin)
  double friction = 1.0;
  // human-like torque limits on the joints (human_torque_limit_nm), written as each joint's
  // actuatorfrcrange; whether a run clamps to them is the scenario's torque_limits
  bool human_limits = false;
  MotionSkeletonOptions skeleton;
  ReferenceOptions reference;  // for the "start" keyframe
};

struct BvhCharacter {
  std::string mjcf;  // the model text
  MotionSkeleton skeleton;
  double total_volume_m3 = 0;
  double density_kg_m3 = 0;
};

// the character of a clip; throws InputError for clips without bones
BvhCharacter make_bvh_character(const BvhClip& clip, const BvhCharacterOptions& options);

// A person's peak joint torque, by the joint group a segment's name tells (the joint at the
// segment's origin: "LeftUpLeg" is a hip, "LeftLeg" a knee, "LeftArm" a shoulder), in N m per kg
// of body mass: the larger of the two directions of the group's main axis, from dynamometry of
// healthy adults (docs/mocap.md cites the sources). 0 for a name that tells no group.
double human_peak_torque_nm_per_kg(const std::string& segment_name);
// that times the character's mass: the limit bvh2mjcf writes (0: none)
double human_torque_limit_nm(const std::string& segment_name, double total_mass_kg);

// true for segment names of a foot (foot, toe, ankle; case-insensitive)
bool is_foot_segment_name(const std::string& name);

// per segment: a foot or a toe (they get a foot box, and the tracker finds the legs by them).
// By name; where the names mark fewer than two feet, the segments whose joints sit in the lowest
// quarter of the skeleton's height at rest.
std::vector<bool> foot_segments(const MotionSkeleton& skeleton);

// reads a BVH file and writes the character's MJCF; throws InputError on bad input
void write_bvh_character(const std::string& bvh_path, const std::string& mjcf_path,
                         const BvhCharacterOptions& options);

}  // namespace stance
