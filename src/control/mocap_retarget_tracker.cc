#include "control/mocap_retarget_tracker.h"

#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "core/error.h"
#include "engine/engine.h"
#include "math/rotations.h"

namespace stance {

namespace {
constexpr double kRadToDeg = 180.0 / std::numbers::pi;
}

std::shared_ptr<const Controller> make_mocap_retarget_tracker(const YAML::Node& node,
                                                              const ControllerContext& ctx,
                                                              const Engine& engine) {
  if (!ctx.scratch_engine)
    throw InputError("mocap_retarget: needs a scratch engine of the model to probe it");
  std::unique_ptr<Engine> probe = ctx.scratch_engine();
  std::string dir = std::filesystem::path(ctx.source.file).parent_path().string();
  return std::make_shared<const LegacyModel<MocapRetargetTracker>>(MocapRetargetTracker(
      read_params<MocapRetargetParams>(node, ctx), engine, *probe, ctx.duration_s, dir));
}

MocapRetargetTracker::MocapRetargetTracker(const MocapRetargetParams& params, const Engine& engine,
                                           Engine& probe, double duration_s,
                                           const std::string& base_dir)
    : params_(params), mode_(parse_mocap_root_mode(params.mode)) {
  if (probe.nq() != engine.nq() || probe.nv() != engine.nv())
    throw InputError("mocap_retarget: the scratch engine is not the run's model");
  clip_ = load_mocap_clip(params, base_dir);
  if (params.joint_map.empty()) throw InputError("joint_map: a joint map file is required");
  std::filesystem::path map_path(params.joint_map);
  if (map_path.is_relative() && !base_dir.empty())
    map_path = std::filesystem::path(base_dir) / map_path;
  JointMap map = read_joint_map(map_path.string());
  motion_ = std::make_shared<RetargetedMotion>(*clip_.reference, map, probe, duration_s);

  // the root: the free joint above the body the clip's root is mapped onto
  int top = -1;
  for (size_t i = 0; i < motion_->bodies().size(); ++i)
    if (motion_->bodies()[i].segment == 0) {
      top = motion_->bodies()[i].body;
      root_mapped_ = static_cast<int>(i);
    }
  while (engine.body_parent(top) >= 0) top = engine.body_parent(top);
  root_body_ = top;
  for (int j = 0; j < engine.njoint(); ++j)
    if (engine.joint(j).body == top && engine.joint(j).type == JointType::kFree)
      root_dof_ = engine.joint(j).dof_adr;

  // free mode balance: the legs, as mapped bodies
  if (mode_ == MocapRootMode::kFree && params.balance) {
    const MotionSkeleton& sk = clip_.reference->skeleton();
    int hip_seg[2], foot_seg[2];
    find_mocap_legs(sk, {params.left_hip, params.right_hip, params.left_foot, params.right_foot},
                    hip_seg, foot_seg);
    const auto& bodies = motion_->bodies();
    for (int side = 0; side < 2; ++side)
      for (size_t i = 0; i < bodies.size(); ++i) {
        if (bodies[i].segment == hip_seg[side]) hip_[side] = static_cast<int>(i);
        if (bodies[i].segment == foot_seg[side]) foot_[side] = static_cast<int>(i);
      }
    if (hip_[0] < 0 || hip_[1] < 0 || foot_[0] < 0 || foot_[1] < 0 || hip_[0] == hip_[1])
      throw InputError(
          "free mode balance: map both thighs and both feet (or set left_hip, right_hip, "
          "left_foot and right_foot to mapped clip joints)");
    for (int side = 0; side < 2; ++side)
      for (int b = 0; b < engine.nbody(); ++b)
        for (int a = b; a >= 0; a = engine.body_parent(a))
          if (a == bodies[foot_[side]].body) {
            foot_bodies_[side].push_back(b);
            break;
          }
    // the walking direction in the root body's frame: the mean horizontal root velocity
    std::vector<Eigen::Quaterniond> world(bodies.size()), local(bodies.size());
    std::vector<Eigen::Vector3d> a(bodies.size()), b(bodies.size());
    const Eigen::Vector3d g = engine.gravity();
    const Eigen::Vector3d up = g.norm() > 0 ? Eigen::Vector3d(-g.normalized()) : up_;
    Eigen::Vector3d fwd = Eigen::Vector3d::Zero();
    const double h = motion_->frame_time_s();
    for (double t = 0; t + h <= clip_.reference->duration_s(); t += h) {
      motion_->sample_bodies(t, local, a);
      motion_->sample_bodies(t + h, local, b);
      motion_->sample_world(t, world);
      Eigen::Vector3d vel = b[root_mapped_] - a[root_mapped_];
      vel -= vel.dot(up) * up;
      fwd += world[root_mapped_].conjugate() * vel;
    }
    if (fwd.norm() > 1e-9) forward_in_root_ = fwd.normalized();
  }

  // gains: every dof but the root's; the root's in assisted mode
  const int nv = engine.nv();
  kp_ = Eigen::VectorXd::Constant(nv, params.kp);
  kd_ = Eigen::VectorXd::Constant(nv, params.kd);
  for (const auto& [name, value] : params.kp_joints) kp_[engine.require_dof(name)] = value;
  for (const auto& [name, value] : params.kd_joints) kd_[engine.require_dof(name)] = value;
  for (int i = root_dof_; i < root_dof_ + 6; ++i) {
    const bool translation = engine.dof_name(i).find("_pos_") != std::string::npos;
    root_translation_[i - root_dof_] = translation;
    const bool assisted = mode_ == MocapRootMode::kAssisted;
    kp_[i] = assisted ? (translation ? params.root_kp : params.root_kp_rot) : 0;
    kd_[i] = assisted ? (translation ? params.root_kd : params.root_kd_rot) : 0;
  }
}

bool MocapRetargetTracker::initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                                         Eigen::VectorXd& qvel) const {
  qpos.resize(engine.nq());
  qvel.resize(engine.nv());
  Eigen::VectorXd scratch(engine.nv());
  motion_->sample(engine, 0, qpos, qvel, scratch);
  return true;
}

