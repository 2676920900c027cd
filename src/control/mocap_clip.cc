#include "control/mocap_clip.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "model/bvh_to_mjcf.h"

namespace stance {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// a warning on stderr, once per process (a batch or a planner loads the same clip many times)
void warn_once(const std::string& message) {
  static std::mutex mutex;
  static std::set<std::string> printed;
  std::lock_guard<std::mutex> lock(mutex);
  if (printed.insert(message).second) std::cerr << "warning: " << message << "\n";
}

}  // namespace

int side_of_joint_name(const std::string& name) {
  // words: split at anything but letters, at digits and at case changes ("Bip01 L Foot" ->
  // bip 01 l foot, "lFoot" -> l foot, "LFoot" -> l foot, "Foot_R" -> foot r)
  std::vector<std::string> words;
  std::string word;
  auto flush = [&] {
    if (!word.empty()) words.push_back(lower(word));
    word.clear();
  };
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (!std::isalpha(c)) {
      flush();
      continue;
    }
    if (!word.empty()) {
      const unsigned char prev = static_cast<unsigned char>(word.back());
      const bool next_lower =
          i + 1 < name.size() && std::islower(static_cast<unsigned char>(name[i + 1]));
      if (std::isupper(c) && (std::islower(prev) || next_lower)) flush();
    }
    word += static_cast<char>(c);
  }
  flush();
  for (const std::string& w : words) {
    if (w == "l" || w == "left") return -1;
    if (w == "r" || w == "right") return 1;
  }
  // run-on lower-case names: "leftfoot", "rfoot", "lfemur" (CMU's ASF names)
  static constexpr const char* kParts[] = {
      "hip",      "femur", "thigh",   "upleg",  "knee",     "shin",     "tibia",
      "calf",     "ankle", "foot",    "toe",    "heel",     "clavicle", "collar",
      "shoulder", "shldr", "humerus", "arm",    "upperarm", "forearm",  "elbow",
      "radius",   "wrist", "hand",    "finger", "thumb",    "leg"};
  for (const std::string& w : words) {
    if (w.rfind("left", 0) == 0) return -1;
    if (w.rfind("right", 0) == 0) return 1;
    for (const char* part : kParts)
      if (w.size() > std::strlen(part) && w.compare(1, std::strlen(part), part) == 0) {
        if (w[0] == 'l') return -1;
        if (w[0] == 'r') return 1;
      }
  }
  return 0;
}

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
  // counted in double and bounded before the cast: a tiny or non-finite step must not turn into
  // an undefined size (the BVH reader bounds the frame time; this is the backstop)
  constexpr double kMaxFrames = double(1 << 20);
  const double frames = std::max(120.0, duration_s) / frame_time_s;
  return static_cast<size_t>(frames >= 0 && frames < kMaxFrames ? frames : kMaxFrames) + 1;
}

bool same_mocap_clip(const MocapClipParams& a, const MocapClipParams& b) {
  return a.bvh == b.bvh && a.scale_to_meters == b.scale_to_meters && a.up_axis == b.up_axis &&
         a.first_frame == b.first_frame && a.skip_leading_pose == b.skip_leading_pose &&
         a.last_frame == b.last_frame && a.start_s == b.start_s && a.end_s == b.end_s &&
         a.loop == b.loop && a.loop_blend_s == b.loop_blend_s && a.align_ground == b.align_ground &&
         a.ground == b.ground && a.export_bvh == b.export_bvh &&
         a.export_origin_centred == b.export_origin_centred;
}

