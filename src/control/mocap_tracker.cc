#include "control/mocap_tracker.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "core/error.h"
#include "math/rotations.h"
#include "model/bvh_to_mjcf.h"

namespace stance {

namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

Eigen::Quaterniond read_quat(const Eigen::VectorXd& q, int adr) {
  return Eigen::Quaterniond(q[adr], q[adr + 1], q[adr + 2], q[adr + 3]);
}
void write_quat(Eigen::VectorXd& q, int adr, const Eigen::Quaterniond& r) {
  q[adr] = r.w();
  q[adr + 1] = r.x();
  q[adr + 2] = r.y();
  q[adr + 3] = r.z();
}

}  // namespace

void add_com_support_torque(const Engine& engine, int support_body, const Eigen::Vector3d& force,
                            const Eigen::MatrixXd& jac_com, Eigen::MatrixXd& jac_scratch,
                            Eigen::VectorXd& tau) {
  // the reaction -F acts at the COM's location, as a point of the support body
  Eigen::Map<Eigen::MatrixXd> none(nullptr, 3, 0);
  engine.point_jacobian(support_body, engine.com(), jac_scratch, none);
  jac_scratch = jac_com - jac_scratch;
  tau.noalias() += jac_scratch.transpose() * force;
}

MocapRootMode parse_mocap_root_mode(const std::string& mode) {
  if (mode == "kinematic") return MocapRootMode::kKinematic;
  if (mode == "assisted") return MocapRootMode::kAssisted;
  if (mode == "free") return MocapRootMode::kFree;
  throw InputError(fmt::format("mode: expected kinematic, assisted or free, found '{}'", mode));
}

std::string mocap_base_dir(const ControllerContext& ctx) {
  return std::filesystem::path(ctx.source.file).parent_path().string();
}

size_t mocap_record_frames(double duration_s, double frame_time_s) {
  return static_cast<size_t>(std::max(120.0, duration_s) / frame_time_s) + 1;
}

bool same_mocap_clip(const MocapClipParams& a, const MocapClipParams& b) {
  return a.bvh == b.bvh && a.scale_to_meters == b.scale_to_meters && a.up_axis == b.up_axis &&
         a.first_frame == b.first_frame && a.last_frame == b.last_frame && a.start_s == b.start_s &&
         a.end_s == b.end_s && a.loop == b.loop && a.align_ground == b.align_ground &&
         a.ground == b.ground && a.export_bvh == b.export_bvh;
}

MocapClip load_mocap_clip(const MocapClipParams& params, const std::string& base_dir) {
  if (params.bvh.empty()) throw InputError("bvh: a BVH file is required");
  std::filesystem::path path(params.bvh);
  if (path.is_relative() && !base_dir.empty()) path = std::filesystem::path(base_dir) / path;
  auto clip = std::make_shared<BvhClip>(read_bvh(path.string()));
  MotionSkeletonOptions so;
  so.scale_to_meters = params.scale_to_meters;
  if (params.up_axis.size() != 1) throw InputError("up_axis: expected y or z");
  so.up_axis = params.up_axis[0];
  ReferenceOptions ro;
  ro.first_frame = params.first_frame;
  ro.last_frame = params.last_frame;
  ro.start_s = params.start_s;
  ro.end_s = params.end_s;
  ro.loop = params.loop;
  ro.align_ground = params.align_ground;
  ro.align_whole_clip = params.ground == "clip";
  if (params.ground != "clip" && params.ground != "start")
    throw InputError("ground: expected start or clip, found '" + params.ground + "'");
  MocapClip out;
  out.first_frame = params.start_s >= 0
                        ? static_cast<int>(std::lround(params.start_s / clip->frame_time_s))
                        : params.first_frame;
  out.reference = std::make_shared<ReferenceMotion>(*clip, make_motion_skeleton(*clip, so), ro);
  out.clip = clip;
  return out;
}

