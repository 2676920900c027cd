// A BVH clip made ready to track: the skeleton reduced to simulated segments, units and axes
// converted (metres, Z-up), and a pose at any time t with slerp for rotations, linear
// interpolation for the root, target velocities from the quaternion derivative, optional looping
// with the root displacement accumulated, a clip range and ground alignment.
//
// Segments. Every BVH joint becomes one simulated segment (body), except:
//  - joints whose name contains one of `skip_name_patterns` ("_RIGMESH" helpers), with their
//    subtree, are dropped;
//  - a leaf joint without a usable End Site (MASS toes: zero length) is not a body: its offset
//  becomes
//    an end point of its parent's geometry;
//  - a joint at zero distance from its parent (CMU LHipJoint, lowerneck, lhand) is merged into
//    the parent segment: its children hang off the parent at the rest-pose offsets and its
//    rotation is composed into each child's local rotation (exact when, as in the CMU files,
//    the helper's rotation channels stay 0);
//  - a ROOT whose only child has position channels of its own (Bandai Namco's joint_Root on
//    the floor above a floating Hips) carries that child, which becomes the root segment: the
//    carrier's translation and rotation are composed into the root's (its rotation chain).
//
// Frames. BVH coordinates are converted by the constant rotation C taking the file's up axis to
// +z (Y-up: +90 deg about x): offsets become s C o and local rotations C R C^T, so the rest pose
// is the identity in the Z-up world.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "motion/bvh.h"

namespace stance {

struct MotionSkeletonOptions {
  double scale_to_meters = 0;  // metres per file unit; 0: detect_bvh_scale_to_meters
  // the file's up axis, 'y' or 'z'; 0: detect_bvh_up_axis, separately for the skeleton at rest
  // and for the world the frames pose it in
  char up_axis = 0;
  std::vector<std::string> skip_name_patterns = {"_RIGMESH"};
  double zero_length_m = 1e-3;  // offsets shorter than this count as zero length
  // end sites outside [min, max] are ignored: shorter ones are markers, longer ones rig
  // artefacts (MASS's right hand: 1.6 m)
  double min_end_site_m = 0.02;
  double max_end_site_m = 0.5;
};

// one simulated body
struct MotionSegment {
  std::string name;    // the BVH joint's name
  int bvh_joint = -1;  // index into BvhClip::joints
  int parent = -1;     // segment index; -1 for the root
  // BVH joints whose local rotations, multiplied in this order, give this segment's rotation
  // relative to its parent segment: merged helper joints (the root's carriers) first, the joint
  // itself last
  std::vector<int> rotation_chain;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // m, Z-up, in the parent frame at rest
  // end points of this segment's bones, m, in its own frame: children, end sites, and the
  // children and end sites of merged helpers (the geometry of bvh2mjcf)
  std::vector<Eigen::Vector3d> bone_ends;
  std::vector<int> children;  // segment indices
};

struct MotionSkeleton {
  std::vector<MotionSegment> segments;   // parents precede children; segments[0] is the root
  std::vector<int> segment_of_joint;     // per BVH joint: its segment, or -1 (merged/skipped)
  std::vector<std::string> joint_names;  // per BVH joint
  double scale_to_meters = 1;
  char up_axis = 'y';        // the skeleton's at rest, as read
  char world_up_axis = 'y';  // the world's, in which the frames pose the skeleton
  Eigen::Quaterniond to_z_up = Eigen::Quaterniond::Identity();        // C: rest frames
  Eigen::Quaterniond world_to_z_up = Eigen::Quaterniond::Identity();  // the root's world
  // where a detected scale makes no person (bvh_character_warnings): one line each, for the
  // commands to print; empty when scale_to_meters was given
  std::vector<std::string> warnings;

  int segment_count() const { return static_cast<int>(segments.size()); }
  // index of the segment called `name`, or -1
  int find_segment(const std::string& name) const;
  // segments without children: feet/toes, hands, head
  std::vector<int> end_effectors() const;
};

// throws InputError when the clip has no joints or its root is skipped
MotionSkeleton make_motion_skeleton(const BvhClip& clip, const MotionSkeletonOptions& options);

// the pose of the joints that carry the root segment (its rotation chain but its own joint) at
// `frame`, composed: file frame and units; the identity when nothing carries it
struct RootCarriers {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
};
RootCarriers root_carriers(const BvhClip& clip, const MotionSkeleton& skeleton, int frame);

// the root segment's position in the file's frame and units at `frame`: its own translation
// moved by its carriers
Eigen::Vector3d root_chain_translation(const BvhClip& clip, const MotionSkeleton& skeleton,
                                       int frame);

struct ReferenceOptions {
  // clip range, inclusive, in frames; last_frame < 0: to the end. start_s/end_s (>= 0) override.
  int first_frame = 0;
  int last_frame = -1;
  double start_s = -1;
  double end_s = -1;
  bool loop = false;  // repeat the clip, accumulating the root's displacement and yaw
  // looping: the seam's jump (from the last frame to the first of the next pass: every
  // rotation, the root's height) is spread over the last loop_blend_s of the range, so that a
  // cut which is no cycle joins itself without a jump; the root's heading and horizontal path
  // stay the clip's. A cycle has no jump and is left as it is.
  double loop_blend_s = 0;
  bool align_ground = true;  // shift so that the lowest point touches ground_height at start
  double ground_height_m = 0;
  bool align_whole_clip = false;  // align the lowest point over all frames, not the first's
  bool root_to_origin = true;     // start the root above the world origin (x = y = 0)
};

// a pose of the segments at one time
struct ReferencePose {
  Eigen::Vector3d root_position = Eigen::Vector3d::Zero();  // m, world
  Eigen::Vector3d root_velocity = Eigen::Vector3d::Zero();  // m/s, world
  // local rotation of each segment relative to its parent (segment 0: world orientation)
  std::vector<Eigen::Quaterniond> rotations;
  // angular velocity of each local rotation in the segment's own frame (q' = q [0, w] / 2):
  // what a MuJoCo ball joint's qvel, and the free joint's angular qvel, hold. rad/s.
  std::vector<Eigen::Vector3d> angular_velocities;
};

class ReferenceMotion {
 public:
  ReferenceMotion(const BvhClip& clip, MotionSkeleton skeleton, const ReferenceOptions& options);

