#include "app/track_batch.h"

#include <fmt/format.h>
#include <glob.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "app/guarded.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "params/option_check.h"
#include "scenario/batch_ranks.h"
#include "scenario/planner_params.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "scenario/sweep.h"

namespace stance {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kBatchFile = "track_batch.json";
// the strip's finest bin, doubled until a clip has at most this many
constexpr double kStripBinS = 0.1;
constexpr int kStripMaxBins = 256;

// ---- finding the clips

bool has_glob_chars(const std::string& s) {
  return s.find_first_of("*?[") != std::string::npos;
}

std::string lowercase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// a path's identity for "named twice": canonical where it exists
std::string path_key(const fs::path& p) {
  std::error_code ec;
  fs::path k = fs::weakly_canonical(p, ec);
  if (ec) k = fs::absolute(p).lexically_normal();
  return k.string();
}

// the clips list being built: each file once, each name once
class ClipList {
 public:
  void add(const fs::path& file, std::string name) {
    if (!files_.insert(path_key(file)).second) return;
    if (name.empty()) name = "clip";
    std::string unique = name;
    for (int k = 2; names_.count(unique); ++k) unique = fmt::format("{}_{}", name, k);
    names_.insert(unique);
    clips_.push_back({file.string(), unique});
  }
  std::vector<TrackClip> take() { return std::move(clips_); }

 private:
  std::set<std::string> files_, names_;
  std::vector<TrackClip> clips_;
};

// a folder's .bvh files at any depth, sorted, named by their path under it; hidden names and the
// folder `skip` (the batch's own output) are left out
void add_folder(const fs::path& folder, const std::string& skip_key, ClipList& list) {
  std::vector<fs::path> found;
  std::error_code ec;
  auto fail = [&](const std::error_code& e) {
    throw InputError(fmt::format("{}: cannot read the folder ({})", folder.string(), e.message()));
  };
  fs::recursive_directory_iterator it(folder, ec), end;
  if (ec) fail(ec);
  for (; it != end; it.increment(ec)) {
    if (ec) fail(ec);
    const fs::path& p = it->path();
    const bool is_dir = it->is_directory(ec);
    const std::string leaf = p.filename().string();
    if ((!leaf.empty() && leaf[0] == '.') || (is_dir && path_key(p) == skip_key)) {
      if (is_dir) it.disable_recursion_pending();
      continue;
    }
    if (!is_dir && it->is_regular_file(ec) && lowercase(p.extension().string()) == ".bvh")
      found.push_back(p);
  }
  if (ec) fail(ec);
  if (found.empty())
    throw InputError(fmt::format("{}: no .bvh file in this folder or below it", folder.string()));
  std::sort(found.begin(), found.end());
  for (const fs::path& p : found)
    list.add(p, p.lexically_relative(folder).replace_extension().generic_string());
}

void add_input(const fs::path& input, const std::string& skip_key, ClipList& list) {
  std::error_code ec;
  if (fs::is_directory(input, ec))
    add_folder(input, skip_key, list);
  else
    list.add(input, input.stem().string());
}

// ---- a clip's row

double number_at(const nlohmann::json& o, const char* key) {
  return o.is_object() && o.contains(key) && o[key].is_number() ? o[key].get<double>() : kNaN;
}

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
  return cells;
}

// log.csv's mocap_root_error_m as the mean over each bin of time
void read_root_error_strip(const fs::path& log, TrackRow& row) {
  std::ifstream in(log);
  std::string line;
  if (!std::getline(in, line)) return;
  const std::vector<std::string> header = split_csv_line(line);
  const auto column = [&](const char* name) {
    return static_cast<int>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const int time_col = column("time"), error_col = column("mocap_root_error_m");
  const int width = static_cast<int>(header.size());
  if (time_col >= width || error_col >= width) return;
  std::vector<std::pair<double, double>> samples;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = split_csv_line(line);
    if (static_cast<int>(cells.size()) < width) continue;
    samples.emplace_back(std::strtod(cells[time_col].c_str(), nullptr),
                         std::strtod(cells[error_col].c_str(), nullptr));
  }
  if (samples.empty()) return;
  double bin = kStripBinS;
  while (samples.back().first / bin > kStripMaxBins) bin *= 2;
  // the last sample, at the run's end, closes the last bin
  const int bins = std::max(1, static_cast<int>(std::ceil(samples.back().first / bin - 1e-9)));
  std::vector<double> sum(bins, 0.0);
  std::vector<int> count(bins, 0);
  for (const auto& [t, e] : samples) {
    const int k = std::clamp(static_cast<int>(std::floor(t / bin + 1e-9)), 0, bins - 1);
    if (!std::isfinite(e)) continue;
    sum[k] += e;
    ++count[k];
  }
  row.strip_bin_s = bin;
  row.strip.resize(bins);
  for (int k = 0; k < bins; ++k) row.strip[k] = count[k] ? sum[k] / count[k] : kNaN;
}

nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

double number_from(const nlohmann::json& v) {
  return v.is_number() ? v.get<double>() : kNaN;
}

// ---- the batch's options, checked on --resume

nlohmann::json batch_fingerprint(const BvhTrackBatchCommand& cmd,
                                 const std::vector<TrackClip>& clips) {
  const BvhTrackCommand& t = cmd.track;
  nlohmann::json list = nlohmann::json::array();
  for (const TrackClip& c : clips)
    list.push_back({{"name", c.name}, {"path", fs::absolute(c.path).lexically_normal().string()}});
  const auto file = [](const std::string& p) {
    return p.empty() || p.find("://") != std::string::npos ? p : fs::absolute(p).string();
  };
  nlohmann::json options = {
      {"clips", list},
      {"duration", t.duration ? nlohmann::json(*t.duration) : nlohmann::json(nullptr)},
      {"loop", t.loop},
      {"first_frame", t.first_frame},
      {"last_frame", t.last_frame},
      {"map", file(t.map)},
      {"model", file(t.model)},
      {"engine", t.engine},
      {"sets", t.sets},
      {"origin_centred", t.origin_centred},
      {"scale_to_meters", t.scale_to_meters}};
  // as it reads back from the file (a name that is not UTF-8 is written with U+FFFD)
  return nlohmann::json::parse(
      options.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

std::string dump_json(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

void check_resume(const fs::path& out, const nlohmann::json& now) {
  const fs::path file = out / kBatchFile;
  std::ifstream in(file);
  if (!in)
    throw InputError(
        fmt::format("--resume: {} has no {} (no batch to resume there)", out.string(), kBatchFile));
  nlohmann::json saved;
  try {
    saved = nlohmann::json::parse(in).at("options");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not a batch file of stance ({})", file.string(), e.what()));
  }
  for (auto it = now.begin(); it != now.end(); ++it) {
    const nlohmann::json was = saved.contains(it.key()) ? saved[it.key()] : nlohmann::json();
    if (was == it.value()) continue;
    if (it.key() == "clips")
      throw InputError(fmt::format(
          "--resume {}: the clips differ from the interrupted batch's ({} then, {} now)",
          out.string(), was.is_array() ? was.size() : 0, it.value().size()));
    throw InputError(fmt::format("--resume {}: option '{}' was {} in the interrupted batch, now {}",
                                 out.string(), it.key(), dump_json(was), dump_json(it.value())));
  }
}

// the options every clip shares, checked once before any clip runs
void check_batch_options(const BvhTrackBatchCommand& cmd) {
  const BvhTrackCommand& t = cmd.track;
  if (!cmd.record.empty())
    throw InputError("--record: renders one clip; track that clip alone to record it");
  if (cmd.view) throw InputError("--view: shows one clip; track that clip alone to watch it");
  if (t.out_dir.empty()) throw InputError("--out: give an output folder");
  if (cmd.resume && !is_track_batch(cmd.inputs))
    throw InputError(
        "--resume: finishes a batch (several clips, a folder or a glob); one clip "
        "alone has nothing to resume");
  if (!t.map.empty() && t.model.empty())
    throw InputError("bvh track: --map needs --model (the model it maps the clips onto)");
  check_option_number("--duration", t.duration, param_meta<Scenario>("duration"));
  if (t.duration && !(*t.duration > 0))
    throw InputError("--duration: expected a positive number of seconds");
  check_option_number("--threads", t.threads, param_meta<PlannerParams>("threads"));
  check_option_number("--jobs", cmd.jobs, {.min = 0, .max = 1024});
}

// one clip tracked as `stance bvh track CLIP --out DIR` would (planner_threads: the rollout
// threads of its planner, which do not change its result)
TrackRow track_one_clip(const BvhTrackBatchCommand& cmd, const TrackClip& clip, int planner_threads,
                        const std::atomic<bool>* interrupt) {
  BvhTrackCommand c = cmd.track;
  c.bvh = clip.path;
  c.out_dir = (fs::path(cmd.track.out_dir) / clip.name).string();
  c.quiet = true;
  TrackRow row;
  row.clip = clip.name;
  try {
    std::error_code ec;
    fs::remove(fs::path(c.out_dir) / "summary.json", ec);  // only this run's counts as finished
    const std::string scenario = write_bvh_track_scenario(c);
    RunCommand run = bvh_track_run(c, scenario);
    run.sets.push_back(fmt::format("planner.threads={}", planner_threads));
    LoadedScenario loaded = load_scenario(run.scenario, run.sets);
    if (loaded.scenario.name.empty()) loaded.scenario.name = fs::path(scenario).stem().string();
    RunOptions opt;
    opt.engine = run.engine;
    opt.out_dir = run.out_dir;
    opt.quiet = true;
    opt.interrupt = interrupt;
    opt.check_expect_names = true;
    if (Simulation(loaded, opt).run().interrupted) return row;
    // the row as it reads back from the folder, as a resumed batch reads it
    row = read_track_row(clip.name, c.out_dir);
    if (!row.done) row.error = "the run wrote no summary.json", row.done = true;
  } catch (const InputError& e) {
    row.error = e.what();
    row.done = true;
  } catch (const EnvironmentError& e) {
    row.error = e.what();
    row.done = true;
  } catch (const std::exception& e) {
    row.error = fmt::format("internal error: {} (a bug in stance; please report it)", e.what());
    row.internal_error = true;
    row.done = true;
  }
  return row;
}

// ---- the tables

std::string csv_field(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  if (s.find_first_of(",\"") == std::string::npos) return s;
  std::string quoted = "\"";
  for (char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string csv_number(double v) {
  return std::isfinite(v) ? fmt::format("{:.9g}", v) : "";
}

std::string md_text(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::string out;
  for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string md_number(double v, int digits) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, digits) : "-";
}

std::string clip_count(size_t n) {
  return fmt::format("{} clip{}", n, n == 1 ? "" : "s");
}

std::string yes_no(bool b) {
  return b ? "yes" : "no";
}

double percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return kNaN;
  const double h = (sorted.size() - 1) * p;
  const size_t lo = static_cast<size_t>(std::floor(h));
  const size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (h - lo) * (sorted[hi] - sorted[lo]);
}

// ---- the plot

// a bin width for n values up to `top`: 1, 2 or 5 times a power of ten, about 20 bins
double nice_bin(double top) {
  const double raw = std::max(top, 1e-3) / 20;
  const double decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * decade >= raw) return m * decade;
  return 10 * decade;
}

std::string gnuplot_text(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out;
}

// every strip on one time grid: the widest clip bin, doubled while there are too many columns
std::vector<std::vector<double>> common_strips(const std::vector<const TrackRow*>& rows,
                                               double& bin) {
  bin = kStripBinS;
  double end = 0;
  for (const TrackRow* r : rows) {
    bin = std::max(bin, r->strip_bin_s);
    end = std::max(end, r->strip_bin_s * r->strip.size());
  }
  while (end / bin > kStripMaxBins) bin *= 2;
  const int columns = std::max(1, static_cast<int>(std::ceil(end / bin - 1e-9)));
  std::vector<std::vector<double>> grid;
  for (const TrackRow* r : rows) {
    std::vector<double> line(columns, kNaN);
    const int group = std::max(1, static_cast<int>(std::lround(bin / r->strip_bin_s)));
    for (int c = 0; c < columns; ++c) {
      double sum = 0;
      int n = 0;
      for (int k = c * group; k < (c + 1) * group && k < static_cast<int>(r->strip.size()); ++k)
        if (std::isfinite(r->strip[k])) sum += r->strip[k], ++n;
      if (n) line[c] = sum / n;
    }
    grid.push_back(std::move(line));
  }
  return grid;
}

std::string track_plot_script(const TrackBatchResult& result) {
  std::vector<double> errors;
  std::vector<const TrackRow*> stripped;
  for (const TrackRow& r : result.rows) {
    if (!r.error.empty() || !r.done) continue;
    if (std::isfinite(r.g_mpjpe_m)) errors.push_back(r.g_mpjpe_m);
    if (!r.strip.empty()) stripped.push_back(&r);
  }
  if (errors.empty() || stripped.empty())
    throw InputError("results.png: no clip was tracked, nothing to plot");
  double bin = 0;
  const std::vector<std::vector<double>> grid = common_strips(stripped, bin);
  std::vector<double> all;
  for (const auto& line : grid)
    for (double v : line)
      if (std::isfinite(v)) all.push_back(v);
  std::sort(all.begin(), all.end());
  const double top = std::max(0.05, std::ceil(percentile(all, 0.95) / 0.05) * 0.05);
  const int rows = static_cast<int>(grid.size());
  const int height = 520 + 14 * std::min(rows, 60);
  std::string s = fmt::format(
      "set terminal pngcairo size 1000,{} enhanced font 'sans,10'\nset output png\n", height);
  // the histogram's counts, from here: bins of a round width, whole clips on the axis
  const double binw = nice_bin(*std::max_element(errors.begin(), errors.end()));
  std::map<long, int> counts;
  for (double e : errors) ++counts[static_cast<long>(std::floor(e / binw))];
  int most = 0;
  for (const auto& [k, c] : counts) most = std::max(most, c);
  s += "$gmpjpe << EOD\n";
  for (const auto& [k, c] : counts) s += fmt::format("{:.9g} {}\n", (k + 0.5) * binw, c);
  s += "EOD\n$strips << EOD\n";
  for (const auto& line : grid) {
    for (size_t c = 0; c < line.size(); ++c)
      s += (c ? " " : "") + (std::isfinite(line[c]) ? fmt::format("{:.6g}", line[c]) : "NaN");
    s += "\n";
  }
  s += "EOD\n";
  const double hist_share = 300.0 / height;
  const TrackBatchSummary& sum = result.summary;
  s += fmt::format(
      "set multiplot\nset size 1,{0:.4f}\nset origin 0,{1:.4f}\n"
      "set title \"G-MPJPE of {2} tracked clips: median {3:.3f} m, 90th percentile {4:.3f} m\" "
      "noenhanced\nset xlabel 'G-MPJPE (m)'\nset ylabel 'clips'\nset grid ytics\n"
      "set style fill solid 0.7 border -1\nset boxwidth {5:.9g}\n"
      "set xrange [0:{6:.9g}]\nset yrange [0:{7}]\nset ytics {8}\n"
      "plot $gmpjpe using 1:2 with boxes lc rgb '#1f4e9c' notitle\n",
      hist_share, 1 - hist_share, errors.size(), sum.median_g_mpjpe_m, sum.p90_g_mpjpe_m,
      0.9 * binw, (counts.rbegin()->first + 1) * binw, most + 1, std::max(1, (most + 4) / 5));
  s += fmt::format(
      "set size 1,{0:.4f}\nset origin 0,0\nunset grid\n"
      "set title 'root error over time (m), one strip per clip'\nset xlabel 'time (s)'\n"
      "unset ylabel\nset xrange [0:{1:.9g}]\nset yrange [{2}-0.5:-0.5]\nset cbrange [0:{3:.9g}]\n"
      "set palette defined (0 '#0d0887', 0.35 '#7e03a8', 0.65 '#cc4778', 0.85 '#f89540', "
      "1 '#f0f921')\n",
      1 - hist_share, bin * grid.front().size(), rows, top);
  if (rows <= 60) {
    s += "set ytics noenhanced (";
    for (int r = 0; r < rows; ++r)
      s += fmt::format("{}\"{}\" {}", r ? ", " : "", gnuplot_text(stripped[r]->clip), r);
    s += ")\n";
  } else {
    s += "set ylabel 'clip (row of results.csv)'\nset ytics auto\n";
  }
  s += fmt::format(
      "plot $strips matrix using (($1 + 0.5) * {0:.9g}):2:3 with image notitle\n"
      "unset multiplot\n",
      bin);
  return s;
}

// ---- the command's progress: a bar on a terminal, or a line per clip

class ClipProgress {
 public:
  ClipProgress(bool quiet, int rank) : quiet_(quiet), rank_(rank) {
    bar_ = !quiet && rank == 0 && isatty(fileno(stderr));
  }
  void start(int done, int total) {
    start_done_ = done;
    wall0_ = std::chrono::steady_clock::now();
    draw(done, total);
  }
  void clip_done(const TrackRow& row, int done, int total) {
    if (quiet_) return;
    if (bar_) std::fprintf(stderr, "\r\033[K");
    std::cout << (rank_ > 0 ? fmt::format("  rank {} ", rank_)
                            : fmt::format("  [{}/{}] ", done, total))
              << row.clip << ": " << outcome(row) << std::endl;
    draw(done, total);
  }
  void finish() {
    if (bar_ && drawn_) std::fprintf(stderr, "\n");
  }

 private:
  static std::string outcome(const TrackRow& r) {
    if (!r.error.empty()) return "error: " + r.error;
    std::string what = r.diverged  ? "diverged"
                       : r.fell    ? "fell"
                       : r.success ? "held"
                                   : "no success";
    return fmt::format("{}, G-MPJPE {} m, {:.1f} s", what, md_number(r.g_mpjpe_m, 3), r.sim_s);
  }
  void draw(int done, int total) {
    if (!bar_ || total <= 0) return;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(std::lround(kWidth * static_cast<double>(done) / total));
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
    const int ran = done - start_done_;
    std::string eta = "--";
    if (ran > 0) {
      const double left = elapsed / ran * (total - done);
      eta = left >= 60 ? fmt::format("{}m{:02d}s", int(left) / 60, int(left) % 60)
                       : fmt::format("{:.0f}s", left);
    }
    std::fprintf(stderr, "\r\033[K[%s%s] %d/%d clips  ETA %s", std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, ' ').c_str(), done, total, eta.c_str());
    std::fflush(stderr);
    drawn_ = true;
  }
  bool quiet_, bar_ = false, drawn_ = false;
  int rank_, start_done_ = 0;
  std::chrono::steady_clock::time_point wall0_;
};

// SIGINT and SIGTERM stop the batch cleanly while it lives; a second one kills at once
std::atomic<bool> g_track_batch_interrupt{false};

extern "C" void on_track_batch_signal(int) {
  g_track_batch_interrupt.store(true);
}

class TrackBatchSignals {
 public:
  TrackBatchSignals() {
    g_track_batch_interrupt.store(false);
    struct sigaction sa {};
    sa.sa_handler = on_track_batch_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~TrackBatchSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  TrackBatchSignals(const TrackBatchSignals&) = delete;
  TrackBatchSignals& operator=(const TrackBatchSignals&) = delete;

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};

}  // namespace

bool is_track_batch(const std::vector<std::string>& inputs) {
  if (inputs.size() != 1) return inputs.size() > 1;
  std::error_code ec;
  const std::string& in = inputs.front();
  return fs::is_directory(in, ec) || (has_glob_chars(in) && !fs::exists(in, ec));
}

std::vector<TrackClip> find_track_clips(const std::vector<std::string>& inputs,
                                        const std::string& skip) {
  ClipList list;
  const std::string skip_key = skip.empty() ? std::string() : path_key(skip);
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (fs::exists(input, ec)) {
      add_input(input, skip_key, list);
      continue;
    }
    if (!has_glob_chars(input)) throw InputError(fmt::format("{}: no such file or folder", input));
    glob_t found{};
    const int code = glob(input.c_str(), 0, nullptr, &found);
    std::vector<std::string> matches(found.gl_pathv, found.gl_pathv + found.gl_pathc);
    globfree(&found);
    if (code != 0 || matches.empty())
      throw InputError(fmt::format("{}: no file or folder matches", input));
    for (const std::string& m : matches) add_input(m, skip_key, list);
  }
  std::vector<TrackClip> clips = list.take();
  if (clips.empty()) throw InputError("bvh track: no clip to track");
  return clips;
}

