#include "params/yaml_params.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <fmt/ranges.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>

#include "core/text_check.h"

namespace stance {

namespace {
// a copy without source positions, so that messages about it say "--set"
YAML::Node without_marks(const YAML::Node& n) {
  if (n.IsScalar()) return YAML::Node(n.Scalar());
  if (n.IsSequence()) {
    YAML::Node out(YAML::NodeType::Sequence);
    for (const auto& item : n) out.push_back(without_marks(item));
    return out;
  }
  if (n.IsMap()) {
    YAML::Node out(YAML::NodeType::Map);
    for (const auto& kv : n) out[kv.first.Scalar()] = without_marks(kv.second);
    return out;
  }
  return YAML::Node();
}

int line_of(const YAML::Node& n) {
  const YAML::Mark m = n.Mark();
  return m.line >= 0 ? m.line + 1 : 0;
}
// empty when `s` is UTF-8 text (strings end up in summary.json, which must be UTF-8)
std::string utf8_problem(const std::string& s) {
  const size_t bad = invalid_utf8_offset(s);
  if (bad == std::string::npos) return "";
  return fmt::format("not UTF-8 text (byte 0x{:02X} at character {})",
                     static_cast<unsigned char>(s[bad]), bad + 1);
}
std::string describe(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + printable_text(n.Scalar()) + "'";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  return "nothing";
}
}  // namespace

void YamlParamReader::fail(const YAML::Node& at, const std::string& message) const {
  // nodes made by --set carry no position
  int line = line_of(at);
  if (line == 0) throw InputError(located(source_.file, 0, "(from --set) " + message));
  throw InputError(located(source_.file, line, message));
}

void YamlParamReader::check_unknown_keys() const {
  if (!node_ || !node_.IsMap()) return;
  std::vector<std::string> known(claimed_.begin(), claimed_.end());
  for (const auto& kv : node_) {
    if (!kv.first.IsScalar())
      fail(kv.first, fmt::format("a parameter name must be a word, found {}", describe(kv.first)));
    std::string key = kv.first.Scalar();
    if (claimed_.count(key)) continue;
    std::string path = join(key);
    fail(kv.first, fmt::format("unknown parameter '{}'{}", path, did_you_mean(key, known)));
  }
}

double YamlParamReader::read_number(const YAML::Node& n, const std::string& path,
                                    const ParamMeta& m) const {
  if (!n.IsScalar())
    fail(n, fmt::format("parameter '{}': expected a number, found {}", path, describe(n)));
  double v = 0;
  const std::string& s = n.Scalar();
  // YAML spellings of non-finite numbers are rejected explicitly below
  std::string lower;
  for (char c : s) lower += static_cast<char>(std::tolower(c));
  if (lower == ".nan" || lower == "nan" || lower == ".inf" || lower == "-.inf" || lower == "inf" ||
      lower == "-inf" || lower == "+.inf")
    fail(n, fmt::format("parameter '{}': must be a finite number, found '{}'", path, s));
  try {
    size_t used = 0;
    v = std::stod(s, &used);
    if (used != s.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    fail(n, fmt::format("parameter '{}': expected a number, found '{}'", path, s));
  }
  if (!std::isfinite(v))
    fail(n, fmt::format("parameter '{}': must be a finite number, found '{}'", path, s));
  if (v < m.min || v > m.max)
    fail(n, fmt::format("parameter '{}': {} is outside [{}, {}]", path, s, m.min, m.max));
  return v;
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path, double& v,
                                 const ParamMeta& m) {
  v = read_number(n, path, m);
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path, int& v,
                                 const ParamMeta& m) {
  double d = read_number(n, path, m);
  if (d != std::floor(d) || std::abs(d) > 2e9)
    fail(n, fmt::format("parameter '{}': expected an integer, found '{}'", path, n.Scalar()));
  v = static_cast<int>(d);
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path, bool& v,
                                 const ParamMeta&) {
  bool ok = n.IsScalar();
  if (ok) {
    const std::string& s = n.Scalar();
    if (s == "true" || s == "True" || s == "yes" || s == "on")
      v = true;
    else if (s == "false" || s == "False" || s == "no" || s == "off")
      v = false;
    else
      ok = false;
  }
  if (!ok)
    fail(n, fmt::format("parameter '{}': expected true or false, found {}", path, describe(n)));
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path, std::string& v,
                                 const ParamMeta&) {
  if (!n.IsScalar())
    fail(n, fmt::format("parameter '{}': expected a string, found {}", path, describe(n)));
  const std::string problem = utf8_problem(n.Scalar());
  if (!problem.empty()) fail(n, fmt::format("parameter '{}': {}", path, problem));
  v = n.Scalar();
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path, Eigen::Vector3d& v,
                                 const ParamMeta& m) {
  if (!n.IsSequence() || n.size() != 3)
    fail(n,
         fmt::format("parameter '{}': expected a list of 3 numbers, found {}", path, describe(n)));
  for (int i = 0; i < 3; ++i) v[i] = read_number(n[i], fmt::format("{}[{}]", path, i), m);
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path,
                                 std::vector<double>& v, const ParamMeta& m) {
  if (!n.IsSequence())
    fail(n, fmt::format("parameter '{}': expected a list of numbers, found {}", path, describe(n)));
  v.clear();
  for (size_t i = 0; i < n.size(); ++i)
    v.push_back(read_number(n[i], fmt::format("{}[{}]", path, i), m));
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path,
                                 std::vector<std::string>& v, const ParamMeta&) {
  if (!n.IsSequence())
    fail(n, fmt::format("parameter '{}': expected a list of names, found {}", path, describe(n)));
  v.clear();
  for (size_t i = 0; i < n.size(); ++i) {
    if (!n[i].IsScalar()) fail(n[i], fmt::format("parameter '{}[{}]': expected a name", path, i));
    const std::string problem = utf8_problem(n[i].Scalar());
    if (!problem.empty()) fail(n[i], fmt::format("parameter '{}[{}]': {}", path, i, problem));
    v.push_back(n[i].Scalar());
  }
}

void YamlParamReader::read_value(const YAML::Node& n, const std::string& path, NamedValues& v,
                                 const ParamMeta& m) {
  if (!n.IsMap())
    fail(n, fmt::format("parameter '{}': expected a mapping of name: value, found {}", path,
                        describe(n)));
  v.clear();
  for (const auto& kv : n) {
    if (!kv.first.IsScalar())
      fail(kv.first, fmt::format("parameter '{}': a name must be a word, found {}", path,
                                 describe(kv.first)));
    std::string key = kv.first.Scalar();
    v[key] = read_number(kv.second, path + "." + key, m);
  }
}

namespace {
// deeper lists and mappings are refused before yaml-cpp recurses into them (its parser recurses
// once per level, and so would every reader and writer of the tree)
constexpr size_t kMaxYamlDepth = 64;

// the checks yaml-cpp leaves out, made on the raw event stream (which carries every node's
// line): a duplicate key in a mapping, a key that is not a word, an alias (yaml-cpp shares the
// aliased node, so a --set through one copy would change all of them), a recursive alias, and
// nesting deeper than kMaxYamlDepth. The first finding is kept and reported once yaml-cpp has
// read the whole document, so that a syntax error (an unclosed '[' read as a key) wins; the depth
// is reported at once, to stop the recursion.
class StrictYamlCheck final : public YAML::EventHandler {
 public:
  explicit StrictYamlCheck(const YamlTextSource& source) : source_(source) {}

  // throws the first finding, if any
  void report() const {
    if (!finding_.empty()) throw InputError(finding_);
  }

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t anchor) override {
    begin_node(mark, "nothing", nullptr);
    name_anchor(mark, anchor, false);
  }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t anchor) override {
    auto it = anchors_.find(anchor);
    std::string name = it != anchors_.end() ? it->second.name : "?";
    int line = it != anchors_.end() ? it->second.line : 0;
    bool open = it != anchors_.end() && it->second.open;
    if (open)
      return fail(mark, fmt::format("recursive alias '*{}' inside its own anchor '&{}' (line {})",
                                    name, name, line));
    fail(mark, fmt::format("YAML aliases are not supported ('*{}' repeats '&{}' of line {}): write "
                           "the value out",
                           name, name, line));
  }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                const std::string& value) override {
    begin_node(mark, "", &value);
    name_anchor(mark, anchor, false);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override {
    check_depth(mark);
    begin_node(mark, "a list", nullptr);
    levels_.push_back({false, true, {}, anchor});
    name_anchor(mark, anchor, true);
  }
  void OnSequenceEnd() override { end_level(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                  YAML::EmitterStyle::value) override {
    check_depth(mark);
    begin_node(mark, "a mapping", nullptr);
    levels_.push_back({true, true, {}, anchor});
    name_anchor(mark, anchor, true);
  }
  void OnMapEnd() override { end_level(); }
  void OnAnchor(const YAML::Mark&, const std::string& name) override { pending_anchor_ = name; }

 private:
  struct Level {
    bool is_map = false;
    bool expect_key = true;
    std::map<std::string, int> keys;  // key -> its line (1-based)
    YAML::anchor_t anchor = 0;
  };
  struct Anchor {
    std::string name;
    int line = 0;
    bool open = false;  // its node is still being read
  };

  void fail(const YAML::Mark& mark, const std::string& message) {
    if (finding_.empty()) finding_ = source_.where(mark, false, message);
  }

  void check_depth(const YAML::Mark& mark) const {
    if (levels_.size() < kMaxYamlDepth) return;
    throw InputError(source_.where(
        mark, false, fmt::format("lists and mappings nested more than {} deep", kMaxYamlDepth)));
  }

  // every node is a key or a value of the mapping around it, or an item of a list
  void begin_node(const YAML::Mark& mark, const char* kind, const std::string* scalar) {
    if (levels_.empty() || !levels_.back().is_map) return;
    Level& level = levels_.back();
    level.expect_key = !level.expect_key;
    if (level.expect_key) return;  // it was the value
    if (!scalar) return fail(mark, fmt::format("a key must be a word, found {}", kind));
    const int line = mark.line + 1;
    auto [it, inserted] = level.keys.emplace(*scalar, line);
    if (!inserted)
      fail(mark, fmt::format("duplicate key '{}' (first at line {})", *scalar, it->second));
  }

  void name_anchor(const YAML::Mark& mark, YAML::anchor_t anchor, bool open) {
    if (anchor == 0) return;
    anchors_[anchor] = {pending_anchor_, mark.line + 1, open};
    pending_anchor_.clear();
  }

  void end_level() {
    if (levels_.back().anchor) anchors_[levels_.back().anchor].open = false;
    levels_.pop_back();
  }

  const YamlTextSource& source_;
  std::vector<Level> levels_;
  std::map<YAML::anchor_t, Anchor> anchors_;
  std::string pending_anchor_;
  std::string finding_;  // the first, as a whole message
};
}  // namespace

std::string YamlTextSource::where(const YAML::Mark& mark, bool column,
                                  const std::string& message) const {
  if (!assignment.empty()) return fmt::format("--set {}: {}", printable_text(assignment), message);
  if (column) return fmt::format("{}:{}:{}: {}", file, mark.line + 1, mark.column + 1, message);
  return located(file, mark.line + 1, message);
}

YAML::Node load_yaml_text(const std::string& text, const YamlTextSource& source) {
  // what yaml-cpp would misread: UTF-16 (decoded silently), a NUL byte (reported as a bad hex
  // number), bytes that are not UTF-8 (passed on to summary.json)
  if (auto problem = find_text_problem(text)) {
    if (!source.assignment.empty())
      throw InputError(
          fmt::format("--set {}: {}", printable_text(source.assignment), problem->message));
    throw InputError(located(source.file, problem->line, problem->message));
  }
  try {
    // the strict checks first: yaml-cpp would build a cycle from a recursive alias
    std::istringstream events(text);
    YAML::Parser parser(events);
    StrictYamlCheck check(source);
    const bool read = parser.HandleNextDocument(check);
    check.report();
    if (read) {
      YAML::Mark second;
      struct DocumentStart final : YAML::EventHandler {
        YAML::Mark* at;
        explicit DocumentStart(YAML::Mark* m) : at(m) {}
        void OnDocumentStart(const YAML::Mark& m) override { *at = m; }
        void OnDocumentEnd() override {}
        void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
        void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
        void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                      const std::string&) override {}
        void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                             YAML::EmitterStyle::value) override {}
        void OnSequenceEnd() override {}
        void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                        YAML::EmitterStyle::value) override {}
        void OnMapEnd() override {}
      } start(&second);
      if (parser.HandleNextDocument(start))
        throw InputError(source.where(second, false, "a second YAML document: a file holds one"));
    }
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(source.where(e.mark, true, fmt::format("malformed YAML: {}", e.msg)));
  }
}

