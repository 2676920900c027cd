// the retargeting's view of the model: its body tree and joints as probed (retarget_probe.cc),
// and a joint's coordinates written and solved; retarget.cc builds the pose table with them,
// retarget_sample.cc samples it
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "control/retarget.h"
#include "engine/engine.h"

namespace stance {

// a model body, with what probing found out about it and its joints
struct RetargetModelBody {
  int parent = -1;
  std::vector<RetargetJoint> joints;
  Eigen::Quaterniond rest_world = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond rest_local = Eigen::Quaterniond::Identity();  // B: parent^T * body at rest
  Eigen::Vector3d rest_pos = Eigen::Vector3d::Zero();
  int mapped = -1;  // index into the map's entries
  int depth = 0;
};

inline constexpr int kMaxHinges = 6;  // per body

// one joint of a model body, with what probing found out about it
using JointSlot = RetargetJoint;

// the rotation part of a ball or free joint in the engine's coordinates: MuJoCo stores a
// quaternion (w x y z; free: after the position), DART a rotation vector (free: before it)
void set_joint_rotation(const JointSlot& j, const Eigen::Quaterniond& r, Eigen::VectorXd& q);

template <class Q>
void set_joint_translation(const JointSlot& j, const Eigen::Vector3d& p, Q& q) {
  q.template segment<3>(j.qpos + (j.nq == 7 ? 0 : 3)) = p;
}

template <class Q>
Eigen::Vector3d frame_translation(const JointSlot& j, const Q& q) {
  return q.template segment<3>(j.qpos + (j.nq == 7 ? 0 : 3));
}

// the rotation of a body's hinge chain: the product of its hinges in joint order
Eigen::Quaterniond hinge_rotation(const std::vector<JointSlot>& joints, const double* angles);

// the hinge angles whose product is closest to `want` (Gauss-Newton from `angles`, then limits).
// With a bone direction `bone` (unit, body frame; zero: none), a chain too short to reach every
// rotation (fewer than three hinges) puts the bone on the wanted direction first and fits the
// twist only as well as it can: a two-hinge shoulder aims the upper arm rather than splitting
// the difference between aim and twist.
void solve_hinges(const std::vector<JointSlot>& joints, const Eigen::Quaterniond& want,
                  const Eigen::Vector3d& bone, double* angles, int n);

// the model's bodies (parents, depths) and the joints on each
std::vector<RetargetModelBody> read_model_tree(const Engine& probe);

// positions q at rest, kinematics updated
void set_pose(Engine& probe, const Eigen::VectorXd& q);

// Fills the bodies' rest poses (in q0, the zero pose it writes), hinge axes and ball/free joint
// frames by setting one coordinate at a time and reading the body's rotation; returns the
// inverse of the free joint's translation map (coordinates -> world displacement).
Eigen::Matrix3d probe_kinematics(Engine& probe, std::vector<RetargetModelBody>& model,
                                 const std::vector<int>& order, int free_body,
                                 const JointSlot& free_joint, Eigen::VectorXd& q0);

// A mapped body whose parent chain up to the next mapped body holds unmapped bodies of hinges
// only (a robot's hip, shoulder or ankle: one link per hinge) takes those hinges into its own
// fit, while it has fewer than three: its parent becomes the chain's top's parent, its
// rest_local the chain's, and each hinge's axis is turned into its frame (the product
// A1 H1 A2 H2 ... Am Hm is (A1 ... Am) times the hinges about the turned axes). The folded
// bodies keep no joints, so the fit leaves their coordinates to the mapped body's.
void fold_hinge_chains(std::vector<RetargetModelBody>& model, const std::vector<int>& order,
                       int free_body);

}  // namespace stance
