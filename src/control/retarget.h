// A BVH clip mapped onto an existing model through a YAML joint-name map (retargeting), for
// models not built by `stance bvh2mjcf`: MuJoCo's humanoid.xml, DART's fullbody1, your robot.
//
// The map pairs clip segments with model bodies. Each mapped body is turned the way its segment
// turns away from the rest pose, in the world:
//     R_b(t) = M W_s(t) A_s M^T R_b(rest)
// with W_s the segment's world rotation (rest = identity, Z-up), M the rotation from the clip's
// Z-up world to the model's world (its up axis and a yaw, found by aligning the two rest
// skeletons), and A_s a rest-pose correction that turns the model's bone onto the clip's bone
// direction (a model standing with its arms down then follows a clip recorded from a T-pose).
// Bodies are solved from the root down, each relative to its parent as actually posed, so a
// joint that cannot reach its target (a knee hinge asked to twist) leaves the error to be
// corrected by the bodies below. Hinge chains are solved by Gauss-Newton (continued from the
// previous frame), ball and free joints exactly; unmapped joints stay at zero.
//
// Everything about the model comes from probing a scratch engine (body tree, hinge axes, ball
// and free joint frames, translation directions), so the same map works on MuJoCo and DART.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "engine/engine.h"
#include "motion/joint_map.h"
#include "motion/reference_motion.h"

namespace stance {

// one joint of a model body, as probed: enough to turn a body rotation into coordinates
struct RetargetJoint {
  JointType type = JointType::kHinge;
  int qpos = -1, nq = 0;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();      // hinge, in the body frame
  Eigen::Matrix3d frame = Eigen::Matrix3d::Identity();  // ball/free: local = T Q T^T
  bool limited = false;
  double lower = 0, upper = 0;
};

// per mapped body: the joint rotation's dofs, for error metrics
struct RetargetBody {
  int body = -1;     // engine body
  int segment = -1;  // clip segment
  std::string name;  // "segment -> body"
  // the engine body its joint rotation is relative to: its parent, or above a hinge chain
  // folded into its fit (fold_hinge_chains: a robot's hip of three one-hinge links)
  int parent = -1;
};

class RetargetedMotion {
 public:
  // Builds the model's pose table at the clip's frame rate over [0, duration_s] (at least one
  // pass of the clip; the reference loops or clamps). `probe` is a scratch engine of the model:
  // its state is overwritten. Throws InputError for unknown names, a root segment that is not
  // mapped, or a model without a free root.
  // `level_feet`: clip segments (feet and toes) whose bodies are turned level while the clip
  // has them planted: within 2 cm of their planted height (the 20th percentile of their
  // heights) and below 0.3 m/s, fading out by 5 cm and 0.8 m/s. A foot whose capture is tilted
  // then stands on its sole, not on an edge.
  RetargetedMotion(const ReferenceMotion& reference, const JointMap& map, Engine& probe,
                   double duration_s, const std::vector<int>& level_feet = {});

  int nq() const { return nq_; }
  int nv() const { return nv_; }
  int frame_count() const { return frames_; }
  double frame_time_s() const { return frame_time_; }
  double duration_s() const { return (frames_ - 1) * frame_time_; }
  const std::vector<RetargetBody>& bodies() const { return bodies_; }
  double yaw_rad() const { return yaw_; }
  double scale() const { return scale_; }
  double height_offset_m() const { return height_offset_; }
  // mean and max geodesic angle (deg) between each mapped body's wanted world rotation and the
  // one its joints reach: what the model's joints cannot express (hinges asked to twist)
  double mean_fit_error_deg() const { return fit_error_mean_; }
  double max_fit_error_deg() const { return fit_error_max_; }
  // the same per mapped body (the order of bodies()), mean over the table
  double body_fit_error_deg(int i) const { return body_fit_error_[i]; }
  // the angle between each mapped body's bone (towards its one mapped child; 0 without one)
  // as posed and as wanted, mean over the table (deg): where the limbs point
  double body_aim_error_deg(int i) const { return body_aim_error_[i]; }

