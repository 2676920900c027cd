// Writing BVH files: the shortest text that reads back as the same clip.
#include <charconv>
#include <cmath>
#include <numbers>
#include <ostream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/atomic_file.h"
#include "motion/bvh.h"
#include "motion/bvh_columns.h"
#include "motion/bvh_measure.h"

namespace stance {

namespace {

using bvh_detail::joint_columns;
using bvh_detail::JointColumns;

// shortest text that reads back as exactly v ("-0" written as "0")
void append_number(std::string& out, double v) {
  if (v == 0.0) v = 0.0;
  char buf[32];
  auto [p, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, p);
}

// angles (deg) to write for one joint, continuous with `previous` after the first frame. Joints
// with fewer than three rotation channels take the branch in which the unlisted angles are 0.
Eigen::Vector3d joint_angles_deg(const Eigen::Quaterniond& q, const BvhJoint& joint,
                                 const Eigen::Vector3d& previous_deg, bool first_frame) {
  const Eigen::Vector3d canonical = quaternion_to_euler(q, joint.order);
  if (joint.rotation_channel_count == 3) {
    if (first_frame) return canonical * kRadToDeg;
    return quaternion_to_euler_near(q, joint.order, previous_deg * kDegToRad) * kRadToDeg;
  }
  const double pi = std::numbers::pi;
  const Eigen::Vector3d other(canonical[0] + pi, pi - canonical[1], canonical[2] + pi);
  // how far the unlisted angles are from a multiple of 2 pi
  auto unlisted_error = [&](const Eigen::Vector3d& e) {
    double err = 0.0;
    for (int k = joint.rotation_channel_count; k < 3; ++k) {
      err += std::abs(std::remainder(e[k], 2.0 * pi));
    }
    return err;
  };
  Eigen::Vector3d best = unlisted_error(other) < unlisted_error(canonical) ? other : canonical;
  Eigen::Vector3d deg = best * kRadToDeg;
  for (int k = 0; k < 3; ++k) {
    if (k >= joint.rotation_channel_count)
      deg[k] = 0.0;
    else if (!first_frame)
      deg[k] += 360.0 * std::round((previous_deg[k] - deg[k]) / 360.0);
  }
  return deg;
}

void format_joint(const BvhClip& clip, const std::vector<std::vector<int>>& children, int j,
                  int depth, std::string& out) {
  const BvhJoint& joint = clip.joints[j];
  const std::string indent(depth, '\t');
  out += indent;
  out += joint.parent < 0 ? "ROOT " : "JOINT ";
  out += joint.name;
  out += '\n';
  out += indent + "{\n";
  out += indent + "\tOFFSET";
  for (int k = 0; k < 3; ++k) {
    out += ' ';
    append_number(out, joint.offset[k]);
  }
  out += '\n';
  out += indent + fmt::format("\tCHANNELS {}", joint.channels.size());
  for (BvhChannel c : joint.channels) {
    out += ' ';
    out += bvh_channel_name(c);
  }
  out += '\n';
  for (int child : children[j]) format_joint(clip, children, child, depth + 1, out);
  if (joint.has_end_site) {
    out += indent + "\tEnd Site\n" + indent + "\t{\n" + indent + "\t\tOFFSET";
    for (int k = 0; k < 3; ++k) {
      out += ' ';
      append_number(out, joint.end_site_offset[k]);
    }
    out += '\n' + indent + "\t}\n";
  }
  out += indent + "}\n";
}

// the BVH text of `clip` into `out`; with a `stream`, written out in pieces as it goes, so a long
// clip's text is never whole in memory
void format_bvh_into(const BvhClip& clip, std::string& out, std::ostream* stream) {
  constexpr size_t kPiece = 1 << 16;
  std::vector<std::vector<int>> children(clip.joints.size());
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    if (clip.joints[j].parent >= 0) children[clip.joints[j].parent].push_back(static_cast<int>(j));
  }
  out = "HIERARCHY\n";
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    if (clip.joints[j].parent < 0) format_joint(clip, children, static_cast<int>(j), 0, out);
  }
  out += "MOTION\n";
  out += fmt::format("Frames: {}\n", clip.frame_count);
  out += "Frame Time: ";
  append_number(out, clip.frame_time_s);
  out += '\n';

  const auto columns = joint_columns(clip);
  std::vector<Eigen::Vector3d> previous(clip.joints.size(), Eigen::Vector3d::Zero());
  std::vector<double> row(clip.channel_count);
  if (!stream)
    out.reserve(out.size() + static_cast<size_t>(clip.frame_count) * clip.channel_count * 12);
  for (int f = 0; f < clip.frame_count; ++f) {
    for (size_t j = 0; j < clip.joints.size(); ++j) {
      const BvhJoint& joint = clip.joints[j];
      const JointColumns& col = columns[j];
      if (joint.rotation_channel_count > 0) {
        Eigen::Vector3d deg =
            joint_angles_deg(clip.rotation(f, static_cast<int>(j)), joint, previous[j], f == 0);
        previous[j] = deg;
        for (int k = 0; k < 3; ++k) {
          // 1e-9 deg is far below the 1e-9 rad round-trip promise and keeps "12.34" short
          if (col.rotation[k] >= 0) row[col.rotation[k]] = std::round(deg[k] * 1e9) / 1e9;
        }
      }
      if (joint.position_slot >= 0) {
        Eigen::Vector3d p = clip.translation(f, static_cast<int>(j));
        for (int k = 0; k < 3; ++k) {
          if (col.position[k] >= 0) row[col.position[k]] = p[k];
        }
      }
    }
    for (int c = 0; c < clip.channel_count; ++c) {
      if (c > 0) out += ' ';
      append_number(out, row[c]);
    }
    out += '\n';
    if (stream && out.size() >= kPiece) {
      stream->write(out.data(), static_cast<std::streamsize>(out.size()));
      out.clear();
    }
  }
  if (stream) {
    stream->write(out.data(), static_cast<std::streamsize>(out.size()));
    out.clear();
  }
}
}  // namespace

std::string format_bvh(const BvhClip& clip) {
  std::string out;
  format_bvh_into(clip, out, nullptr);
  return out;
}

void write_bvh(const BvhClip& clip, const std::string& path) {
  AtomicFile file(path);
  std::string piece;
  format_bvh_into(clip, piece, &file.stream());
  file.commit();
}

}  // namespace stance
