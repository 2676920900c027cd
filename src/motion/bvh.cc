#include "motion/bvh.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>

#include <fmt/format.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "motion/bvh_measure.h"

namespace stance {

namespace {

// at most this many poses (frames x joints) are held: 1 GB of quaternions
constexpr size_t kMaxBvhPoses = size_t{1} << 25;

constexpr std::array<std::string_view, 6> kChannelNames = {"Xposition", "Yposition", "Zposition",
                                                           "Xrotation", "Yrotation", "Zrotation"};

bool is_rotation(BvhChannel c) {
  return c >= BvhChannel::kXrotation;
}
int channel_axis(BvhChannel c) {
  return static_cast<int>(c) % 3;
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  }
  return true;
}

bool is_hspace(char c) {
  return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}

// a quoted token for messages, shortened when huge; control bytes (a NUL would cut the line
// on a terminal) shown as \xNN
std::string quoted(std::string_view token) {
  std::string shown;
  for (char c : token.substr(0, 40)) {
    const auto b = static_cast<unsigned char>(c);
    shown += b < 0x20 || b == 0x7f ? fmt::format("\\x{:02x}", b) : std::string(1, c);
  }
  return fmt::format("'{}{}'", shown, token.size() > 40 ? "..." : "");
}

// std::from_chars for a whole token, also accepting a leading '+'; false when the token is not
// exactly one finite number
bool parse_double(std::string_view token, double& out) {
  const char* b = token.data();
  const char* e = b + token.size();
  if (b != e && *b == '+') ++b;
  auto [p, ec] = std::from_chars(b, e, out);
  return ec == std::errc() && p == e && b != e && std::isfinite(out);
}

// Cursor over the whole text. Lines end at LF, CRLF or a lone CR; `line` is 1-based.
class Scanner {
 public:
  Scanner(std::string_view text, const std::string& name) : text_(text), name_(name) {}

  [[noreturn]] void fail(int line, std::string_view message) const {
    throw InputError(located(name_, line, message));
  }
  [[noreturn]] void fail(std::string_view message) const { fail(line_, message); }

  int line() const { return line_; }
  bool at_end() const { return pos_ >= text_.size(); }

  // skips all whitespace, newlines included
  void skip_space() {
    while (pos_ < text_.size()) {
      char c = text_[pos_];
      if (c == '\n') {
        ++line_;
      } else if (c == '\r') {
        if (pos_ + 1 >= text_.size() || text_[pos_ + 1] != '\n') ++line_;
      } else if (!is_hspace(c)) {
        return;
      }
      ++pos_;
    }
  }

  // skips spaces and tabs (and the CR of a CRLF) but stops at the end of the line
  void skip_hspace() {
    while (pos_ < text_.size()) {
      char c = text_[pos_];
      if (is_hspace(c) || (c == '\r' && pos_ + 1 < text_.size() && text_[pos_ + 1] == '\n')) {
        ++pos_;
      } else {
        return;
      }
    }
  }

  bool at_line_end() const {
    return pos_ >= text_.size() || text_[pos_] == '\n' || text_[pos_] == '\r';
  }

  // next whitespace-separated token, on any line; braces are tokens of their own. "" at the end.
  std::string_view token() {
    skip_space();
    return token_on_this_line();
  }

  // next token if it is on the current line, else ""
  std::string_view token_on_this_line() {
    skip_hspace();
    size_t start = pos_;
    if (at_line_end()) return {};
    if (text_[pos_] == '{' || text_[pos_] == '}') return text_.substr(pos_++, 1);
    while (pos_ < text_.size()) {
      char c = text_[pos_];
      if (is_hspace(c) || c == '\n' || c == '\r' || c == '{' || c == '}') break;
      ++pos_;
    }
    return text_.substr(start, pos_ - start);
  }

  // the rest of the current line without surrounding whitespace
  std::string_view rest_of_line() {
    skip_hspace();
    size_t start = pos_;
    while (!at_line_end()) ++pos_;
    std::string_view s = text_.substr(start, pos_ - start);
    while (!s.empty() && (is_hspace(s.back()) || s.back() == '\r')) s.remove_suffix(1);
    return s;
  }