void find_mocap_legs(const MotionSkeleton& sk, const std::array<std::string, 4>& names, int hip[2],
                     int foot[2]) {
  auto find = [&](const std::string& name, const char* what) {
    int k = sk.find_segment(name);
    if (k < 0) throw InputError(fmt::format("{}: unknown joint '{}'", what, name));
    return k;
  };
  hip[0] = hip[1] = foot[0] = foot[1] = -1;
  // the topmost foot segment of each chain, and the root's child above it
  for (int k = 1; k < sk.segment_count(); ++k) {
    if (!is_foot_segment_name(sk.segments[k].name)) continue;
    bool top = true;
    for (int a = sk.segments[k].parent; a > 0; a = sk.segments[a].parent)
      if (is_foot_segment_name(sk.segments[a].name)) top = false;
    if (!top) continue;
    int side = lower(sk.segments[k].name).find("right") != std::string::npos ||
                       sk.segments[k].name[0] == 'R'
                   ? 1
                   : 0;
    if (foot[side] < 0) foot[side] = k;
  }
  if (!names[2].empty()) foot[0] = find(names[2], "left_foot");
  if (!names[3].empty()) foot[1] = find(names[3], "right_foot");
  for (int side = 0; side < 2; ++side) {
    int k = foot[side];
    while (k > 0 && sk.segments[k].parent > 0) k = sk.segments[k].parent;
    hip[side] = k > 0 ? k : -1;
  }
  if (!names[0].empty()) hip[0] = find(names[0], "left_hip");
  if (!names[1].empty()) hip[1] = find(names[1], "right_hip");
}

namespace {

// the clip, its reference and the engine indices, gains, end effectors and legs
MocapTrackerModel make_tracker_model(const MocapTrackerParams& params, const Engine& engine,
                                     const std::string& base_dir) {
  MocapTrackerModel m;
  m.params = params;
  m.mode = parse_mocap_root_mode(params.mode);
  MocapClip loaded = load_mocap_clip(params, base_dir);
  m.first_frame = loaded.first_frame;
  m.clip = loaded.clip;
  m.reference = loaded.reference;
  const ReferenceMotion* ref = m.reference.get();
  const MotionSkeleton& sk = ref->skeleton();
  const int n = sk.segment_count();

  // engine indices: bodies named after segments, ball joints likewise, free joint on the root
  m.body.resize(n);
  m.qpos_adr.resize(n);
  m.dof_adr.resize(n);
  for (int k = 0; k < n; ++k) {
    const std::string& name = sk.segments[k].name;
    m.body[k] = engine.body_index(name);
    if (m.body[k] < 0)
      throw InputError(
          fmt::format("bvh: the model has no body '{}' for the clip's joint (build the "
                      "model with `stance bvh2mjcf`){}",
                      name, did_you_mean(name, engine.body_names())));
    int joint = -1;
    for (int j = 0; j < engine.njoint(); ++j)
      if (engine.joint(j).body == m.body[k]) joint = j;
    if (joint < 0) throw InputError("body '" + name + "' has no joint");
    const JointInfo& info = engine.joint(joint);
    JointType want = k == 0 ? JointType::kFree : JointType::kBall;
    int want_nq = k == 0 ? 7 : 4;
    if (info.type != want || info.nq != want_nq)
      throw InputError(fmt::format("joint '{}': expected a {} joint with a quaternion (MuJoCo)",
                                   info.name, k == 0 ? "free" : "ball"));
    m.qpos_adr[k] = info.qpos_adr;
    m.dof_adr[k] = info.dof_adr;
  }
  if (engine.nv() != 3 * n + 3)
    throw InputError(
        fmt::format("the model has {} dofs; the clip's character has {}", engine.nv(), 3 * n + 3));

  // gains: joints, then the root in assisted mode
  const int nv = engine.nv();
  m.kp = Eigen::VectorXd::Zero(nv);
  m.kd = Eigen::VectorXd::Zero(nv);
  for (int k = 1; k < n; ++k) {
    const std::string& name = sk.segments[k].name;
    double kp = params.kp, kd = params.kd;
    if (auto it = params.kp_joints.find(name); it != params.kp_joints.end()) kp = it->second;
    if (auto it = params.kd_joints.find(name); it != params.kd_joints.end()) kd = it->second;
    m.kp.segment<3>(m.dof_adr[k]).setConstant(kp);
    m.kd.segment<3>(m.dof_adr[k]).setConstant(kd);
  }
  for (const auto& table : {params.kp_joints, params.kd_joints})
    for (const auto& [name, value] : table)
      if (sk.find_segment(name) < 1)
        throw InputError(fmt::format("kp_joints/kd_joints: unknown joint '{}'", name));
  if (m.mode == MocapRootMode::kAssisted) {
    m.kp.segment<3>(m.dof_adr[0]).setConstant(params.root_kp);
    m.kd.segment<3>(m.dof_adr[0]).setConstant(params.root_kd);
    m.kp.segment<3>(m.dof_adr[0] + 3).setConstant(params.root_kp_rot);
    m.kd.segment<3>(m.dof_adr[0] + 3).setConstant(params.root_kd_rot);
  }

  // end effectors: leaf segments, at their furthest bone end
  for (int k : sk.end_effectors()) {
    Eigen::Vector3d tip = Eigen::Vector3d::Zero();
    for (const auto& e : sk.segments[k].bone_ends)
      if (e.norm() > tip.norm()) tip = e;
    m.end_effectors.push_back(k);
    m.end_points.push_back(tip);
  }

  find_mocap_legs(sk, {params.left_hip, params.right_hip, params.left_foot, params.right_foot},
                  m.hip, m.foot);
  for (int side = 0; side < 2; ++side) {
    if (m.foot[side] < 0) continue;
    for (int k = 0; k < n; ++k)
      for (int a = k; a > 0; a = sk.segments[a].parent)
        if (a == m.foot[side]) {
          m.foot_bodies[side].push_back(m.body[k]);
          break;
        }
  }
  if (m.mode == MocapRootMode::kFree && params.balance &&
      (m.hip[0] < 0 || m.hip[1] < 0 || m.foot[0] < 0 || m.foot[1] < 0 || m.hip[0] == m.hip[1]))
    throw InputError(
        "free mode balance: cannot find both legs; set left_hip, right_hip, "
        "left_foot and right_foot");

  // walking direction in the root frame: the mean horizontal root velocity over one pass
  ReferencePose a = ref->make_pose();
  Eigen::Vector3d fwd = Eigen::Vector3d::Zero();
  for (int f = 0; f + 1 < ref->frame_count(); ++f) {
    ref->frame_pose(f, a);
    Eigen::Vector3d vel = a.root_velocity;
    vel.z() = 0;
    fwd += a.rotations[0].conjugate() * vel;
  }
  fwd.z() = 0;
  if (fwd.norm() > 1e-9) m.forward_in_root = fwd.normalized();
  return m;
}

}  // namespace

