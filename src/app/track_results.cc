// the results of a batch: each clip's row (read from its folder, to and from JSON), the
// summary, results.csv and results.md, and the results.png plot
#include "app/track_batch.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "app/track_batch_text.h"
#include "batch/sweep.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace stance {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// the strip's finest bin, doubled until a clip has at most this many
constexpr double kStripBinS = 0.1;
constexpr int kStripMaxBins = 256;

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

// log.csv's tracking_body_error_m (G-MPJPE's per-step term) as the mean over each bin of time
void read_body_error_strip(const fs::path& log, TrackRow& row) {
  std::ifstream in(log);
  std::string line;
  if (!std::getline(in, line)) return;
  const std::vector<std::string> header = split_csv_line(line);
  const auto column = [&](const char* name) {
    return static_cast<int>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const int time_col = column("time"), error_col = column("tracking_body_error_m");
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
      "set title 'body position error (m, G-MPJPE per step) over time, one strip per clip'\n"
      "set xlabel 'time (s)'\n"
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

}  // namespace

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
          {"cpu_s_per_sim_s", number_or_null(r.cpu_s_per_sim_s)},
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
  r.cpu_s_per_sim_s = number_from(j.at("cpu_s_per_sim_s"));
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
    row.cpu_s_per_sim_s = number_at(mocap, "cpu_s_per_sim_s");
  } catch (const nlohmann::json::exception&) {
    return row;  // not a summary of stance: the clip runs again
  }
  read_body_error_strip(fs::path(dir) / "log.csv", row);
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

void write_track_results(const std::string& dir, const TrackBatchResult& result) {
  AtomicFile csv_file(fs::path(dir) / "results.csv");
  AtomicFile md_file(fs::path(dir) / "results.md");
  std::ostream& csv = csv_file.stream();
  std::ostream& md = md_file.stream();
  csv << "clip,frames,clip_s,sim_s,fell,diverged,success,g_mpjpe_m,root_error_m,"
         "joint_error_deg,foot_skate_m_per_s,error,compute_s_per_sim_s,cpu_s_per_sim_s\n";
  md << "| clip | frames | clip s | sim s | fell | success | G-MPJPE m | root m | joint deg | "
        "skate m/s | compute s/s | CPU s/s | error |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const TrackRow& r : result.rows) {
    if (!r.error.empty()) {
      csv << csv_field(r.clip) << ",,,,,,0,,,,," << csv_field(r.error) << ",,\n";
      md << "| " << md_text(r.clip) << " | | | | | no | | | | | | | " << md_text(r.error) << " |\n";
      continue;
    }
    csv << csv_field(r.clip) << ',' << r.frames << ',' << csv_number(r.clip_s) << ','
        << csv_number(r.sim_s) << ',' << r.fell << ',' << r.diverged << ',' << r.success << ','
        << csv_number(r.g_mpjpe_m) << ',' << csv_number(r.root_error_m) << ','
        << csv_number(r.joint_error_deg) << ',' << csv_number(r.foot_skate_m_per_s) << ",,"
        << csv_number(r.compute_s_per_sim_s) << ',' << csv_number(r.cpu_s_per_sim_s) << '\n';
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | |\n",
                      md_text(r.clip), r.frames, md_number(r.clip_s, 2), md_number(r.sim_s, 2),
                      r.diverged ? "diverged" : yes_no(r.fell), yes_no(r.success),
                      md_number(r.g_mpjpe_m, 3), md_number(r.root_error_m, 3),
                      md_number(r.joint_error_deg, 2), md_number(r.foot_skate_m_per_s, 3),
                      md_number(r.compute_s_per_sim_s, 1), md_number(r.cpu_s_per_sim_s, 1));
  }
  md << "\n" << result.summary.line() << "\n";
  csv_file.commit();
  md_file.commit();
}

std::string plot_track_results(const std::string& dir, const TrackBatchResult& result) {
  return render_gnuplot(dir, "results.gp", track_plot_script(result), "results.png");
}

}  // namespace stance