nlohmann::json track_row_to_json(const TrackRow& r) {
  nlohmann::json strip = nlohmann::json::array();
  for (double v : r.strip) strip.push_back(number_or_null(v));
  return {{"clip", r.clip},
          {"frames", r.frames},
          {"clip_s", number_or_null(r.clip_s)},
          {"sim_s", number_or_null(r.sim_s)},
          {"fell", r.fell},
          {"diverged", r.diverged},
          {"success", r.success},
          {"g_mpjpe_m", number_or_null(r.g_mpjpe_m)},
          {"root_error_m", number_or_null(r.root_error_m)},
          {"joint_error_deg", number_or_null(r.joint_error_deg)},
          {"foot_skate_m_per_s", number_or_null(r.foot_skate_m_per_s)},
          {"compute_s_per_sim_s", number_or_null(r.compute_s_per_sim_s)},
          {"error", r.error},
          {"internal_error", r.internal_error},
          {"strip_bin_s", r.strip_bin_s},
          {"strip", strip},
          {"done", r.done}};
}

TrackRow track_row_from_json(const nlohmann::json& j) {
  TrackRow r;
  r.clip = j.at("clip").get<std::string>();
  r.frames = j.at("frames").get<int>();
  r.clip_s = number_from(j.at("clip_s"));
  r.sim_s = number_from(j.at("sim_s"));
  r.fell = j.at("fell").get<bool>();
  r.diverged = j.at("diverged").get<bool>();
  r.success = j.at("success").get<bool>();
  r.g_mpjpe_m = number_from(j.at("g_mpjpe_m"));
  r.root_error_m = number_from(j.at("root_error_m"));
  r.joint_error_deg = number_from(j.at("joint_error_deg"));
  r.foot_skate_m_per_s = number_from(j.at("foot_skate_m_per_s"));
  r.compute_s_per_sim_s = number_from(j.at("compute_s_per_sim_s"));
  r.error = j.at("error").get<std::string>();
  r.internal_error = j.at("internal_error").get<bool>();
  r.strip_bin_s = j.at("strip_bin_s").get<double>();
  for (const auto& v : j.at("strip")) r.strip.push_back(number_from(v));
  r.done = j.at("done").get<bool>();
  return r;
}

