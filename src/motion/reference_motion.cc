#include "motion/reference_motion.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/format.h>

#include "core/error.h"
#include "motion/bvh_measure.h"

namespace stance {

namespace {

bool name_matches(const std::string& name, const std::vector<std::string>& patterns) {
  for (const auto& p : patterns)
    if (!p.empty() && name.find(p) != std::string::npos) return true;
  return false;
}

// The synthetic run's legs and root, in the skeleton's sagittal plane (Y up, Z forward; cm, s,
// degrees). The root advances at a constant speed and moves vertically as a body under a
// half-sine vertical ground force in stance and ballistically in flight, so that the force
// averages to the weight over a step: the clip asks only for what a body can do. The stance
// foot's toe tip is planted on the floor while the heel rises; a swing ankle moves about the hip
// from its take-off reach and angle to its landing ones along cubic Hermite curves, folded
// towards the hip in between. Both legs' angles follow from hip and ankle by two-link inverse
// kinematics, in leg planes rolled in so that the feet land near the midline.
class SyntheticRunGait {
 public:
  static constexpr double kHipSide = 9, kHipDrop = 6, kThigh = 44, kShank = 42, kToeDown = 7,
                          kToeAhead = 16;

  SyntheticRunGait(const SyntheticWalkOptions& o, double (*root_pitch_deg)(double phase))
      : o_(o),
        pitch_(root_pitch_deg),
        period_(o.period_s),
        stance_(o.stance_fraction * o.period_s),
        speed_(100 * o.run_speed_mps) {
    if (!(o.stance_fraction > 0 && o.stance_fraction < 0.5))
      throw InputError("synthetic run: stance_fraction must be in (0, 0.5)");
    const double step = period_ / 2, g = 981;
    force_ = std::numbers::pi * g * step / (2 * stance_);  // the stance's peak, per unit mass
    // each thigh rolled in so that the feet land run_step_width_cm apart (about 80 cm below)
    roll_ = std::asin(std::clamp((kHipSide - o.run_step_width_cm / 2) / 80, -0.5, 0.5));
    // the root's height at mid-stance: the stance knee never straighter than run_knee_min_deg
    double lo = 40, hi = 120;
    for (int it = 0; it < 60; ++it) {
      mid_height_ = 0.5 * (lo + hi);
      double least = 1e9;
      for (int k = 0; k <= 20; ++k) {
        const double tau = (k / 20.0 - 0.5) * stance_;
        Foot f = stance_foot(tau, tau);
        double hip, knee, ankle;
        solve(tau, f, hip, knee, ankle);
        least = std::min(least, knee);
      }
      (least < o.run_knee_min_deg ? hi : lo) = mid_height_;
    }
  }

  // the root's height and advance at time t; right mid-stance at t = 0, left at period / 2
  double root_height(double t) const {
    const double g = 981, pi = std::numbers::pi, step = period_ / 2;
    const double tau = std::abs(std::remainder(t, step)), w = stance_ / 2;
    const double c = force_ * stance_ * stance_ / (pi * pi);
    if (tau <= w) return mid_height_ + c * (1 - std::cos(pi * tau / stance_)) - g * tau * tau / 2;
    const double take_off = mid_height_ + c - g * w * w / 2, u = tau - w;
    return take_off + g * (step - stance_) / 2 * u - g * u * u / 2;
  }
  double root_advance(double t) const { return speed_ * t; }
  // the roll (deg) of leg s's thigh towards the midline (a Z rotation), undone at its foot
  double leg_roll_deg(int s) const { return (s == 0 ? -1 : 1) * roll_ * 180 / std::numbers::pi; }