YAML::Node load_yaml_file(const std::string& path) {
  std::error_code ec;
  const bool exists = std::filesystem::exists(path, ec);
  if (ec) throw InputError(path + ": " + ec.message());
  if (!exists) throw InputError(path + ": no such file");
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": a folder, not a YAML file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return load_yaml_text(text, {path, ""});
}

namespace {
// a list index: digits only (strtol would read "" and " 1" as indices)
std::optional<long> list_index(const std::string& part) {
  if (part.empty() || part.size() > 9) return std::nullopt;
  for (char c : part)
    if (c < '0' || c > '9') return std::nullopt;
  return std::stol(part);
}

// the names of a --set path: "a.b.0.c"; an empty one (two dots in a row, a dot at an end) or a
// path deeper than YAML may nest is bad input (the message's prefix is `where`)
std::vector<std::string> split_set_path(const std::string& key, const std::string& where) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t dot = key.find('.', start);
    parts.push_back(key.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  for (size_t i = 0; i < parts.size(); ++i) {
    if (!parts[i].empty()) continue;
    const char* why = i == 0                  ? "a dot at its start"
                      : i + 1 == parts.size() ? "a dot at its end"
                                              : "two dots in a row";
    throw InputError(fmt::format("{}: an empty name in '{}' ({})", where, key, why));
  }
  if (parts.size() > kMaxYamlDepth)
    throw InputError(
        fmt::format("{}: a path of {} names (at most {})", where, parts.size(), kMaxYamlDepth));
  return parts;
}

// a value in flow style ("[0, 0", "{a: 1") whose brackets do not close: yaml-cpp would read it
// as something else (a list used as a key); empty when they close
std::string unclosed_bracket(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t");
  if (first == std::string::npos || (text[first] != '[' && text[first] != '{')) return "";
  std::vector<char> open;
  char previous = ' ';  // the last character that is not a space
  for (size_t i = first; i < text.size() && !(open.empty() && i > first); ++i) {
    const char c = text[i];
    const bool starts_scalar =
        previous == '[' || previous == '{' || previous == ',' || previous == ':' || previous == '?';
    if (c == '"' && starts_scalar) {
      for (++i; i < text.size() && text[i] != '"'; ++i)
        if (text[i] == '\\') ++i;  // an escape
    } else if (c == '\'' && starts_scalar) {
      for (++i; i < text.size(); ++i) {
        if (text[i] != '\'') continue;
        if (i + 1 < text.size() && text[i + 1] == '\'') {
          ++i;  // '' is a quote inside
          continue;
        }
        break;
      }
    } else if (c == '[' || c == '{') {
      open.push_back(c);
    } else if ((c == ']' || c == '}') && !open.empty()) {
      if ((c == ']') != (open.back() == '['))
        return fmt::format("the value's '{}' is closed by '{}'", open.back(), c);
      open.pop_back();
    }
    if (c != ' ' && c != '\t') previous = c;
  }
  if (open.empty()) return "";
  return fmt::format("the value has an unclosed '{}'", open.back());
}
}  // namespace