  double number(std::string_view what) {
    int l = line_;
    std::string_view t = token();
    if (t.empty()) fail(l, fmt::format("expected {}, found the end of the file", what));
    double v;
    if (!parse_double(t, v)) fail(fmt::format("bad number {} for {}", quoted(t), what));
    return v;
  }

  // "Frames:" / "Frame Time:" style labels: words separated by spaces or tabs, then ':'
  bool label(std::initializer_list<std::string_view> words) {
    skip_space();
    size_t save = pos_;
    for (std::string_view w : words) {
      skip_hspace();
      if (text_.size() - pos_ < w.size() || !iequals(text_.substr(pos_, w.size()), w)) {
        pos_ = save;
        return false;
      }
      pos_ += w.size();
    }
    skip_hspace();
    if (pos_ < text_.size() && text_[pos_] == ':') {
      ++pos_;
      return true;
    }
    pos_ = save;
    return false;
  }

  // parses one motion row of exactly `count` numbers on the current line into out[0..count)
  void motion_row(double* out, int count) {
    const int row_line = line_;
    const char* const end = text_.data() + text_.size();
    int found = 0;
    while (true) {
      skip_hspace();
      if (at_line_end()) break;
      const char* b = text_.data() + pos_;
      const char* num = (*b == '+') ? b + 1 : b;
      double v;
      auto [p, ec] = std::from_chars(num, end, v);
      // the number must end at whitespace, and be finite
      bool ok = ec == std::errc() && (p == end || is_hspace(*p) || *p == '\n' || *p == '\r') &&
                std::isfinite(v);
      if (!ok) {
        std::string_view t = token_on_this_line();
        fail(row_line,
             fmt::format("bad number {} (value {} of the motion row)", quoted(t), found + 1));
      }
      if (found < count) out[found] = v;
      ++found;
      pos_ = static_cast<size_t>(p - text_.data());
    }
    if (found != count) {
      fail(row_line, fmt::format("wrong channel count in motion row: expected {} values, found {}",
                                 count, found));
    }
  }