  // leg s's (0 left, 1 right) joint angles at time t
  void leg_angles(int s, double t, double& hip, double& knee, double& ankle) const {
    const double mid = s == 1 ? 0 : period_ / 2;
    const double tau = std::remainder(t - mid, period_), w = stance_ / 2;
    if (std::abs(tau) <= w) return solve(t, stance_foot(t, tau), hip, knee, ankle);
    // the swing: from take-off (tau = w) to the next landing (tau = period - w)
    const double since = tau > 0 ? tau - w : tau + period_ - w, span = period_ - stance_;
    const double h = 1e-5, start = t - since, end = start + span;
    const Foot f0 = stance_foot(start, w), f0b = stance_foot(start - h, w - h);
    const Foot f1 = stance_foot(end, -w), f1b = stance_foot(end + h, -w + h);
    const double u = since / span, u2 = u * u, u3 = u2 * u;
    auto hermite = [&](double p0, double r0, double p1, double r1) {
      r0 *= span, r1 *= span;
      return (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * r0 + (-2 * u3 + 3 * u2) * p1 +
             (u3 - u2) * r1;
    };
    // the ankle about the hip in polar form (reach and angle) at take-off, landing and h on
    double reach[4], angle[4];
    const Foot ends[4] = {f0, f0b, f1, f1b};
    const double times[4] = {start, start - h, end, end + h};
    for (int k = 0; k < 4; ++k) {
      double hy, hz;
      hip_at(times[k], hy, hz);
      reach[k] = std::hypot(ends[k].y - hy, ends[k].z - hz);
      angle[k] = std::atan2(hz - ends[k].z, hy - ends[k].y);
    }
    // the reach: stopping its stance extension at take-off and starting its compression at
    // landing (a step in its rate, as at a real foot's push-off and impact), folded in between
    const double fold = std::sin(std::numbers::pi * u);
    const double d = hermite(reach[0], std::min(0.0, (reach[0] - reach[1]) / h), reach[2],
                             std::max(0.0, (reach[3] - reach[2]) / h)) -
                     o_.run_ankle_lift_cm * fold * fold;
    const double b =
        hermite(angle[0], (angle[0] - angle[1]) / h, angle[2], (angle[3] - angle[2]) / h);
    double hy, hz;
    hip_at(t, hy, hz);
    Foot f;
    f.y = hy - d * std::cos(b);
    f.z = hz - d * std::sin(b);
    f.pitch = hermite(f0.pitch, (f0.pitch - f0b.pitch) / h, f1.pitch, (f1b.pitch - f1.pitch) / h);
    solve(t, f, hip, knee, ankle);
  }

 private:
  struct Foot {
    double y = 0, z = 0, pitch = 0;  // the ankle (cm) and the foot's pitch in the world (rad)
  };
  void hip_at(double t, double& y, double& z) const {
    const double p = pitch_(2 * std::numbers::pi * t / period_) * std::numbers::pi / 180;
    y = root_height(t) - kHipDrop * std::cos(p);
    z = root_advance(t) - kHipDrop * std::sin(p);
  }
  // a stance foot at time t, tau after its mid-stance (|tau| <= stance / 2): the toe tip planted
  // run_toe_ahead_cm ahead of the hip at mid-stance, the heel rising from flat at landing
  Foot stance_foot(double t, double tau) const {
    const double deg = std::numbers::pi / 180;
    auto foot_pitch = [&](double at) {
      const double u = at / stance_ + 0.5;
      return o_.run_foot_pitch_deg * deg * u * u;
    };
    double hy, hz;
    hip_at(t - tau, hy, hz);
    const double toe_z = hz + o_.run_toe_ahead_cm;
    Foot f;
    f.pitch = foot_pitch(tau);
    f.y = kToeDown * std::cos(f.pitch) + kToeAhead * std::sin(f.pitch);
    f.z = toe_z - (kToeAhead * std::cos(f.pitch) - kToeDown * std::sin(f.pitch));
    return f;
  }
  // the leg's joint angles (deg) that put its ankle at f with the foot at f's pitch
  void solve(double t, const Foot& f, double& hip, double& knee, double& ankle) const {
    const double deg = std::numbers::pi / 180;
    double hy, hz;
    hip_at(t, hy, hz);
    // the leg's plane is rolled in by roll_ (run_step_width_cm): its height in that plane
    const double ry = (f.y - hy) / std::cos(roll_), rz = f.z - hz, d = std::hypot(ry, rz);
    const double l1 = kThigh, l2 = kShank;
    const double k = std::acos(std::clamp((d * d - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1.0, 1.0));
    const double alpha =
        std::acos(std::clamp((l1 * l1 + d * d - l2 * l2) / (2 * l1 * d), -1.0, 1.0));
    const double a1 = std::atan2(-rz, -ry) - alpha, a2 = a1 + k;
    hip = a1 / deg - pitch_(2 * std::numbers::pi * t / period_);
    knee = k / deg;
    ankle = (f.pitch - a2) / deg;
  }

  const SyntheticWalkOptions& o_;
  double (*pitch_)(double);
  double period_, stance_, speed_, force_ = 0, mid_height_ = 0;
  double roll_ = 0;  // rad, each leg's roll towards the body's midline
};

}  // namespace

int MotionSkeleton::find_segment(const std::string& name) const {
  for (int i = 0; i < segment_count(); ++i)
    if (segments[i].name == name) return i;
  return -1;
}

std::vector<int> MotionSkeleton::end_effectors() const {
  std::vector<int> out;
  for (int i = 0; i < segment_count(); ++i)
    if (segments[i].children.empty()) out.push_back(i);
  return out;
}

Eigen::Quaterniond yaw_of(const Eigen::Quaterniond& q) {
  Eigen::Matrix3d r = q.toRotationMatrix();
  double yaw = std::atan2(r(1, 0), r(0, 0));
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
}

RootCarriers root_carriers(const BvhClip& clip, const MotionSkeleton& skeleton, int frame) {
  RootCarriers out;
  const std::vector<int>& chain = skeleton.segments[0].rotation_chain;
  for (size_t i = 0; i + 1 < chain.size(); ++i) {
    out.translation += out.rotation * clip.translation(frame, chain[i]);
    out.rotation = out.rotation * clip.rotation(frame, chain[i]);
  }
  return out;
}

Eigen::Vector3d root_chain_translation(const BvhClip& clip, const MotionSkeleton& skeleton,
                                       int frame) {
  const RootCarriers c = root_carriers(clip, skeleton, frame);
  return c.translation + c.rotation * clip.translation(frame, skeleton.segments[0].bvh_joint);
}

MotionSkeleton make_motion_skeleton(const BvhClip& clip, const MotionSkeletonOptions& options) {
  const int n = clip.joint_count();
  if (n == 0) throw InputError(clip.source + ": no joints");
  MotionSkeleton sk;
  sk.scale_to_meters =
      options.scale_to_meters > 0 ? options.scale_to_meters : detect_bvh_scale_to_meters(clip);
  // a detected size is checked against a person's; a given scale_to_meters is the user's word
  if (options.scale_to_meters <= 0)
    sk.warnings = bvh_character_warnings(clip, measure_bvh_character(clip, sk.scale_to_meters));
  auto lower = [](char axis) {
    return static_cast<char>(std::tolower(static_cast<unsigned char>(axis)));
  };
  auto turn_z_up = [](char axis) {
    if (axis == 'y')
      return Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitX()));
    if (axis != 'z') throw InputError(fmt::format("up axis: expected y or z, found '{}'", axis));
    return Eigen::Quaterniond::Identity();
  };
  const bool detect = options.up_axis == 0;
  sk.up_axis = detect ? detect_bvh_up_axis(clip, false) : lower(options.up_axis);
  sk.world_up_axis = detect ? detect_bvh_up_axis(clip, true) : lower(options.up_axis);
  sk.to_z_up = turn_z_up(sk.up_axis);
  sk.world_to_z_up = turn_z_up(sk.world_up_axis);
  const Eigen::Matrix3d c = sk.to_z_up.toRotationMatrix();
  const double s = sk.scale_to_meters;
  auto end_site_kept = [&](const BvhJoint& jt) {
    double len = jt.end_site_offset.norm() * s;
    return jt.has_end_site && len >= options.min_end_site_m && len <= options.max_end_site_m;
  };
  auto convert = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d { return s * (c * v); };