  // the pose and velocity at time t (clamped to the table), interpolated with the engine's own
  // position arithmetic; `scratch` has dim nv. Allocates nothing.
  void sample(const Engine& engine, double t, Eigen::Ref<Eigen::VectorXd> q,
              Eigen::Ref<Eigen::VectorXd> v, Eigen::Ref<Eigen::VectorXd> scratch) const;
  // the reference local rotation (relative to bodies()[i].parent) and world position of
  // each mapped body at time t; vectors sized bodies().size(). Allocates nothing.
  void sample_bodies(double t, std::vector<Eigen::Quaterniond>& local,
                     std::vector<Eigen::Vector3d>& position) const;
  // the reference world rotation of each mapped body at time t; sized bodies().size().
  // Allocates nothing.
  void sample_world(double t, std::vector<Eigen::Quaterniond>& world) const;
  // mapped body i's reference world pose at time t, and its local rotation (as sample_bodies'):
  // one body without work vectors, for queries on a const run (the planner's cost)
  BodyPose sample_body_pose(double t, int i) const;
  Eigen::Quaterniond sample_body_local(double t, int i) const;
  // mapped body i's reference world acceleration at time t: a central difference over +-30 ms,
  // which smooths the kinks of the frame-by-frame interpolation. Allocates nothing.
  Eigen::Vector3d sample_body_acceleration(double t, int i) const;
  // mapped body i's rest rotation relative to bodies()[i].parent (the joints at zero):
  // its world rotation is parent * rest_local * (joint rotation)
  const Eigen::Quaterniond& rest_local(int i) const { return rest_local_[i]; }
  // writes into q the joint coordinates of mapped body i that come closest to the joint
  // rotation `local` (hinges by the same fit as the table, warm-started from q; ball joints
  // exactly). Allocates nothing.
  void set_body_local(int i, const Eigen::Quaterniond& local, Eigen::VectorXd& q) const;
  // mapped bodies with no mapped body below them (feet, hands, head): indices into bodies()
  const std::vector<int>& end_bodies() const { return end_bodies_; }
  // back to the clip (export): the clip-world rotation of mapped body i's segment given the
  // body's world rotation, and the clip root position given the root-mapped body's position
  Eigen::Quaterniond clip_world_rotation(int i, const Eigen::Quaterniond& body_world) const;
  Eigen::Vector3d clip_root_position(const Eigen::Vector3d& body_position) const;
  // the stored pose of frame f
  Eigen::Map<const Eigen::VectorXd> frame(int f) const {
    return Eigen::Map<const Eigen::VectorXd>(q_.data() + static_cast<size_t>(f) * nq_, nq_);
  }

 private:
  int nq_ = 0, nv_ = 0, frames_ = 0;
  double frame_time_ = 0;
  double yaw_ = 0, scale_ = 1, height_offset_ = 0;
  double fit_error_mean_ = 0, fit_error_max_ = 0;
  std::vector<RetargetBody> bodies_;
  std::vector<double> q_, v_;              // frame-major
  std::vector<Eigen::Quaterniond> local_;  // frame-major, per mapped body
  std::vector<Eigen::Vector3d> position_;
  std::vector<int> end_bodies_;
  std::vector<double> body_fit_error_, body_aim_error_;
  Eigen::Quaterniond to_model_ = Eigen::Quaterniond::Identity();  // M
  Eigen::Vector3d up_ = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Quaterniond> rest_world_, rest_local_, bone_fix_;  // per mapped body
  std::vector<std::vector<RetargetJoint>> joints_;
  std::vector<Eigen::Vector3d> bone_;
  std::vector<Eigen::Quaterniond> world_;  // frame-major, per mapped body

  void locate(double t, int& frame, double& alpha) const;

  // the constructor's steps, in order, over its working state (retarget.cc)
  struct Build;
  void map_bodies(Build& b);          // the map's entries onto bodies_
  void find_character(Build& b);      // the free joint and the bodies under it, parents first
  void fit_rest_skeletons(Build& b);  // clip world -> model world: up, yaw_, scale_
  // the clip's first frame where its rest pose does not stand (for fit_rest_skeletons)
  void find_lying_rest(Build& b) const;
  void fix_bones(Build& b);  // rest-pose corrections and bone directions
  // where the rest pose does not stand: the corrections from the first frame's pose instead
  void fix_bones_from_first_frame(Build& b, const std::vector<std::vector<int>>& children);
  void keep_rest(Build& b, double duration_s);  // the rest members; the table's size
  void find_planted_feet(Build& b, const std::vector<int>& level_feet);
  void fit_frame(Build& b, int f);             // table frame f
  void solve_body(Build& b, int body, int f);  // one body's joints in frame f
  void put_on_ground(Build& b);                // height_offset_
  void finish(Build& b);                       // velocities, end bodies, the probe at frame 0
};

}  // namespace stance
