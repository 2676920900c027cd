// The arguments of stance tune (--param, --neighbour, --metric) and the scores of its runs.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "batch/sweep.h"
#include "batch/tune.h"
#include "batch/tune_detail.h"
#include "core/error.h"
#include "params/yaml_params.h"

namespace stance {

namespace tune_detail {

std::string trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  return s.substr(a, b - a);
}

// a whole finite number, or nothing
std::optional<double> to_number(const std::string& text) {
  std::string t = trim(text);
  if (t.empty()) return std::nullopt;
  try {
    size_t used = 0;
    double v = std::stod(t, &used);
    if (used != t.size() || !std::isfinite(v)) return std::nullopt;
    return v;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

std::vector<std::string> split_path(const std::string& key) {
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string part; std::getline(ss, part, '.');) parts.push_back(part);
  return parts;
}

std::string param_text(const TuneParam& p) {
  return fmt::format("{}={}:{}{}", p.key, format_sweep_value(p.lo), format_sweep_value(p.hi),
                     p.log ? ":log" : "");
}

}  // namespace tune_detail

using namespace tune_detail;

TuneParam parse_tune_param(const std::string& text) {
  auto bad = [&](const std::string& why) {
    return InputError(fmt::format("--param '{}': {}", text, why));
  };
  size_t eq = text.find('=');
  if (eq == std::string::npos) throw bad("expected key=lo:hi or key=lo:hi:log");
  TuneParam p;
  p.key = trim(text.substr(0, eq));
  if (p.key.empty()) throw bad("no key path before '='");
  std::vector<std::string> parts;
  std::stringstream ss(text.substr(eq + 1));
  for (std::string part; std::getline(ss, part, ':');) parts.push_back(trim(part));
  if (parts.size() < 2 || parts.size() > 3) throw bad("expected key=lo:hi or key=lo:hi:log");
  auto lo = to_number(parts[0]), hi = to_number(parts[1]);
  if (!lo) throw bad(fmt::format("lower bound '{}' is not a finite number", parts[0]));
  if (!hi) throw bad(fmt::format("upper bound '{}' is not a finite number", parts[1]));
  if (parts.size() == 3) {
    if (parts[2] != "log") throw bad(fmt::format("'{}': the only flag is 'log'", parts[2]));
    p.log = true;
  }
  p.lo = *lo;
  p.hi = *hi;
  if (!(p.lo < p.hi)) throw bad("the lower bound must be below the upper bound");
  if (p.log && p.lo <= 0) throw bad("a log range needs a positive lower bound");
  return p;
}

Neighbour parse_neighbour(const std::string& text) {
  auto bad = [&](const std::string& why) {
    return InputError(fmt::format("--neighbour '{}': {}", text, why));
  };
  Neighbour n;
  n.text = text;
  // split on commas outside brackets, so that "gravity=[0, 0, -9]" stays whole
  std::vector<std::string> items;
  std::string cur;
  int depth = 0;
  for (char ch : text) {
    if (ch == '[' || ch == '{') ++depth;
    if (ch == ']' || ch == '}') --depth;
    if (ch == ',' && depth == 0) {
      items.push_back(cur);
      cur.clear();
    } else {
      cur += ch;
    }
  }
  items.push_back(cur);
  for (const std::string& raw : items) {
    std::string item = trim(raw);
    if (item.empty()) throw bad("empty override (expected key*=factor or key=value)");
    NeighbourOverride ov;
    size_t mul = item.find("*=");
    size_t eq = item.find('=');
    if (mul != std::string::npos && mul < eq) {
      ov.key = trim(item.substr(0, mul));
      ov.multiply = true;
      auto f = to_number(item.substr(mul + 2));
      if (!f)
        throw bad(fmt::format("'{}': the factor '{}' is not a finite number", item,
                              trim(item.substr(mul + 2))));
      ov.factor = *f;
    } else if (eq != std::string::npos) {
      ov.key = trim(item.substr(0, eq));
      ov.value = trim(item.substr(eq + 1));
      if (ov.value.empty()) throw bad(fmt::format("'{}': no value after '='", item));
    } else {
      throw bad(fmt::format("'{}': expected key*=factor or key=value", item));
    }
    if (ov.key.empty()) throw bad(fmt::format("'{}': no key path", item));
    n.overrides.push_back(ov);
  }
  return n;
}

std::optional<double> yaml_number_at(const YAML::Node& root, const std::string& key) {
  // const nodes: lookups must not insert missing keys
  const YAML::Node top = root;
  std::vector<YAML::Node> chain{top};
  for (const std::string& part : split_path(key)) {
    const YAML::Node cur = chain.back();
    if (cur.IsSequence()) {
      char* end = nullptr;
      long idx = std::strtol(part.c_str(), &end, 10);
      if (part.empty() || *end || idx < 0 || idx >= static_cast<long>(cur.size()))
        return std::nullopt;
      chain.push_back(cur[idx]);
    } else if (cur.IsMap()) {
      const YAML::Node next = cur[part];
      if (!next) return std::nullopt;
      chain.push_back(next);
    } else {
      return std::nullopt;
    }
  }
  const YAML::Node leaf = chain.back();
  if (!leaf.IsScalar()) return std::nullopt;
  return to_number(leaf.Scalar());
}

void apply_neighbour(YAML::Node& root, const Neighbour& n) {
  for (const auto& ov : n.overrides) {
    try {
      if (ov.multiply) {
        std::optional<double> v = yaml_number_at(root, ov.key);
        if (!v) throw InputError(fmt::format("{}: no number to multiply", ov.key));
        apply_yaml_override(root, ov.key + "=" + format_sweep_value(*v * ov.factor));
      } else {
        apply_yaml_override(root, ov.key + "=" + ov.value);
      }
    } catch (const InputError& e) {
      throw InputError(fmt::format("--neighbour '{}': {}", n.text, e.what()));
    }
  }
}

std::optional<double> metric_at(const nlohmann::json& metrics, const std::string& path) {
  // a weighted sum: "a.b+2.5*c.d"
  if (path.find('+') != std::string::npos) {
    double sum = 0;
    size_t start = 0;
    while (start <= path.size()) {
      size_t end = path.find('+', start);
      if (end == std::string::npos) end = path.size();
      std::optional<double> term = metric_at(metrics, path.substr(start, end - start));
      if (!term) return std::nullopt;
      sum += *term;
      start = end + 1;
    }
    return sum;
  }
  if (size_t star = path.find('*'); star != std::string::npos) {
    double weight = 0;
    try {
      size_t used = 0;
      weight = std::stod(path.substr(0, star), &used);
      if (used != star) return std::nullopt;
    } catch (const std::exception&) {
      return std::nullopt;
    }
    std::optional<double> value = metric_at(metrics, path.substr(star + 1));
    if (!value) return std::nullopt;
    return weight * *value;
  }
  // a one-sided penalty: below(m,c) = max(0, c - m), above(m,c) = max(0, m - c)
  for (const char* side : {"below(", "above("}) {
    const std::string open = side;
    if (path.rfind(open, 0) != 0 || path.back() != ')') continue;
    const size_t comma = path.rfind(',');
    if (comma == std::string::npos || comma < open.size()) return std::nullopt;
    double bound = 0;
    try {
      size_t used = 0;
      const std::string text = path.substr(comma + 1, path.size() - comma - 2);
      bound = std::stod(text, &used);
      if (used != text.size()) return std::nullopt;
    } catch (const std::exception&) {
      return std::nullopt;
    }
    std::optional<double> value = metric_at(metrics, path.substr(open.size(), comma - open.size()));
    if (!value) return std::nullopt;
    return std::max(0.0, open == "below(" ? bound - *value : *value - bound);
  }
  const nlohmann::json* j = &metrics;
  if (metrics.is_object() && metrics.contains(path)) {
    j = &metrics[path];
  } else {
    for (const std::string& part : split_path(path)) {
      if (!j->is_object() || !j->contains(part)) return std::nullopt;
      j = &(*j)[part];
    }
  }
  if (!j->is_number()) return std::nullopt;
  return j->get<double>();
}

TuneRun score_run(const RunResult& r, double duration, const std::string& metric,
                  double fall_penalty) {
  TuneRun t;
  t.fell = r.fell;
  t.diverged = r.diverged;
  if (r.diverged) {
    t.error = "diverged: " + r.divergence;
    t.time_up = 0;
  } else if (r.fell && r.fall_time) {
    t.time_up = std::clamp(*r.fall_time, 0.0, duration);
  } else {
    t.time_up = duration;
  }
  if (!metric.empty() && !r.diverged) {
    t.metric = metric_at(r.metrics, metric);
    if (!t.metric || !std::isfinite(*t.metric)) {
      t.error = fmt::format("metric '{}' missing or not a finite number", metric);
      t.metric.reset();
      t.time_up = 0;
    }
  }
  t.score = fall_penalty * (duration - t.time_up) + t.metric.value_or(0.0);
  return t;
}

TuneRun failed_run(const std::string& error, double duration, double fall_penalty) {
  TuneRun t;
  t.error = error.empty() ? "failed" : error;
  t.time_up = 0;
  t.score = fall_penalty * duration;
  return t;
}

void aggregate_runs(TuneCandidate& c) {
  c.robust_score = -std::numeric_limits<double>::infinity();
  c.worst_time_up = std::numeric_limits<double>::infinity();
  c.failed_runs = 0;
  double sum = 0;
  int n = 0;
  for (const auto& r : c.runs) {
    c.robust_score = std::max(c.robust_score, r.score);
    c.worst_time_up = std::min(c.worst_time_up, r.time_up);
    if (!r.error.empty()) ++c.failed_runs;
    if (r.metric) {
      sum += *r.metric;
      ++n;
    }
  }
  if (c.runs.empty()) c.robust_score = c.worst_time_up = 0;
  c.mean_metric = n > 0 ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace stance