 private:
  std::string_view text_;
  const std::string& name_;
  size_t pos_ = 0;
  int line_ = 1;
};

// one open '{' block of the hierarchy
struct OpenBlock {
  int joint;      // joint index
  bool end_site;  // an End Site block of that joint
  int line;       // of the '{'
};

void parse_channels(Scanner& in, BvhJoint& joint, const std::vector<std::string>& all_names) {
  const int line = in.line();
  std::string_view count_token = in.token_on_this_line();
  int count = -1;
  auto [p, ec] =
      std::from_chars(count_token.data(), count_token.data() + count_token.size(), count);
  if (ec != std::errc() || p != count_token.data() + count_token.size() || count < 0 || count > 6) {
    in.fail(line, fmt::format("bad channel count {} for joint '{}' (expected 0..6)",
                              quoted(count_token), joint.name));
  }
  if (!joint.channels.empty())
    in.fail(line, fmt::format("joint '{}' has two CHANNELS", joint.name));
  for (int i = 0; i < count; ++i) {
    std::string_view t = in.token_on_this_line();
    if (t.empty()) {
      in.fail(line, fmt::format("CHANNELS {} for joint '{}' lists only {} channel names", count,
                                joint.name, i));
    }
    int found = -1;
    for (int c = 0; c < 6; ++c) {
      if (iequals(t, kChannelNames[c])) found = c;
    }
    if (found < 0) {
      in.fail(line,
              fmt::format("unknown channel name {}{}", quoted(t), did_you_mean(t, all_names)));
    }
    auto ch = static_cast<BvhChannel>(found);
    if (std::find(joint.channels.begin(), joint.channels.end(), ch) != joint.channels.end()) {
      in.fail(line, fmt::format("channel '{}' listed twice for joint '{}'", kChannelNames[found],
                                joint.name));
    }
    joint.channels.push_back(ch);
  }
  std::string_view extra = in.token_on_this_line();
  if (!extra.empty()) {
    in.fail(line, fmt::format("CHANNELS {} for joint '{}' is followed by {}", count, joint.name,
                              quoted(extra)));
  }

  // rotation order: listed rotation axes, then the unlisted ones in x, y, z order
  std::array<int, 3> axes{};
  int n = 0;
  for (BvhChannel c : joint.channels) {
    if (is_rotation(c))
      axes[n++] = channel_axis(c);
    else
      joint.has_position = true;
  }
  joint.rotation_channel_count = n;
  for (int a = 0; a < 3 && n < 3; ++a) {
    if (std::find(axes.begin(), axes.begin() + n, a) == axes.begin() + n) axes[n++] = a;
  }
  joint.order = *rotation_order_from_axes(axes[0], axes[1], axes[2]);
}

// length of the UTF-8 sequence starting at s[i], or 0 when it is not valid UTF-8 (RFC 3629: no
// overlong forms, no surrogates, nothing above U+10FFFF; what JSON writers accept)
size_t utf8_length(std::string_view s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[i + k]); };
  const unsigned char c = byte(0);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  }
  if (n == 0 || i + n > s.size()) return 0;
  if (byte(1) < lo || byte(1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if ((byte(k) >> 6) != 0x2) return 0;
  return n;
}

// a joint name must be valid UTF-8 (it goes into JSON and MJCF) and must read back the same
// from a written file: no braces, no control characters
void check_joint_name(const Scanner& in, int line, std::string_view name) {
  for (size_t i = 0; i < name.size();) {
    size_t n = utf8_length(name, i);
    if (n == 0) {
      in.fail(line, fmt::format("joint name has a byte that is not UTF-8 (0x{:02x}) at column "
                                "{} of the name",
                                static_cast<unsigned char>(name[i]), i + 1));
    }
    const char c = name[i];
    if (n == 1 && (c == '{' || c == '}' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f)) {
      std::string shown;
      for (char x : name) shown += static_cast<unsigned char>(x) < 0x20 ? '?' : x;
      in.fail(line, fmt::format("joint name '{}' has a character BVH cannot write back ({})",
                                shown.substr(0, 40),
                                c == '{' || c == '}' ? "a brace" : "a control character"));
    }
    i += n;
  }
}

void parse_hierarchy(Scanner& in, BvhClip& clip) {
  const std::vector<std::string> channel_names(kChannelNames.begin(), kChannelNames.end());
  std::string_view first = in.token();
  if (!iequals(first, "HIERARCHY")) {
    in.fail(fmt::format("expected HIERARCHY at the start of a BVH file, found {}",
                        first.empty() ? std::string("nothing") : quoted(first)));
  }
  std::vector<OpenBlock> open;
  while (true) {
    std::string_view t = in.token();
    const int line = in.line();
    if (t.empty()) {
      if (!open.empty()) {
        const OpenBlock& b = open.back();
        in.fail(line, fmt::format("unbalanced braces: end of file inside the block of '{}' opened "
                                  "at line {}",
                                  clip.joints[b.joint].name, b.line));
      }
      in.fail(line, "missing MOTION section after the hierarchy");
    }
    bool root = iequals(t, "ROOT");
    if (root || iequals(t, "JOINT")) {
      if (root && !open.empty()) in.fail(line, "ROOT inside another joint's block");
      if (root && !clip.joints.empty()) {
        in.fail(line, fmt::format("a second ROOT: stance reads one skeleton per BVH file (the "
                                  "first ROOT '{}' is at line {})",
                                  clip.joints.front().name, clip.joints.front().line));
      }
      if (static_cast<int>(open.size()) >= kMaxBvhDepth) {
        in.fail(line, fmt::format("joints nested more than {} deep", kMaxBvhDepth));
      }
      if (clip.joint_count() >= kMaxBvhJoints) {
        in.fail(line, fmt::format("more than {} joints", kMaxBvhJoints));
      }
      if (!root && open.empty()) in.fail(line, "JOINT outside any ROOT block");
      if (!open.empty() && open.back().end_site) in.fail(line, "JOINT inside an End Site block");
      std::string_view name = in.rest_of_line();
      bool brace_on_line = !name.empty() && name.back() == '{';
      if (brace_on_line) {
        name.remove_suffix(1);
        while (!name.empty() && is_hspace(name.back())) name.remove_suffix(1);
      }
      if (name.empty()) in.fail(line, fmt::format("{} without a name", t));
      check_joint_name(in, line, name);
      // a joint is found by its name (joint maps, the character's bodies)
      if (int first = clip.find_joint(name); first >= 0) {
        in.fail(line, fmt::format("a second joint named '{}' (the first is at line {}): joint "
                                  "names must be unique",
                                  name, clip.joints[first].line));
      }
      BvhJoint j;
      j.name = std::string(name);
      j.parent = open.empty() ? -1 : open.back().joint;
      j.line = line;
      clip.joints.push_back(std::move(j));
      if (!brace_on_line) {
        std::string_view brace = in.token();
        if (brace != "{") {
          in.fail(fmt::format("expected '{{' after {} {}, found {}", t, name, quoted(brace)));
        }
      }
      open.push_back({clip.joint_count() - 1, false, in.line()});
    } else if (iequals(t, "End")) {
      std::string_view site = in.token_on_this_line();
      if (!iequals(site, "Site"))
        in.fail(line, fmt::format("expected 'End Site', found 'End {}'", site));
      if (open.empty() || open.back().end_site) in.fail(line, "End Site outside a joint block");
      BvhJoint& parent = clip.joints[open.back().joint];
      if (parent.has_end_site) {
        in.fail(line, fmt::format("joint '{}' has a second End Site", parent.name));
      }
      parent.has_end_site = true;
      std::string_view brace = in.token();
      if (brace != "{")
        in.fail(fmt::format("expected '{{' after End Site, found {}", quoted(brace)));
      open.push_back({open.back().joint, true, in.line()});
    } else if (iequals(t, "OFFSET")) {
      if (open.empty()) in.fail(line, "OFFSET outside a joint block");
      Eigen::Vector3d v;
      for (int i = 0; i < 3; ++i) v[i] = in.number("an OFFSET value");
      for (int i = 0; i < 3; ++i) {
        if (std::abs(v[i]) > kMaxBvhCoordinate) {
          in.fail(line, fmt::format("OFFSET value {:g} is beyond the {:g} file units a "
                                    "skeleton can span",
                                    v[i], kMaxBvhCoordinate));
        }
      }
      BvhJoint& j = clip.joints[open.back().joint];
      (open.back().end_site ? j.end_site_offset : j.offset) = v;
    } else if (iequals(t, "CHANNELS")) {
      if (open.empty() || open.back().end_site) in.fail(line, "CHANNELS outside a joint block");
      parse_channels(in, clip.joints[open.back().joint], channel_names);
    } else if (t == "}") {
      if (open.empty()) in.fail(line, "unbalanced braces: '}' without a matching '{'");
      open.pop_back();
    } else if (iequals(t, "MOTION")) {
      if (!open.empty()) {
        const OpenBlock& b = open.back();
        in.fail(line, fmt::format("unbalanced braces: MOTION inside the block of '{}' opened at "
                                  "line {}",
                                  clip.joints[b.joint].name, b.line));
      }
      break;
    } else {
      in.fail(line, fmt::format("unexpected {} in the hierarchy", quoted(t)));
    }
  }
  if (clip.joints.empty()) in.fail("no ROOT joint before MOTION");
}

void parse_motion(Scanner& in, BvhClip& clip) {
  // Frames: N
  if (!in.label({"Frames"})) {
    std::string_view found = in.rest_of_line();
    in.fail(fmt::format("missing 'Frames:' after MOTION, found {}", quoted(found)));
  }
  const int frames_line = in.line();
  std::string_view t = in.token_on_this_line();
  int frames = -1;
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), frames);
  if (t.empty() || ec != std::errc() || p != t.data() + t.size() || frames < 0) {
    in.fail(frames_line, fmt::format("bad frame count {} after 'Frames:'", quoted(t)));
  }
  // Frame Time: dt
  if (!in.label({"Frame", "Time"})) {
    std::string_view found = in.rest_of_line();
    in.fail(fmt::format("missing 'Frame Time:' after 'Frames:', found {}", quoted(found)));
  }
  t = in.token_on_this_line();
  double dt = 0.0;
  if (!parse_double(t, dt) || !(dt >= kMinBvhFrameTimeS && dt <= kMaxBvhFrameTimeS)) {
    in.fail(fmt::format("bad frame time {} (expected {} to {} s: {} to {} frames per second)",
                        quoted(t), kMinBvhFrameTimeS, kMaxBvhFrameTimeS, 1 / kMinBvhFrameTimeS,
                        1 / kMaxBvhFrameTimeS));
  }
  clip.frame_count = frames;
  clip.frames_line = frames_line;
  clip.frame_time_s = dt;

  // the frame count is a claim: the buffer grows with the rows actually read, and the poses
  // built from them are bounded
  const int cols = clip.channel_count;
  if (static_cast<size_t>(frames) * clip.joints.size() > kMaxBvhPoses) {
    in.fail(frames_line, fmt::format("'Frames: {}' x {} joints is more than the {} joint poses "
                                     "stance holds in memory",
                                     frames, clip.joints.size(), kMaxBvhPoses));
  }
  std::vector<int> position_columns;
  for (const BvhJoint& j : clip.joints)
    for (size_t c = 0; c < j.channels.size(); ++c)
      if (!is_rotation(j.channels[c])) position_columns.push_back(j.first_column + int(c));
  std::vector<double> rows;
  for (int f = 0; f < frames; ++f) {
    rows.resize(rows.size() + cols);
    in.skip_space();
    if (in.at_end()) {
      in.fail(fmt::format("truncated data: 'Frames: {}' (line {}) but only {} motion rows", frames,
                          frames_line, f));
    }
    double* row = rows.data() + static_cast<size_t>(f) * cols;
    in.motion_row(row, cols);
    for (int c : position_columns) {
      if (std::abs(row[c]) > kMaxBvhCoordinate) {
        in.fail(
            fmt::format("position {:g} (value {} of the motion row) is beyond the {:g} file "
                        "units a clip can span",
                        row[c], c + 1, kMaxBvhCoordinate));
      }
    }
  }
  in.skip_space();
  if (!in.at_end()) {
    in.fail(fmt::format("more motion rows than 'Frames: {}' (line {})", frames, frames_line));
  }
  clip.raw = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      rows.data(), frames, cols);
}