MocapClip load_mocap_clip(const MocapClipParams& params, const std::string& base_dir) {
  if (params.bvh.empty()) throw InputError("bvh: a BVH file is required");
  std::filesystem::path path(params.bvh);
  if (path.is_relative() && !base_dir.empty()) path = std::filesystem::path(base_dir) / path;
  auto clip = std::make_shared<BvhClip>(read_bvh(path.string()));
  MotionSkeletonOptions so;
  so.scale_to_meters = params.scale_to_meters;
  if (params.up_axis == "auto")
    so.up_axis = 0;
  else if (params.up_axis == "y" || params.up_axis == "z")
    so.up_axis = params.up_axis[0];
  else
    throw InputError("up_axis: expected y, z or auto, found '" + params.up_axis + "'");
  ReferenceOptions ro;
  ro.first_frame = params.first_frame;
  if (params.skip_leading_pose && params.first_frame == 0 && params.start_s < 0)
    ro.first_frame = detect_bvh_first_motion_frame(*clip);
  ro.last_frame = params.last_frame;
  ro.start_s = params.start_s;
  ro.end_s = params.end_s;
  ro.loop = params.loop;
  ro.loop_blend_s = params.loop_blend_s;
  ro.align_ground = params.align_ground;
  ro.align_whole_clip = params.ground == "clip";
  if (params.ground != "clip" && params.ground != "start")
    throw InputError("ground: expected start or clip, found '" + params.ground + "'");
  MocapClip out;
  out.first_frame = params.start_s >= 0
                        ? static_cast<int>(std::lround(params.start_s / clip->frame_time_s))
                        : ro.first_frame;
  out.reference = std::make_shared<ReferenceMotion>(*clip, make_motion_skeleton(*clip, so), ro);
  out.clip = clip;
  for (const std::string& w : out.reference->skeleton().warnings) warn_once(w);
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
  const int n = sk.segment_count();
  // rest positions (Z-up, every rotation the identity)
  std::vector<Eigen::Vector3d> rest(n, Eigen::Vector3d::Zero());
  for (int k = 1; k < n; ++k) rest[k] = rest[sk.segments[k].parent] + sk.segments[k].offset;
  // the topmost foot segment of each chain; of more than two, the two lowest at rest
  const std::vector<bool> foot_like = foot_segments(sk);
  std::vector<int> feet;
  for (int k = 1; k < n; ++k) {
    if (!foot_like[k]) continue;
    bool top = true;
    for (int a = sk.segments[k].parent; a > 0; a = sk.segments[a].parent)
      if (foot_like[a]) top = false;
    if (top) feet.push_back(k);
  }
  std::stable_sort(feet.begin(), feet.end(),
                   [&](int a, int b) { return rest[a].z() < rest[b].z() - 1e-9; });
  if (feet.size() > 2) feet.resize(2);
  if (feet.size() == 1) foot[side_of_joint_name(sk.segments[feet[0]].name) > 0 ? 1 : 0] = feet[0];
  if (feet.size() == 2) {
    // the sides by name; where the names do not tell, by the toes: the left foot is on the
    // left of the direction they point
    int a = feet[0], b = feet[1];
    const int side_a = side_of_joint_name(sk.segments[a].name);
    const int side_b = side_of_joint_name(sk.segments[b].name);
    bool a_right = side_a > 0 || (side_a == 0 && side_b < 0);
    if (side_a == side_b) {
      Eigen::Vector3d toes = Eigen::Vector3d::Zero();
      for (int k : {a, b})
        for (const Eigen::Vector3d& e : sk.segments[k].bone_ends) toes += e;
      const Eigen::Vector3d left =
          Eigen::Vector3d::UnitZ().cross(Eigen::Vector3d(toes.x(), toes.y(), 0));
      a_right = (rest[a] - rest[b]).dot(left) < 0;
    }
    foot[a_right ? 1 : 0] = a;
    foot[a_right ? 0 : 1] = b;
  }
  if (!names[2].empty()) foot[0] = find(names[2], "left_foot");
  if (!names[3].empty()) foot[1] = find(names[3], "right_foot");
  // the thighs: below the segment where the two legs part (a pelvis, or a spine as in 3ds Max's
  // Biped), each the top of its leg's chain
  auto chain = [&](int k) {
    std::vector<int> up;
    for (; k >= 0; k = sk.segments[k].parent) up.push_back(k);
    return std::vector<int>(up.rbegin(), up.rend());
  };
  if (foot[0] >= 0 && foot[1] >= 0 && foot[0] != foot[1]) {
    const std::vector<int> l = chain(foot[0]), r = chain(foot[1]);
    size_t split = 0;
    while (split < l.size() && split < r.size() && l[split] == r[split]) ++split;
    if (split < l.size()) hip[0] = l[split];
    if (split < r.size()) hip[1] = r[split];
  } else {
    for (int side = 0; side < 2; ++side) {
      int k = foot[side];
      while (k > 0 && sk.segments[k].parent > 0) k = sk.segments[k].parent;
      hip[side] = k > 0 ? k : -1;
    }
  }
  if (!names[0].empty()) hip[0] = find(names[0], "left_hip");
  if (!names[1].empty()) hip[1] = find(names[1], "right_hip");
}

