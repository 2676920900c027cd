#include "params/yaml_params.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

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
std::string describe(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
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
// the checks yaml-cpp leaves out, made on the raw event stream (which carries every node's
// line): a duplicate key in a mapping, a key that is not a word, an alias (yaml-cpp shares the
// aliased node, so a --set through one copy would change all of them), a recursive alias
class StrictYamlCheck final : public YAML::EventHandler {
 public:
  explicit StrictYamlCheck(const YamlTextSource& source) : source_(source) {}

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
      fail(mark, fmt::format("recursive alias '*{}' inside its own anchor '&{}' (line {})", name,
                             name, line));
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
    begin_node(mark, "a list", nullptr);
    levels_.push_back({false, true, {}, anchor});
    name_anchor(mark, anchor, true);
  }
  void OnSequenceEnd() override { end_level(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                  YAML::EmitterStyle::value) override {
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

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& message) const {
    throw InputError(source_.where(mark, false, message));
  }

  // every node is a key or a value of the mapping around it, or an item of a list
  void begin_node(const YAML::Mark& mark, const char* kind, const std::string* scalar) {
    if (levels_.empty() || !levels_.back().is_map) return;
    Level& level = levels_.back();
    level.expect_key = !level.expect_key;
    if (level.expect_key) return;  // it was the value
    if (!scalar) fail(mark, fmt::format("a key must be a word, found {}", kind));
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
};
}  // namespace

std::string YamlTextSource::where(const YAML::Mark& mark, bool column,
                                  const std::string& message) const {
  if (!assignment.empty()) return fmt::format("--set {}: {}", assignment, message);
  if (column) return fmt::format("{}:{}:{}: {}", file, mark.line + 1, mark.column + 1, message);
  return located(file, mark.line + 1, message);
}

YAML::Node load_yaml_text(const std::string& text, const YamlTextSource& source) {
  try {
    // the strict checks first: yaml-cpp would build a cycle from a recursive alias
    std::istringstream events(text);
    YAML::Parser parser(events);
    StrictYamlCheck check(source);
    if (parser.HandleNextDocument(check)) {
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

void apply_yaml_override(YAML::Node& root, const std::string& assignment) {
  auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("--set {}: expected key=value", assignment));
  std::string key = assignment.substr(0, eq);
  std::string text = assignment.substr(eq + 1);
  YAML::Node value = load_yaml_text(text, {"", assignment});
  // clear the marks so that errors on this value say "--set" rather than a line
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string part; std::getline(ss, part, '.');) parts.push_back(part);
  // walk with a chain of nodes: yaml-cpp nodes are handles, so assignments reach the root
  std::vector<YAML::Node> chain{root};
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node cur = chain.back();
    const std::string& p = parts[i];
    YAML::Node next;
    if (cur.IsSequence()) {
      char* end = nullptr;
      long idx = std::strtol(p.c_str(), &end, 10);
      if (*end || idx < 0 || idx >= static_cast<long>(cur.size()))
        throw InputError(fmt::format("--set {}: '{}' is not an index of a list of {}", assignment,
                                     p, cur.size()));
      next = cur[idx];
    } else {
      if (!cur.IsMap() && !cur.IsNull())
        throw InputError(
            fmt::format("--set {}: '{}' is inside a value, not a mapping", assignment, p));
      if (!cur[p]) cur[p] = YAML::Node(YAML::NodeType::Map);
      next = cur[p];
    }
    chain.push_back(next);
  }
  YAML::Node leaf = chain.back();
  if (!leaf.IsSequence() && !leaf.IsMap() && !leaf.IsNull())
    throw InputError(
        fmt::format("--set {}: '{}' is inside a value, not a mapping", assignment, parts.back()));
  if (leaf.IsSequence()) {
    char* end = nullptr;
    long idx = std::strtol(parts.back().c_str(), &end, 10);
    if (*end || idx < 0 || idx >= static_cast<long>(leaf.size()))
      throw InputError(fmt::format("--set {}: bad list index '{}'", assignment, parts.back()));
    leaf[idx] = without_marks(value);
  } else {
    leaf[parts.back()] = without_marks(value);
  }
}

}  // namespace stance
