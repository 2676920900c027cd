#include "sim/expectation.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"
#include "sim/simulation.h"

namespace stance {

namespace {
// the YAML entry of bound i (its `name` when there is one), for the line of a message
YAML::Node bound_node(const YAML::Node& expect_node, size_t i, bool name) {
  if (!expect_node || !expect_node.IsMap()) return {};
  const YAML::Node list = expect_node["metrics"];
  if (!list || !list.IsSequence() || i >= list.size()) return {};
  const YAML::Node entry = list[i];
  return name && entry.IsMap() && entry["name"] ? entry["name"] : entry;
}

[[noreturn]] void fail_at(const std::string& source, const YAML::Node& at,
                          const std::string& message) {
  const int line = at && at.Mark().line >= 0 ? at.Mark().line + 1 : 0;
  throw InputError(located(source, line, line > 0 ? message : "(from --set) " + message));
}

// the value at a dotted path ("mocap.mean_root_error_m"); null when there is none
const nlohmann::json* metric_at_path(const nlohmann::json& metrics, const std::string& path) {
  const nlohmann::json* j = &metrics;
  size_t start = 0;
  while (true) {
    const size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? dot : dot - start);
    if (!j->is_object() || !j->contains(key)) return nullptr;
    j = &(*j)[key];
    if (dot == std::string::npos) return j;
    start = dot + 1;
  }
}

// every leaf path of the metrics, for "did you mean"
void leaf_paths(const nlohmann::json& j, const std::string& prefix, std::vector<std::string>& out) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string path = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it.value().is_object())
      leaf_paths(it.value(), path, out);
    else
      out.push_back(path);
  }
}

bool wall_clock_path(const std::string& path) {
  size_t start = 0;
  for (size_t dot = path.find('.');; dot = path.find('.', start)) {
    if (is_wall_clock_metric(path.substr(start, dot == std::string::npos ? dot : dot - start)))
      return true;
    if (dot == std::string::npos) return false;
    start = dot + 1;
  }
}

std::string number(double x) {
  return fmt::format("{:.4g}", x);
}

nlohmann::json bound_check(const MetricBound& b, const nlohmann::json& metrics) {
  nlohmann::json c;
  c["check"] = "metrics." + b.name;
  if (std::isfinite(b.min)) c["min"] = b.min;
  if (std::isfinite(b.max)) c["max"] = b.max;
  const nlohmann::json* found = metric_at_path(metrics, b.name);
  const bool is_number = found && (found->is_number() || found->is_boolean());
  c["found"] = found ? *found : nlohmann::json(nullptr);
  // true and false count as 1 and 0 (mocap.success)
  const double x = !is_number            ? 0.0
                   : found->is_boolean() ? double(found->get<bool>())
                                         : found->get<double>();
  c["held"] = is_number && std::isfinite(x) && x >= b.min && x <= b.max;
  return c;
}

nlohmann::json flag_check(const char* what, bool expected, bool found) {
  return {{"check", what}, {"expected", expected}, {"found", found}, {"held", expected == found}};
}

std::string describe_check(const nlohmann::json& c) {
  const std::string what = c.at("check").get<std::string>();
  const bool held = c.at("held").get<bool>();
  if (what == "fell") {
    const bool fell = c.at("found").get<bool>();
    return fell == c.at("expected").get<bool>()
               ? (fell ? "fell" : "no fall")
               : (fell ? "fell (expected no fall)" : "no fall (expected a fall)");
  }
  if (what == "diverged" || what == "interrupted") return what;
  const std::string name = what.substr(std::string("metrics.").size());
  const nlohmann::json& found = c.at("found");
  const std::string value =
      found.is_number() && !found.is_boolean() ? number(found.get<double>()) : found.dump();
  std::string range;
  if (c.contains("min") && c.contains("max"))
    range =
        fmt::format("in [{}, {}]", number(c["min"].get<double>()), number(c["max"].get<double>()));
  else if (c.contains("min"))
    range = ">= " + number(c["min"].get<double>());
  else
    range = "<= " + number(c["max"].get<double>());
  return fmt::format("{} {} {}{}", name, value, held ? "" : "not ", range);
}
}  // namespace