TrackRow read_track_row(const std::string& clip, const std::string& dir) {
  TrackRow row;
  row.clip = clip;
  std::ifstream in(fs::path(dir) / "summary.json");
  if (!in) return row;
  try {
    const nlohmann::json s = nlohmann::json::parse(in);
    if (!s.is_object() || s.value("interrupted", true)) return row;
    const nlohmann::json metrics = s.value("metrics", nlohmann::json::object());
    const nlohmann::json mocap = metrics.value("mocap", nlohmann::json::object());
    row.frames = mocap.value("clip_frames", 0);
    row.clip_s = number_at(mocap, "clip_duration_s");
    row.sim_s = number_at(s, "sim_time");
    row.fell = s.value("fell", false);
    row.diverged = s.value("diverged", false);
    row.success = mocap.value("success", false);
    row.g_mpjpe_m = number_at(mocap, "mean_body_position_error_m");
    row.root_error_m = number_at(mocap, "mean_root_error_m");
    row.joint_error_deg = number_at(mocap, "mean_joint_error_deg");
    row.foot_skate_m_per_s = number_at(mocap, "foot_skate_m_per_s");
    row.compute_s_per_sim_s = number_at(mocap, "compute_s_per_sim_s");
  } catch (const nlohmann::json::exception&) {
    return row;  // not a summary of stance: the clip runs again
  }
  read_root_error_strip(fs::path(dir) / "log.csv", row);
  row.done = true;
  return row;
}