JointMap bvh_character_joint_map(const MotionSkeleton& skeleton, const Engine& engine) {
  JointMap map;
  map.source = "the clip's own character";
  map.model_up = 'z';
  map.yaw_deg = 0.0;
  map.scale = 1.0;
  map.height_offset_m = 0.0;
  map.align_bones = false;
  for (const MotionSegment& seg : skeleton.segments) {
    if (engine.body_index(seg.name) < 0)
      throw InputError(fmt::format(
          "joint_map: none given, and the model has no body '{}' for the clip's joint (give a "
          "joint map, or build the model with `stance bvh2mjcf`){}",
          seg.name, did_you_mean(seg.name, engine.body_names())));
    map.joints.push_back({seg.name, seg.name, 0});
  }
  return map;
}

BvhClip clip_from_segment_poses(const MocapClip& mocap,
                                const std::vector<Eigen::Quaterniond>& locals,
                                const std::vector<Eigen::Vector3d>& roots, bool origin_centred) {
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
  const Eigen::Quaterniond wt = sk.world_to_z_up.conjugate();
  const int range = mocap.reference->frame_count();
  const Eigen::Vector3d shift =
      origin_centred ? Eigen::Vector3d::Zero() : mocap.reference->alignment_shift_m();
  for (int f = 0; f < frames; ++f) {
    // joints that are no segment keep the clip's own values at the matching frame
    int sf = mocap.first_frame + (f % range);
    for (size_t j = 0; j < nj; ++j) out.rotation(f, j) = src.rotation(sf, j);
    for (int s = 0; s < src.position_joint_count; ++s)
      out.positions[static_cast<size_t>(f) * src.position_joint_count + s] =
          src.positions[static_cast<size_t>(sf) * src.position_joint_count + s];
    for (int k = 0; k < n; ++k) {
      const MotionSegment& seg = sk.segments[k];
      Eigen::Quaterniond r =
          (k == 0 ? wt : ct) * locals[static_cast<size_t>(f) * n + k].normalized() * c;
      // merged helpers keep their clip rotation; the segment's own joint takes the rest
      Eigen::Quaterniond helpers = Eigen::Quaterniond::Identity();
      for (size_t i = 0; i + 1 < seg.rotation_chain.size(); ++i)
        helpers = helpers * src.rotation(sf, seg.rotation_chain[i]);
      out.rotation(f, seg.bvh_joint) = (helpers.conjugate() * r).normalized();
    }
    // the root's translation: what is left after its carriers' (which keep the clip's values)
    const BvhJoint& root = src.joints[sk.segments[0].bvh_joint];
    const RootCarriers carriers = root_carriers(src, sk, sf);
    if (root.position_slot >= 0)
      out.positions[static_cast<size_t>(f) * src.position_joint_count + root.position_slot] =
          carriers.rotation.conjugate() *
          ((wt * (roots[f] - shift)) / sk.scale_to_meters - carriers.translation);
  }
  return out;
}

void write_exported_bvh(const BvhClip& clip, const std::string& export_path,
                        const std::string& out_dir) {
  std::filesystem::path path(export_path);
  if (path.is_relative() && !out_dir.empty()) path = std::filesystem::path(out_dir) / path;
  write_bvh(clip, path.string());
}

}  // namespace stance
