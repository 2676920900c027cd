// The pieces of motion-capture tracking that do not depend on how the clip reaches the model:
// reading a clip and its options (MocapClipParams, load_mocap_clip), the assisted mode's helper
// gains, the free mode's balance parameters, the legs of a skeleton, the identity joint map of
// a `stance bvh2mjcf` character, the Coros virtual-force torques, and writing the simulated
// motion back as BVH. The tracker itself is control/mocap_retarget_tracker.h.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "control/controller.h"
#include "engine/engine.h"
#include "motion/bvh.h"
#include "motion/joint_map.h"
#include "motion/reference_motion.h"

namespace stance {

// the clip and how it is read: shared by the trackers
struct MocapClipParams {
  std::string bvh;               // clip; relative paths start at the scenario's folder
  double scale_to_meters = 0;    // 0: detect from the leg length
  std::string up_axis = "auto";  // the file's up axis: y, z, or auto (detect_bvh_up_axis)
  int first_frame = 0;
  // first_frame 0 and no start_s: start after leading frames that jump to the motion (a T-pose
  // first frame, as in cgspeed's CMU release: detect_bvh_first_motion_frame)
  bool skip_leading_pose = true;
  int last_frame = -1;  // -1: the last
  double start_s = -1;  // >= 0: overrides first_frame
  double end_s = -1;    // >= 0: overrides last_frame
  bool loop = true;
  double loop_blend_s = 0.2;  // the last seconds of a pass cross-faded onto its first frame
  bool align_ground = true;
  std::string ground = "start";  // align at the start, or the lowest point of the whole clip
  std::string export_bvh;        // write the simulated motion here (relative: to the output)
  // the export where the reference is (started above the origin, on the ground), not where the
  // clip is
  bool export_origin_centred = false;

  template <class V>
  void visit(V& v) {
    v("bvh", bvh, {.help = "BVH clip to track"});
    v("scale_to_meters", scale_to_meters, {.unit = "m", .min = 0, .help = "0: detect"});
    v("up_axis", up_axis, {.help = "the file's up axis: y, z, or auto (from the legs)"});
    v("first_frame", first_frame, {.min = 0, .help = "first clip frame tracked"});
    v("skip_leading_pose", skip_leading_pose,
      {.help = "first_frame 0: start after leading frames that jump to the motion (a T-pose)"});
    v("last_frame", last_frame, {.min = -1, .help = "-1: the last frame"});
    v("start_s", start_s, {.unit = "s", .min = -1, .help = ">= 0: overrides first_frame"});
    v("end_s", end_s, {.unit = "s", .min = -1, .help = ">= 0: overrides last_frame"});
    v("loop", loop, {.help = "repeat the clip, accumulating the root displacement"});
    v("loop_blend_s", loop_blend_s,
      {.unit = "s", .min = 0, .max = 10, .help = "loop: cross-fade the seam over this time"});
    v("align_ground", align_ground, {.help = "lowest point on the floor at the start"});
    v("ground", ground,
      {.help = "start: lowest point at the start on the floor; clip: over the clip"});
    v("export_bvh", export_bvh, {.help = "write the simulated motion as BVH"});
    v("export_origin_centred", export_origin_centred,
      {.help = "export_bvh: start above the origin, on the ground (not in the clip's own frame)"});
  }
};

// the assisted mode's helper: PD gains on the root, inside the SPD solve
struct MocapHelperParams {
  double root_kp = 20000;     // assisted: N/m on the root position
  double root_kd = 2000;      // N s/m
  double root_kp_rot = 2000;  // N m/rad on the root orientation
  double root_kd_rot = 200;   // N m s/rad