void check_expectation(const Expectation& e, const std::string& source,
                       const YAML::Node& expect_node) {
  for (size_t i = 0; i < e.metrics.size(); ++i) {
    const MetricBound& b = e.metrics[i];
    const std::string where = fmt::format("expect.metrics[{}]", i);
    if (b.name.empty())
      fail_at(source, bound_node(expect_node, i, false), where + ": needs a 'name' (a metric)");
    if (!std::isfinite(b.min) && !std::isfinite(b.max))
      fail_at(source, bound_node(expect_node, i, false),
              fmt::format("{} ('{}'): needs a 'min' or a 'max'", where, b.name));
    if (b.min > b.max)
      fail_at(source, bound_node(expect_node, i, false),
              fmt::format("{} ('{}'): min {} is above max {}", where, b.name, b.min, b.max));
  }
}

void check_expectation_metrics(const Expectation& e, const nlohmann::json& metrics,
                               const std::string& source, const YAML::Node& expect_node) {
  std::vector<std::string> known;
  leaf_paths(metrics, "", known);
  for (size_t i = 0; i < e.metrics.size(); ++i) {
    const std::string& name = e.metrics[i].name;
    const YAML::Node at = bound_node(expect_node, i, true);
    const std::string where = fmt::format("expect.metrics[{}].name", i);
    if (wall_clock_path(name))
      fail_at(source, at,
              fmt::format("{}: '{}' is measured on the wall clock: an expectation cannot depend on "
                          "the machine's speed",
                          where, name));
    const nlohmann::json* found = metric_at_path(metrics, name);
    if (!found)
      fail_at(source, at,
              fmt::format("{}: unknown metric '{}'{}", where, name, did_you_mean(name, known)));
    if (found->is_object())
      fail_at(source, at,
              fmt::format("{}: '{}' is a group of metrics: name one in it (e.g. '{}.{}')", where,
                          name, name, found->empty() ? "?" : found->begin().key()));
    if (!found->is_number() && !found->is_boolean() && !found->is_null())
      fail_at(source, at, fmt::format("{}: '{}' is not a number ({})", where, name, found->dump()));
  }
}

nlohmann::json evaluate_expectation(const Expectation& e, const nlohmann::json& run_summary) {
  nlohmann::json checks = nlohmann::json::array();
  checks.push_back(flag_check("fell", e.fell, run_summary.value("fell", false)));
  checks.push_back(flag_check("diverged", false, run_summary.value("diverged", false)));
  if (run_summary.value("interrupted", false))
    checks.push_back(flag_check("interrupted", false, true));
  const nlohmann::json metrics = run_summary.value("metrics", nlohmann::json::object());
  for (const MetricBound& b : e.metrics) checks.push_back(bound_check(b, metrics));
  bool held = true;
  for (const auto& c : checks) held = held && c.at("held").get<bool>();
  return {{"held", held}, {"sim_time", run_summary.value("sim_time", 0.0)}, {"checks", checks}};
}

std::string expectation_line(const nlohmann::json& verdict) {
  std::string parts;
  for (const auto& c : verdict.at("checks")) {
    // a run that neither diverged nor was stopped says nothing about them
    const std::string what = c.at("check").get<std::string>();
    if ((what == "diverged" || what == "interrupted") && c.at("held").get<bool>()) continue;
    parts += (parts.empty() ? "" : "; ") + describe_check(c);
  }
  return fmt::format("expectation {} at {:.3f} s: {}",
                     verdict.at("held").get<bool>() ? "held" : "NOT held",
                     verdict.at("sim_time").get<double>(), parts);
}

}  // namespace stance
