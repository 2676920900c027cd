#include "control/mocap_retarget_tracker.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "control/mocap_gains.h"
#include "core/error.h"
#include "engine/engine.h"
#include "math/rotations.h"

namespace stance {

namespace {
// the offsets the planner may make (correction_dims), in this order
enum Correction {
  kSwingHipPitch,
  kSwingHipRoll,
  kPelvisPitch,
  kPelvisRoll,
  kStanceAnklePitch,
  kStanceAnkleRoll,
  kCorrections
};
}  // namespace

MocapRetargetTracker::MocapRetargetTracker(const MocapRetargetParams& params,
                                           const ControllerContext& ctx, const Engine& engine,
                                           std::string_view type_name)
    : type_name_(type_name),
      params_(params),
      mode_(parse_mocap_root_mode(params.mode)),
      duration_s_(ctx.duration_s),
      metrics_(!ctx.rollout) {
  if (!ctx.scratch_engine)
    throw InputError("mocap_retarget: needs a scratch engine of the model to probe it");
  std::unique_ptr<Engine> probe = ctx.scratch_engine();
  if (probe->nq() != engine.nq() || probe->nv() != engine.nv())
    throw InputError("mocap_retarget: the scratch engine is not the run's model");
  const std::string base_dir = mocap_base_dir(ctx);
  clip_ = load_mocap_clip(params, base_dir);
  JointMap map;
  if (params.joint_map.empty()) {
    map = bvh_character_joint_map(clip_.reference->skeleton(), engine);
  } else {
    std::filesystem::path map_path(params.joint_map);
    if (map_path.is_relative() && !base_dir.empty())
      map_path = std::filesystem::path(base_dir) / map_path;
    map = read_joint_map(map_path.string());
  }
  // the legs, as clip segments: the balance layer's, the fall rule's and the planted feet's
  int hip_seg[2] = {-1, -1}, foot_seg[2] = {-1, -1};
  const MotionSkeleton& sk = clip_.reference->skeleton();
  find_mocap_legs(sk, {params.left_hip, params.right_hip, params.left_foot, params.right_foot},
                  hip_seg, foot_seg);
  // free mode stands on level feet: each foot segment and the segments below it
  std::vector<int> level_feet;
  if (mode_ == MocapRootMode::kFree && params.level_planted_feet)
    for (int seg = 0; seg < sk.segment_count(); ++seg)
      for (int a = seg; a >= 0; a = sk.segments[a].parent)
        if (a == foot_seg[0] || a == foot_seg[1]) {
          level_feet.push_back(seg);
          break;
        }
  motion_ =
      std::make_shared<RetargetedMotion>(*clip_.reference, map, *probe, ctx.duration_s, level_feet);
  const Eigen::Vector3d g = engine.gravity();
  up_ = g.norm() > 0 ? Eigen::Vector3d(-g.normalized()) : Eigen::Vector3d::UnitZ();

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

  // the legs, as mapped bodies: the balance layer's, the fall rule's feet and the foot skate's
  const auto& bodies = motion_->bodies();
  {
    for (int side = 0; side < 2; ++side)
      for (size_t i = 0; i < bodies.size(); ++i) {
        if (bodies[i].segment == hip_seg[side]) hip_[side] = static_cast<int>(i);
        if (bodies[i].segment == foot_seg[side]) foot_[side] = static_cast<int>(i);
      }
    has_legs_ =
        hip_[0] >= 0 && hip_[1] >= 0 && foot_[0] >= 0 && foot_[1] >= 0 && hip_[0] != hip_[1];
  }
  if (mode_ == MocapRootMode::kFree && params.balance && !has_legs_)
    throw InputError(
        "free mode balance: map both thighs and both feet (or set left_hip, right_hip, "
        "left_foot and right_foot to mapped clip joints)");
  is_foot_.assign(engine.nbody(), 0);
  for (int side = 0; side < 2; ++side)
    if (foot_[side] >= 0)
      for (int b = 0; b < engine.nbody(); ++b)
        for (int a = b; a >= 0; a = engine.body_parent(a))
          if (a == bodies[foot_[side]].body) {
            foot_bodies_[side].push_back(b);
            is_foot_[b] = 1;
            break;
          }
  // the ankles: the dofs between each foot and the body above its folded chain (a weak ankle
  // keeps its corrections: without them Atlas, 90 N m ankle rolls, lost mass_walk; robots.md)
  for (int side = 0; side < 2 && has_legs_; ++side) {
    int dofs = 0;
    for (int j = 0; j < engine.njoint(); ++j)
      for (int b = bodies[foot_[side]].body; b >= 0 && b != bodies[foot_[side]].parent;
           b = engine.body_parent(b))
        if (engine.joint(j).body == b) dofs += engine.joint(j).nv;
    ankle_corrections_ = std::min(ankle_corrections_, dofs);
  }
  if (mode_ == MocapRootMode::kFree && params.balance) {
    if (params.weak_ankles) weak_legs_ = find_weak_ankle_legs(engine, bodies, root_mapped_, foot_);
    // the walking direction in the root body's frame: the mean horizontal root velocity
    std::vector<Eigen::Quaterniond> world(bodies.size()), local(bodies.size());
    std::vector<Eigen::Vector3d> a(bodies.size()), b(bodies.size());
    Eigen::Vector3d fwd = Eigen::Vector3d::Zero();
    const double h = motion_->frame_time_s();
    for (double t = 0; t + h <= clip_.reference->duration_s(); t += h) {
      motion_->sample_bodies(t, local, a);
      motion_->sample_bodies(t + h, local, b);
      motion_->sample_world(t, world);
      Eigen::Vector3d vel = b[root_mapped_] - a[root_mapped_];
      vel -= vel.dot(up_) * up_;
      fwd += world[root_mapped_].conjugate() * vel;
    }
    if (fwd.norm() > 1e-9) forward_in_root_ = fwd.normalized();
  }

  init_fall_rule(engine, *probe);
  init_gains(params, engine);
}

// the fall rule's tables (anchors, children, the sole level), from the probe at the first frame
void MocapRetargetTracker::init_fall_rule(const Engine& engine, const Engine& probe_engine) {
  const auto& bodies = motion_->bodies();
  const Engine* probe = &probe_engine;
  // the fall rule: every body moves with its nearest mapped ancestor (the joints between are not
  // driven and stay at zero), so its reference COM and origin are fixed in that body's frame;
  // the probe stands at the table's first frame
  std::vector<int> mapped_of_body(engine.nbody(), -1);
  for (size_t i = 0; i < bodies.size(); ++i) mapped_of_body[bodies[i].body] = static_cast<int>(i);
  body_names_ = engine.body_names();
  anchor_.assign(engine.nbody(), -1);
  anchor_com_.assign(engine.nbody(), Eigen::Vector3d::Zero());
  anchor_origin_.assign(engine.nbody(), Eigen::Vector3d::Zero());
  for (int b = 0; b < engine.nbody(); ++b) {
    int a = b;
    while (a >= 0 && mapped_of_body[a] < 0) a = engine.body_parent(a);
    if (a < 0) continue;
    anchor_[b] = mapped_of_body[a];
    const BodyPose base = probe->body_pose(a);
    anchor_com_[b] = base.quat.conjugate() * (probe->body_com(b) - base.pos);
    anchor_origin_[b] = base.quat.conjugate() * (probe->body_pose(b).pos - base.pos);
    anchored_mass_ += engine.body_mass(b);
  }
  child_first_.assign(engine.nbody() + 1, 0);
  children_.clear();
  for (int b = 0; b < engine.nbody(); ++b) {
    child_first_[b] = static_cast<int>(children_.size());
    for (int c = 0; c < engine.nbody(); ++c)
      if (engine.body_parent(c) == b && anchor_[c] >= 0) children_.push_back(c);
  }
  child_first_[engine.nbody()] = static_cast<int>(children_.size());
  sole_level_ = 1e300;
  for (int f = 0; f < motion_->frame_count(); ++f)
    for (size_t i = 0; i < bodies.size(); ++i)
      sole_level_ = std::min(
          sole_level_, up_.dot(motion_->sample_body_pose(f * motion_->frame_time_s(), i).pos));
  com_height_ = up_.dot(probe->com()) - sole_level_;
}

// kp_ and kd_ per dof (kp_joints, kd_joints, the limit cap, the root's)
void MocapRetargetTracker::init_gains(const MocapRetargetParams& params, const Engine& engine) {
  // gains: every dof but the root's; the root's in assisted mode. A name is a dof, or a joint
  // for all its dofs.
  const int nv = engine.nv();
  kp_ = Eigen::VectorXd::Constant(nv, params.kp);
  kd_ = Eigen::VectorXd::Constant(nv, params.kd);
  for (const auto& [name, value] : params.kp_joints)
    set_gain_by_name(engine, kp_, name, value, "kp_joints");
  for (const auto& [name, value] : params.kd_joints)
    set_gain_by_name(engine, kd_, name, value, "kd_joints");
  if (mode_ == MocapRootMode::kFree && params.limit_gain_error > 0)
    cap_gains_at_limits(engine, params.limit_gain_error, kp_, kd_);
  // free mode: a leg softer than the body's gravity stiffness m g h lets the body topple about
  // its stance foot (kp 1600 on a 150 kg robot is about m g h); the legs' dofs, from the feet
  // up to the root body, get at least load_gain_margin x m g h, and then the cap above
  if (mode_ == MocapRootMode::kFree && has_legs_ && params.load_gain_margin > 0) {
    std::vector<int> leg_bodies;
    for (int side = 0; side < 2; ++side)
      for (int b = motion_->bodies()[foot_[side]].body; b >= 0 && b != root_body_;
           b = engine.body_parent(b))
        leg_bodies.push_back(b);
    raise_gains_to_floor(
        engine, leg_bodies,
        params.load_gain_margin * engine.total_mass() * engine.gravity().norm() * com_height_,
        params.limit_gain_error, kp_, kd_);
  }
  for (int i = root_dof_; i < root_dof_ + 6; ++i) {
    const bool translation = engine.dof_name(i).find("_pos_") != std::string::npos;
    root_translation_[i - root_dof_] = translation;
    const bool assisted = mode_ == MocapRootMode::kAssisted;
    kp_[i] = assisted ? (translation ? params.root_kp : params.root_kp_rot) : 0;
    kd_[i] = assisted ? (translation ? params.root_kd : params.root_kd_rot) : 0;
  }
}

void MocapRetargetTracker::correction_dims(std::vector<CorrectionDim>& dims) const {
  if (mode_ != MocapRootMode::kFree || !params_.balance) return;
  dims.push_back({"swing_hip_pitch", 0.15, "rad"});
  dims.push_back({"swing_hip_roll", 0.15, "rad"});
  dims.push_back({"pelvis_pitch", 0.1, "rad"});
  dims.push_back({"pelvis_roll", 0.1, "rad"});
  if (ankle_corrections_ > 0) dims.push_back({"stance_ankle_pitch", 0.1, "rad"});
  if (ankle_corrections_ > 1) dims.push_back({"stance_ankle_roll", 0.1, "rad"});
}

std::unique_ptr<ReferenceHorizon> MocapRetargetTracker::make_reference_horizon() const {
  return std::make_unique<MocapReferenceHorizon>();
}

// the same calls a rollout's step makes, once per planning step (the results are the same to
// the bit: the same functions at the same times)
void MocapRetargetTracker::sample_reference_horizon(ReferenceHorizon& horizon, const Engine& engine,
                                                    double t0, int steps) const {
  auto& h = static_cast<MocapReferenceHorizon&>(horizon);
  const int n = static_cast<int>(motion_->bodies().size());
  const size_t all = static_cast<size_t>(steps) * n;
  h.dt = engine.timestep();
  h.bodies = n;
  h.time.resize(steps);
  h.q.resize(engine.nq(), steps);
  h.v.resize(engine.nv(), steps);
  h.scratch.resize(engine.nv());
  h.world.resize(all);
  h.local.resize(all);
  h.position.resize(all);
  h.pose.resize(all);
  h.body_local.resize(all);
  h.root_ahead.resize(steps);
  h.root_acceleration.resize(steps);
  h.com_height.resize(steps);
  // per body, as sample_world() and sample_bodies() write them
  std::vector<Eigen::Quaterniond>&world = h.work_world, &local = h.work_local;
  std::vector<Eigen::Vector3d>&position = h.work_position, &ahead = h.work_ahead;
  for (auto* x : {&world, &local}) x->resize(n);
  for (auto* x : {&position, &ahead}) x->resize(n);
  double t = t0;
  for (int k = 0; k < steps; ++k) {
    t += h.dt;  // the engine's clock: each step adds its timestep
    h.time[k] = t;
    motion_->sample(engine, t, h.q.col(k), h.v.col(k), h.scratch);
    if (mode_ == MocapRootMode::kFree && params_.balance) {
      motion_->sample_world(t, world);
      motion_->sample_bodies(t + kRootVelocityStep, local, ahead);
      motion_->sample_bodies(t, local, position);
      const size_t at = static_cast<size_t>(k) * n;
      std::copy(world.begin(), world.end(), h.world.begin() + at);
      std::copy(local.begin(), local.end(), h.local.begin() + at);
      std::copy(position.begin(), position.end(), h.position.begin() + at);
      h.root_ahead[k] = ahead[root_mapped_];
      h.root_acceleration[k] = motion_->sample_body_acceleration(t, root_mapped_);
    }
    for (int i = 0; i < n; ++i) {
      h.pose[static_cast<size_t>(k) * n + i] = motion_->sample_body_pose(t, i);
      h.body_local[static_cast<size_t>(k) * n + i] = motion_->sample_body_local(t, i);
    }
    h.com_height[k] = reference_com_height(engine, t);
  }
}

void MocapRetargetTracker::use_reference_horizon(ControllerState& state,
                                                 const ReferenceHorizon* horizon) const {
  cast(state).horizon = static_cast<const MocapReferenceHorizon*>(horizon);
}

bool MocapRetargetTracker::tracking_error(const ControllerState& state, const Engine& engine,
                                          TrackingError& error) const {
  const State& s = cast(state);
  const double t = engine.time();
  const auto& bodies = motion_->bodies();
  const int k = s.horizon ? s.horizon->find(t) : -1;
  const size_t at = k >= 0 ? static_cast<size_t>(k) * bodies.size() : 0;
  double joints = 0, positions = 0;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const int b = bodies[i].body;
    const BodyPose pose = engine.body_pose(b);
    const BodyPose ref =
        k >= 0 ? s.horizon->pose[at + i] : motion_->sample_body_pose(t, static_cast<int>(i));
    const double e = (pose.pos - ref.pos).norm();
    positions += e;
    if (static_cast<int>(i) == root_mapped_) {
      error.root_m = e;
      // the angle between the up axis as the two roots see it: tilt, not heading
      const Eigen::Vector3d a = pose.quat.conjugate() * up_, r = ref.quat.conjugate() * up_;
      error.root_tilt_rad = std::atan2(a.cross(r).norm(), a.dot(r));
      continue;
    }
    const int p = bodies[i].parent;
    const Eigen::Quaterniond local =
        p >= 0 ? Eigen::Quaterniond(engine.body_pose(p).quat.conjugate() * pose.quat) : pose.quat;
    joints += geodesic_angle(local, k >= 0 ? s.horizon->body_local[at + i]
                                           : motion_->sample_body_local(t, static_cast<int>(i)));
  }
  error.joint_rad = bodies.size() > 1 ? joints / (bodies.size() - 1) : 0.0;
  error.body_m = positions / bodies.size();
  return true;
}