MocapTracker::MocapTracker(const MocapTrackerParams& params, const ControllerContext& ctx,
                           const Engine& engine)
    : model_(make_tracker_model(params, engine, mocap_base_dir(ctx))),
      duration_s_(ctx.duration_s) {}

bool MocapTracker::keeps_state_of(const Controller& previous) const {
  const auto* p = dynamic_cast<const MocapTracker*>(&previous);
  return p && p->model_.params.mode == model_.params.mode &&
         same_mocap_clip(p->model_.params, model_.params);
}

void MocapTracker::reset_state(State& s, const Engine& engine) const {
  const ReferenceMotion& ref = *model_.reference;
  s.pose = ref.make_pose();
  s.pose_now = ref.make_pose();
  const int n = ref.skeleton().segment_count();
  s.fk_pos.assign(n, Eigen::Vector3d::Zero());
  s.fk_rot.assign(n, Eigen::Quaterniond::Identity());
  const int nq = engine.nq(), nv = engine.nv();
  for (Eigen::VectorXd* x : {&s.q, &s.q_ref}) x->setZero(nq);
  for (Eigen::VectorXd* x : {&s.v, &s.v_ref, &s.tau}) x->setZero(nv);
  s.work.resize(nq, nv);
  s.jac_a.setZero(3, nv);
  s.jac_b.setZero(3, nv);
  s.stance_share = {1, 0};
  s.recorded.clear();
  s.recorded_frames = 0;
  s.next_record_t = 0;
  if (!model_.params.export_bvh.empty())
    s.recorded.reserve(static_cast<size_t>(nq) *
                       mocap_record_frames(duration_s_, ref.frame_time_s()));
  s.stance = 0;
  s.error_sum_deg = s.max_error_deg = 0;
  s.joint_error_sum_deg.assign(n, 0.0);
  s.error_samples = 0;
  s.root_error_sum = s.root_error_max = s.ee_error_sum = s.ee_error_max = 0;
  s.steps = 0;
  s.helper_impulse = s.helper_angular_impulse = 0;
  s.fall_time = -1;
  s.last_error_deg = s.last_root_error = 0;
  s.last_helper_force.setZero();
}

