// The files stance tune writes: tune.csv, best.yaml and best_scenario.yaml.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <ostream>

#include "batch/sweep.h"
#include "batch/tune.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace stance {

namespace {

std::string csv_number(double v) {
  return std::isfinite(v) ? fmt::format("{:.9g}", v) : "";
}

}  // namespace

void write_tune_outputs(const std::string& dir, const TuneOptions& o, const TuneResult& r) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", dir, ec.message()));
  if (r.candidates.empty()) throw InputError("tune: no candidates to write");

  // all three are renamed into place together, once all of them are written
  AtomicFile csv_file(fs::path(dir) / "tune.csv");
  AtomicFile yaml_file(fs::path(dir) / "best.yaml");
  AtomicFile scn_file(fs::path(dir) / "best_scenario.yaml");
  std::ostream& csv = csv_file.stream();
  csv << "generation,index";
  for (const auto& p : o.params) csv << ',' << p.key;
  csv << ",robust_score,worst_time_up_s,mean_metric,failed_runs\n";
  for (const auto& c : r.candidates) {
    csv << c.generation << ',' << c.index;
    for (double v : c.values) csv << ',' << format_sweep_value(v);
    csv << ',' << csv_number(c.robust_score) << ',' << csv_number(c.worst_time_up) << ','
        << csv_number(c.mean_metric) << ',' << c.failed_runs << '\n';
  }

  const TuneCandidate& b = r.candidates[r.best];
  const TuneCandidate& s = r.candidates.front();
  std::ostream& yaml = yaml_file.stream();
  yaml << fmt::format("# stance tune {}: best of {} candidates (generation {}, candidate {})\n",
                      o.scenario, r.candidates.size(), b.generation, b.index);
  yaml << fmt::format(
      "# robust score {:.6g} (max over the nominal run and {} neighbour(s)), worst time up {:.6g} "
      "of {:.6g} s",
      b.robust_score, o.neighbours.size(), b.worst_time_up, r.duration);
  if (!o.metric.empty()) yaml << fmt::format(", mean {} {:.6g}", o.metric, b.mean_metric);
  yaml << fmt::format("\n# the start: robust score {:.6g}, worst time up {:.6g} s\n",
                      s.robust_score, s.worst_time_up);
  for (const auto& set : o.sets) yaml << "# base: --set " << set << "\n";
  for (const auto& n : o.neighbours) yaml << "# neighbour: " << n.text << "\n";
  yaml << "# as --set lines:\n";
  for (const auto& a : tune_assignments(o, b)) yaml << "#   --set " << a << "\n";
  for (size_t i = 0; i < o.params.size(); ++i)
    yaml << o.params[i].key << ": " << format_sweep_value(b.values[i]) << "\n";

  std::ostream& scn = scn_file.stream();
  fs::path folder = fs::absolute(o.scenario).parent_path();
  scn << "# " << o.scenario << " with --set and the best point of stance tune applied.\n"
      << "# Relative paths in it are relative to " << folder.string()
      << ": save it there to run it.\n"
      << r.scenario_yaml << "\n";
  csv_file.commit();
  yaml_file.commit();
  scn_file.commit();
}

}  // namespace stance