  // classify: skipped by name (with the subtree), end-point leaves, merged helpers, segments
  enum class Role { kSegment, kMerged, kEndPoint, kSkipped, kCarrier };
  std::vector<Role> role(n, Role::kSegment);
  std::vector<int> kept_children(n, 0);
  for (int j = 0; j < n; ++j) {
    const BvhJoint& jt = clip.joints[j];
    if ((jt.parent >= 0 && role[jt.parent] == Role::kSkipped) ||
        (jt.parent >= 0 && name_matches(jt.name, options.skip_name_patterns)))
      role[j] = Role::kSkipped;
  }
  if (role[0] == Role::kSkipped) throw InputError(clip.source + ": the root is skipped");
  for (int j = n - 1; j >= 0; --j) {
    const BvhJoint& jt = clip.joints[j];
    if (role[j] == Role::kSkipped) continue;
    if (jt.parent >= 0 && kept_children[j] == 0 && !end_site_kept(jt)) role[j] = Role::kEndPoint;
    if (jt.parent >= 0) ++kept_children[jt.parent];
  }
  // carriers: the joints above bvh_body_root, which becomes the root segment
  int body_root = bvh_body_root(clip);
  if (role[body_root] != Role::kSegment) body_root = 0;
  for (int c = clip.joints[body_root].parent; c >= 0; c = clip.joints[c].parent)
    role[c] = Role::kCarrier;
  for (int j = 1; j < n; ++j) {
    if (role[j] == Role::kSegment && j != body_root &&
        bvh_rest_translation(clip, j).norm() * s < options.zero_length_m)
      role[j] = Role::kMerged;
  }