bool MocapRetargetTracker::reference_qpos(const Engine& engine, Eigen::VectorXd& qpos) const {
  qpos.resize(engine.nq());
  Eigen::VectorXd v(engine.nv()), scratch(engine.nv());
  motion_->sample(engine, engine.time(), qpos, v, scratch);
  return true;
}

void MocapRetargetTracker::reset(const Engine& engine) {
  const int nq = engine.nq(), nv = engine.nv();
  for (Eigen::VectorXd* x : {&q_, &q_ref_}) x->setZero(nq);
  for (Eigen::VectorXd* x : {&v_, &v_ref_, &tau_, &scratch_}) x->setZero(nv);
  work_.resize(nq, nv);
  ref_local_.assign(motion_->bodies().size(), Eigen::Quaterniond::Identity());
  ref_position_.assign(motion_->bodies().size(), Eigen::Vector3d::Zero());
  error_sum_deg_ = max_error_deg_ = last_error_deg_ = 0;
  error_samples_ = 0;
  root_error_sum_ = root_error_max_ = last_root_error_ = 0;
  end_error_sum_ = end_error_max_ = 0;
  steps_ = 0;
  helper_impulse_ = helper_angular_impulse_ = 0;
  fall_time_ = -1;
  recorded_rotations_.clear();
  recorded_roots_.clear();
  next_record_t_ = 0;
  if (!params_.export_bvh.empty()) {
    const size_t frames = static_cast<size_t>(120.0 / clip_.reference->frame_time_s());
    recorded_rotations_.reserve(frames * motion_->bodies().size());
    recorded_roots_.reserve(frames);
  }
  Eigen::Vector3d g = engine.gravity();
  up_ = g.norm() > 0 ? Eigen::Vector3d(-g.normalized()) : Eigen::Vector3d::UnitZ();
  const size_t n = motion_->bodies().size();
  bal_world_.assign(n, Eigen::Quaterniond::Identity());
  bal_local_.assign(n, Eigen::Quaterniond::Identity());
  bal_pos_.assign(n, Eigen::Vector3d::Zero());
  bal_pos_ahead_.assign(n, Eigen::Vector3d::Zero());
  jac_a_.setZero(3, engine.nv());
  jac_b_.setZero(3, engine.nv());
  stance_ = 0;
  stance_share_[0] = 1;
  stance_share_[1] = 0;
}

