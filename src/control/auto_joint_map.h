// The joint map found without a map file (`stance bvh track CLIP --model ROBOT`, no --map): the
// clip's segments paired with the model's bodies by role (pelvis, spine, chest, head, thighs,
// shins, feet, upper and lower arms), the roles found on each side by the tree's structure.
//
// On the model: the feet are the lowest leaf bodies of two chains that part high up; the pelvis
// is where they part; along each leg, bodies whose origins coincide (a hinge chain: three hinges
// at a hip on three bodies) form one joint, and the foot, shin and thigh are the last bodies of
// the first joint near the floor and the two joints above it. The hands are the leaves furthest
// to each side, the chest where their chains part, the spine the bodies between pelvis and
// chest, the head the highest leaf above the chest. On the clip, the legs are find_mocap_legs'.
// Names only decide sides (side_of_joint_name; else the model's rest pose, facing +x) and skip
// shoulder girdles (clavicle, scapula, collar) on the arms, so names may differ on every robot.
#pragma once

#include <string>
#include <vector>

#include "engine/engine.h"
#include "motion/joint_map.h"
#include "motion/reference_motion.h"

namespace stance {

// one role of the map: the clip segment and model body found for it (empty: not found there)
struct JointMapRole {
  std::string role;  // "pelvis", "left thigh", ...
  std::string segment, body;
  bool matched() const { return !segment.empty() && !body.empty(); }
};

struct AutoJointMap {
  JointMap map;                     // the matched roles; scale from the leg lengths
  std::vector<JointMapRole> roles;  // every role, matched or not, in a fixed order
  double clip_leg_length_m = 0;     // thigh to ankle, mean of the two legs
  double model_leg_length_m = 0;
};

// Finds the map of the clip's skeleton onto the model in `model` (its state is read as the rest
// pose). The names are the files', for messages. The model's up axis comes from its gravity.
// `posed`, when not empty, places the clip's segments instead of its rest pose (a frame of a
// clip whose rest pose does not stand). Throws InputError when either side has no two complete
// legs (thigh, shin, foot), naming the bodies (or the clip's joints) it saw.
AutoJointMap find_joint_map(const MotionSkeleton& clip, const std::string& clip_name,
                            const Engine& model, const std::string& model_name,
                            const std::vector<Eigen::Vector3d>& posed = {});

// bvh track without --map: the map of the clip file (read as a tracker reads it) onto the model
// file, loaded on `engine`; scale_to_meters 0: detected, as the tracker does
AutoJointMap find_joint_map_of_files(const std::string& bvh_path, const std::string& model_path,
                                     const std::string& engine, double scale_to_meters = 0);

// what was matched and what was not, one line per role, for the terminal
std::string joint_map_report(const AutoJointMap& found);

// the map as a YAML file that read_joint_map reads back (the same map), with comments
std::string joint_map_yaml(const AutoJointMap& found, const std::string& clip_name,
                           const std::string& model_name);

}  // namespace stance
