#include "model/bvh_to_mjcf.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>

#include <fmt/format.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "motion/bvh_measure.h"

namespace stance {

namespace {

constexpr double kPi = std::numbers::pi;

struct Geom {
  bool box = false;
  Eigen::Vector3d from = Eigen::Vector3d::Zero(), to = Eigen::Vector3d::Zero();  // capsule
  double radius = 0;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero(), half = Eigen::Vector3d::Zero();  // box
  Eigen::Quaterniond quat = Eigen::Quaterniond::Identity();
  double volume() const {
    if (box) return 8 * half.x() * half.y() * half.z();
    return kPi * radius * radius * (to - from).norm() + 4.0 / 3.0 * kPi * std::pow(radius, 3);
  }
};

std::string mjcf_vec(const Eigen::Vector3d& v) {
  return fmt::format("{:.9g} {:.9g} {:.9g}", v.x(), v.y(), v.z());
}
std::string mjcf_quat(const Eigen::Quaterniond& q) {
  return fmt::format("{:.9g} {:.9g} {:.9g} {:.9g}", q.w(), q.x(), q.y(), q.z());
}

// the sole box of a foot segment: from the heel behind the joint to the furthest bone end,
// from the lowest bone point up to the joint (at least 3 cm tall); `up` is the world's up in the
// segment's frame as the foot stands
Geom foot_box(const MotionSegment& seg, const BvhCharacterOptions& o, const Eigen::Vector3d& up) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& e : seg.bone_ends) mean += e;
  Eigen::Vector3d fwd = mean - mean.dot(up) * up;
  if (fwd.norm() < 1e-6) fwd = Eigen::Vector3d::UnitX() - up.x() * up;
  if (fwd.norm() < 1e-6) fwd = Eigen::Vector3d::UnitY() - up.y() * up;
  fwd.normalize();
  const Eigen::Vector3d side = up.cross(fwd);
  double f_min = -o.heel_length_m, f_max = 0, z_min = 0, z_max = 0;
  for (const auto& e : seg.bone_ends) {
    f_max = std::max(f_max, e.dot(fwd));
    z_min = std::min(z_min, e.dot(up));
    z_max = std::max(z_max, e.dot(up));
  }
  z_max = std::max(z_max, z_min + 0.03);
  Geom g;
  g.box = true;
  g.half = Eigen::Vector3d(0.5 * (f_max - f_min), o.foot_half_width_m, 0.5 * (z_max - z_min));
  g.pos = 0.5 * (f_max + f_min) * fwd + 0.5 * (z_max + z_min) * up;
  Eigen::Matrix3d axes;
  axes << fwd, side, up;
  g.quat = Eigen::Quaterniond(axes);
  return g;
}

// per foot segment, the world's up in its own frame as it stands: +z where the rest pose
// stands; else (Bandai Namco's bones lie along X) the mean over the posed frames of the clip's
// first second from `first` in which the segment is within 2 cm of its lowest (planted)
std::vector<Eigen::Vector3d> standing_up_of_feet(const ReferenceMotion& ref,
                                                 const std::vector<bool>& feet, bool rest_stands,
                                                 int first) {
  const int n = ref.skeleton().segment_count();
  std::vector<Eigen::Vector3d> up(n, Eigen::Vector3d::UnitZ());
  if (rest_stands || ref.frame_count() == 0) return up;
  first = std::clamp(first, 0, ref.frame_count() - 1);
  const int last = std::min(ref.frame_count() - 1,
                            first + static_cast<int>(std::ceil(1.0 / ref.frame_time_s())));
  ReferencePose pose = ref.make_pose();
  std::vector<std::vector<Eigen::Vector3d>> pos(last - first + 1);
  std::vector<std::vector<Eigen::Quaterniond>> rot(last - first + 1);
  for (int f = first; f <= last; ++f) {
    ref.frame_pose(f, pose);
    ref.forward_kinematics(pose, pos[f - first], rot[f - first]);
  }
  for (int k = 0; k < n; ++k) {
    if (!feet[k]) continue;
    double lowest = INFINITY;
    for (const auto& p : pos) lowest = std::min(lowest, p[k].z());
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < pos.size(); ++i)
      if (pos[i][k].z() <= lowest + 0.02) sum += rot[i][k].conjugate() * Eigen::Vector3d::UnitZ();
    if (sum.norm() > 1e-9) up[k] = sum.normalized();
  }
  return up;
}

std::string joint_limit_attribute(const std::string& segment, const BvhCharacterOptions& o);

}  // namespace