double MocapRetargetTracker::reference_com_height(const Engine& engine, double t) const {
  // the reference's COM from its body poses and the model's masses
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  for (int b = 0; b < engine.nbody(); ++b) {
    if (anchor_[b] < 0) continue;
    const BodyPose ref = motion_->sample_body_pose(t, anchor_[b]);
    com += engine.body_mass(b) * (ref.pos + ref.quat * anchor_com_[b]);
  }
  return up_.dot(com) / anchored_mass_ - sole_level_;
}

MocapFallCause MocapRetargetTracker::judge_fall(const Engine& engine,
                                                const MocapReferenceHorizon* horizon, int& body,
                                                double& com_height, double& ref_height) const {
  const double t = engine.time();
  const int k = horizon ? horizon->find(t) : -1;
  const size_t at = k >= 0 ? static_cast<size_t>(k) * horizon->bodies : 0;
  auto reference_pose = [&](int i) {
    return k >= 0 ? horizon->pose[at + i] : motion_->sample_body_pose(t, i);
  };
  ref_height = k >= 0 ? horizon->com_height[k] : reference_com_height(engine, t);
  com_height = up_.dot(engine.com()) - sole_level_;
  if (com_height < kComFraction * ref_height) return MocapFallCause::kComLow;
  // a body outside the feet on the ground, where the reference's is not
  for (int i = 0, n = engine.num_contacts(); i < n; ++i) {
    const Contact c = engine.contact(i);
    const int b = c.body1 < 0 ? c.body2 : (c.body2 < 0 ? c.body1 : -1);
    if (b < 0 || is_foot_[b] || anchor_[b] < 0) continue;
    // the lowest point of the body's bone in the reference: its origin or a child's
    const BodyPose ref = reference_pose(anchor_[b]);
    double low = up_.dot(ref.pos + ref.quat * anchor_origin_[b]);
    for (int j = child_first_[b]; j < child_first_[b + 1]; ++j) {
      const int c = children_[j];
      const BodyPose rc = reference_pose(anchor_[c]);
      low = std::min(low, up_.dot(rc.pos + rc.quat * anchor_origin_[c]));
    }
    if (low - sole_level_ > kTouchHeight) {
      body = b;
      return MocapFallCause::kBodyTouches;
    }
  }
  return MocapFallCause::kNone;
}