// per joint: motion-row column of each rotation angle (listed order) and position axis, or -1
struct JointColumns {
  std::array<int, 3> rotation{-1, -1, -1};
  std::array<int, 3> position{-1, -1, -1};
};

std::vector<JointColumns> joint_columns(const BvhClip& clip) {
  std::vector<JointColumns> out(clip.joints.size());
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    const BvhJoint& joint = clip.joints[j];
    auto axes = rotation_axes(joint.order);
    for (size_t c = 0; c < joint.channels.size(); ++c) {
      BvhChannel ch = joint.channels[c];
      int col = joint.first_column + static_cast<int>(c);
      if (is_rotation(ch)) {
        int slot =
            static_cast<int>(std::find(axes.begin(), axes.end(), channel_axis(ch)) - axes.begin());
        out[j].rotation[slot] = col;
      } else {
        out[j].position[channel_axis(ch)] = col;
      }
    }
  }
  return out;
}

// quaternions and positions from the raw rows, once
void convert_motion(BvhClip& clip) {
  const auto columns = joint_columns(clip);
  const size_t nj = clip.joints.size();
  clip.rotations.assign(static_cast<size_t>(clip.frame_count) * nj, Eigen::Quaterniond::Identity());
  clip.positions.assign(static_cast<size_t>(clip.frame_count) * clip.position_joint_count,
                        Eigen::Vector3d::Zero());
  for (int f = 0; f < clip.frame_count; ++f) {
    for (size_t j = 0; j < nj; ++j) {
      const BvhJoint& joint = clip.joints[j];
      const JointColumns& col = columns[j];
      if (joint.rotation_channel_count > 0) {
        Eigen::Vector3d angles;
        for (int k = 0; k < 3; ++k)
          angles[k] = col.rotation[k] < 0 ? 0.0 : clip.raw(f, col.rotation[k]);
        clip.rotation(f, static_cast<int>(j)) =
            euler_to_quaternion(angles * kDegToRad, joint.order);
      }
      if (joint.position_slot >= 0) {
        Eigen::Vector3d p = joint.offset;
        for (int k = 0; k < 3; ++k) {
          if (col.position[k] >= 0) p[k] = clip.raw(f, col.position[k]);
        }
        clip.positions[static_cast<size_t>(f) * clip.position_joint_count + joint.position_slot] =
            p;
      }
    }
  }
}

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