std::string TrackBatchSummary::line() const {
  std::string s =
      fmt::format("{}: {} succeeded ({:.1f}%), {} fell, {} diverged, {} could not be read",
                  clip_count(clips), succeeded, 100 * success_rate, fell, diverged, errors);
  if (tracked == 0) return s + "; no clip tracked";
  return s + fmt::format("; G-MPJPE median {:.3f} m, 90th percentile {:.3f} m", median_g_mpjpe_m,
                         p90_g_mpjpe_m);
}

TrackBatchSummary summarize_track_rows(const std::vector<TrackRow>& rows) {
  TrackBatchSummary s;
  std::vector<double> errors;
  for (const TrackRow& r : rows) {
    if (!r.done) continue;
    ++s.clips;
    if (!r.error.empty()) {
      ++s.errors;
      continue;
    }
    ++s.tracked;
    s.succeeded += r.success;
    s.fell += r.fell;
    s.diverged += r.diverged;
    if (std::isfinite(r.g_mpjpe_m)) errors.push_back(r.g_mpjpe_m);
  }
  s.success_rate = s.clips ? static_cast<double>(s.succeeded) / s.clips : 0;
  std::sort(errors.begin(), errors.end());
  s.median_g_mpjpe_m = percentile(errors, 0.5);
  s.p90_g_mpjpe_m = percentile(errors, 0.9);
  return s;
}