FallVerdict MocapRetargetTracker::fall_verdict(const ControllerState& state, const Engine& engine,
                                               std::string& reason) const {
  const State& s = cast(state);
  int body = -1;
  double h = 0, h_ref = 0;
  switch (judge_fall(engine, s.horizon, body, h, h_ref)) {
    case MocapFallCause::kNone:
      return FallVerdict::kUp;
    case MocapFallCause::kComLow:
      reason = fmt::format("the COM is {:.3f} m high, below {:.0f}% of the reference's {:.3f} m", h,
                           100 * kComFraction, h_ref);
      return FallVerdict::kFell;
    case MocapFallCause::kBodyTouches:
      reason = fmt::format("body '{}' touches the ground and the reference's does not",
                           engine.body_name(body));
      return FallVerdict::kFell;
  }
  return FallVerdict::kNoOpinion;
}

bool MocapRetargetTracker::initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                                         Eigen::VectorXd& qvel) const {
  qpos.resize(engine.nq());
  qvel.resize(engine.nv());
  Eigen::VectorXd scratch(engine.nv());
  motion_->sample(engine, 0, qpos, qvel, scratch);
  return true;
}

// the YAML's numbers, without the visit's units and ranges (as before the typed panel)
std::vector<ParamEntry> MocapRetargetTracker::tunable_params() const {
  std::vector<ParamEntry> out;
  list_yaml_params(params_yaml(), "", out);
  return out;
}