struct UnitGuess {
  double scale_to_meters;
  std::string units;
};

// the text after a UTF-8 byte order mark, if any. UTF-16, with its mark or without (ASCII text
// in UTF-16 has a NUL in one of its first two bytes), is refused by name rather than read as
// bytes that stop at the first NUL.
std::string_view text_without_utf8_bom(std::string_view text, const std::string& name) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF") return text.substr(3);
  if (text.size() < 2) return text;
  // what the file is, and the encoding iconv converts it from
  const char* what = nullptr;
  const char* from = "UTF-16";
  if (text.substr(0, 2) == "\xFF\xFE") {
    what = "little-endian, with a byte order mark";
  } else if (text.substr(0, 2) == "\xFE\xFF") {
    what = "big-endian, with a byte order mark";
  } else if (text[0] != '\0' && text[1] == '\0') {
    what = "little-endian";
    from = "UTF-16LE";
  } else if (text[0] == '\0' && text[1] != '\0') {
    what = "big-endian";
    from = "UTF-16BE";
  }
  if (what) {
    throw InputError(located(name, 1,
                             fmt::format("the file is UTF-16 ({}); stance reads BVH as "
                                         "ASCII or UTF-8: convert it, e.g. with iconv "
                                         "-f {} -t UTF-8",
                                         what, from)));
  }
  return text;
}

}  // namespace

