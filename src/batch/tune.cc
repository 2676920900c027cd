#include "batch/tune.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>

#include "batch/batch_ranks.h"
#include "batch/sweep.h"
#include "batch/tune_detail.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "math/cem.h"
#include "math/cmaes.h"
#include "params/param_list.h"
#include "params/yaml_params.h"
#include "sim/scenario.h"

namespace stance {

using namespace tune_detail;

namespace {

double to_unit(const TuneParam& p, double x) {
  if (p.log) return (std::log(x) - std::log(p.lo)) / (std::log(p.hi) - std::log(p.lo));
  return (x - p.lo) / (p.hi - p.lo);
}

// the value of a unit coordinate, rounded to 6 significant digits so that the text written to
// the CSV and to --set is the value that was run
double from_unit(const TuneParam& p, double u) {
  u = std::clamp(u, 0.0, 1.0);
  double x = p.log ? std::exp(std::log(p.lo) + u * (std::log(p.hi) - std::log(p.lo)))
                   : p.lo + u * (p.hi - p.lo);
  x = std::stod(fmt::format("{:.6g}", x));
  return std::clamp(x, p.lo, p.hi);
}

// "key=value" for every searched parameter
std::vector<std::string> assignments(const TuneOptions& o, const std::vector<double>& values) {
  std::vector<std::string> out;
  for (size_t i = 0; i < o.params.size(); ++i)
    out.push_back(o.params[i].key + "=" + format_sweep_value(values[i]));
  return out;
}

// the scalar metric paths of a run, for "did you mean"
void metric_paths(const nlohmann::json& j, const std::string& prefix,
                  std::vector<std::string>& out) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    std::string path = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it.value().is_object())
      metric_paths(it.value(), path, out);
    else if (it.value().is_number())
      out.push_back(path);
  }
}

// the numeric defaults of a loaded scenario: its own fields and its controllers' parameters
// (typed at load: no controller is built)
std::optional<double> default_value(const LoadedScenario& loaded, const std::string& key) {
  std::vector<std::string> parts = split_path(key);
  if (parts.size() >= 3 && parts[0] == "controllers") {
    char* end = nullptr;
    long idx = std::strtol(parts[1].c_str(), &end, 10);
    if (*end || idx < 0 || idx >= static_cast<long>(loaded.controllers.size())) return std::nullopt;
    std::string rest = key.substr(parts[0].size() + parts[1].size() + 2);
    for (const ParamEntry& e : controller_params(loaded, idx))
      if (e.path == rest) return e.value;
    return std::nullopt;
  }
  for (const ParamEntry& e : list_params(loaded.scenario))
    if (e.path == key) return e.value;
  return std::nullopt;
}

// the numeric key paths a scenario offers (for "did you mean")
std::vector<std::string> known_keys(const YAML::Node& doc, const LoadedScenario& loaded) {
  std::vector<ParamEntry> entries;
  list_yaml_params(doc, "", entries);
  std::vector<std::string> out;
  for (const auto& e : entries) out.push_back(e.path);
  for (const auto& e : list_params(loaded.scenario)) out.push_back(e.path);
  for (size_t i = 0; i < loaded.controllers.size(); ++i)
    for (const auto& e : controller_params(loaded, i))
      out.push_back(fmt::format("controllers.{}.{}", i, e.path));
  return out;
}

LoadedScenario parse_doc(const TuneOptions& o, const YAML::Node& doc) {
  std::string base = std::filesystem::path(o.scenario).parent_path().string();
  LoadedScenario loaded = parse_scenario(doc, o.scenario, base);
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(o.scenario).stem().string();
  return loaded;
}

// the tree of one run: base, the candidate's values, then neighbour j (-1: nominal)
YAML::Node run_doc(const TuneOptions& o, const YAML::Node& base, const std::vector<double>& values,
                   int neighbour) {
  YAML::Node doc = YAML::Clone(base);
  for (const auto& a : assignments(o, values)) apply_yaml_override(doc, a);
  if (neighbour >= 0) apply_neighbour(doc, o.neighbours[neighbour]);
  return doc;
}