TrackBatchResult run_track_batch(const BvhTrackBatchCommand& cmd,
                                 const std::atomic<bool>* interrupt, const TrackRowDone& on_done,
                                 const std::function<void(int, int)>& on_start) {
  check_batch_options(cmd);
  const fs::path out = cmd.track.out_dir;
  TrackBatchResult result;
  result.clips = find_track_clips(cmd.inputs, cmd.track.out_dir);
  const int n = static_cast<int>(result.clips.size());
  const nlohmann::json fingerprint = batch_fingerprint(cmd, result.clips);
  BatchRanks& ranks = BatchRanks::get();
  result.rows.resize(n);
  for (int i = 0; i < n; ++i) result.rows[i].clip = result.clips[i].name;
  if (cmd.resume) {
    check_resume(out, fingerprint);
    for (int i = 0; i < n; ++i) {
      result.rows[i] = read_track_row(result.clips[i].name, (out / result.clips[i].name).string());
      result.resumed += result.rows[i].done;
    }
  } else if (ranks.root()) {
    // a fresh batch: no clip of an earlier one in this folder counts as finished
    std::error_code ec;
    fs::create_directories(out, ec);
    if (ec) throw InputError(fmt::format("--out {}: {}", out.string(), ec.message()));
    for (const TrackClip& c : result.clips) fs::remove(out / c.name / "summary.json", ec);
    for (const char* f : {"results.csv", "results.md", "results.png", "results.gp"})
      fs::remove(out / f, ec);
    write_file_atomically(out / kBatchFile, dump_json({{"options", fingerprint}}, 2) + "\n");
  }
  // the threads of this process: `jobs` clips at once, the rest to their planners
  const int todo = n - result.resumed;
  const int threads = cmd.track.threads > 0
                          ? cmd.track.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const int jobs = std::clamp(cmd.jobs > 0 ? cmd.jobs : threads, 1, std::max(1, todo));
  const int planner_threads = std::max(1, threads / jobs);

  std::mutex done_mutex;
  int done = result.resumed;
  bool cut = false;  // a clip of this process was interrupted or not started
  if (on_start) on_start(done, n);
  // every clip is handed out, kept ones too: the rank given a clip decides from what it read of
  // the folder before any clip of this batch ran, so one that another rank has just finished is
  // never taken for an earlier run's
  ranks.distributed_for(
      n, jobs,
      [&](int i) {
        if (result.rows[i].done) return;  // kept from the earlier run
        TrackRow row;
        if (!interrupt || !interrupt->load())
          row = track_one_clip(cmd, result.clips[i], planner_threads, interrupt);
        std::lock_guard<std::mutex> lock(done_mutex);
        cut |= !row.done;
        if (!row.done) return;
        result.rows[i] = std::move(row);
        ++done;
        if (on_done) on_done(result.rows[i], done, n);
      },
      [&](int i) {
        const TrackRow& row = result.rows[i];
        return row.done ? dump_json(track_row_to_json(row)) : std::string();
      },
      [&](int i, const std::string& text) {
        if (text.empty()) return;
        result.rows[i] = track_row_from_json(nlohmann::json::parse(text));
        result.rows[i].clip = result.clips[i].name;
      });
  // rank 0 holds every row; another rank knows its own clips
  result.interrupted = cut;
  if (ranks.root())
    for (const TrackRow& r : result.rows) result.interrupted |= !r.done;
  if (!ranks.root() || result.interrupted) return result;
  result.summary = summarize_track_rows(result.rows);
  write_track_results(out.string(), result);
  return result;
}

