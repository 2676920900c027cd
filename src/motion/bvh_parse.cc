// Reading BVH files: the hierarchy, the motion rows, and their quaternions and positions.
#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

#include "core/error.h"
#include "motion/bvh.h"
#include "motion/bvh_columns.h"
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

}  // namespace

namespace bvh_detail {

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

}  // namespace bvh_detail

namespace {

using bvh_detail::joint_columns;
using bvh_detail::JointColumns;

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

}  // namespace stance