bool MocapRetargetTracker::keeps_state_of(const Controller& previous) const {
  const auto* p = dynamic_cast<const MocapRetargetTracker*>(&previous);
  return p && p->params_.mode == params_.mode && p->params_.joint_map == params_.joint_map &&
         same_mocap_clip(p->params_, params_);
}

bool MocapRetargetTracker::reference_qpos(const ControllerState&, const Engine& engine,
                                          Eigen::VectorXd& qpos) const {
  qpos.resize(engine.nq());
  Eigen::VectorXd v(engine.nv()), scratch(engine.nv());
  motion_->sample(engine, engine.time(), qpos, v, scratch);
  return true;
}

void MocapRetargetTracker::reset_state(State& s, const Engine& engine) const {
  const int nq = engine.nq(), nv = engine.nv();
  for (Eigen::VectorXd* x : {&s.q, &s.q_ref}) x->setZero(nq);
  for (Eigen::VectorXd* x : {&s.v, &s.v_ref, &s.tau, &s.scratch}) x->setZero(nv);
  s.work.resize(nq, nv);
  s.ref_local.assign(motion_->bodies().size(), Eigen::Quaterniond::Identity());
  s.ref_position.assign(motion_->bodies().size(), Eigen::Vector3d::Zero());
  s.error_sum_deg = s.max_error_deg = s.last_error_deg = 0;
  s.error_samples = 0;
  s.root_error_sum = s.root_error_max = s.last_root_error = 0;
  s.end_error_sum = s.end_error_max = 0;
  s.body_error_sum = s.body_error_max = s.last_body_error = 0;
  s.skate_sum = 0;
  s.skate_samples = 0;
  s.steps = 0;
  s.helper_impulse = s.helper_angular_impulse = 0;
  s.fall_time = -1;
  s.ref_fall_time = -1;
  s.fall_cause = static_cast<int>(MocapFallCause::kNone);
  s.fall_body = -1;
  s.recorded_rotations.clear();
  s.recorded_roots.clear();
  s.next_record_t = 0;
  if (!params_.export_bvh.empty()) {
    // a frame is recorded at most once a step
    const size_t frames = mocap_record_frames(
        duration_s_, std::max(clip_.reference->frame_time_s(), engine.timestep()));
    s.recorded_rotations.reserve(frames * motion_->bodies().size());
    s.recorded_roots.reserve(frames);
  }
  Eigen::Vector3d g = engine.gravity();
  s.up = g.norm() > 0 ? Eigen::Vector3d(-g.normalized()) : Eigen::Vector3d::UnitZ();
  const size_t n = motion_->bodies().size();
  s.bal_world.assign(n, Eigen::Quaterniond::Identity());
  s.bal_local.assign(n, Eigen::Quaterniond::Identity());
  s.bal_pos.assign(n, Eigen::Vector3d::Zero());
  s.bal_pos_ahead.assign(n, Eigen::Vector3d::Zero());
  s.jac_a.setZero(3, engine.nv());
  s.jac_b.setZero(3, engine.nv());
  s.stance = 0;
  s.stance_share = {1, 0};
  s.horizon = nullptr;
}