double human_peak_torque_nm_per_kg(const std::string& segment_name) {
  std::string n = segment_name;
  for (char& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto has = [&](std::initializer_list<const char*> words) {
    for (const char* w : words)
      if (n.find(w) != std::string::npos) return true;
    return false;
  };
  // the order matters: "upleg" before "leg", "forearm" before "arm", "toe" before "foot"
  if (has({"toe"})) return 0.3;                                     // toe flexion
  if (has({"foot", "ankle"})) return 2.7;                           // ankle plantarflexion
  if (has({"upleg", "thigh", "hip", "upperleg"})) return 3.5;       // hip extension
  if (has({"leg", "knee", "shin", "calf"})) return 3.3;             // knee extension
  if (has({"forearm", "elbow", "lowarm", "lowerarm"})) return 0.9;  // elbow flexion
  if (has({"hand", "wrist", "finger", "thumb"})) return 0.2;        // wrist flexion
  if (has({"shoulder", "collar", "clavicle", "arm", "humerus"})) return 1.2;  // shoulder flexion
  if (has({"neck", "head"})) return 0.4;                                      // neck extension
  if (has({"spine", "chest", "back", "abdomen", "torso", "waist", "lumbar", "thorax", "pelvis"}))
    return 3.3;  // trunk extension
  return 0;
}

double human_torque_limit_nm(const std::string& segment_name, double total_mass_kg) {
  return human_peak_torque_nm_per_kg(segment_name) * total_mass_kg;
}

namespace {
// a ball joint's human limit as its actuatorfrcrange (stance reads it: model/mjcf_newer.h)
std::string joint_limit_attribute(const std::string& segment, const BvhCharacterOptions& o) {
  const double limit = o.human_limits ? human_torque_limit_nm(segment, o.total_mass_kg) : 0;
  if (!(limit > 0)) return "";
  return fmt::format(" actuatorfrcrange=\"{:.6g} {:.6g}\"", -limit, limit);
}
}  // namespace

bool is_foot_segment_name(const std::string& name) {
  std::string lower = name;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find("foot") != std::string::npos || lower.find("toe") != std::string::npos ||
         lower.find("ankle") != std::string::npos;
}

std::vector<bool> foot_segments(const MotionSkeleton& sk) {
  const int n = sk.segment_count();
  std::vector<bool> named(n, false);
  int named_tops = 0;
  for (int k = 1; k < n; ++k) {
    named[k] = is_foot_segment_name(sk.segments[k].name);
    named_tops += named[k] && !named[sk.segments[k].parent];
  }
  if (named_tops >= 2) return named;
  // the names do not tell: a foot is what stands lowest. The ankle of a standing skeleton sits
  // below a tenth of the root's height, the knee near half of it.
  std::vector<Eigen::Vector3d> rest(n, Eigen::Vector3d::Zero());
  double lowest = 0;
  for (int k = 0; k < n; ++k) {
    if (k > 0) rest[k] = rest[sk.segments[k].parent] + sk.segments[k].offset;
    lowest = std::min(lowest, rest[k].z());
    for (const Eigen::Vector3d& e : sk.segments[k].bone_ends)
      lowest = std::min(lowest, rest[k].z() + e.z());
  }
  const double height = rest[0].z() - lowest;
  if (!(height > 0)) return named;
  std::vector<bool> low(n, false);
  for (int k = 1; k < n; ++k) low[k] = rest[k].z() - lowest <= 0.25 * height;
  return low;
}

BvhCharacter make_bvh_character(const BvhClip& clip, const BvhCharacterOptions& o) {
  if (!(o.total_mass_kg > 0)) throw InputError("--mass must be > 0");
  BvhCharacter ch;
  ch.skeleton = make_motion_skeleton(clip, o.skeleton);
  const MotionSkeleton& sk = ch.skeleton;
  const int n = sk.segment_count();
  const std::vector<bool> feet = foot_segments(sk);
  // the reference: the start keyframe (t = 0) and the feet's standing pose
  ReferenceMotion ref(clip, sk, o.reference);
  const bool first_given = o.reference.first_frame > 0 || o.reference.start_s >= 0;
  const std::vector<Eigen::Vector3d> sole_up = standing_up_of_feet(
      ref, feet, measure_bvh_character(clip, sk.scale_to_meters).rest_pose_stands,
      first_given ? 0 : detect_bvh_first_motion_frame(clip));

  // geometry per segment, then one density for the total mass
  std::vector<std::vector<Geom>> geoms(n);
  bool any_bone = false;
  for (int k = 0; k < n; ++k) {
    const MotionSegment& seg = sk.segments[k];
    if (feet[k] && !seg.bone_ends.empty()) {
      geoms[k].push_back(foot_box(seg, o, sole_up[k]));
      any_bone = true;
      continue;
    }
    for (const auto& e : seg.bone_ends) {
      double len = e.norm();
      if (len < o.skeleton.zero_length_m) continue;
      Geom g;
      g.to = e;
      g.radius = std::clamp(o.limb_radius_fraction * len, o.min_radius_m, o.max_radius_m);
      // a shin ends one radius short of the ankle: its round end must not reach below the foot's
      // sole, or the character stands on two balls and no ankle torque can balance it
      for (int c : seg.children)
        if (feet[c] && (sk.segments[c].offset - e).norm() < 1e-9)
          g.to = e * std::max(0.0, 1 - g.radius / len);
      geoms[k].push_back(g);
      any_bone = true;
    }
    if (geoms[k].empty()) {
      // a body without bones still needs mass: a small sphere (capsule of zero length)
      Geom g;
      g.radius = o.min_radius_m;
      geoms[k].push_back(g);
    }
  }
  if (!any_bone) throw InputError(clip.source + ": the skeleton has no bones");
  for (const auto& gs : geoms)
    for (const auto& g : gs) ch.total_volume_m3 += g.volume();
  ch.density_kg_m3 = o.total_mass_kg / ch.total_volume_m3;

  // the start keyframe: the reference at t = 0
  ReferencePose pose = ref.make_pose();
  ref.sample(0.0, pose);

  std::string name = clip.source;
  if (auto slash = name.find_last_of("/\\"); slash != std::string::npos) name.erase(0, slash + 1);
  std::string out;
  out += fmt::format(
      "<!-- generated by `stance bvh2mjcf` from {}: {} bodies, {:.6g} kg, "
      "{:.6g} m per file unit -->\n",
      name, n, o.total_mass_kg, sk.scale_to_meters);
  out += fmt::format("<mujoco model=\"{}\">\n", name);
  out += "  <compiler angle=\"radian\"/>\n";
  out += fmt::format("  <option timestep=\"{:.9g}\" gravity=\"0 0 -9.81\"/>\n", o.timestep_s);
  out += "  <default>\n";
  out += fmt::format("    <joint armature=\"{:.6g}\" damping=\"0\"/>\n", o.armature);
  out += fmt::format(
      "    <geom contype=\"1\" conaffinity=\"0\" condim=\"3\" friction=\"{:.6g} 0.005 0.0001\" "
      "density=\"{:.9g}\" rgba=\"0.75 0.6 0.45 1\"/>\n",
      o.friction, ch.density_kg_m3);
  out += "  </default>\n";
  out += "  <worldbody>\n";
  out += "    <light pos=\"0 0 4\" dir=\"0 0 -1\" directional=\"true\"/>\n";
  out +=
      "    <geom name=\"floor\" type=\"plane\" size=\"100 100 0.1\" contype=\"1\" "
      "conaffinity=\"1\" rgba=\"0.8 0.85 0.9 1\"/>\n";
  // bodies, depth first: segments are in parent-first order, so recurse on children
  std::function<void(int, int)> emit = [&](int k, int depth) {
    const MotionSegment& seg = sk.segments[k];
    std::string pad(2 * depth, ' ');
    Eigen::Vector3d pos = k == 0 ? Eigen::Vector3d(0, 0, 1) : seg.offset;
    out += fmt::format("{}<body name=\"{}\" pos=\"{}\">\n", pad, seg.name, mjcf_vec(pos));
    if (k == 0)
      out += fmt::format("{}  <freejoint name=\"root\"/>\n", pad);
    else
      out += fmt::format("{}  <joint name=\"{}\" type=\"ball\"{}/>\n", pad, seg.name,
                         joint_limit_attribute(seg.name, o));
    for (size_t g = 0; g < geoms[k].size(); ++g) {
      const Geom& geom = geoms[k][g];
      std::string gname = fmt::format("{}_{}", seg.name, g);
      if (geom.box)
        out +=
            fmt::format("{}  <geom name=\"{}\" type=\"box\" pos=\"{}\" quat=\"{}\" size=\"{}\"/>\n",
                        pad, gname, mjcf_vec(geom.pos), mjcf_quat(geom.quat), mjcf_vec(geom.half));
      else if ((geom.to - geom.from).norm() > 0)
        out += fmt::format(
            "{}  <geom name=\"{}\" type=\"capsule\" fromto=\"{} {}\" size=\"{:.6g}\"/>\n", pad,
            gname, mjcf_vec(geom.from), mjcf_vec(geom.to), geom.radius);
      else
        out += fmt::format("{}  <geom name=\"{}\" type=\"sphere\" size=\"{:.6g}\"/>\n", pad, gname,
                           geom.radius);
    }
    for (int c : seg.children) emit(c, depth + 1);
    out += fmt::format("{}</body>\n", pad);
  };
  emit(0, 2);
  out += "  </worldbody>\n";
  // keyframe: free joint (pos, quat) then ball quaternions in body order; qvel likewise
  std::string qpos = mjcf_vec(pose.root_position) + " " + mjcf_quat(pose.rotations[0]);
  Eigen::Vector3d w0 = pose.angular_velocities[0];
  std::string qvel = mjcf_vec(pose.root_velocity) + " " + mjcf_vec(w0);
  std::function<void(int)> key = [&](int k) {
    for (int c : sk.segments[k].children) {
      qpos.append(" ").append(mjcf_quat(pose.rotations[c]));
      qvel.append(" ").append(mjcf_vec(pose.angular_velocities[c]));
      key(c);
    }
  };
  key(0);
  out += "  <keyframe>\n";
  out += fmt::format("    <key name=\"start\" qpos=\"{}\" qvel=\"{}\"/>\n", qpos, qvel);
  out += "  </keyframe>\n";
  out += "</mujoco>\n";
  ch.mjcf = std::move(out);
  return ch;
}

void write_bvh_character(const std::string& bvh_path, const std::string& mjcf_path,
                         const BvhCharacterOptions& options) {
  BvhClip clip = read_bvh(bvh_path);
  BvhCharacter ch = make_bvh_character(clip, options);
  write_file_atomically(mjcf_path, ch.mjcf);
}

}  // namespace stance