// s.q_ref, s.v_ref <- the reference pose at time t (s.pose holds it)
void MocapTracker::track_state(State& s, double t) const {
  const MocapTrackerModel& m = model_;
  m.reference->sample(t, s.pose);
  const int n = static_cast<int>(m.body.size());
  s.q_ref.segment<3>(m.qpos_adr[0]) = s.pose.root_position;
  write_quat(s.q_ref, m.qpos_adr[0] + 3, s.pose.rotations[0]);
  s.v_ref.segment<3>(m.dof_adr[0]) = s.pose.root_velocity;
  s.v_ref.segment<3>(m.dof_adr[0] + 3) = s.pose.angular_velocities[0];
  for (int k = 1; k < n; ++k) {
    write_quat(s.q_ref, m.qpos_adr[k], s.pose.rotations[k]);
    s.v_ref.segment<3>(m.dof_adr[k]) = s.pose.angular_velocities[k];
  }
}

// SIMBICON-style feedback on the swing thigh (world frame), the stance hip's pelvis servo, and
// Coros-style virtual forces carried by J^T through the stance leg(s)
void MocapTracker::balance(State& s, const Engine& engine, double t_target) const {
  const MocapTrackerModel& m = model_;
  const MocapTrackerParams& p = m.params;
  const ReferenceMotion& ref = *m.reference;
  ref.forward_kinematics(s.pose, s.fk_pos, s.fk_rot);
  // stance: the foot lower in the reference, unless only the other one touches the ground
  const int ref_stance = s.fk_pos[m.foot[0]].z() <= s.fk_pos[m.foot[1]].z() ? 0 : 1;
  s.stance = ref_stance;
  s.stance_share[s.stance] = 1;
  s.stance_share[1 - s.stance] = 0;
  if (p.contact_stance) {
    bool touch[2] = {false, false};
    for (int side = 0; side < 2; ++side)
      for (int b : m.foot_bodies[side]) touch[side] = touch[side] || engine.body_touches_ground(b);
    if (touch[0] != touch[1]) s.stance = touch[0] ? 0 : 1;
    // double support shares the weight; in flight nothing is carried
    for (int side = 0; side < 2; ++side)
      s.stance_share[side] = touch[side] ? (touch[1 - side] ? 0.5 : 1.0) : 0.0;
  }
  const int swing = 1 - s.stance;
  // heading frames of the simulation and the reference
  const int root_body = m.body[0];
  BodyPose root = engine.body_pose(root_body);
  auto heading = [&](const Eigen::Quaterniond& r) {
    Eigen::Vector3d f = r * m.forward_in_root;
    f.z() = 0;
    return f.norm() > 1e-9 ? Eigen::Vector3d(f.normalized()) : Eigen::Vector3d::UnitX();
  };
  Eigen::Vector3d fwd = heading(root.quat), fwd_ref = heading(s.pose.rotations[0]);
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d lat = up.cross(fwd), lat_ref = up.cross(fwd_ref);
  // the reference turned onto the simulated heading, less the share heading_gain corrects
  const double yaw_error = std::atan2(fwd_ref.cross(fwd).z(), fwd_ref.dot(fwd));
  // the heading to correct towards: the reference's, turned towards the clip's path when the
  // character has drifted sideways off it
  const double path_offset = (s.pose.root_position - root.pos).dot(lat_ref);
  const double turn = std::clamp(p.path_gain * path_offset, -0.5, 0.5);
  const double heading_error = yaw_error - turn;
  Eigen::Quaterniond yaw_fix(Eigen::AngleAxisd(yaw_error - p.heading_gain * heading_error, up));
  Eigen::Quaterniond swing_yaw_fix(
      Eigen::AngleAxisd(yaw_error - p.swing_heading_gain * heading_error, up));
  // d: root (or COM) offset from the stance ankle; v: its velocity; both against the reference's
  const Eigen::Vector3d ankle = engine.body_pose(m.body[m.foot[s.stance]]).pos;
  const Eigen::Vector3d ankle_ref = s.fk_pos[m.foot[s.stance]];
  Eigen::Vector3d d = root.pos - ankle;
  Eigen::Vector3d d_ref = s.pose.root_position - ankle_ref;
  Eigen::Vector3d vel = engine.body_velocity(root_body).tail<3>();
  Eigen::Vector3d vel_ref = s.pose.root_velocity;
  if (p.com_feedback) {
    // the reference COM is taken at the simulated COM's offset from the root
    d = engine.com() - ankle;
    vel = engine.com_velocity();
  }
  double th_sag = p.cd_sagittal * (d.dot(fwd) - d_ref.dot(fwd_ref)) +
                  p.cv_sagittal * (vel.dot(fwd) - vel_ref.dot(fwd_ref));
  double th_cor = p.cd_coronal * (d.dot(lat) - d_ref.dot(lat_ref)) +
                  p.cv_coronal * (vel.dot(lat) - vel_ref.dot(lat_ref));
  th_sag = std::clamp(th_sag, -0.8, 0.8);
  th_cor = std::clamp(th_cor, -0.5, 0.5);
  // the reference thigh in the world, turned onto the simulated heading, then the feedback
  Eigen::Quaterniond delta = Eigen::Quaterniond(Eigen::AngleAxisd(th_sag, -lat)) *
                             Eigen::Quaterniond(Eigen::AngleAxisd(th_cor, fwd));
  const MotionSkeleton& sk = ref.skeleton();
  const int hip = m.hip[swing];
  Eigen::Quaterniond thigh_des = delta * swing_yaw_fix * s.fk_rot[hip];
  Eigen::Quaterniond parent = engine.body_pose(m.body[sk.segments[hip].parent]).quat;
  Eigen::Quaterniond local = (parent.conjugate() * thigh_des).normalized();
  if (local.coeffs().dot(s.pose.rotations[hip].coeffs()) < 0) local.coeffs() *= -1;
  write_quat(s.q_ref, m.qpos_adr[hip], local);
  // swing foot: its reference world orientation on the simulated heading (lands flat)
  if (p.swing_foot_world) {
    const int foot = m.foot[swing];
    Eigen::Quaterniond shank = engine.body_pose(m.body[sk.segments[foot].parent]).quat;
    Eigen::Quaterniond target = (shank.conjugate() * swing_yaw_fix * s.fk_rot[foot]).normalized();
    if (target.coeffs().dot(s.pose.rotations[foot].coeffs()) < 0) target.coeffs() *= -1;
    write_quat(s.q_ref, m.qpos_adr[foot], target);
  }
  // stance ankle: the reference ankle angle tilted in the world against the same offset error,
  // so the foot presses the centre of pressure towards the side the body leans to
  if (p.ankle_cd_sagittal != 0 || p.ankle_cv_sagittal != 0 || p.ankle_cd_coronal != 0 ||
      p.ankle_cv_coronal != 0) {
    double ph_sag = -(p.ankle_cd_sagittal * (d.dot(fwd) - d_ref.dot(fwd_ref)) +
                      p.ankle_cv_sagittal * (vel.dot(fwd) - vel_ref.dot(fwd_ref)));
    double ph_cor = -(p.ankle_cd_coronal * (d.dot(lat) - d_ref.dot(lat_ref)) +
                      p.ankle_cv_coronal * (vel.dot(lat) - vel_ref.dot(lat_ref)));
    ph_sag = std::clamp(ph_sag, -0.3, 0.3);
    ph_cor = std::clamp(ph_cor, -0.3, 0.3);
    Eigen::Quaterniond tilt = Eigen::Quaterniond(Eigen::AngleAxisd(ph_sag, -lat)) *
                              Eigen::Quaterniond(Eigen::AngleAxisd(ph_cor, fwd));
    const int foot = m.foot[s.stance];
    Eigen::Quaterniond shank = engine.body_pose(m.body[sk.segments[foot].parent]).quat;
    Eigen::Quaterniond local = read_quat(s.q_ref, m.qpos_adr[foot]);
    Eigen::Quaterniond target = (shank.conjugate() * tilt * shank * local).normalized();
    if (target.coeffs().dot(local.coeffs()) < 0) target.coeffs() *= -1;
    write_quat(s.q_ref, m.qpos_adr[foot], target);
  }
  // pelvis servo through the stance hip's SPD: its target is the rotation that would put the
  // pelvis at the reference orientation over the thigh as it is (implicit, hence stable)
  Eigen::Quaterniond root_des = yaw_fix * s.pose.rotations[0];
  const int stance_hip = m.hip[s.stance];
  Eigen::Quaterniond thigh = engine.body_pose(m.body[stance_hip]).quat;
  if (p.stance_hip_world) {
    Eigen::Quaterniond between = Eigen::Quaterniond::Identity();
    for (int a = sk.segments[stance_hip].parent; a > 0; a = sk.segments[a].parent)
      between = s.pose.rotations[a] * between;  // merged-away segments between root and hip
    Eigen::Quaterniond target = ((root_des * between).conjugate() * thigh).normalized();
    if (target.coeffs().dot(s.pose.rotations[stance_hip].coeffs()) < 0) target.coeffs() *= -1;
    // partly towards the reference hip angle, which keeps the stance thigh's own twist in check
    target = s.pose.rotations[stance_hip].slerp(p.stance_hip_world_weight, target);
    write_quat(s.q_ref, m.qpos_adr[stance_hip], target);
  }
  // optional explicit torque T on the pelvis; the stance hip applies -T to its thigh
  Eigen::Vector3d rot_err = quaternion_log((root_des * root.quat.conjugate()).normalized());
  Eigen::Vector3d w = engine.body_velocity(root_body).head<3>();
  Eigen::Vector3d w_ref = root_des * s.pose.angular_velocities[0];
  Eigen::Vector3d torque = p.torso_kp * rot_err + p.torso_kd * (w_ref - w);
  s.tau.segment<3>(m.dof_adr[stance_hip]) -= thigh.conjugate() * torque;

  // virtual force F at the COM, reacted at each supporting foot (Coros et al. 2010): the
  // torques (J_com - J_foot(com))^T F act on the joints between the foot and every body, and
  // cancel on the root. F carries the weight and holds the root at its reference offset.
  const double weight = engine.total_mass() * engine.gravity().norm();
  Eigen::Vector3d root_d = root.pos - ankle,
                  root_d_ref = yaw_fix * (s.pose.root_position - ankle_ref);
  Eigen::Vector3d root_v = engine.body_velocity(root_body).tail<3>();
  Eigen::Vector3d root_v_ref = yaw_fix * s.pose.root_velocity;
  Eigen::Vector3d e = root_d_ref - root_d, ev = root_v_ref - root_v;
  Eigen::Vector3d force = -p.gravity_compensation * engine.total_mass() * engine.gravity();
  force.x() += p.root_force_kp * e.x() + p.root_force_kd * ev.x();
  force.y() += p.root_force_kp * e.y() + p.root_force_kd * ev.y();
  force.z() += p.root_force_kp_z * e.z() + p.root_force_kd_z * ev.z();
  force.z() = std::clamp(force.z(), 0.0, 2 * weight);  // the feet can only push
  if (force.squaredNorm() == 0) return;
  engine.com_jacobian(s.jac_a);
  for (int side = 0; side < 2; ++side)
    if (s.stance_share[side] > 0)
      add_com_support_torque(engine, m.body[m.foot[side]], s.stance_share[side] * force, s.jac_a,
                             s.jac_b, s.tau);
}