// a random generator or distribution as the text its operator<< writes, and back
template <class T>
std::string stream_text(const T& value) {
  std::ostringstream out;
  out << value;
  return out.str();
}
template <class T>
void from_text(const std::string& text, T& value) {
  std::istringstream in(text);
  in >> value;
  if (in.fail()) throw std::runtime_error("a random generator state that does not read back");
}

Eigen::VectorXd to_vector(const nlohmann::json& j, int size) {
  std::vector<double> v = j.get<std::vector<double>>();
  if (static_cast<int>(v.size()) != size) throw std::runtime_error("a vector of another size");
  return Eigen::Map<Eigen::VectorXd>(v.data(), size);
}

}  // namespace

std::vector<std::string> tune_assignments(const TuneOptions& o, const TuneCandidate& c) {
  return assignments(o, c.values);
}

namespace {

// the arguments, before any file is read; throws InputError naming the option
void check_tune_options(const TuneOptions& o, const nlohmann::json* resume_from) {
  if (o.params.empty()) throw InputError("tune: no parameter to search (--param key=lo:hi)");
  if (o.method != "cem" && o.method != "cmaes")
    throw InputError(fmt::format("--method '{}': expected cem or cmaes", o.method));
  if (o.budget < 1) throw InputError(fmt::format("--budget {}: expected at least 1", o.budget));
  if (o.population < 1)
    throw InputError(fmt::format("--population {}: expected at least 1", o.population));
  if (o.method == "cmaes" && o.population < 2)
    throw InputError(fmt::format(
        "--population {}: CMA-ES needs at least 2 candidates per generation", o.population));
  if (resume_from) check_tune_resume(o, *resume_from, "--resume");
  if (o.threads < 0) throw InputError(fmt::format("--threads {}: expected 0 or more", o.threads));
  if (!std::isfinite(o.fall_penalty) || o.fall_penalty < 0)
    throw InputError(fmt::format("--fall-penalty {}: expected a number >= 0", o.fall_penalty));
  if (o.duration && !(*o.duration > 0 && std::isfinite(*o.duration)))
    throw InputError(fmt::format("--duration {}: expected a positive number", *o.duration));
  std::set<std::string> seen;
  for (const auto& p : o.params) {
    if (!(p.lo < p.hi) || (p.log && p.lo <= 0))
      throw InputError(fmt::format("--param '{}': bad range", param_text(p)));
    if (!seen.insert(p.key).second)
      throw InputError(fmt::format("--param '{}': {} is searched twice", param_text(p), p.key));
  }
}

// what every run of a tune shares; not copied or moved (the run options point at the cache)
struct TuneSetup {
  // the scenario after --engine, --set and the defaults of the searched and multiplied keys
  YAML::Node base;
  // candidates that repeat a controller's parameters on the same world share its model
  ControllerCache cache;
  RunOptions run_options;
  // run_options stopped by TuneOptions::interrupt: such a run is marked cut
  RunOptions interruptible;
  std::vector<double> start;  // one value per searched parameter
  int runs_per = 1;           // the nominal run, then one per neighbour
};

// the scenario tree, with the numbers the YAML leaves at their defaults written in, so that the
// start point and "k*=f" see the value the run would use; fills result.duration
void load_tune_base(const TuneOptions& o, TuneSetup& s, TuneResult& result) {
  s.base = load_yaml_file(o.scenario);
  // --engine is the scenario's engine, so that a neighbour "engine=dart" still picks its own
  if (!o.engine.empty()) s.base["engine"] = o.engine;
  for (const auto& set : o.sets) apply_yaml_override(s.base, set);
  s.run_options.duration = o.duration;
  s.run_options.quiet = true;
  s.run_options.cache = &s.cache;
  LoadedScenario loaded = parse_doc(o, s.base);
  result.duration = o.duration ? *o.duration : loaded.scenario.duration;
  auto resolve = [&](const std::string& key, const std::string& arg) {
    if (yaml_number_at(s.base, key)) return;
    std::optional<double> v = default_value(loaded, key);
    if (!v)
      throw InputError(fmt::format("{}: no number at key path '{}' in {}{}", arg, key, o.scenario,
                                   did_you_mean(key, known_keys(s.base, loaded))));
    apply_yaml_override(s.base, key + "=" + format_sweep_value(*v));
  };
  for (const auto& p : o.params) resolve(p.key, fmt::format("--param '{}'", param_text(p)));
  for (const auto& n : o.neighbours)
    for (const auto& ov : n.overrides)
      if (ov.multiply) resolve(ov.key, fmt::format("--neighbour '{}'", n.text));
}

// the start: the base's values, clamped into their ranges (with a note)
void find_start(const TuneOptions& o, TuneSetup& s, TuneResult& result) {
  s.start.resize(o.params.size());
  for (size_t i = 0; i < o.params.size(); ++i) {
    const TuneParam& p = o.params[i];
    double v = *yaml_number_at(s.base, p.key);
    if (v < p.lo || v > p.hi) {
      double c = std::clamp(v, p.lo, p.hi);
      result.notes.push_back(fmt::format("{} starts at {}, outside {}..{}: the start uses {}",
                                         p.key, format_sweep_value(v), format_sweep_value(p.lo),
                                         format_sweep_value(p.hi), format_sweep_value(c)));
      v = c;
    }
    s.start[i] = v;
  }
}

// before any run: every neighbour of the start must build (it may change the world: an engine,
// a model, a timestep), and each parameter at its bounds must load (the loader types every
// parameter, controllers' too, so a value out of range fails there without a build)
void check_probe_builds(const TuneOptions& o, TuneSetup& s) {
  s.runs_per = 1 + static_cast<int>(o.neighbours.size());
  for (int j = 0; j < static_cast<int>(o.neighbours.size()); ++j) {
    try {
      Simulation probe(parse_doc(o, run_doc(o, s.base, s.start, j)), s.run_options);
    } catch (const InputError& e) {
      std::string msg = e.what();
      if (msg.rfind("--neighbour", 0) == 0) throw;
      throw InputError(fmt::format("--neighbour '{}': {}", o.neighbours[j].text, msg));
    }
  }
  for (size_t i = 0; i < o.params.size(); ++i)
    for (double bound : {o.params[i].lo, o.params[i].hi}) {
      std::vector<double> v = s.start;
      v[i] = bound;
      try {
        parse_doc(o, run_doc(o, s.base, v, -1));
      } catch (const InputError& e) {
        throw InputError(fmt::format("--param '{}': {} = {} is rejected: {}",
                                     param_text(o.params[i]), o.params[i].key,
                                     format_sweep_value(bound), e.what()));
      }
    }
}

// one run of a candidate (neighbour -1: nominal); `cut` is set when an interrupt stopped it
TuneRun run_candidate(const TuneOptions& o, const TuneSetup& s, double nominal_duration,
                      const std::vector<double>& values, int neighbour, char& cut) {
  double duration = nominal_duration;
  try {
    LoadedScenario loaded = parse_doc(o, run_doc(o, s.base, values, neighbour));
    duration = o.duration ? *o.duration : loaded.scenario.duration;
    RunResult r = run_without_timing(loaded, s.interruptible);
    cut = r.interrupted;
    return score_run(r, duration, o.metric, o.fall_penalty);
  } catch (const InputError& e) {
    // a candidate its controllers reject scores as failed; anything else is a bug
    return failed_run(e.what(), duration, o.fall_penalty);
  }
}

// the start's nominal run, which also checks the metric; nothing when it was interrupted
std::optional<TuneRun> run_first(const TuneOptions& o, const TuneSetup& s, double duration) {
  try {
    LoadedScenario loaded = parse_doc(o, run_doc(o, s.base, s.start, -1));
    RunResult r = run_without_timing(loaded, s.interruptible);
    if (r.interrupted) return std::nullopt;
    if (!o.metric.empty() && !r.diverged && !metric_at(r.metrics, o.metric)) {
      std::vector<std::string> paths;
      metric_paths(r.metrics, "", paths);
      std::string list;
      for (const auto& p : paths) list += (list.empty() ? "" : ", ") + p;
      throw InputError(fmt::format("--metric '{}': not a number in the run's metrics{} (there: {})",
                                   o.metric, did_you_mean(o.metric, paths), list));
    }
    return score_run(r, duration, o.metric, o.fall_penalty);
  } catch (const InputError& e) {
    if (std::string(e.what()).rfind("--metric", 0) == 0) throw;
    return failed_run(e.what(), duration, o.fall_penalty);
  } catch (const std::exception& e) {
    return failed_run(e.what(), duration, o.fall_penalty);
  }
}

std::vector<double> to_std(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

// the search in the unit box: CEM or CMA-ES, and the one generator both draw from
class TuneSearch {
 public:
  TuneSearch(const TuneOptions& o, const Eigen::VectorXd& start_unit)
      : o_(o), start_unit_(start_unit), rng_(o.seed) {
    const int d = static_cast<int>(start_unit.size());
    const Eigen::VectorXd lower = Eigen::VectorXd::Zero(d), upper = Eigen::VectorXd::Ones(d);
    if (o.method == "cmaes") {
      // lambda is the population (at least 2, checked)
      cmaes_.emplace(start_unit, 0.3, o.population, lower, upper);
    } else {
      // spread 0.3 of the box, floor 0.02, half the old spread kept; elites among all so far
      CemParams p;
      p.elites = std::max(2, (o.population + 3) / 4);
      cem_.emplace(start_unit, lower, upper, p);
    }
  }

  // generation g's points, `count` columns: the start is the first point of generation 0;
  // cem's generation 0 is then a Latin-hypercube sample of the box
  Eigen::MatrixXd draw(int g, int count) {
    if (cmaes_) {
      drawn_ = cmaes_->ask(rng_);
      if (g == 0) drawn_.col(0) = start_unit_;
      return drawn_.leftCols(count);
    }
    Eigen::MatrixXd unit(start_unit_.size(), count);
    if (g == 0) {
      unit.col(0) = start_unit_;
      cem_->ask_latin_hypercube(rng_, unit.rightCols(count - 1));
    } else {
      cem_->ask(rng_, unit);
    }
    return unit;
  }

  // tells the optimiser the robust scores of the points of draw()
  void learn(const Eigen::MatrixXd& unit, const std::vector<TuneCandidate>& gen) {
    const int count = static_cast<int>(gen.size());
    std::vector<double> scores(count);
    for (int c = 0; c < count; ++c) scores[c] = gen[c].robust_score;
    if (cem_) {
      cem_->tell(unit, scores);
      return;
    }
    // CMA-ES learns from full generations only; a short last one ends the search
    if (count == o_.population) cmaes_->tell(drawn_, scores);
  }

  // the state after a finished generation, as the resume file holds it
  nlohmann::json to_json() const {
    nlohmann::json search = {{"rng", stream_text(rng_)}};
    if (cmaes_) {
      const CmaesState& s = cmaes_->state();
      search["mean"] = to_std(s.mean);
      search["sigma"] = s.sigma;
      search["C"] = std::vector<double>(s.C.data(), s.C.data() + s.C.size());
      search["p_sigma"] = to_std(s.p_sigma);
      search["p_c"] = to_std(s.p_c);
      search["generation"] = s.generation;
    } else {
      const CemState& s = cem_->state();
      std::vector<std::vector<double>> units;
      for (const auto& u : s.told) units.push_back(to_std(u));
      search["normal"] = stream_text(s.normal);
      search["mean"] = to_std(s.mean);
      search["sigma"] = to_std(s.spread);
      search["units"] = units;
    }
    return search;
  }

  // restores to_json()'s state; the candidates' scores are the CEM's told values
  void from_json(const nlohmann::json& search, const std::vector<TuneCandidate>& candidates) {
    const int d = static_cast<int>(start_unit_.size());
    from_text(search.at("rng").get<std::string>(), rng_);
    if (cmaes_) {
      CmaesState s;
      s.mean = to_vector(search.at("mean"), d);
      s.sigma = search.at("sigma").get<double>();
      Eigen::VectorXd c = to_vector(search.at("C"), d * d);
      s.C = Eigen::Map<Eigen::MatrixXd>(c.data(), d, d);
      s.p_sigma = to_vector(search.at("p_sigma"), d);
      s.p_c = to_vector(search.at("p_c"), d);
      s.generation = search.at("generation").get<int>();
      cmaes_->set_state(s);
      return;
    }
    CemState s;
    from_text(search.at("normal").get<std::string>(), s.normal);
    const auto mean = search.at("mean").get<std::vector<double>>();
    const auto sigma = search.at("sigma").get<std::vector<double>>();
    const auto units = search.at("units").get<std::vector<std::vector<double>>>();
    if (static_cast<int>(mean.size()) != d || static_cast<int>(sigma.size()) != d ||
        units.size() != candidates.size())
      throw std::runtime_error("a search state of another size");
    s.mean = to_vector(search.at("mean"), d);
    s.spread = to_vector(search.at("sigma"), d);
    for (size_t i = 0; i < units.size(); ++i) {
      s.told.push_back(to_vector(search.at("units").at(i), d));
      s.told_values.push_back(candidates[i].robust_score);
    }
    cem_->set_state(s);
  }

 private:
  const TuneOptions& o_;
  Eigen::VectorXd start_unit_;
  std::mt19937_64 rng_;
  std::optional<Cmaes> cmaes_;
  std::optional<Cem> cem_;
  Eigen::MatrixXd drawn_;  // cmaes: the last ask, the start in place of its first point
};

nlohmann::json tune_checkpoint(const TuneOptions& o, const TuneResult& result,
                               const TuneSearch& search) {
  nlohmann::json candidates = nlohmann::json::array();
  for (const auto& c : result.candidates) candidates.push_back(candidate_to_json(c));
  return nlohmann::json{{"format", kCheckpointFormat},
                        {"options", tune_fingerprint(o)},
                        {"finished_generations", result.finished_generations},
                        {"best", result.best},
                        {"candidates", candidates},
                        {"search", search.to_json()}};
}

std::string best_scenario_yaml(const TuneOptions& o, const YAML::Node& base,
                               const TuneResult& result) {
  YAML::Node best_doc = run_doc(o, base, result.candidates[result.best].values, -1);
  YAML::Emitter out;
  out << best_doc;
  return std::string(out.c_str());
}

// a resumed search: the finished generations and the state after them, exactly as saved
void resume_tune(const TuneOptions& o, const TuneSetup& s, const nlohmann::json& cp,
                 TuneSearch& search, TuneResult& result) {
  try {
    for (const auto& c : cp.at("candidates")) result.candidates.push_back(candidate_from_json(c));
    result.best = cp.at("best").get<int>();
    result.finished_generations = cp.at("finished_generations").get<int>();
    if (result.candidates.empty() || result.best < 0 ||
        result.best >= static_cast<int>(result.candidates.size()) ||
        result.finished_generations > result.generations)
      throw std::runtime_error("inconsistent candidates");
    search.from_json(cp.at("search"), result.candidates);
  } catch (const std::exception& e) {
    throw InputError(fmt::format("--resume: not a stance tune resume file ({})", e.what()));
  }
  result.checkpoint = cp;
  result.scenario_yaml = best_scenario_yaml(o, s.base, result);
}

// the candidates of generation g at the unit points `unit`
std::vector<TuneCandidate> generation_candidates(const TuneOptions& o, const TuneSetup& s, int g,
                                                 const Eigen::MatrixXd& unit) {
  const int d = static_cast<int>(o.params.size());
  std::vector<TuneCandidate> gen(unit.cols());
  for (int c = 0; c < static_cast<int>(gen.size()); ++c) {
    gen[c].generation = g;
    gen[c].index = c;
    gen[c].values.resize(d);
    for (int k = 0; k < d; ++k)
      gen[c].values[k] = (g == 0 && c == 0) ? s.start[k] : from_unit(o.params[k], unit(k, c));
    gen[c].runs.resize(s.runs_per);
  }
  return gen;
}

// every run of a generation; false when one was cut short (the generation is abandoned)
bool run_generation(const TuneOptions& o, const TuneSetup& s, const TuneRun& first, double duration,
                    int g, std::vector<TuneCandidate>& gen) {
  const int count = static_cast<int>(gen.size()), runs_per = s.runs_per;
  std::vector<char> cut(count * runs_per, 0);
  // over threads, and over MPI ranks under mpirun: every rank needs every score, since the
  // next generation is drawn from them (each rank draws the same, from the same seed)
  BatchRanks::get().distributed_for(
      count * runs_per, o.threads,
      [&](int job) {
        const int c = job / runs_per, j = job % runs_per;
        if (g == 0 && c == 0 && j == 0)
          gen[c].runs[j] = first;
        else
          gen[c].runs[j] = run_candidate(o, s, duration, gen[c].values, j - 1, cut[job]);
      },
      [&](int job) {
        return nlohmann::json{{"run", run_to_json(gen[job / runs_per].runs[job % runs_per])},
                              {"cut", cut[job] != 0}}
            .dump();
      },
      [&](int job, const std::string& text) {
        const nlohmann::json j = nlohmann::json::parse(text);
        gen[job / runs_per].runs[job % runs_per] = run_from_json(j.at("run"));
        cut[job] = j.at("cut").get<bool>() ? 1 : 0;
      },
      /*every_rank=*/true);
  return std::find(cut.begin(), cut.end(), 1) == cut.end();
}

}  // namespace

TuneResult run_tune(const TuneOptions& o,
                    const std::function<void(const TuneResult&, int)>& on_generation,
                    const nlohmann::json* resume_from) {
  check_tune_options(o, resume_from);
  TuneSetup s;
  TuneResult result;
  load_tune_base(o, s, result);
  find_start(o, s, result);
  check_probe_builds(o, s);
  s.interruptible = s.run_options;
  s.interruptible.interrupt = o.interrupt;

  // a checkpoint is made after a finished generation: it holds at least one
  if (resume_from) {
    auto it = resume_from->find("finished_generations");
    if (it == resume_from->end() || !it->is_number_integer() || it->get<int>() < 1)
      throw InputError("--resume: not a stance tune resume file (no finished generation)");
  }
  TuneRun first;
  if (!resume_from) {
    std::optional<TuneRun> run = run_first(o, s, result.duration);
    if (!run) {
      result.interrupted = true;
      return result;
    }
    first = *run;
  }

  const int d = static_cast<int>(o.params.size());
  Eigen::VectorXd start_unit(d);
  for (int k = 0; k < d; ++k)
    start_unit[k] = std::clamp(to_unit(o.params[k], s.start[k]), 0.0, 1.0);
  TuneSearch search(o, start_unit);
  result.generations = (o.budget + o.population - 1) / o.population;
  if (resume_from) resume_tune(o, s, *resume_from, search, result);

  for (int g = result.finished_generations; g < result.generations; ++g) {
    if (o.interrupt && o.interrupt->load()) {
      result.interrupted = true;
      break;
    }
    const int count = std::min(o.population, o.budget - g * o.population);
    const Eigen::MatrixXd unit = search.draw(g, count);
    std::vector<TuneCandidate> gen = generation_candidates(o, s, g, unit);
    // a generation with a run cut short is abandoned: a resumed search runs it again
    if (!run_generation(o, s, first, result.duration, g, gen)) {
      result.interrupted = true;
      break;
    }
    for (TuneCandidate& c : gen) {
      aggregate_runs(c);
      result.candidates.push_back(c);
      if (c.robust_score < result.candidates[result.best].robust_score)
        result.best = static_cast<int>(result.candidates.size()) - 1;
    }
    search.learn(unit, gen);
    result.finished_generations = g + 1;
    result.checkpoint = tune_checkpoint(o, result, search);
    result.scenario_yaml = best_scenario_yaml(o, s.base, result);
    if (on_generation) on_generation(result, g);
  }
  return result;
}

}  // namespace stance