  // owner[j]: the segment a joint's frame belongs to. The helpers merged above a joint are
  // found by walking up the merged parents (no chain is copied from joint to joint).
  sk.segment_of_joint.assign(n, -1);
  for (const BvhJoint& j : clip.joints) sk.joint_names.push_back(j.name);
  std::vector<int> owner(n, -1);
  std::vector<Eigen::Vector3d> pending_offset(n, Eigen::Vector3d::Zero());  // file units
  for (int j = 0; j < n; ++j) {
    const BvhJoint& jt = clip.joints[j];
    if (role[j] == Role::kSkipped || role[j] == Role::kCarrier) continue;
    Eigen::Vector3d offset = bvh_rest_translation(clip, j);
    const bool below_merged = jt.parent >= 0 && role[jt.parent] == Role::kMerged;
    if (below_merged) offset += pending_offset[jt.parent];
    int parent_segment = jt.parent >= 0 ? owner[jt.parent] : -1;
    if (role[j] == Role::kEndPoint) {
      sk.segments[parent_segment].bone_ends.push_back(convert(offset));
      continue;
    }
    if (role[j] == Role::kMerged) {
      owner[j] = parent_segment;
      pending_offset[j] = offset;
      if (end_site_kept(jt))
        sk.segments[parent_segment].bone_ends.push_back(convert(offset + jt.end_site_offset));
      continue;
    }
    MotionSegment seg;
    seg.name = jt.name;
    seg.bvh_joint = j;
    seg.parent = parent_segment;
    // the merged helpers between the parent segment and j, top down, then j
    for (int m = below_merged ? jt.parent : -1; m >= 0 && role[m] == Role::kMerged;
         m = clip.joints[m].parent) {
      seg.rotation_chain.push_back(m);
    }
    for (int c = j == body_root ? jt.parent : -1; c >= 0; c = clip.joints[c].parent)
      seg.rotation_chain.push_back(c);
    std::reverse(seg.rotation_chain.begin(), seg.rotation_chain.end());
    seg.rotation_chain.push_back(j);
    seg.offset = j != body_root ? convert(offset) : Eigen::Vector3d::Zero();
    if (end_site_kept(jt)) seg.bone_ends.push_back(convert(jt.end_site_offset));
    int index = static_cast<int>(sk.segments.size());
    owner[j] = index;
    sk.segment_of_joint[j] = index;
    if (parent_segment >= 0) {
      sk.segments[parent_segment].children.push_back(index);
      sk.segments[parent_segment].bone_ends.push_back(seg.offset);
    }
    sk.segments.push_back(std::move(seg));
  }
  return sk;
}

ReferenceMotion::ReferenceMotion(const BvhClip& clip, MotionSkeleton skeleton,
                                 const ReferenceOptions& options)
    : skeleton_(std::move(skeleton)), options_(options) {
  if (clip.frame_count < 1)
    throw InputError(located(clip.source, clip.frames_line, "'Frames: 0': the clip has no frames"));
  frame_time_ = clip.frame_time_s;
  if (!(frame_time_ > 0)) throw InputError(clip.source + ": frame time must be > 0");
  int first = options.first_frame, last = options.last_frame;
  if (options.start_s >= 0) first = static_cast<int>(std::lround(options.start_s / frame_time_));
  if (options.end_s >= 0) last = static_cast<int>(std::lround(options.end_s / frame_time_));
  if (last < 0) last = clip.frame_count - 1;
  if (first < 0 || first >= clip.frame_count || last < first || last >= clip.frame_count)
    throw InputError(fmt::format("{}: clip range frames {}..{} is outside 0..{}", clip.source,
                                 first, last, clip.frame_count - 1));
  frame_count_ = last - first + 1;
  segments_ = skeleton_.segment_count();
  // rest frames turned by C; the root's world orientation W R C^T, so that it poses the turned
  // rest frames as R posed the file's (W turns the file's world Z-up, usually W = C)
  const Eigen::Quaterniond c = skeleton_.to_z_up;
  const Eigen::Quaterniond ct = c.conjugate();
  const Eigen::Quaterniond w = skeleton_.world_to_z_up;
  rotations_.resize(static_cast<size_t>(frame_count_) * segments_);
  root_positions_.resize(frame_count_);
  for (int f = 0; f < frame_count_; ++f) {
    for (int k = 0; k < segments_; ++k) {
      Eigen::Quaterniond r = Eigen::Quaterniond::Identity();
      for (int j : skeleton_.segments[k].rotation_chain) r = r * clip.rotation(first + f, j);
      Eigen::Quaterniond q = ((k == 0 ? w : c) * r * ct).normalized();
      // keep each joint's quaternion on one hemisphere over time, for clean slerp and logs
      if (f > 0 && q.coeffs().dot(rotations_[(f - 1) * segments_ + k].coeffs()) < 0)
        q.coeffs() = -q.coeffs();
      rotations_[static_cast<size_t>(f) * segments_ + k] = q;
    }
    root_positions_[f] =
        skeleton_.scale_to_meters * (w * root_chain_translation(clip, skeleton_, first + f));
  }
  // ground alignment and start above the origin
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  if (options.root_to_origin) shift.head<2>() = -root_positions_[0].head<2>();
  if (options.align_ground) {
    ReferencePose pose = make_pose();
    std::vector<Eigen::Vector3d> pos;
    std::vector<Eigen::Quaterniond> rot;
    double lowest = 1e300;
    for (int f = 0; f < (options.align_whole_clip ? frame_count_ : 1); ++f) {
      frame_pose(f, pose);
      forward_kinematics(pose, pos, rot);
      for (int k = 0; k < segments_; ++k) {
        lowest = std::min(lowest, pos[k].z());
        for (const auto& e : skeleton_.segments[k].bone_ends)
          lowest = std::min(lowest, (pos[k] + rot[k] * e).z());
      }
    }
    shift.z() = options.ground_height_m - lowest;
  }
  for (auto& p : root_positions_) p += shift;
  alignment_shift_ = shift;
  // the loop transform: yaw and horizontal shift from the first frame's root to the last's
  Eigen::Quaterniond yaw0 = yaw_of(rotations_[0]);
  Eigen::Quaterniond yaw1 = yaw_of(rotations_[static_cast<size_t>(frame_count_ - 1) * segments_]);
  cycle_yaw_ = (yaw1 * yaw0.conjugate()).normalized();
  Eigen::Vector3d p0 = root_positions_.front(), p1 = root_positions_.back();
  p0.z() = p1.z() = 0;
  cycle_shift_ = p1 - cycle_yaw_ * p0;
  if (options.loop && options.loop_blend_s > 0) blend_seam(options.loop_blend_s);
}

void ReferenceMotion::blend_seam(double blend_s) {
  // the seam's jump: per rotation, what turns the last frame into the pose the next pass starts
  // with (frame 0, its root turned by the loop's yaw), and the root's height change. The tail
  // takes a growing share of it, smoothly from 0 to all of it at the last frame, so a cut that
  // is no cycle ends where the next pass begins; a cycle's jump is nothing and nothing changes.
  const int last = frame_count_ - 1;
  const int n = std::min(static_cast<int>(std::lround(blend_s / frame_time_)), last / 2);
  if (n < 1) return;
  const Eigen::Quaterniond* first = &rotations_[0];
  const Eigen::Quaterniond* end = &rotations_[static_cast<size_t>(last) * segments_];
  std::vector<Eigen::Quaterniond> jump(segments_);
  for (int j = 0; j < segments_; ++j) {
    const Eigen::Quaterniond target = j == 0 ? Eigen::Quaterniond(cycle_yaw_ * first[0]) : first[j];
    jump[j] = (target * end[j].conjugate()).normalized();
    if (jump[j].w() < 0) jump[j].coeffs() = -jump[j].coeffs();  // the short way
  }
  const double rise = root_positions_[0].z() - root_positions_[last].z();
  for (int k = 1; k <= n; ++k) {
    const int f = last - n + k;
    const double u = static_cast<double>(k) / n, w = u * u * (3 - 2 * u);
    Eigen::Quaterniond* r = &rotations_[static_cast<size_t>(f) * segments_];
    for (int j = 0; j < segments_; ++j) {
      r[j] = (slerp(Eigen::Quaterniond::Identity(), jump[j], w) * r[j]).normalized();
      // the hemisphere continuity the table keeps
      if (r[j].coeffs().dot(rotations_[static_cast<size_t>(f - 1) * segments_ + j].coeffs()) < 0)
        r[j].coeffs() = -r[j].coeffs();
    }
    root_positions_[f].z() += w * rise;
  }
}

ReferencePose ReferenceMotion::make_pose() const {
  ReferencePose p;
  p.rotations.assign(segments_, Eigen::Quaterniond::Identity());
  p.angular_velocities.assign(segments_, Eigen::Vector3d::Zero());
  return p;
}

void ReferenceMotion::frame_pose(int frame, ReferencePose& out) const {
  frame = std::clamp(frame, 0, frame_count_ - 1);
  sample(frame * frame_time_, out);
}

void ReferenceMotion::sample(double t, ReferencePose& out) const {
  const double period = duration_s();
  long cycle = 0;
  double local = t;
  if (options_.loop && period > 0) {
    cycle = static_cast<long>(std::floor(t / period));
    local = t - cycle * period;
  }
  local = std::clamp(local, 0.0, period);
  // bracketing frames; the derivative is the slerp's own (constant within a frame interval)
  double u = frame_count_ > 1 ? local / frame_time_ : 0.0;
  int i0 = std::min(static_cast<int>(std::floor(u)), std::max(frame_count_ - 2, 0));
  int i1 = std::min(i0 + 1, frame_count_ - 1);
  double a = std::clamp(u - i0, 0.0, 1.0);
  bool moving = i1 != i0 && (options_.loop || (t >= 0 && t <= period));
  const Eigen::Quaterniond* r0 = &rotations_[static_cast<size_t>(i0) * segments_];
  const Eigen::Quaterniond* r1 = &rotations_[static_cast<size_t>(i1) * segments_];
  for (int k = 0; k < segments_; ++k) {
    out.rotations[k] = slerp(r0[k], r1[k], a);
    out.angular_velocities[k] =
        moving ? angular_velocity_body(r0[k], r1[k], frame_time_) : Eigen::Vector3d::Zero();
  }
  out.root_position = (1 - a) * root_positions_[i0] + a * root_positions_[i1];
  out.root_velocity =
      moving ? Eigen::Vector3d((root_positions_[i1] - root_positions_[i0]) / frame_time_)
             : Eigen::Vector3d::Zero();
  // accumulate whole loops: p -> Y p + s, R_root -> Y R_root, v -> Y v
  for (long k = 0; k < cycle; ++k) {
    out.root_position = cycle_yaw_ * out.root_position + cycle_shift_;
    out.root_velocity = cycle_yaw_ * out.root_velocity;
    out.rotations[0] = cycle_yaw_ * out.rotations[0];
  }
}

std::vector<ReferencePose> ReferenceMotion::resample(double dt_s, double duration) const {
  if (!(dt_s > 0)) throw InputError("resample: dt must be > 0");
  long n = static_cast<long>(std::floor(duration / dt_s + 1e-9)) + 1;
  std::vector<ReferencePose> out(n, make_pose());
  for (long i = 0; i < n; ++i) sample(i * dt_s, out[i]);
  return out;
}

void ReferenceMotion::forward_kinematics(const ReferencePose& pose,
                                         std::vector<Eigen::Vector3d>& positions,
                                         std::vector<Eigen::Quaterniond>& orientations) const {
  positions.resize(segments_);
  orientations.resize(segments_);
  for (int k = 0; k < segments_; ++k) {
    const MotionSegment& seg = skeleton_.segments[k];
    if (seg.parent < 0) {
      positions[k] = pose.root_position;
      orientations[k] = pose.rotations[k];
    } else {
      positions[k] = positions[seg.parent] + orientations[seg.parent] * seg.offset;
      orientations[k] = orientations[seg.parent] * pose.rotations[k];
    }
  }
}

BvhClip make_synthetic_walk_clip(const SyntheticWalkOptions& o) {
  // the skeleton, as BVH text (then parsed, so the clip is exactly what a file would give)
  std::string text =
      "HIERARCHY\n"
      "ROOT Hips\n{\n  OFFSET 0 0 0\n"
      "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
      "  JOINT Spine\n  {\n    OFFSET 0 12 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "    JOINT Chest\n    {\n      OFFSET 0 22 0\n"
      "      CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "      JOINT Head\n      {\n        OFFSET 0 24 0\n"
      "        CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "        End Site\n        {\n          OFFSET 0 20 0\n        }\n      }\n";
  for (const char* side : {"Left", "Right"}) {
    double x = side[0] == 'L' ? 1 : -1;
    text += fmt::format(
        "      JOINT {0}Arm\n      {{\n        OFFSET {1} 20 0\n"
        "        CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "        JOINT {0}ForeArm\n        {{\n          OFFSET 0 -28 0\n"
        "          CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "          End Site\n          {{\n            OFFSET 0 -30 0\n          }}\n"
        "        }}\n      }}\n",
        side, 18 * x);
  }
  text += "    }\n  }\n";
  for (const char* side : {"Left", "Right"}) {
    double x = side[0] == 'L' ? 1 : -1;
    text += fmt::format(
        "  JOINT {0}UpLeg\n  {{\n    OFFSET {1} -6 0\n"
        "    CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "    JOINT {0}Leg\n    {{\n      OFFSET 0 -44 0\n"
        "      CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "      JOINT {0}Foot\n      {{\n        OFFSET 0 -42 0\n"
        "        CHANNELS 3 Zrotation Xrotation Yrotation\n"
        "        End Site\n        {{\n          OFFSET 0 -7 16\n        }}\n"
        "      }}\n    }}\n  }}\n",
        side, 9 * x);
  }
  text += "}\n";
  const int frames = static_cast<int>(std::lround(o.period_s / o.frame_time_s)) + 1;
  const double dt = o.period_s / (frames - 1);
  text += fmt::format("MOTION\nFrames: {}\nFrame Time: {:.9g}\n", frames, dt);
  // leg length (cm) hip to sole, and the stride that keeps the stance foot roughly planted:
  // per step the stance hip swings from +A to -A, the hip moves 2 L sin(A) forward
  const double leg = 44 + 42 + 7, pi = std::numbers::pi;
  const double a_hip = o.hip_amplitude_deg * pi / 180;
  const double stride = o.stride_scale * 2 * 2 * leg * std::sin(a_hip);  // cm per cycle
  const double stand = 6 + leg;
  // a walking leg's angles (deg) at its own phase ph: hip flexion is a negative X rotation (the
  // leg swings towards +Z); the knee bends in swing (peaking after mid-swing) and at mid-stance
  auto leg_angles = [&](double ph, double& hip, double& knee, double& ankle) {
    hip = -o.hip_amplitude_deg * std::sin(ph);
    double swing = std::max(0.0, std::sin(ph + 0.6));
    double stance = std::max(0.0, -std::cos(ph));  // 1 at mid-stance
    knee = 5 + o.knee_swing_deg * swing * swing + o.stance_knee_deg * stance * stance;
    ankle = -0.3 * hip - 0.35 * knee + 3;
  };
  // captureless: the run's gait takes it as a function pointer
  auto root_pitch = [](double phase) { return 2.0 * std::sin(2 * phase); };
  std::optional<SyntheticRunGait> run;
  if (o.stance_fraction > 0) run.emplace(o, +root_pitch);
  for (int f = 0; f < frames; ++f) {
    double phase = 2 * pi * f / (frames - 1);
    std::string row;
    const double t = o.period_s * f / (frames - 1);
    const double z = run ? run->root_advance(t) : stride * f / (frames - 1);
    const double y = run ? run->root_height(t)
                         : stand * std::cos(a_hip * 0.7) + o.bounce_cm * std::cos(2 * phase);
    row += fmt::format("0 {:.6f} {:.6f} 0 {:.6f} {:.6f}", y, z, root_pitch(phase),
                       4.0 * std::sin(phase));
    row += fmt::format(" 0 {:.6f} 0", o.lean_deg);                        // spine: lean
    row += fmt::format(" 0 {:.6f} {:.6f}", 2.0, -6.0 * std::sin(phase));  // chest counter-twist
    row += " 0 -5 0";                                                     // head
    for (int s = 0; s < 2; ++s) {
      // arms swing against the same-side leg
      double ph = phase + (s == 0 ? 0 : pi);
      double sign = s == 0 ? 1 : -1;
      row += fmt::format(" {:.6f} {:.6f} 0", sign * 8.0, o.arm_amplitude_deg * std::sin(ph));
      row += fmt::format(" 0 {:.6f} 0",
                         -o.elbow_deg - (2.0 / 3) * o.elbow_deg * std::max(0.0, -std::sin(ph)));
    }
    for (int s = 0; s < 2; ++s) {
      double hip, knee, ankle;
      if (run)
        run->leg_angles(s, o.period_s * f / (frames - 1), hip, knee, ankle);
      else
        leg_angles(phase + (s == 0 ? 0 : pi), hip, knee, ankle);
      const double roll = run ? run->leg_roll_deg(s) : 0;
      row +=
          fmt::format(" {:.6f} {:.6f} 0 0 {:.6f} 0 {:.6f} {:.6f} 0", roll, hip, knee, -roll, ankle);
    }
    text += row + "\n";
  }
  return parse_bvh(text, o.name);
}

SyntheticWalkOptions synthetic_run_options() {
  SyntheticWalkOptions o;
  o.name = "synthetic_run.bvh";
  o.period_s = 0.7;  // 171 steps a minute
  o.stance_fraction = 0.3;
  o.run_speed_mps = 2.5;
  o.arm_amplitude_deg = 25;
  o.elbow_deg = 60;
  o.lean_deg = 8;
  return o;
}

}  // namespace stance