void MocapRetargetTracker::accumulate_metrics(State& s, const Engine& engine) const {
  const double t = engine.time();
  motion_->sample_bodies(t, s.ref_local, s.ref_position);
  const auto& bodies = motion_->bodies();
  // the lowest mapped body of the reference (a foot): falls are measured from it, so the
  // model's floor may be anywhere (fullbody1's is at y = -0.895)
  double lowest = 1e300;
  for (size_t i = 0; i < bodies.size(); ++i) lowest = std::min(lowest, s.up.dot(s.ref_position[i]));
  double sum = 0, positions = 0;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const int b = bodies[i].body;
    positions += (engine.body_pose(b).pos - s.ref_position[i]).norm();
    const int p = bodies[i].parent;
    Eigen::Quaterniond local = engine.body_pose(b).quat;
    if (p >= 0) local = engine.body_pose(p).quat.conjugate() * local;
    double e = geodesic_angle(local, s.ref_local[i]) * kRadToDeg;
    if (bodies[i].segment == 0) {
      double r = (engine.body_pose(b).pos - s.ref_position[i]).norm();
      s.last_root_error = r;
      s.root_error_sum += r;
      s.root_error_max = std::max(s.root_error_max, r);
      const double drop = s.up.dot(s.ref_position[i] - engine.body_pose(b).pos);
      if (s.fall_time < 0 && drop > 0.5 * (s.up.dot(s.ref_position[i]) - lowest)) s.fall_time = t;
      continue;  // the root's orientation is the root's business, not a joint's
    }
    sum += e;
    s.max_error_deg = std::max(s.max_error_deg, e);
  }
  const int joints = static_cast<int>(bodies.size()) - 1;
  if (joints > 0) {
    s.error_sum_deg += sum;
    s.error_samples += joints;
    s.last_error_deg = sum / joints;
  }
  double ends = 0;
  for (int i : motion_->end_bodies()) {
    double e = (engine.body_pose(bodies[i].body).pos - s.ref_position[i]).norm();
    ends += e;
    s.end_error_max = std::max(s.end_error_max, e);
  }
  if (!motion_->end_bodies().empty()) s.end_error_sum += ends / motion_->end_bodies().size();
  // PHC's G-MPJPE: the mean world position error of the mapped bodies, per step
  s.last_body_error = positions / bodies.size();
  s.body_error_sum += s.last_body_error;
  s.body_error_max = std::max(s.body_error_max, s.last_body_error);
  // foot skate: the horizontal speed of a foot (its mapped body's origin) while it touches
  for (int side = 0; side < 2; ++side) {
    if (foot_[side] < 0) continue;
    bool touch = false;
    for (int b : foot_bodies_[side]) touch = touch || engine.body_touches_ground(b);
    if (!touch) continue;
    Eigen::Vector3d v = engine.body_velocity(bodies[foot_[side]].body).tail<3>();
    s.skate_sum += (v - v.dot(s.up) * s.up).norm();
    ++s.skate_samples;
  }
  // the fall rule, as fall_verdict() gives it
  if (s.ref_fall_time < 0) {
    int body = -1;
    double h = 0, h_ref = 0;
    const MocapFallCause cause = judge_fall(engine, s.horizon, body, h, h_ref);
    if (cause != MocapFallCause::kNone) {
      s.ref_fall_time = t;
      s.fall_cause = static_cast<int>(cause);
      s.fall_body = body;
    }
  }
}

