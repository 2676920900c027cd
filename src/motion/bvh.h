// BVH motion capture: reader, writer, unit detection and a summary for `stance bvh info`.
//
// The reader converts each joint's Euler channels, in that joint's own listed order, to a
// quaternion once at load (see math/rotations.h for the convention: "Zrotation Xrotation
// Yrotation" means R = Rz * Rx * Ry). Errors throw InputError with "file:line: message".
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "math/rotations.h"

namespace stance {

enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

// "Xposition", ..., "Zrotation"
std::string_view bvh_channel_name(BvhChannel channel);

// one ROOT or JOINT entry; End Sites are folded into their parent
struct BvhJoint {
  std::string name;
  int parent = -1;                                   // index into BvhClip::joints; -1 for a root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // from the parent, file units
  std::vector<BvhChannel> channels;                  // as listed in the file
  int first_column = 0;                              // column of channels[0] in a motion row
  // rotation order of the listed rotation channels; axes a joint does not list (fewer than
  // three rotation channels) are appended in x, y, z order and always have angle 0
  RotationOrder order = RotationOrder::kZXY;
  int rotation_channel_count = 0;  // 0..3
  bool has_position = false;       // lists at least one position channel
  int position_slot = -1;          // index among joints with position, or -1
  bool has_end_site = false;
  Eigen::Vector3d end_site_offset = Eigen::Vector3d::Zero();  // file units, if has_end_site
  int line = 0;                                               // of its ROOT / JOINT keyword
};

// a whole file. Joints are in file (depth-first) order, so parents precede children.
struct BvhClip {
  std::string source;  // file name used in messages
  std::vector<BvhJoint> joints;
  int frame_count = 0;
  int frames_line = 0;  // of "Frames:" (0: not read from a file), for messages
  double frame_time_s = 0.0;
  int channel_count = 0;  // values per motion row

  // the motion rows as read (degrees, file units), frame_count x channel_count. The writer does
  // not use it: it writes from `rotations` and `positions`, so edit those.
  Eigen::MatrixXd raw;

  // local rotation of each joint relative to its parent, frame-major:
  // rotations[frame * joints.size() + joint]
  std::vector<Eigen::Quaterniond> rotations;

  // translation in the parent frame of each joint that has position channels, frame-major:
  // positions[frame * position_joint_count + joint.position_slot]. File units. The channels
  // replace the joint's OFFSET; axes without a channel keep the OFFSET value.
  std::vector<Eigen::Vector3d> positions;
  int position_joint_count = 0;

  int joint_count() const { return static_cast<int>(joints.size()); }
  const Eigen::Quaterniond& rotation(int frame, int joint) const {
    return rotations[static_cast<size_t>(frame) * joints.size() + joint];
  }
  Eigen::Quaterniond& rotation(int frame, int joint) {
    return rotations[static_cast<size_t>(frame) * joints.size() + joint];
  }
  // translation of `joint` in its parent frame at `frame`: the position channels if it has them,
  // else its OFFSET
  Eigen::Vector3d translation(int frame, int joint) const {
    const BvhJoint& j = joints[joint];
    if (j.position_slot < 0) return j.offset;
    return positions[static_cast<size_t>(frame) * position_joint_count + j.position_slot];
  }
  // index of the joint called `name`, or -1
  int find_joint(std::string_view name) const;
};

// limits of the reader, each rejected with a located message: joints (ROOT + JOINT entries) and
// how deep they nest (within the 96 nested bodies MuJoCo reads, for bvh2mjcf's character)
constexpr int kMaxBvhJoints = 1000;
constexpr int kMaxBvhDepth = 90;
// the frame time every command accepts: 10 kHz to 1 Hz. Exporters write 24 to 240 Hz, optical
// capture reaches 1 kHz; a shorter step is a unit slip (ms read as s), and the recording and
// resampling of a run grow with the frame rate.
constexpr double kMinBvhFrameTimeS = 1e-4;
constexpr double kMaxBvhFrameTimeS = 1.0;
// the largest OFFSET or position channel value, in file units (1e7 mm is 10 km): beyond it a
// character's bodies or its path are no measurement but a corrupt file
constexpr double kMaxBvhCoordinate = 1e7;

// reads and parses a BVH file (the whole file is read into memory first). One ROOT per file.
// Joint names are UTF-8 without braces or control characters, so that they write back, and
// unique. The text is ASCII or UTF-8 (a UTF-8 byte order mark is skipped; UTF-16 is refused by
// name). Frame time and coordinates are checked against the limits above.
BvhClip read_bvh(const std::string& path);

// parses BVH text; name_for_errors prefixes error messages ("name:line: ...")
BvhClip parse_bvh(std::string_view text, const std::string& name_for_errors);

// BVH text of a clip, LF line endings. Angles come from `rotations` in each joint's own channel
// order, kept continuous from frame to frame and rounded to 1e-9 deg; positions and offsets
// are written exactly (shortest round-trip form), so read -> write -> read agrees to 1e-9.
std::string format_bvh(const BvhClip& clip);

// writes format_bvh(clip) to path (atomically, streamed); throws InputError when it cannot
void write_bvh(const BvhClip& clip, const std::string& path);

// a joint's translation from its parent at rest: its OFFSET, or for a joint with position
// channels (they replace the OFFSET), their mean over the frames. Exporters that key every
// joint's position mostly repeat the OFFSET there, but not all do.
Eigen::Vector3d bvh_rest_translation(const BvhClip& clip, int joint);

// the joint the body hangs from: the ROOT, or, below a ROOT that only carries one child with
// position channels of its own (Bandai Namco's static joint_Root on the floor above a floating
// Hips), that child (repeatedly). Units and up axis are measured below it, and
// make_motion_skeleton makes it the root segment.
int bvh_body_root(const BvhClip& clip);

// meters per file unit, detected from the leg length: the rest-pose drop from the root to the
// lowest end site along the up axis (Y, or Z when that drop is larger). Snaps to metres,
// centimetres, millimetres, inches, feet or CMU units (0.056444 m) when one of them gives a
// human leg of 0.45..1.5 m, else scales that leg to 0.9 m. 1.0 when there is no leg to measure.
double detect_bvh_scale_to_meters(const BvhClip& clip);

// the file's up axis, 'y' or 'z': the one along which the feet hang lowest below the root. With
// `posed`, in the first frame's pose (the world's up axis: a Y-up skeleton that every frame
// turns onto Z-up is Z-up), else in the rest pose (the skeleton's own). 'y', the BVH norm, when
// there is no leg to measure.
char detect_bvh_up_axis(const BvhClip& clip, bool posed = true);

// the unit name behind detect_bvh_scale_to_meters: "meters", "centimeters", "millimeters",
// "inches", "feet", "cmu", or "unknown"
std::string detect_bvh_units(const BvhClip& clip);

// the first frame of the motion: 0, or 1..3 after the last jump among the first three steps
// (a step that turns a joint by ten typical steps and at least 30 deg, or moves a joint by ten
// typical steps and at least 0.25 m): leading T-pose frames, as cgspeed's CMU release has
int detect_bvh_first_motion_frame(const BvhClip& clip);

// summary for `stance bvh info --json`: frames, frame_time, joints (ROOT + JOINT entries),
// end_sites, channels (per frame), duration_s (frames * frame_time), rotation_orders
// ({joint name: "ZXY"}), units, scale_to_meters, up_axis, first_motion_frame
nlohmann::json bvh_info_json(const BvhClip& clip);

// the same summary as readable text, with the joint tree
std::string bvh_info_text(const BvhClip& clip);

}  // namespace stance
