// YAML <-> parameter structs through their visit function. Errors are InputError with
// "file:line: parameter 'a.b': ..." and suggest the nearest key for unknown ones.
#pragma once

#include <yaml-cpp/yaml.h>

#include <fmt/format.h>

#include <set>
#include <string>
#include <vector>

#include "core/error.h"
#include "params/params.h"

namespace stance {

// where a YAML node came from, for messages
struct YamlSource {
  std::string file;  // file name, or "--set"
};

class YamlParamReader {
 public:
  YamlParamReader(const YAML::Node& node, YamlSource source, std::string prefix = "")
      : node_(node), source_(std::move(source)), prefix_(std::move(prefix)) {}

  // read every field of `params`, then reject keys that no field claimed
  template <class T>
  void read(T& params) {
    if (node_ && !node_.IsNull() && !node_.IsMap()) fail(node_, "expected a mapping of parameters");
    params.visit(*this);
    check_unknown_keys();
  }

  template <class T>
  void operator()(std::string_view key, T& value, const ParamMeta& meta = {}) {
    claimed_.insert(std::string(key));
    if (!node_ || !node_.IsMap()) return;
    YAML::Node child = node_[std::string(key)];
    if (!child) return;
    std::string path = join(key);
    if constexpr (Visitable<T, YamlParamReader>) {
      YamlParamReader sub(child, source_, path);
      sub.read(value);
    } else if constexpr (is_struct_vector<T>::value) {
      using Item = typename T::value_type;
      if (!child.IsSequence()) fail(child, fmt::format("parameter '{}': expected a list", path));
      value.clear();
      for (size_t i = 0; i < child.size(); ++i) {
        Item item{};
        YamlParamReader sub(child[i], source_, fmt::format("{}[{}]", path, i));
        sub.read(item);
        value.push_back(std::move(item));
      }
    } else {
      read_value(child, path, value, meta);
    }
  }

  // the keys seen in the node (for callers that visit several structs from one node)
  const std::set<std::string>& claimed() const { return claimed_; }
  void claim(const std::string& key) { claimed_.insert(key); }
  void check_unknown_keys() const;

  [[noreturn]] void fail(const YAML::Node& at, const std::string& message) const;

 private:
  template <class T>
  struct is_struct_vector : std::false_type {};
  template <class U>
  struct is_struct_vector<std::vector<U>> : std::bool_constant<Visitable<U, YamlParamReader>> {};

  std::string join(std::string_view key) const {
    return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
  }

  void read_value(const YAML::Node& n, const std::string& path, double& v, const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, int& v, const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, bool& v, const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, std::string& v, const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, Eigen::Vector3d& v,
                  const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, std::vector<double>& v,
                  const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, std::vector<std::string>& v,
                  const ParamMeta& m);
  void read_value(const YAML::Node& n, const std::string& path, NamedValues& v, const ParamMeta& m);
  double read_number(const YAML::Node& n, const std::string& path, const ParamMeta& m) const;

  YAML::Node node_;
  YamlSource source_;
  std::string prefix_;
  std::set<std::string> claimed_;
};

class YamlParamWriter {
 public:
  explicit YamlParamWriter(YAML::Node& out) : out_(out) {}

  template <class T>
  void write(T& params) {
    params.visit(*this);
  }

  template <class T>
  void operator()(std::string_view key, T& value, const ParamMeta& = {}) {
    std::string k(key);
    if constexpr (Visitable<T, YamlParamWriter>) {
      YAML::Node child(YAML::NodeType::Map);
      YamlParamWriter sub(child);
      sub.write(value);
      out_[k] = child;
    } else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
      YAML::Node seq(YAML::NodeType::Sequence);
      for (int i = 0; i < 3; ++i) seq.push_back(value[i]);
      seq.SetStyle(YAML::EmitterStyle::Flow);
      out_[k] = seq;
    } else if constexpr (std::is_same_v<T, NamedValues>) {
      YAML::Node map(YAML::NodeType::Map);
      for (const auto& [name, x] : value) map[name] = x;
      out_[k] = map;
    } else if constexpr (requires { typename T::value_type; } && !std::is_same_v<T, std::string>) {
      YAML::Node seq(YAML::NodeType::Sequence);
      for (auto& item : value) {
        if constexpr (Visitable<typename T::value_type, YamlParamWriter>) {
          YAML::Node child(YAML::NodeType::Map);
          YamlParamWriter sub(child);
          sub.write(item);
          seq.push_back(child);
        } else {
          seq.push_back(item);
        }
      }
      out_[k] = seq;
    } else {
      out_[k] = value;
    }
  }

 private:
  YAML::Node& out_;
};

// where YAML text came from, for messages: a file ("file:line: ...") or a --set assignment
struct YamlTextSource {
  std::string file;
  std::string assignment;  // set: messages say "--set a.b=v: ..."
  std::string where(const YAML::Mark& mark, bool column, const std::string& message) const;
};

// load YAML strictly: text that is not UTF-8 (UTF-16, a binary file, a NUL byte, a bad byte:
// "file:line: ..."), syntax errors ("file:line:col: malformed YAML: ..."), a duplicate key in a
// mapping (naming both lines), a key that is not a word, aliases (recursive ones named as such),
// lists and mappings nested more than 64 deep, and a second document are InputErrors. Every
// stance YAML file is read through these.
YAML::Node load_yaml_text(const std::string& text, const YamlTextSource& source);
YAML::Node load_yaml_file(const std::string& path);

// apply "a.b.c=value" to a YAML tree (value parsed as YAML, so lists work: "[1, 2, 3]").
// Keys inside lists are addressed by index: "controllers.0.kp=300". An empty name ("a..b", ".a",
// "a."), an index into a list the document lacks, a value whose '[' or '{' does not close, and
// bytes that are not UTF-8 are InputErrors naming the assignment.
void apply_yaml_override(YAML::Node& root, const std::string& assignment);

}  // namespace stance