void write_track_results(const std::string& dir, const TrackBatchResult& result) {
  AtomicFile csv_file(fs::path(dir) / "results.csv");
  AtomicFile md_file(fs::path(dir) / "results.md");
  std::ostream& csv = csv_file.stream();
  std::ostream& md = md_file.stream();
  csv << "clip,frames,clip_s,sim_s,fell,diverged,success,g_mpjpe_m,root_error_m,"
         "joint_error_deg,foot_skate_m_per_s,error,compute_s_per_sim_s\n";
  md << "| clip | frames | clip s | sim s | fell | success | G-MPJPE m | root m | joint deg | "
        "skate m/s | compute s/s | error |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const TrackRow& r : result.rows) {
    if (!r.error.empty()) {
      csv << csv_field(r.clip) << ",,,,,,0,,,,," << csv_field(r.error) << ",\n";
      md << "| " << md_text(r.clip) << " | | | | | no | | | | | | " << md_text(r.error) << " |\n";
      continue;
    }
    csv << csv_field(r.clip) << ',' << r.frames << ',' << csv_number(r.clip_s) << ','
        << csv_number(r.sim_s) << ',' << r.fell << ',' << r.diverged << ',' << r.success << ','
        << csv_number(r.g_mpjpe_m) << ',' << csv_number(r.root_error_m) << ','
        << csv_number(r.joint_error_deg) << ',' << csv_number(r.foot_skate_m_per_s) << ",,"
        << csv_number(r.compute_s_per_sim_s) << '\n';
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | |\n",
                      md_text(r.clip), r.frames, md_number(r.clip_s, 2), md_number(r.sim_s, 2),
                      r.diverged ? "diverged" : yes_no(r.fell), yes_no(r.success),
                      md_number(r.g_mpjpe_m, 3), md_number(r.root_error_m, 3),
                      md_number(r.joint_error_deg, 2), md_number(r.foot_skate_m_per_s, 3),
                      md_number(r.compute_s_per_sim_s, 1));
  }
  md << "\n" << result.summary.line() << "\n";
  csv_file.commit();
  md_file.commit();
}