  template <class V>
  void visit(V& v) {
    v("root_kp", root_kp, {.unit = "N/m", .min = 0, .max = 1e8, .help = "assisted mode"});
    v("root_kd", root_kd, {.unit = "N s/m", .min = 0, .max = 1e7});
    v("root_kp_rot", root_kp_rot, {.unit = "N m/rad", .min = 0, .max = 1e8});
    v("root_kd_rot", root_kd_rot, {.unit = "N m s/rad", .min = 0, .max = 1e7});
  }
};

// free mode's balance layer (docs/mocap.md, "Tracking")
struct MocapBalanceParams {
  bool balance = true;
  double cd_sagittal = 0.5;  // rad/m: swing-thigh feedback on the root's offset from the ankle
  double cv_sagittal = 0.2;  // rad s/m: ... and on its velocity
  double cd_coronal = 0.5;
  double cv_coronal = 0.2;
  double path_feedback = 0.15;  // rad/m: swing thigh per metre of the root off the clip's path
  double heading_return = 0.2;  // fraction of the heading error the targets do not follow
  double stance_hip_world_weight = 1;  // stance hip: 1 servoes the pelvis, 0 the reference angle
  bool swing_foot_world = false;       // swing foot at its reference world orientation
  bool level_planted_feet = true;   // free mode: the clip's planted feet turned level (retarget.h)
  double gravity_compensation = 0;  // weight fraction carried through the stance leg(s)
  double reference_support = 0.5;   // share of the clip root's vertical force m (g + a) carried too
  double root_force_kp = 0;         // N/m: virtual force holding the root over the stance foot
  double root_force_kd = 150;       // N s/m: the clip root's speed, held through the stance leg
  double root_force_kd_z = 0;       // N s/m, along up
  // ankles under 1 N m/kg (control/mocap_weak_ankles.h): the clip's swing foot swung even where
  // it scuffs, and lifted by as much as the root rides below the clip's
  bool weak_ankles = true;
  std::string left_hip, right_hip;    // thigh joints (clip names); empty: found from the feet
  std::string left_foot, right_foot;  // feet; empty: the first foot/toe/ankle segment per leg