void MocapTracker::compute_step(State& s, const Engine& engine, ControlOutput& out) const {
  const MocapTrackerModel& m = model_;
  const double dt = engine.timestep();
  const double t = engine.time();
  engine.get_positions(s.q);
  engine.get_velocities(s.v);
  accumulate_metrics(s, engine);
  // record the simulated pose at the clip's frame rate
  if (!m.params.export_bvh.empty() && t + 1e-9 >= s.next_record_t) {
    s.recorded.insert(s.recorded.end(), s.q.data(), s.q.data() + s.q.size());
    ++s.recorded_frames;
    s.next_record_t = s.recorded_frames * m.reference->frame_time_s();
  }
  // targets for the end of this step
  track_state(s, t + dt);
  s.tau.setZero();
  if (m.mode == MocapRootMode::kKinematic) {
    add_deadbeat_torques(engine, s.q, s.v, s.q_ref, s.work, s.tau);
  } else {
    if (m.mode == MocapRootMode::kFree && m.params.balance) balance(s, engine, t + dt);
    add_stable_pd_torques(engine, s.q, s.v, s.q_ref, s.v_ref, m.kp, m.kd, m.params.max_torque,
                          m.dof_adr[0], m.dof_adr[0] + 6, s.work, s.tau);
    if (m.mode == MocapRootMode::kFree) s.tau.segment<6>(m.dof_adr[0]).setZero();
  }
  // helper: whatever lands on the root dofs
  if (m.mode != MocapRootMode::kFree) {
    s.last_helper_force = s.tau.segment<3>(m.dof_adr[0]);
    s.helper_impulse += s.last_helper_force.norm() * dt;
    s.helper_angular_impulse += s.tau.segment<3>(m.dof_adr[0] + 3).norm() * dt;
  }
  out.tau += s.tau;
  ++s.steps;
}

