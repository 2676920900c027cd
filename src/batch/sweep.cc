#include "batch/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "batch/batch_ranks.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "params/yaml_params.h"
#include "sim/scenario.h"

namespace stance {

namespace {
// metrics that measure the machine, not the run: left out of sweep.csv
bool is_timing_metric(const std::string& key) {
  return is_wall_clock_metric(key);
}

std::string csv_cell(const nlohmann::json& v) {
  if (v.is_null()) return "";
  if (v.is_boolean()) return v.get<bool>() ? "1" : "0";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number()) return fmt::format("{:.9g}", v.get<double>());
  if (v.is_string()) {
    std::string s = v.get<std::string>();
    std::replace(s.begin(), s.end(), ',', ';');
    return s;
  }
  return "";
}

bool is_scalar(const nlohmann::json& v) {
  return !v.is_array() && !v.is_object();
}

// a scenario read once, then cloned and overridden per value (yaml-cpp nodes are not shared
// across threads)
LoadedScenario scenario_for_value(const SweepOptions& o, const YAML::Node& doc, double value) {
  YAML::Node copy = YAML::Clone(doc);
  for (const auto& s : o.sets) apply_yaml_override(copy, s);
  apply_yaml_override(copy, o.param + "=" + format_sweep_value(value));
  std::string base = std::filesystem::path(o.scenario).parent_path().string();
  LoadedScenario loaded = parse_scenario(copy, o.scenario, base);
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(o.scenario).stem().string();
  return loaded;
}
}  // namespace

std::vector<double> linspace(double from, double to, int steps) {
  if (steps < 1) throw InputError(fmt::format("--steps: expected at least 1, found {}", steps));
  if (!std::isfinite(from) || !std::isfinite(to))
    throw InputError("--from/--to: expected finite numbers");
  std::vector<double> out(steps);
  for (int i = 0; i < steps; ++i)
    out[i] = steps == 1 ? from : from + (to - from) * static_cast<double>(i) / (steps - 1);
  if (steps > 1) out.back() = to;
  return out;
}

std::vector<double> parse_value_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, ',');) {
    try {
      size_t used = 0;
      double v = std::stod(part, &used);
      while (used < part.size() && std::isspace(static_cast<unsigned char>(part[used]))) ++used;
      if (used != part.size() || !std::isfinite(v)) throw std::invalid_argument("");
      out.push_back(v);
    } catch (const std::exception&) {
      throw InputError(fmt::format("--values '{}': '{}' is not a finite number", text, part));
    }
  }
  if (out.empty()) throw InputError(fmt::format("--values '{}': no values", text));
  return out;
}

std::string format_sweep_value(double value) {
  // fmt's default is the shortest text that reads back to the same double ("10", "2.25")
  return fmt::format("{}", value);
}

RunResult run_without_timing(const LoadedScenario& loaded, const RunOptions& options) {
  RunResult r = Simulation(loaded, options).run();
  r.wall_time_s = 0;
  return r;
}

nlohmann::json sweep_point_to_json(const SweepPoint& p) {
  return {{"value", p.value}, {"error", p.error}, {"result", p.result.to_json()}};
}

SweepPoint sweep_point_from_json(const nlohmann::json& j) {
  SweepPoint p;
  p.value = j.at("value").get<double>();
  p.error = j.at("error").get<std::string>();
  p.result = RunResult::from_json(j.at("result"));
  p.done = true;
  return p;
}

std::vector<SweepPoint> run_sweep(
    const SweepOptions& o,
    const std::function<void(const SweepPoint&, int index, int done, int total)>& on_done,
    const std::map<int, SweepPoint>& finished) {
  if (o.param.empty()) throw InputError("sweep: no parameter given (--param key.path)");
  if (o.values.empty()) throw InputError("sweep: no values to sweep");
  const YAML::Node doc = load_yaml_file(o.scenario);
  const int n = static_cast<int>(o.values.size());

  // every run's scenario, parsed up front: bad keys and values fail here, on this thread
  std::vector<LoadedScenario> scenarios;
  scenarios.reserve(n);
  for (double v : o.values) scenarios.push_back(scenario_for_value(o, doc, v));
  RunOptions run_options;
  run_options.engine = o.engine;
  run_options.duration = o.duration;
  run_options.quiet = true;
  // points that change neither the world nor a controller's parameters (a push force, the
  // fall criterion) share the controllers' models: an LQR is designed once
  ControllerCache cache;
  if (o.share_models) run_options.cache = &cache;
  {
    // the first run's engine and controllers build here too, so their errors are clean
    Simulation probe(scenarios[0], run_options);
  }

  std::vector<SweepPoint> points(n);
  std::mutex done_mutex;
  int done = 0;
  for (const auto& [i, p] : finished) {
    if (i < 0 || i >= n || p.value != o.values[i])
      throw InputError(fmt::format("--resume: point {} is not in this sweep", i));
    points[i] = p;
    points[i].done = true;
    ++done;
  }
  run_options.interrupt = o.interrupt;
  BatchRanks& ranks = BatchRanks::get();
  ranks.distributed_for(
      n, o.threads,
      [&](int i) {
        SweepPoint& pt = points[i];
        if (pt.done || (o.interrupt && o.interrupt->load())) return;
        pt.value = o.values[i];
        try {
          pt.result = run_without_timing(scenarios[i], run_options);
        } catch (const InputError& e) {
          // a value this point's run rejects; anything else is a bug and ends the sweep
          pt.error = e.what();
        }
        pt.done = !pt.result.interrupted;
        if (!pt.done || !ranks.root()) return;
        std::lock_guard<std::mutex> lock(done_mutex);
        ++done;
        if (on_done) on_done(pt, i, done, n);
      },
      [&](int i) { return points[i].done ? sweep_point_to_json(points[i]).dump() : std::string(); },
      [&](int i, const std::string& text) {
        if (text.empty() || points[i].done) return;
        points[i] = sweep_point_from_json(nlohmann::json::parse(text));
        ++done;
        if (on_done) on_done(points[i], i, done, n);
      });
  return points;
}