Eigen::Vector3d bvh_rest_translation(const BvhClip& clip, int joint) {
  const BvhJoint& j = clip.joints[joint];
  if (j.position_slot < 0 || clip.frame_count == 0) return j.offset;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int f = 0; f < clip.frame_count; ++f) sum += clip.translation(f, joint);
  return sum / clip.frame_count;
}

int bvh_body_root(const BvhClip& clip) {
  int body_root = 0;
  for (;;) {
    int children = 0, child = -1;
    for (int j = body_root + 1; j < clip.joint_count(); ++j)
      if (clip.joints[j].parent == body_root) {
        ++children;
        child = j;
      }
    if (children != 1 || !clip.joints[child].has_position) return body_root;
    body_root = child;
  }
}

namespace {

// the lowest drop of a leaf (end site or childless joint) below the body's root
// (bvh_body_root) along -y and -z, in the first frame's pose or at rest
Eigen::Vector2d leaf_drop(const BvhClip& clip, bool posed) {
  const size_t n = clip.joints.size();
  std::vector<Eigen::Vector3d> pos(n, Eigen::Vector3d::Zero());
  std::vector<Eigen::Quaterniond> rot(n, Eigen::Quaterniond::Identity());
  std::vector<bool> has_child(n, false), in_first_tree(n, false);
  Eigen::Vector2d drop = Eigen::Vector2d::Zero();
  for (size_t j = 0; j < n; ++j) {
    const BvhJoint& joint = clip.joints[j];
    const int p = joint.parent;
    const Eigen::Quaterniond local = posed && clip.frame_count > 0
                                         ? clip.rotation(0, static_cast<int>(j))
                                         : Eigen::Quaterniond::Identity();
    if (p < 0) {
      in_first_tree[j] = j == 0;
      rot[j] = local;
    } else {
      in_first_tree[j] = in_first_tree[p];
      has_child[p] = true;
      const int ji = static_cast<int>(j);
      pos[j] = pos[p] + rot[p] * (posed && clip.frame_count > 0 ? clip.translation(0, ji)
                                                                : bvh_rest_translation(clip, ji));
      rot[j] = rot[p] * local;
    }
  }
  const size_t body_root = static_cast<size_t>(bvh_body_root(clip));
  for (size_t j = 0; j < n; ++j) {
    if (!in_first_tree[j]) continue;
    const BvhJoint& joint = clip.joints[j];
    auto lower = [&](const Eigen::Vector3d& q) {
      drop.x() = std::max(drop.x(), pos[body_root].y() - q.y());
      drop.y() = std::max(drop.y(), pos[body_root].z() - q.z());
    };
    if (joint.has_end_site) lower(pos[j] + rot[j] * joint.end_site_offset);
    if (!has_child[j]) lower(pos[j]);
  }
  return drop;
}

UnitGuess guess_units(const BvhClip& clip) {
  if (clip.joints.empty()) return {1.0, "unknown"};
  // the legs: the longest drop below the root, at rest or, where the rest pose does not stand,
  // in the posed frames (bvh_measure.h)
  const double leg = bvh_leg_drop(clip);
  if (!(leg > 0.0)) return {1.0, "unknown"};

  struct Unit {
    double scale;
    const char* name;
  };
  static constexpr Unit kUnits[] = {{1.0, "meters"},        {0.01, "centimeters"},
                                    {0.001, "millimeters"}, {0.0254, "inches"},
                                    {0.3048, "feet"},       {0.056444, "cmu"}};
  constexpr double kTypicalLegM = 0.9;
  const Unit* best = nullptr;
  double best_err = INFINITY;
  for (const Unit& u : kUnits) {
    double leg_m = leg * u.scale;
    if (leg_m < 0.45 || leg_m > 1.5) continue;
    double err = std::abs(std::log(leg_m / kTypicalLegM));
    if (err < best_err) {
      best_err = err;
      best = &u;
    }
  }
  if (best) return {best->scale, best->name};
  return {kTypicalLegM / leg, "unknown"};
}

}  // namespace