void MocapTracker::accumulate_metrics(State& s, const Engine& engine) const {
  const MocapTrackerModel& m = model_;
  const double t = engine.time();
  m.reference->sample(t, s.pose_now);
  const int n = static_cast<int>(m.body.size());
  double sum = 0;
  for (int k = 1; k < n; ++k) {
    double e = geodesic_angle(read_quat(s.q, m.qpos_adr[k]), s.pose_now.rotations[k]) * kRadToDeg;
    sum += e;
    s.joint_error_sum_deg[k] += e;
    s.max_error_deg = std::max(s.max_error_deg, e);
  }
  if (n > 1) {
    s.error_sum_deg += sum;
    s.error_samples += n - 1;
    s.last_error_deg = sum / (n - 1);
  }
  Eigen::Vector3d root = s.q.segment<3>(m.qpos_adr[0]);
  s.last_root_error = (root - s.pose_now.root_position).norm();
  s.root_error_sum += s.last_root_error;
  s.root_error_max = std::max(s.root_error_max, s.last_root_error);
  m.reference->forward_kinematics(s.pose_now, s.fk_pos, s.fk_rot);
  double ee = 0;
  for (size_t i = 0; i < m.end_effectors.size(); ++i) {
    int k = m.end_effectors[i];
    BodyPose b = engine.body_pose(m.body[k]);
    Eigen::Vector3d sim = b.pos + b.quat * m.end_points[i];
    Eigen::Vector3d want = s.fk_pos[k] + s.fk_rot[k] * m.end_points[i];
    double e = (sim - want).norm();
    ee += e;
    s.ee_error_max = std::max(s.ee_error_max, e);
  }
  if (!m.end_effectors.empty()) s.ee_error_sum += ee / m.end_effectors.size();
  if (s.fall_time < 0 && root.z() < 0.5 * s.pose_now.root_position.z()) s.fall_time = t;
}