void MocapRetargetTracker::compute_with(State& s, const Engine& engine, const double* correction,
                                        ControlOutput& out) const {
  const double dt = engine.timestep();
  engine.get_positions(s.q);
  engine.get_velocities(s.v);
  if (metrics_) accumulate_metrics(s, engine);
  if (!params_.export_bvh.empty() && engine.time() + 1e-9 >= s.next_record_t) {
    for (const RetargetBody& b : motion_->bodies())
      s.recorded_rotations.push_back(engine.body_pose(b.body).quat);
    s.recorded_roots.push_back(engine.body_pose(motion_->bodies()[root_mapped_].body).pos);
    s.next_record_t = s.recorded_roots.size() * clip_.reference->frame_time_s();
  }
  const double t_ref = engine.time() + dt;
  const int k = s.horizon ? s.horizon->find(t_ref) : -1;
  if (k >= 0) {
    s.q_ref = s.horizon->q.col(k);
    s.v_ref = s.horizon->v.col(k);
  } else {
    motion_->sample(engine, t_ref, s.q_ref, s.v_ref, s.scratch);
  }
  s.tau.setZero();
  if (mode_ == MocapRootMode::kKinematic) {
    add_deadbeat_torques(engine, s.q, s.v, s.q_ref, s.work, s.tau);
  } else {
    if (mode_ == MocapRootMode::kFree && params_.balance) balance(s, engine, t_ref, correction);
    add_stable_pd_torques(engine, s.q, s.v, s.q_ref, s.v_ref, kp_, kd_, params_.max_torque,
                          root_dof_, root_dof_ + 6, s.work, s.tau);
    if (mode_ == MocapRootMode::kFree) s.tau.segment<6>(root_dof_).setZero();
  }
  if (mode_ != MocapRootMode::kFree) {
    double force = 0, torque = 0;
    for (int k = 0; k < 6; ++k)
      (root_translation_[k] ? force : torque) += s.tau[root_dof_ + k] * s.tau[root_dof_ + k];
    s.helper_impulse += std::sqrt(force) * dt;
    s.helper_angular_impulse += std::sqrt(torque) * dt;
  }
  out.tau += s.tau;
  ++s.steps;
}