std::string plot_track_results(const std::string& dir, const TrackBatchResult& result) {
  return render_gnuplot(dir, "results.gp", track_plot_script(result), "results.png");
}

int bvh_track_batch_command(const BvhTrackBatchCommand& cmd) {
  return guarded([&] {
    const int rank = BatchRanks::get().rank();
    ClipProgress progress(cmd.track.quiet, rank);
    TrackBatchSignals signals;
    const auto wall0 = std::chrono::steady_clock::now();
    const TrackBatchResult r = run_track_batch(
        cmd, &g_track_batch_interrupt,
        [&](const TrackRow& row, int done, int total) { progress.clip_done(row, done, total); },
        [&](int done, int total) { progress.start(done, total); });
    progress.finish();
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    const std::string out = cmd.track.out_dir;
    // under mpirun, rank 0 gathered every row and writes; the others are done
    if (!BatchRanks::get().root()) return r.interrupted ? kExitInterrupted : kExitOk;
    if (r.interrupted) {
      int done = 0;
      for (const TrackRow& row : r.rows) done += row.done;
      std::cerr << fmt::format(
          "interrupted: {} of {} clips done, kept in {}; finish them with the same command and "
          "--resume\n",
          done, r.rows.size(), out);
      return kExitInterrupted;
    }
    std::cout << fmt::format(
        "tracked {} ({} kept from the earlier run) in {:.1f} s wall; "
        "wrote {}/results.csv and results.md\n",
        clip_count(r.rows.size()), r.resumed, wall, out);
    if (cmd.plot) {
      if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
        std::cerr << "note: gnuplot not found, so no results.png (Debian: apt-get install "
                     "gnuplot-nox)\n";
      } else {
        try {
          std::cout << "wrote " << plot_track_results(out, r) << "\n";
        } catch (const InputError& e) {
          std::cerr << "note: " << e.what() << "\n";
        }
      }
    }
    std::cout << r.summary.line() << "\n";
    bool internal = false;
    for (const TrackRow& row : r.rows)
      if (!row.error.empty()) {
        std::cerr << "error: " << row.clip << ": " << row.error << "\n";
        internal |= row.internal_error;
      }
    if (internal) return kExitInternalError;
    return r.summary.errors > 0 ? kExitBadInput : kExitOk;
  });
}

}  // namespace stance