void MocapTracker::signal_names(std::vector<std::string>& names) const {
  for (const char* s : {"mocap_joint_error_deg", "mocap_root_error_m", "mocap_helper_fx",
                        "mocap_helper_fy", "mocap_helper_fz", "mocap_stance", "mocap_ref_root_x",
                        "mocap_ref_root_y", "mocap_ref_root_z"})
    names.emplace_back(s);
}

void MocapTracker::state_signals(const State& s, std::vector<double>& values) const {
  values.push_back(s.last_error_deg);
  values.push_back(s.last_root_error);
  for (int i = 0; i < 3; ++i) values.push_back(s.last_helper_force[i]);
  values.push_back(s.stance);
  for (int i = 0; i < 3; ++i) values.push_back(s.pose_now.root_position[i]);
}

void MocapTracker::state_metrics(const State& s, nlohmann::json& metrics) const {
  const double steps = std::max<long>(s.steps, 1);
  nlohmann::json j;
  j["mode"] = model_.params.mode;
  j["mean_joint_error_deg"] = s.mean_joint_error_deg();
  j["max_joint_error_deg"] = s.max_error_deg;
  j["mean_root_error_m"] = s.root_error_sum / steps;
  j["max_root_error_m"] = s.root_error_max;
  j["mean_end_effector_error_m"] = s.ee_error_sum / steps;
  j["max_end_effector_error_m"] = s.ee_error_max;
  nlohmann::json names = nlohmann::json::array();
  for (int k : model_.end_effectors) names.push_back(model_.reference->skeleton().segments[k].name);
  j["end_effectors"] = names;
  // per joint: where the error is
  nlohmann::json per_joint = nlohmann::json::object();
  const MotionSkeleton& sk = model_.reference->skeleton();
  for (int k = 1; k < sk.segment_count(); ++k)
    per_joint[sk.segments[k].name] = s.joint_error_sum_deg[k] / steps;
  j["joint_error_deg"] = per_joint;
  j["helper_impulse_Ns"] = s.helper_impulse;
  j["helper_angular_impulse_Nms"] = s.helper_angular_impulse;
  j["root_fall_time_s"] = s.fall_time >= 0 ? nlohmann::json(s.fall_time) : nlohmann::json(nullptr);
  j["clip_frames"] = model_.reference->frame_count();
  j["clip_duration_s"] = model_.reference->duration_s();
  metrics["mocap"] = j;
}