// the balance layer on the model's bodies: world-frame targets for the swing thigh and foot and
// the stance thigh (the pelvis servo), fitted to joint coordinates in s.q_ref, and a virtual COM
// force carried by the stance leg(s) as joint torques in s.tau. `correction` (the planner's,
// correction_dims() order; null: none) offsets the swing thigh's feedback angles, tilts the
// pelvis target and tilts the stance foot.
void MocapRetargetTracker::balance(State& s, const Engine& engine, double t,
                                   const double* correction) const {
  // the planner's offsets, zero for the dimensions the model's ankles do not have
  double c[kCorrections] = {};
  if (correction) std::copy_n(correction, kStanceAnklePitch + ankle_corrections_, c);
  const auto& bodies = motion_->bodies();
  const MocapRetargetParams& p = params_;
  const double h = kRootVelocityStep;  // the reference root velocity by a forward difference
  const int k = s.horizon ? s.horizon->find(t) : -1;
  if (k >= 0) {  // a planner rollout: sampled once for every rollout
    const size_t n = bodies.size(), at = static_cast<size_t>(k) * n;
    std::copy_n(s.horizon->world.begin() + at, n, s.bal_world.begin());
    std::copy_n(s.horizon->local.begin() + at, n, s.bal_local.begin());
    std::copy_n(s.horizon->position.begin() + at, n, s.bal_pos.begin());
    s.bal_pos_ahead[root_mapped_] = s.horizon->root_ahead[k];
  } else {
    motion_->sample_world(t, s.bal_world);
    motion_->sample_bodies(t + h, s.bal_local, s.bal_pos_ahead);
    motion_->sample_bodies(t, s.bal_local, s.bal_pos);
  }
  auto height = [&](const Eigen::Vector3d& x) { return s.up.dot(x); };
  auto horizontal = [&](const Eigen::Vector3d& x) {
    return Eigen::Vector3d(x - s.up.dot(x) * s.up);
  };
  // stance: the foot that alone touches the ground, else the lower one in the reference
  bool touch[2] = {false, false};
  for (int side = 0; side < 2; ++side)
    for (int b : foot_bodies_[side]) touch[side] = touch[side] || engine.body_touches_ground(b);
  s.stance = height(s.bal_pos[foot_[0]]) <= height(s.bal_pos[foot_[1]]) ? 0 : 1;
  if (touch[0] != touch[1]) s.stance = touch[0] ? 0 : 1;
  for (int side = 0; side < 2; ++side)
    s.stance_share[side] = touch[side] ? (touch[1 - side] ? 0.5 : 1.0) : 0.0;
  const int swing = 1 - s.stance;
  // headings of the simulation and the reference; the targets turn onto the simulated one
  const int root_body = bodies[root_mapped_].body;
  const BodyPose root = engine.body_pose(root_body);
  auto heading = [&](const Eigen::Quaterniond& r) {
    Eigen::Vector3d f = horizontal(r * forward_in_root_);
    return f.norm() > 1e-9 ? Eigen::Vector3d(f.normalized()) : forward_in_root_;
  };
  const Eigen::Vector3d fwd = heading(root.quat), fwd_ref = heading(s.bal_world[root_mapped_]);
  const Eigen::Vector3d lat = s.up.cross(fwd), lat_ref = s.up.cross(fwd_ref);
  const double yaw_error = std::atan2(s.up.dot(fwd_ref.cross(fwd)), fwd_ref.dot(fwd));
  // the targets follow most of the simulated heading; the rest steers back to the clip's
  const Eigen::Quaterniond yaw_fix(Eigen::AngleAxisd((1 - p.heading_return) * yaw_error, s.up));
  // SIMBICON feedback on the root's offset from the stance ankle and its velocity
  const Eigen::Vector3d ankle = engine.body_pose(bodies[foot_[s.stance]].body).pos;
  const Eigen::Vector3d ankle_ref = s.bal_pos[foot_[s.stance]];
  const Eigen::Vector3d d = root.pos - ankle, d_ref = s.bal_pos[root_mapped_] - ankle_ref;
  const Eigen::Vector3d vel = engine.body_velocity(root_body).tail<3>();
  const Eigen::Vector3d vel_ref = (s.bal_pos_ahead[root_mapped_] - s.bal_pos[root_mapped_]) / h;
  // ... and on the root's drift from the clip's path: a step placed to walk back onto it
  const Eigen::Vector3d path_error = horizontal(root.pos - s.bal_pos[root_mapped_]);
  const double th_sag = std::clamp(p.path_feedback * path_error.dot(fwd) +
                                       p.cd_sagittal * (d.dot(fwd) - d_ref.dot(fwd_ref)) +
                                       p.cv_sagittal * (vel.dot(fwd) - vel_ref.dot(fwd_ref)),
                                   -0.8, 0.8);
  const double th_cor = std::clamp(p.path_feedback * path_error.dot(lat) +
                                       p.cd_coronal * (d.dot(lat) - d_ref.dot(lat_ref)) +
                                       p.cv_coronal * (vel.dot(lat) - vel_ref.dot(lat_ref)),
                                   -0.5, 0.5);
  // the planner's offsets act after the clamps: it may go where the feedback alone may not
  const Eigen::Quaterniond delta =
      Eigen::Quaterniond(Eigen::AngleAxisd(th_sag + c[kSwingHipPitch], -lat)) *
      Eigen::Quaterniond(Eigen::AngleAxisd(th_cor + c[kSwingHipRoll], fwd));
  // a world rotation for mapped body i, as its joint rotation under the parent as it is
  auto set_world = [&](int i, const Eigen::Quaterniond& world) {
    const int parent = bodies[i].parent;
    Eigen::Quaterniond base = motion_->rest_local(i);
    if (parent >= 0) base = engine.body_pose(parent).quat * base;
    motion_->set_body_local(i, (base.conjugate() * world).normalized(), s.q_ref);
  };
  // the swing servo while the swing foot is off the ground (a foot that is down is a second
  // stance foot: servoing its thigh drags it) and, on weak ankles, while the clip swings it
  const double clip_lift = height(s.bal_pos[foot_[swing]]) - height(s.bal_pos[foot_[s.stance]]);
  const bool swinging = !touch[swing] || (weak_legs_.weak && clip_lift > kWeakSwingClearance);
  if (swinging) {
    set_world(hip_[swing], delta * yaw_fix * s.bal_world[hip_[swing]]);
    if (p.swing_foot_world) set_world(foot_[swing], yaw_fix * s.bal_world[foot_[swing]]);
    if (weak_legs_.weak) lift_swing_foot(s, engine, swing, root);
  }
  // the stance hip (both hips when both feet are down): the joint rotation that puts the pelvis
  // at its reference over the thigh as it is, blended with the reference's own
  for (int side = 0; side < 2; ++side) {
    const int hip = hip_[side];
    if ((side != s.stance && swinging) || bodies[hip].parent != root_body) continue;
    const Eigen::Quaterniond tilt = Eigen::Quaterniond(Eigen::AngleAxisd(c[kPelvisPitch], -lat)) *
                                    Eigen::Quaterniond(Eigen::AngleAxisd(c[kPelvisRoll], fwd));
    const Eigen::Quaterniond pelvis = tilt * yaw_fix * s.bal_world[root_mapped_];
    const Eigen::Quaterniond servo =
        ((pelvis * motion_->rest_local(hip)).conjugate() * engine.body_pose(bodies[hip].body).quat)
            .normalized();
    motion_->set_body_local(hip, s.bal_local[hip].slerp(p.stance_hip_world_weight, servo), s.q_ref);
  }
  // the stance foot tilted in the world about its target, pressing the centre of pressure
  // towards a side
  if (c[kStanceAnklePitch] != 0 || c[kStanceAnkleRoll] != 0) {
    const int foot = foot_[s.stance];
    const Eigen::Quaterniond tilt =
        Eigen::Quaterniond(Eigen::AngleAxisd(c[kStanceAnklePitch], -lat)) *
        Eigen::Quaterniond(Eigen::AngleAxisd(c[kStanceAnkleRoll], fwd));
    const int parent = bodies[foot].parent;
    Eigen::Quaterniond base = motion_->rest_local(foot);
    if (parent >= 0) base = engine.body_pose(parent).quat * base;
    motion_->set_body_local(foot, (base.conjugate() * tilt * base * s.bal_local[foot]).normalized(),
                            s.q_ref);
  }
  // the virtual force at the COM, reacted by the supporting feet (Coros et al. 2010)
  const double weight = engine.total_mass() * engine.gravity().norm();
  Eigen::Vector3d force = -p.gravity_compensation * engine.total_mass() * engine.gravity();
  if (p.reference_support > 0) {
    // the vertical force the clip's root motion needs, m (g + a): a run's stance asks for over
    // twice the weight, its flight for none
    const Eigen::Vector3d a_ref = k >= 0 ? s.horizon->root_acceleration[k]
                                         : motion_->sample_body_acceleration(t, root_mapped_);
    const double need = s.up.dot(a_ref) - s.up.dot(engine.gravity());
    force += p.reference_support * engine.total_mass() * std::max(need, 0.0) * s.up;
  }
  const Eigen::Vector3d e = yaw_fix * d_ref - d, ev = yaw_fix * vel_ref - vel;
  force += horizontal(p.root_force_kp * e + p.root_force_kd * ev);
  force += p.root_force_kd_z * s.up.dot(ev) * s.up;
  const double lift = std::clamp(s.up.dot(force), 0.0, 2 * weight);  // the feet can only push
  force = horizontal(force) + lift * s.up;
  if (force.squaredNorm() == 0) return;
  engine.com_jacobian(s.jac_a);
  for (int side = 0; side < 2; ++side)
    if (s.stance_share[side] > 0)
      add_com_support_torque(engine, bodies[foot_[side]].body, s.stance_share[side] * force,
                             s.jac_a, s.jac_b, s.tau);
}