char detect_bvh_up_axis(const BvhClip& clip, bool posed) {
  if (clip.joints.empty()) return 'y';
  const Eigen::Vector2d drop = leaf_drop(clip, posed);
  return drop.y() > drop.x() ? 'z' : 'y';
}

std::string_view bvh_channel_name(BvhChannel channel) {
  return kChannelNames[static_cast<int>(channel)];
}

int BvhClip::find_joint(std::string_view name) const {
  for (size_t j = 0; j < joints.size(); ++j) {
    if (joints[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

BvhClip parse_bvh(std::string_view text, const std::string& name_for_errors) {
  BvhClip clip;
  clip.source = name_for_errors;
  Scanner in(text_without_utf8_bom(text, name_for_errors), name_for_errors);
  parse_hierarchy(in, clip);

  // motion-row columns and position slots
  int column = 0;
  for (BvhJoint& j : clip.joints) {
    j.first_column = column;
    column += static_cast<int>(j.channels.size());
    if (j.has_position) j.position_slot = clip.position_joint_count++;
  }
  clip.channel_count = column;

  parse_motion(in, clip);
  convert_motion(clip);
  return clip;
}

BvhClip read_bvh(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(located(path, 0, "cannot open BVH file (a folder)"));
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    throw InputError(
        located(path, 0, fmt::format("cannot open BVH file ({})", std::strerror(errno))));
  }
  std::string text;
  std::fseek(f, 0, SEEK_END);
  long size = std::ftell(f);
  std::fseek(f, 0, SEEK_SET);
  if (size > 0) {
    text.resize(static_cast<size_t>(size));
    size_t got = std::fread(text.data(), 1, text.size(), f);
    text.resize(got);
  }
  bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) throw InputError(located(path, 0, "cannot read BVH file"));
  return parse_bvh(text, path);
}

namespace {
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

double detect_bvh_scale_to_meters(const BvhClip& clip) {
  return guess_units(clip).scale_to_meters;
}

std::string detect_bvh_units(const BvhClip& clip) {
  return guess_units(clip).units;
}

int detect_bvh_first_motion_frame(const BvhClip& clip) {
  const int frames = clip.frame_count;
  if (frames < 8) return 0;
  const double scale = detect_bvh_scale_to_meters(clip);
  // per step from frame f to f + 1: the largest turn of a joint and the largest move of a joint
  // with position channels
  std::vector<double> turn(frames - 1, 0.0), move(frames - 1, 0.0);
  for (int f = 0; f + 1 < frames; ++f)
    for (int j = 0; j < clip.joint_count(); ++j) {
      turn[f] = std::max(turn[f], geodesic_angle(clip.rotation(f, j), clip.rotation(f + 1, j)));
      if (clip.joints[j].position_slot >= 0)
        move[f] =
            std::max(move[f], scale * (clip.translation(f + 1, j) - clip.translation(f, j)).norm());
    }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  // a jump: ten times a typical step, and at least 30 deg or 0.25 m
  const double turn_jump = std::max(30 * std::numbers::pi / 180, 10 * median(turn));
  const double move_jump = std::max(0.25, 10 * median(move));
  // after the last jump among the first three steps
  int first = 0;
  for (int f = 0; f < std::min(3, frames - 2); ++f)
    if (turn[f] > turn_jump || move[f] > move_jump) first = f + 1;
  return first;
}

nlohmann::json bvh_info_json(const BvhClip& clip) {
  UnitGuess units = guess_units(clip);
  nlohmann::json orders = nlohmann::json::object();
  int end_sites = 0;
  for (const BvhJoint& j : clip.joints) {
    if (j.has_end_site) ++end_sites;
    if (j.rotation_channel_count > 0) orders[j.name] = rotation_order_name(j.order);
  }
  return {
      {"file", clip.source},
      {"frames", clip.frame_count},
      {"frame_time", clip.frame_time_s},
      {"joints", clip.joint_count()},
      {"end_sites", end_sites},
      {"channels", clip.channel_count},
      {"duration_s", clip.frame_count * clip.frame_time_s},
      {"rotation_orders", orders},
      {"units", units.units},
      {"scale_to_meters", units.scale_to_meters},
      {"up_axis", std::string(1, detect_bvh_up_axis(clip))},
      {"first_motion_frame", detect_bvh_first_motion_frame(clip)},
      {"character", bvh_measures_json(clip)},
  };
}

std::string bvh_info_text(const BvhClip& clip) {
  UnitGuess units = guess_units(clip);
  int end_sites = 0;
  std::map<std::string_view, int> order_counts;
  for (const BvhJoint& j : clip.joints) {
    if (j.has_end_site) ++end_sites;
    if (j.rotation_channel_count > 0) ++order_counts[rotation_order_name(j.order)];
  }
  std::string out;
  out += fmt::format("file:        {}\n", clip.source);
  out += fmt::format("frames:      {}\n", clip.frame_count);
  out +=
      fmt::format("frame time:  {} s ({:.4g} fps)\n", clip.frame_time_s, 1.0 / clip.frame_time_s);
  out += fmt::format("duration:    {:.4g} s\n", clip.frame_count * clip.frame_time_s);
  out += fmt::format("joints:      {} (+{} End Sites)\n", clip.joint_count(), end_sites);
  out += fmt::format("channels:    {} per frame\n", clip.channel_count);
  out +=
      fmt::format("units:       {} ({:.6g} m per file unit)\n", units.units, units.scale_to_meters);
  out += fmt::format("up axis:     {}\n", detect_bvh_up_axis(clip));
  if (int first = detect_bvh_first_motion_frame(clip); first > 0)
    out += fmt::format(
        "motion from: frame {} (the frames before jump to it: a T-pose or rest pose)\n", first);
  out += bvh_measures_text(clip);
  std::string orders;
  for (const auto& [name, count] : order_counts) {
    orders += fmt::format("{}{} x{}", orders.empty() ? "" : ", ", name, count);
  }
  out += fmt::format("rotations:   {}\n", orders.empty() ? "none" : orders);
  out += "joint tree (order, channels):\n";
  std::vector<int> depth(clip.joints.size(), 0);
  for (size_t j = 0; j < clip.joints.size(); ++j) {
    const BvhJoint& joint = clip.joints[j];
    if (joint.parent >= 0) depth[j] = depth[joint.parent] + 1;
    std::string order = joint.rotation_channel_count > 0
                            ? std::string(rotation_order_name(joint.order))
                            : std::string("-");
    out += fmt::format("  {}{}  {}  {}{}{}\n", std::string(2 * depth[j], ' '), joint.name, order,
                       joint.channels.size(), joint.has_position ? " +position" : "",
                       joint.has_end_site ? "  [End Site]" : "");
  }
  return out;
}

}  // namespace stance