BvhClip clip_from_segment_poses(const MocapClip& mocap,
                                const std::vector<Eigen::Quaterniond>& locals,
                                const std::vector<Eigen::Vector3d>& roots) {
  const BvhClip& src = *mocap.clip;
  const MotionSkeleton& sk = mocap.reference->skeleton();
  const int n = sk.segment_count();
  BvhClip out;
  out.source = src.source;
  out.joints = src.joints;
  out.channel_count = src.channel_count;
  out.frame_time_s = src.frame_time_s;
  out.position_joint_count = src.position_joint_count;
  const int frames = static_cast<int>(roots.size());
  out.frame_count = frames;
  const size_t nj = src.joints.size();
  out.rotations.resize(nj * frames);
  out.positions.resize(static_cast<size_t>(src.position_joint_count) * frames);
  const Eigen::Quaterniond c = sk.to_z_up, ct = c.conjugate();
  const int range = mocap.reference->frame_count();
  for (int f = 0; f < frames; ++f) {
    // joints that are no segment keep the clip's own values at the matching frame
    int sf = mocap.first_frame + (f % range);
    for (size_t j = 0; j < nj; ++j) out.rotation(f, j) = src.rotation(sf, j);
    for (int s = 0; s < src.position_joint_count; ++s)
      out.positions[static_cast<size_t>(f) * src.position_joint_count + s] =
          src.positions[static_cast<size_t>(sf) * src.position_joint_count + s];
    for (int k = 0; k < n; ++k) {
      const MotionSegment& seg = sk.segments[k];
      Eigen::Quaterniond r = ct * locals[static_cast<size_t>(f) * n + k].normalized() * c;
      // merged helpers keep their clip rotation; the segment's own joint takes the rest
      Eigen::Quaterniond helpers = Eigen::Quaterniond::Identity();
      for (size_t i = 0; i + 1 < seg.rotation_chain.size(); ++i)
        helpers = helpers * src.rotation(sf, seg.rotation_chain[i]);
      out.rotation(f, seg.bvh_joint) = (helpers.conjugate() * r).normalized();
    }
    const BvhJoint& root = src.joints[sk.segments[0].bvh_joint];
    if (root.position_slot >= 0)
      out.positions[static_cast<size_t>(f) * src.position_joint_count + root.position_slot] =
          (ct * roots[f]) / sk.scale_to_meters;
  }
  return out;
}

void write_exported_bvh(const BvhClip& clip, const std::string& export_path,
                        const std::string& out_dir) {
  std::filesystem::path path(export_path);
  if (path.is_relative() && !out_dir.empty()) path = std::filesystem::path(out_dir) / path;
  write_bvh(clip, path.string());
}

BvhClip MocapTracker::recorded_clip(const State& s) const {
  const MocapTrackerModel& m = model_;
  const int n = m.reference->skeleton().segment_count();
  const int nq = s.q.size();
  std::vector<Eigen::Quaterniond> locals(static_cast<size_t>(s.recorded_frames) * n);
  std::vector<Eigen::Vector3d> roots(s.recorded_frames);
  for (int f = 0; f < s.recorded_frames; ++f) {
    Eigen::Map<const Eigen::VectorXd> qf(s.recorded.data() + static_cast<size_t>(f) * nq, nq);
    for (int k = 0; k < n; ++k)
      locals[static_cast<size_t>(f) * n + k] = read_quat(qf, m.qpos_adr[k]);
    roots[f] = qf.segment<3>(m.qpos_adr[0]);
  }
  return clip_from_segment_poses({m.clip, m.reference, m.first_frame}, locals, roots);
}

void MocapTracker::state_outputs(const State& s, const std::string& out_dir) const {
  if (model_.params.export_bvh.empty() || s.recorded_frames == 0) return;
  write_exported_bvh(recorded_clip(s), model_.params.export_bvh, out_dir);
}

bool MocapTracker::state_reference_qpos(const State&, const Engine& engine,
                                        Eigen::VectorXd& qpos) const {
  const MocapTrackerModel& m = model_;
  ReferencePose pose = m.reference->make_pose();
  m.reference->sample(engine.time(), pose);
  // coordinates the clip does not drive keep the engine's values
  qpos.resize(engine.nq());
  engine.get_positions(qpos);
  qpos.segment<3>(m.qpos_adr[0]) = pose.root_position;
  write_quat(qpos, m.qpos_adr[0] + 3, pose.rotations[0]);
  for (size_t k = 1; k < m.body.size(); ++k) write_quat(qpos, m.qpos_adr[k], pose.rotations[k]);
  return true;
}

}  // namespace stance
