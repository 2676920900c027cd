#include "control/mocap_clip.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include <fmt/format.h>

#include "core/error.h"
#include "model/bvh_to_mjcf.h"

namespace stance {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
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
         a.end_s == b.end_s && a.loop == b.loop && a.loop_blend_s == b.loop_blend_s &&
         a.align_ground == b.align_ground && a.ground == b.ground && a.export_bvh == b.export_bvh;
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
  const Eigen::Quaterniond wt = sk.world_to_z_up.conjugate();
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
      Eigen::Quaterniond r =
          (k == 0 ? wt : ct) * locals[static_cast<size_t>(f) * n + k].normalized() * c;
      // merged helpers keep their clip rotation; the segment's own joint takes the rest
      Eigen::Quaterniond helpers = Eigen::Quaterniond::Identity();
      for (size_t i = 0; i + 1 < seg.rotation_chain.size(); ++i)
        helpers = helpers * src.rotation(sf, seg.rotation_chain[i]);
      out.rotation(f, seg.bvh_joint) = (helpers.conjugate() * r).normalized();
    }
    const BvhJoint& root = src.joints[sk.segments[0].bvh_joint];
    if (root.position_slot >= 0)
      out.positions[static_cast<size_t>(f) * src.position_joint_count + root.position_slot] =
          (wt * roots[f]) / sk.scale_to_meters;
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