void MocapRetargetTracker::accumulate_metrics(const Engine& engine) {
  const double t = engine.time();
  motion_->sample_bodies(t, ref_local_, ref_position_);
  const auto& bodies = motion_->bodies();
  // the lowest mapped body of the reference (a foot): falls are measured from it, so the
  // model's floor may be anywhere (fullbody1's is at y = -0.895)
  double lowest = 1e300;
  for (size_t i = 0; i < bodies.size(); ++i) lowest = std::min(lowest, up_.dot(ref_position_[i]));
  double sum = 0;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const int b = bodies[i].body;
    const int p = engine.body_parent(b);
    Eigen::Quaterniond local = engine.body_pose(b).quat;
    if (p >= 0) local = engine.body_pose(p).quat.conjugate() * local;
    double e = geodesic_angle(local, ref_local_[i]) * kRadToDeg;
    if (bodies[i].segment == 0) {
      double r = (engine.body_pose(b).pos - ref_position_[i]).norm();
      last_root_error_ = r;
      root_error_sum_ += r;
      root_error_max_ = std::max(root_error_max_, r);
      const double drop = up_.dot(ref_position_[i] - engine.body_pose(b).pos);
      if (fall_time_ < 0 && drop > 0.5 * (up_.dot(ref_position_[i]) - lowest)) fall_time_ = t;
      continue;  // the root's orientation is the root's business, not a joint's
    }
    sum += e;
    max_error_deg_ = std::max(max_error_deg_, e);
  }
  const int joints = static_cast<int>(bodies.size()) - 1;
  if (joints > 0) {
    error_sum_deg_ += sum;
    error_samples_ += joints;
    last_error_deg_ = sum / joints;
  }
  double ends = 0;
  for (int i : motion_->end_bodies()) {
    double e = (engine.body_pose(bodies[i].body).pos - ref_position_[i]).norm();
    ends += e;
    end_error_max_ = std::max(end_error_max_, e);
  }
  if (!motion_->end_bodies().empty()) end_error_sum_ += ends / motion_->end_bodies().size();
}

void MocapRetargetTracker::compute(const Engine& engine, ControlOutput& out) {
  const double dt = engine.timestep();
  engine.get_positions(q_);
  engine.get_velocities(v_);
  accumulate_metrics(engine);
  if (!params_.export_bvh.empty() && engine.time() + 1e-9 >= next_record_t_) {
    for (const RetargetBody& b : motion_->bodies())
      recorded_rotations_.push_back(engine.body_pose(b.body).quat);
    recorded_roots_.push_back(engine.body_pose(motion_->bodies()[root_mapped_].body).pos);
    next_record_t_ = recorded_roots_.size() * clip_.reference->frame_time_s();
  }
  motion_->sample(engine, engine.time() + dt, q_ref_, v_ref_, scratch_);
  tau_.setZero();
  if (mode_ == MocapRootMode::kKinematic) {
    add_deadbeat_torques(engine, q_, v_, q_ref_, work_, tau_);
  } else {
    if (mode_ == MocapRootMode::kFree && params_.balance) balance(engine, engine.time() + dt);
    add_stable_pd_torques(engine, q_, v_, q_ref_, v_ref_, kp_, kd_, params_.max_torque, root_dof_,
                          root_dof_ + 6, work_, tau_);
    if (mode_ == MocapRootMode::kFree) tau_.segment<6>(root_dof_).setZero();
  }
  if (mode_ != MocapRootMode::kFree) {
    double force = 0, torque = 0;
    for (int k = 0; k < 6; ++k)
      (root_translation_[k] ? force : torque) += tau_[root_dof_ + k] * tau_[root_dof_ + k];
    helper_impulse_ += std::sqrt(force) * dt;
    helper_angular_impulse_ += std::sqrt(torque) * dt;
  }
  out.tau += tau_;
  ++steps_;
}