  const MotionSkeleton& skeleton() const { return skeleton_; }
  int frame_count() const { return frame_count_; }  // frames in the clip range
  double frame_time_s() const { return frame_time_; }
  double duration_s() const { return (frame_count_ - 1) * frame_time_; }  // one pass
  bool loops() const { return options_.loop; }

  // a pose with its vectors sized for sample()
  ReferencePose make_pose() const;
  // the pose at time t (s from the range's first frame); clamps to the ends unless looping.
  // Allocates nothing when `out` came from make_pose().
  void sample(double t, ReferencePose& out) const;
  // the poses at t = 0, dt, 2 dt, ... up to duration_s (the simulation-rate table)
  std::vector<ReferencePose> resample(double dt_s, double duration_s) const;

  // world position (m) and orientation of each segment's frame; vectors sized segment_count
  void forward_kinematics(const ReferencePose& pose, std::vector<Eigen::Vector3d>& positions,
                          std::vector<Eigen::Quaterniond>& orientations) const;

  // the pose at a stored frame of the range (no interpolation)
  void frame_pose(int frame, ReferencePose& out) const;

  // what the ground alignment and the start above the origin added to every root position (m,
  // Z-up world): the clip's own frame is the reference's minus this
  const Eigen::Vector3d& alignment_shift_m() const { return alignment_shift_; }

 private:
  MotionSkeleton skeleton_;
  ReferenceOptions options_;
  int frame_count_ = 0;
  double frame_time_ = 0;
  int segments_ = 0;
  std::vector<Eigen::Quaterniond> rotations_;    // frame-major, converted and chained
  std::vector<Eigen::Vector3d> root_positions_;  // m, world (aligned)
  Eigen::Vector3d alignment_shift_ = Eigen::Vector3d::Zero();
  // one loop: the yaw and horizontal translation taking the first frame's root onto the last's
  Eigen::Quaterniond cycle_yaw_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d cycle_shift_ = Eigen::Vector3d::Zero();

  void blend_seam(double blend_s);
};

// A synthetic walking clip, generated by code so that demos and tests need no captured data:
// a 13-joint skeleton in centimetres, Y-up, walking along +Z, ZXY channels, one gait cycle of
// period_s plus the closing frame (the last frame is the first one a stride further on). Hips,
// knees, ankles, arms and the root height follow smooth periodic curves; the root advances at
// the speed the stance leg's swing implies, so the feet slide only a little. Not a captured
// human walk: a stand-in with the right structure. synthetic_run_options() makes it a run with
// a flight phase, generated the other way round so that a body can do it: the root at a
// constant speed, rising and falling as under a half-sine ground force in stance and
// ballistically in flight; the stance foot planted, its leg by inverse kinematics; the swing leg
// by smooth curves between take-off and landing.
struct SyntheticWalkOptions {
  std::string name = "synthetic_walk.bvh";  // the clip's source name
  double period_s = 1.1;                    // one full cycle (two steps)
  double frame_time_s = 1.0 / 60;
  double hip_amplitude_deg = 22;  // a walk's
  double knee_swing_deg = 55;     // a walk's extra knee flexion at mid-swing
  double stance_knee_deg = 0;     // a walk's extra knee flexion at mid-stance
  double arm_amplitude_deg = 15;
  double elbow_deg = 15;  // elbow flexion, and as much again at the back of the arm swing
  double lean_deg = 3;    // forward lean of the spine
  // a walk's root height oscillation at twice the cycle's frequency (cm), highest at mid-stance
  double bounce_cm = 1.2;
  double stride_scale = 1;  // a walk's root advance per cycle over the stance legs' sweep
  // > 0 (and < 0.5): a run; each leg stands this fraction of the cycle, and the rest between
  // the two stances is flight
  double stance_fraction = 0;
  double run_speed_mps = 2.5;      // a run's forward speed
  double run_knee_min_deg = 15;    // a run's least knee bend in stance (sets the root's height)
  double run_foot_pitch_deg = 30;  // a run's heel rise at take-off (flat at landing)
  double run_toe_ahead_cm = 0;     // a run's planted toe ahead of the hip at mid-stance
  double run_ankle_lift_cm = 30;   // a run's swing ankle raised at mid-swing over its path
  double run_step_width_cm = 8;    // a run's feet apart sideways (the hips are 18 cm apart)
};
BvhClip make_synthetic_walk_clip(const SyntheticWalkOptions& options = {});
// the synthetic run: 2.5 m/s at 171 steps a minute, 40% of each step in flight
SyntheticWalkOptions synthetic_run_options();

// the yaw (rotation about +z) part of an orientation whose body axes are a Z-up rest frame
Eigen::Quaterniond yaw_of(const Eigen::Quaterniond& q);

}  // namespace stance