  template <class V>
  void visit(V& v) {
    v("balance", balance, {.help = "free mode: SIMBICON balance layer"});
    v("cd_sagittal", cd_sagittal, {.unit = "rad/m", .min = -100, .max = 100});
    v("cv_sagittal", cv_sagittal, {.unit = "rad s/m", .min = -100, .max = 100});
    v("cd_coronal", cd_coronal, {.unit = "rad/m", .min = -100, .max = 100});
    v("cv_coronal", cv_coronal, {.unit = "rad s/m", .min = -100, .max = 100});
    v("path_feedback", path_feedback,
      {.unit = "rad/m",
       .min = -10,
       .max = 10,
       .help = "free mode: steps back towards the clip's root path"});
    v("heading_return", heading_return,
      {.min = 0, .max = 1, .help = "free mode: share of the heading error steered back"});
    v("stance_hip_world_weight", stance_hip_world_weight,
      {.min = 0, .max = 1, .help = "free mode: 1 pelvis servo, 0 the reference hip angle"});
    v("swing_foot_world", swing_foot_world, {.help = "free mode: swing foot world orientation"});
    v("level_planted_feet", level_planted_feet,
      {.help = "free mode: turn the clip's planted feet level"});
    v("gravity_compensation", gravity_compensation,
      {.min = 0, .max = 2, .help = "free mode: weight fraction carried through the stance leg"});
    v("reference_support", reference_support,
      {.min = 0,
       .max = 2,
       .help = "free mode: share of the clip root's vertical force carried by the stance leg"});
    v("root_force_kp", root_force_kp,
      {.unit = "N/m", .min = 0, .max = 1e6, .help = "free mode: virtual root force, horizontal"});
    v("root_force_kd", root_force_kd, {.unit = "N s/m", .min = 0, .max = 1e6});
    v("root_force_kd_z", root_force_kd_z, {.unit = "N s/m", .min = 0, .max = 1e6});
    v("weak_ankles", weak_ankles,
      {.help = "free mode: on ankles under 1 N m/kg, swing the clip's swing foot, lifted"});
    v("left_hip", left_hip);
    v("right_hip", right_hip);
    v("left_foot", left_foot);
    v("right_foot", right_foot);
  }
};

// a clip read and made ready to track
struct MocapClip {
  std::shared_ptr<const BvhClip> clip;
  std::shared_ptr<const ReferenceMotion> reference;
  int first_frame = 0;  // of the clip range, in the clip
};
// reads params.bvh (relative to base_dir) and builds its reference; throws InputError
MocapClip load_mocap_clip(const MocapClipParams& params, const std::string& base_dir);

// a clip on the source's skeleton from per-frame segment poses: local rotations (Z-up, as in
// ReferencePose::rotations; frame-major, segment_count per frame) and root positions (m, Z-up
// world of the reference). Joints that are no segment keep the clip's values at the matching
// frame of the range. The root is put back in the clip's own frame (the reference's alignment
// shift taken off), so that the clip overlays its source, unless `origin_centred`.
BvhClip clip_from_segment_poses(const MocapClip& mocap,
                                const std::vector<Eigen::Quaterniond>& locals,
                                const std::vector<Eigen::Vector3d>& roots,
                                bool origin_centred = false);
// writes clip to export_path (relative: to out_dir)
void write_exported_bvh(const BvhClip& clip, const std::string& export_path,
                        const std::string& out_dir);
// whether two clip settings read the same clip the same way and export alike (a run's State
// made under one can go on under the other)
bool same_mocap_clip(const MocapClipParams& a, const MocapClipParams& b);
// the folder relative clip and map paths start at: the scenario file's
std::string mocap_base_dir(const ControllerContext& ctx);
// the recorded frames a run reserves, at the clip's frame rate: the run's length (at least
// two minutes, as a viewer runs on), plus a frame; at most 2^20 + 1 (more grow on demand)
size_t mocap_record_frames(double duration_s, double frame_time_s);

enum class MocapRootMode { kKinematic, kAssisted, kFree };

// the joint torques that push the whole-body COM with a virtual force F (N, world) while the
// support body pushes back with -F at the same point (Coros et al. 2010):
// tau += (J_com - J_support(com))^T F, dim nv. The two forces cancel, so the free root's share is
// zero: these are internal torques on the joints between the support body and every other body.
// jac_com is the engine's COM Jacobian (3 x nv); jac_scratch is 3 x nv scratch.
void add_com_support_torque(const Engine& engine, int support_body, const Eigen::Vector3d& force,
                            const Eigen::MatrixXd& jac_com, Eigen::MatrixXd& jac_scratch,
                            Eigen::VectorXd& tau);

// the side a joint's name gives: -1 left, +1 right, 0 none. Reads "Left"/"Right" and "L"/"R" as
// words (LeftFoot, Foot_R, "Bip01 L Foot", lFoot, mixamorig:RightFoot) and run-on lower-case
// names (leftfoot, rfemur).
int side_of_joint_name(const std::string& name);

// the legs of a skeleton: per side (left, right) the thigh segment and the topmost foot segment
// (named like a foot, toe or ankle), or -1. The side comes from the name, else from the toes'
// direction; each thigh is the top of its leg below the segment where the legs part. Non-empty
// names (left_hip, right_hip, left_foot, right_foot) override; unknown ones throw InputError.
void find_mocap_legs(const MotionSkeleton& skeleton, const std::array<std::string, 4>& names,
                     int hip[2], int foot[2]);

// the joint map of a character built from the clip by `stance bvh2mjcf` (bodies named after the
// skeleton's segments): every segment onto its own body, no yaw, scale 1, no height offset and
// no rest-pose correction, so that the retargeted table is the reference itself. Throws
// InputError naming the first segment the model has no body for.
JointMap bvh_character_joint_map(const MotionSkeleton& skeleton, const Engine& engine);

// "kinematic", "assisted", "free"; throws InputError otherwise
MocapRootMode parse_mocap_root_mode(const std::string& mode);

}  // namespace stance