std::vector<std::string> sweep_list_metrics(const std::vector<SweepPoint>& points) {
  std::set<std::string> keys;
  for (const auto& p : points)
    for (auto it = p.result.metrics.begin(); it != p.result.metrics.end(); ++it)
      if (it.value().is_array()) keys.insert(it.key());
  return {keys.begin(), keys.end()};
}

void write_sweep_outputs(const std::string& dir, const std::string& param,
                         const std::vector<SweepPoint>& points) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", dir, ec.message()));
  std::set<std::string> scalar_keys;
  for (const auto& p : points)
    for (auto it = p.result.metrics.begin(); it != p.result.metrics.end(); ++it)
      if (is_scalar(it.value()) && !is_timing_metric(it.key())) scalar_keys.insert(it.key());

  AtomicFile table_file(std::filesystem::path(dir) / "sweep.csv");
  AtomicFile points_file(std::filesystem::path(dir) / "points.csv");
  std::ostream& table = table_file.stream();
  table << param << ",fell,diverged,sim_time,error";
  for (const auto& k : scalar_keys) table << ',' << k;
  table << '\n';
  for (const auto& p : points) {
    std::string error = p.error;
    std::replace(error.begin(), error.end(), ',', ';');
    std::replace(error.begin(), error.end(), '\n', ' ');
    table << format_sweep_value(p.value) << ',' << (p.result.fell ? 1 : 0) << ','
          << (p.result.diverged ? 1 : 0) << ',' << fmt::format("{:.6f}", p.result.sim_time) << ','
          << error;
    for (const auto& k : scalar_keys) {
      table << ',';
      if (p.result.metrics.contains(k)) table << csv_cell(p.result.metrics[k]);
    }
    table << '\n';
  }

  std::ostream& pts = points_file.stream();
  pts << param << ",metric,index,y\n";
  for (const auto& p : points)
    for (auto it = p.result.metrics.begin(); it != p.result.metrics.end(); ++it) {
      if (!it.value().is_array()) continue;
      const auto& arr = it.value();
      for (size_t i = 0; i < arr.size(); ++i)
        if (arr[i].is_number())
          pts << format_sweep_value(p.value) << ',' << it.key() << ',' << i << ','
              << fmt::format("{:.9g}", arr[i].get<double>()) << '\n';
    }
  table_file.commit();
  points_file.commit();
}

std::string plot_sweep(const std::string& dir, const std::string& param, const std::string& metric,
                       const std::string& title, const std::string& png_name) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0)
    throw InputError("--plot: gnuplot not found on PATH (Debian: apt-get install gnuplot-nox)");
  namespace fs = std::filesystem;
  const fs::path folder = fs::absolute(dir);
  {
    // gnuplot fails obscurely on an empty plot: say why here
    std::ifstream in(folder / "points.csv");
    std::string line, tag = "," + metric + ",";
    bool any = false;
    while (!any && std::getline(in, line)) any = line.find(tag) != std::string::npos;
    if (!any)
      throw InputError(fmt::format("--plot: no values of '{}' in {} (runs too short?)", metric,
                                   (folder / "points.csv").string()));
  }
  // one dot per post-transient value: the passive-walker bifurcation picture
  std::string script = fmt::format(
      "set terminal pngcairo size 1000,650 enhanced font 'sans,11'\n"
      "set output png\n"
      "set datafile separator ','\n"
      "set title \"{}\" noenhanced\n"
      "set xlabel \"{}\" noenhanced\n"
      "set ylabel \"{}\" noenhanced\n"
      "set grid\n"
      "unset key\n"
      "plot 'points.csv' every ::1 using 1:(strcol(2) eq \"{}\" ? $4 : NaN) with points pt 7 "
      "ps 0.4 lc rgb '#1f4e9c'\n",
      title, param, metric, metric);
  return render_gnuplot(folder.string(), fs::path(png_name).stem().string() + ".gp", script,
                        png_name);
}

std::string render_gnuplot(const std::string& dir, const std::string& script_name,
                           const std::string& script, const std::string& png_name) {
  namespace fs = std::filesystem;
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0)
    throw InputError("gnuplot not found on PATH (Debian: apt-get install gnuplot-nox)");
  const fs::path folder = fs::absolute(dir);
  // run by hand, the script writes the PNG itself
  write_file_atomically(folder / script_name,
                        fmt::format("if (!exists('png')) png = '{}'\n", png_name) + script);
  const fs::path png_tmp = temporary_path_for(folder / png_name);
  const std::string cmd =
      fmt::format("cd '{}' && gnuplot -e \"png='{}'\" '{}' 2>'{}'", folder.string(),
                  png_tmp.string(), script_name, (folder / "gnuplot.err").string());
  std::error_code ec;
  if (std::system(cmd.c_str()) != 0) {
    fs::remove(png_tmp, ec);
    std::ifstream err(folder / "gnuplot.err");
    std::string first;
    std::getline(err, first);
    throw InputError(
        fmt::format("gnuplot failed on {}: {}", (folder / script_name).string(), first));
  }
  fs::remove(folder / "gnuplot.err", ec);
  rename_into_place(png_tmp, folder / png_name);
  return (folder / png_name).string();
}

}  // namespace stance