// mocap_tracker's balance layer on the model's bodies: world-frame targets for the swing thigh
// and foot and the stance thigh (the pelvis servo), fitted to joint coordinates in q_ref_, and a
// virtual COM force carried by the stance leg(s) as joint torques in tau_
void MocapRetargetTracker::balance(const Engine& engine, double t) {
  const auto& bodies = motion_->bodies();
  const MocapRetargetParams& p = params_;
  const double h = 0.01;  // s: the reference root velocity by a forward difference
  motion_->sample_world(t, bal_world_);
  motion_->sample_bodies(t + h, bal_local_, bal_pos_ahead_);
  motion_->sample_bodies(t, bal_local_, bal_pos_);
  auto height = [&](const Eigen::Vector3d& x) { return up_.dot(x); };
  auto horizontal = [&](const Eigen::Vector3d& x) { return Eigen::Vector3d(x - up_.dot(x) * up_); };
  // stance: the foot that alone touches the ground, else the lower one in the reference
  bool touch[2] = {false, false};
  for (int side = 0; side < 2; ++side)
    for (int b : foot_bodies_[side]) touch[side] = touch[side] || engine.body_touches_ground(b);
  stance_ = height(bal_pos_[foot_[0]]) <= height(bal_pos_[foot_[1]]) ? 0 : 1;
  if (touch[0] != touch[1]) stance_ = touch[0] ? 0 : 1;
  for (int side = 0; side < 2; ++side)
    stance_share_[side] = touch[side] ? (touch[1 - side] ? 0.5 : 1.0) : 0.0;
  const int swing = 1 - stance_;
  // headings of the simulation and the reference; the targets turn onto the simulated one
  const int root_body = bodies[root_mapped_].body;
  const BodyPose root = engine.body_pose(root_body);
  auto heading = [&](const Eigen::Quaterniond& r) {
    Eigen::Vector3d f = horizontal(r * forward_in_root_);
    return f.norm() > 1e-9 ? Eigen::Vector3d(f.normalized()) : forward_in_root_;
  };
  const Eigen::Vector3d fwd = heading(root.quat), fwd_ref = heading(bal_world_[root_mapped_]);
  const Eigen::Vector3d lat = up_.cross(fwd), lat_ref = up_.cross(fwd_ref);
  const double yaw_error = std::atan2(up_.dot(fwd_ref.cross(fwd)), fwd_ref.dot(fwd));
  const Eigen::Quaterniond yaw_fix(Eigen::AngleAxisd(yaw_error, up_));
  // SIMBICON feedback on the root's offset from the stance ankle and its velocity
  const Eigen::Vector3d ankle = engine.body_pose(bodies[foot_[stance_]].body).pos;
  const Eigen::Vector3d ankle_ref = bal_pos_[foot_[stance_]];
  const Eigen::Vector3d d = root.pos - ankle, d_ref = bal_pos_[root_mapped_] - ankle_ref;
  const Eigen::Vector3d vel = engine.body_velocity(root_body).tail<3>();
  const Eigen::Vector3d vel_ref = (bal_pos_ahead_[root_mapped_] - bal_pos_[root_mapped_]) / h;
  const double th_sag = std::clamp(p.cd_sagittal * (d.dot(fwd) - d_ref.dot(fwd_ref)) +
                                       p.cv_sagittal * (vel.dot(fwd) - vel_ref.dot(fwd_ref)),
                                   -0.8, 0.8);
  const double th_cor = std::clamp(p.cd_coronal * (d.dot(lat) - d_ref.dot(lat_ref)) +
                                       p.cv_coronal * (vel.dot(lat) - vel_ref.dot(lat_ref)),
                                   -0.5, 0.5);
  const Eigen::Quaterniond delta = Eigen::Quaterniond(Eigen::AngleAxisd(th_sag, -lat)) *
                                   Eigen::Quaterniond(Eigen::AngleAxisd(th_cor, fwd));
  // a world rotation for mapped body i, as its joint rotation under the parent as it is
  auto set_world = [&](int i, const Eigen::Quaterniond& world) {
    const int parent = engine.body_parent(bodies[i].body);
    Eigen::Quaterniond base = motion_->rest_local(i);
    if (parent >= 0) base = engine.body_pose(parent).quat * base;
    motion_->set_body_local(i, (base.conjugate() * world).normalized(), q_ref_);
  };
  set_world(hip_[swing], delta * yaw_fix * bal_world_[hip_[swing]]);
  if (p.swing_foot_world) set_world(foot_[swing], yaw_fix * bal_world_[foot_[swing]]);
  // the stance hip: the joint rotation that puts the pelvis at its reference over the thigh as
  // it is, blended with the reference's own
  const int hip = hip_[stance_];
  if (engine.body_parent(bodies[hip].body) == root_body) {
    const Eigen::Quaterniond pelvis = yaw_fix * bal_world_[root_mapped_];
    const Eigen::Quaterniond servo =
        ((pelvis * motion_->rest_local(hip)).conjugate() * engine.body_pose(bodies[hip].body).quat)
            .normalized();
    motion_->set_body_local(hip, bal_local_[hip].slerp(p.stance_hip_world_weight, servo), q_ref_);
  }
  // the virtual force at the COM, reacted by the supporting feet (Coros et al. 2010)
  const double weight = engine.total_mass() * engine.gravity().norm();
  Eigen::Vector3d force = -p.gravity_compensation * engine.total_mass() * engine.gravity();
  const Eigen::Vector3d e = yaw_fix * d_ref - d, ev = yaw_fix * vel_ref - vel;
  force += horizontal(p.root_force_kp * e + p.root_force_kd * ev);
  force += p.root_force_kd_z * up_.dot(ev) * up_;
  const double lift = std::clamp(up_.dot(force), 0.0, 2 * weight);  // the feet can only push
  force = horizontal(force) + lift * up_;
  if (force.squaredNorm() == 0) return;
  engine.com_jacobian(jac_a_);
  for (int side = 0; side < 2; ++side)
    if (stance_share_[side] > 0)
      add_com_support_torque(engine, bodies[foot_[side]].body, stance_share_[side] * force, jac_a_,
                             jac_b_, tau_);
}