void MocapRetargetTracker::signal_names(std::vector<std::string>& names) const {
  for (const char* s : {"mocap_joint_error_deg", "mocap_root_error_m"}) names.emplace_back(s);
}

void MocapRetargetTracker::signals(const ControllerState& state,
                                   std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.last_error_deg);
  values.push_back(s.last_root_error);
}

void MocapRetargetTracker::add_metrics(const ControllerState& state,
                                       nlohmann::json& metrics) const {
  const State& s = cast(state);
  const double steps = std::max<long>(s.steps, 1);
  nlohmann::json j;
  j["mode"] = params_.mode;
  j["mean_joint_error_deg"] = s.mean_joint_error_deg();
  j["max_joint_error_deg"] = s.max_error_deg;
  j["mean_root_error_m"] = s.root_error_sum / steps;
  j["max_root_error_m"] = s.root_error_max;
  j["mean_end_effector_error_m"] = s.end_error_sum / steps;
  j["max_end_effector_error_m"] = s.end_error_max;
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
  j["helper_impulse_Ns"] = s.helper_impulse;
  j["helper_angular_impulse_Nms"] = s.helper_angular_impulse;
  j["root_fall_time_s"] = s.fall_time >= 0 ? nlohmann::json(s.fall_time) : nlohmann::json(nullptr);
  j["clip_duration_s"] = clip_.reference->duration_s();
  j["clip_frames"] = clip_.reference->frame_count();
  // the field's metrics (PHC): body positions against the reference's, success, foot skate
  j["mean_body_position_error_m"] = s.body_error_sum / steps;
  j["max_body_position_error_m"] = s.body_error_max;
  j["foot_skate_m_per_s"] = s.skate_samples ? s.skate_sum / s.skate_samples : 0.0;
  j["fall_time_s"] =
      s.ref_fall_time >= 0 ? nlohmann::json(s.ref_fall_time) : nlohmann::json(nullptr);
  const auto cause = static_cast<MocapFallCause>(s.fall_cause);
  j["fall_cause"] = cause == MocapFallCause::kComLow        ? "com_low"
                    : cause == MocapFallCause::kBodyTouches ? "body_touches_ground"
                                                            : "";
  if (cause == MocapFallCause::kBodyTouches && s.fall_body >= 0)
    j["fall_body"] = body_names_[s.fall_body];
  j["success"] = s.steps > 0 && s.ref_fall_time < 0 && s.body_error_max <= kSuccessBodyError;
  metrics["mocap"] = j;
}

BvhClip MocapRetargetTracker::recorded_clip(const State& s) const {
  const ReferenceMotion& ref = *clip_.reference;
  const MotionSkeleton& sk = ref.skeleton();
  const int n = sk.segment_count();
  const auto& bodies = motion_->bodies();
  std::vector<int> mapped(n, -1);
  for (size_t i = 0; i < bodies.size(); ++i) mapped[bodies[i].segment] = static_cast<int>(i);
  const int frames = static_cast<int>(s.recorded_roots.size());
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
                              i, s.recorded_rotations[static_cast<size_t>(f) * bodies.size() + i])
                        : world[parent] * pose.rotations[k];
      locals[static_cast<size_t>(f) * n + k] =
          parent >= 0 ? (world[parent].conjugate() * world[k]).normalized() : world[k];
    }
    roots[f] = motion_->clip_root_position(s.recorded_roots[f]);
  }
  return clip_from_segment_poses(clip_, locals, roots, params_.export_origin_centred);
}

void MocapRetargetTracker::write_outputs(const ControllerState& state,
                                         const std::string& out_dir) const {
  const State& s = cast(state);
  if (params_.export_bvh.empty() || s.recorded_roots.empty()) return;
  write_exported_bvh(recorded_clip(s), params_.export_bvh, out_dir);
}

}  // namespace stance