void apply_yaml_override(YAML::Node& root, const std::string& assignment) {
  const std::string where = "--set " + printable_text(assignment);
  const std::string problem = utf8_problem(assignment);
  if (!problem.empty()) throw InputError(fmt::format("{}: {}", where, problem));
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("{}: expected key=value", where));
  std::string key = assignment.substr(0, eq);
  std::string text = assignment.substr(eq + 1);
  const std::vector<std::string> parts = split_set_path(key, where);
  const std::string unclosed = unclosed_bracket(text);
  if (!unclosed.empty()) throw InputError(fmt::format("{}: {}", where, unclosed));
  YAML::Node value = load_yaml_text(text, {"", assignment});
  // walk with a chain of nodes: yaml-cpp nodes are handles, so assignments reach the root
  std::vector<YAML::Node> chain{root};
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node cur = chain.back();
    const std::string& p = parts[i];
    YAML::Node next;
    if (cur.IsSequence()) {
      const std::optional<long> idx = list_index(p);
      if (!idx || *idx >= static_cast<long>(cur.size()))
        throw InputError(
            fmt::format("{}: '{}' is not an index of a list of {}", where, p, cur.size()));
      next = cur[*idx];
    } else {
      if (!cur.IsMap() && !cur.IsNull())
        throw InputError(fmt::format("{}: '{}' is inside a value, not a mapping", where, p));
      // an index into a list the document lacks: a mapping made here would read as "not a list"
      const std::optional<long> idx = list_index(parts[i + 1]);
      if (idx && (!cur[p] || cur[p].IsNull()))
        throw InputError(fmt::format(
            "{}: the scenario has no '{}', so index {} is past the end of an empty list", where,
            fmt::join(parts.begin(), parts.begin() + i + 1, "."), *idx));
      if (!cur[p]) cur[p] = YAML::Node(YAML::NodeType::Map);
      next = cur[p];
    }
    chain.push_back(next);
  }
  YAML::Node leaf = chain.back();
  if (!leaf.IsSequence() && !leaf.IsMap() && !leaf.IsNull())
    throw InputError(fmt::format("{}: '{}' is inside a value, not a mapping", where, parts.back()));
  // clear the marks so that errors on this value say "--set" rather than a line
  if (leaf.IsSequence()) {
    const std::optional<long> idx = list_index(parts.back());
    if (!idx || *idx >= static_cast<long>(leaf.size()))
      throw InputError(fmt::format("{}: bad list index '{}'", where, parts.back()));
    leaf[*idx] = without_marks(value);
  } else {
    leaf[parts.back()] = without_marks(value);
  }
}

}  // namespace stance