double MocapRetargetTracker::mean_joint_error_deg() const {
  return error_samples_ ? error_sum_deg_ / error_samples_ : 0.0;
}

void MocapRetargetTracker::signal_names(std::vector<std::string>& names) const {
  for (const char* s : {"mocap_joint_error_deg", "mocap_root_error_m"}) names.emplace_back(s);
}

void MocapRetargetTracker::signals(std::vector<double>& values) const {
  values.push_back(last_error_deg_);
  values.push_back(last_root_error_);
}

void MocapRetargetTracker::add_metrics(nlohmann::json& metrics) const {
  const double steps = std::max<long>(steps_, 1);
  nlohmann::json j;
  j["mode"] = params_.mode;
  j["mean_joint_error_deg"] = mean_joint_error_deg();
  j["max_joint_error_deg"] = max_error_deg_;
  j["mean_root_error_m"] = root_error_sum_ / steps;
  j["max_root_error_m"] = root_error_max_;
  j["mean_end_effector_error_m"] = end_error_sum_ / steps;
  j["max_end_effector_error_m"] = end_error_max_;
  j["map_fit_error_mean_deg"] = motion_->mean_fit_error_deg();
  j["map_fit_error_max_deg"] = motion_->max_fit_error_deg();
  j["map_yaw_deg"] = motion_->yaw_rad() * kRadToDeg;
  j["map_scale"] = motion_->scale();
  j["map_height_offset_m"] = motion_->height_offset_m();
  // per pair: what the model's joints cannot express
  nlohmann::json pairs = nlohmann::json::object();
  for (size_t i = 0; i < motion_->bodies().size(); ++i)
    pairs[motion_->bodies()[i].name] = motion_->body_fit_error_deg(static_cast<int>(i));
  j["map_fit_error_deg"] = pairs;
  nlohmann::json aims = nlohmann::json::object();
  for (size_t i = 0; i < motion_->bodies().size(); ++i)
    aims[motion_->bodies()[i].name] = motion_->body_aim_error_deg(static_cast<int>(i));
  j["map_aim_error_deg"] = aims;
  j["helper_impulse_Ns"] = helper_impulse_;
  j["helper_angular_impulse_Nms"] = helper_angular_impulse_;
  j["root_fall_time_s"] = fall_time_ >= 0 ? nlohmann::json(fall_time_) : nlohmann::json(nullptr);
  j["clip_duration_s"] = clip_.reference->duration_s();
  metrics["mocap"] = j;
}

BvhClip MocapRetargetTracker::recorded_clip() const {
  const ReferenceMotion& ref = *clip_.reference;
  const MotionSkeleton& sk = ref.skeleton();
  const int n = sk.segment_count();
  const auto& bodies = motion_->bodies();
  std::vector<int> mapped(n, -1);
  for (size_t i = 0; i < bodies.size(); ++i) mapped[bodies[i].segment] = static_cast<int>(i);
  const int frames = static_cast<int>(recorded_roots_.size());
  std::vector<Eigen::Quaterniond> locals(static_cast<size_t>(frames) * n);
  std::vector<Eigen::Vector3d> roots(frames);
  std::vector<Eigen::Quaterniond> world(n);
  ReferencePose pose = ref.make_pose();
  for (int f = 0; f < frames; ++f) {
    ref.sample(f * ref.frame_time_s(), pose);  // unmapped joints keep the clip's rotations
    for (int k = 0; k < n; ++k) {
      const int parent = sk.segments[k].parent;
      const int i = mapped[k];
      world[k] = i >= 0 ? motion_->clip_world_rotation(
                              i, recorded_rotations_[static_cast<size_t>(f) * bodies.size() + i])
                        : world[parent] * pose.rotations[k];
      locals[static_cast<size_t>(f) * n + k] =
          parent >= 0 ? (world[parent].conjugate() * world[k]).normalized() : world[k];
    }
    roots[f] = motion_->clip_root_position(recorded_roots_[f]);
  }
  return clip_from_segment_poses(clip_, locals, roots);
}

void MocapRetargetTracker::write_outputs(const std::string& out_dir) const {
  if (params_.export_bvh.empty() || recorded_roots_.empty()) return;
  write_exported_bvh(recorded_clip(), params_.export_bvh, out_dir);
}

}  // namespace stance
