// Batches from Python: stance.sweep, stance.tune and stance.robustness, the CLI's commands over
// threads with the GIL released, their results as numpy arrays.
#include <cmath>
#include <optional>

#include "batch/robustness.h"
#include "batch/sweep.h"
#include "batch/tune.h"
#include "bindings.h"
#include "sim/scenario.h"

namespace stance::python {
namespace {

// d[name] = a numpy array of `rows` values of type T, value(i) for row i
template <class T, class Value>
void add_column(py::dict& d, const char* name, py::ssize_t rows, Value value) {
  py::array_t<T> column(rows);
  for (py::ssize_t i = 0; i < rows; ++i) column.mutable_at(i) = value(i);
  d[name] = column;
}

// NaN where a time is absent
double time_or_nan(const std::optional<double>& t) {
  return t ? *t : std::nan("");
}

void bind_sweep(py::module_& m) {
  m.def(
      "sweep",
      [](const PathArg& path, const std::string& param, std::vector<double> values,
         const py::object& overrides, const std::string& engine, std::optional<double> duration,
         int threads) {
        SweepOptions o;
        o.scenario = path.string();
        o.sets = override_list(overrides);
        o.param = param;
        o.values = std::move(values);
        o.engine = engine;
        o.duration = duration;
        o.threads = threads;
        std::vector<SweepPoint> points;
        {
          py::gil_scoped_release release;
          points = run_sweep(o);
        }
        const py::ssize_t n = points.size();
        py::list metrics, errors;
        for (const SweepPoint& p : points) {
          metrics.append(json_to_py(without_wall_clock(p.result.metrics)));
          errors.append(p.error);
        }
        const auto& p = points;
        py::dict d;
        add_column<double>(d, "value", n, [&](py::ssize_t i) { return p[i].value; });
        add_column<bool>(d, "fell", n, [&](py::ssize_t i) { return p[i].result.fell; });
        add_column<double>(d, "fall_time", n,
                           [&](py::ssize_t i) { return time_or_nan(p[i].result.fall_time); });
        add_column<bool>(d, "diverged", n, [&](py::ssize_t i) { return p[i].result.diverged; });
        add_column<double>(d, "sim_time", n, [&](py::ssize_t i) { return p[i].result.sim_time; });
        d["metrics"] = metrics;
        d["error"] = errors;
        return d;
      },
      py::arg("path"), py::arg("param"), py::arg("values"), py::arg("overrides") = py::none(),
      py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("threads") = 0,
      R"(`stance sweep`: the scenario run once per value of the key path `param`, on `threads`
threads (0: every core; results do not depend on it), the GIL released. Returns a dict of numpy
arrays (value, fell, fall_time (NaN: stood), diverged, sim_time) and lists (metrics without the
wall-clock ones, error: non-empty where that run's input was bad).)");
}

void bind_tune(py::module_& m) {
  m.def(
      "tune",
      [](const PathArg& path, const std::vector<std::string>& params,
         const std::vector<std::string>& neighbours, int budget, int population,
         unsigned long long seed, const std::string& metric, double fall_penalty,
         const py::object& overrides, const std::string& engine, std::optional<double> duration,
         int threads, const std::string& method) {
        TuneOptions o;
        o.method = method;
        o.scenario = path.string();
        o.sets = override_list(overrides);
        for (const auto& p : params) o.params.push_back(parse_tune_param(p));
        for (const auto& n : neighbours) o.neighbours.push_back(parse_neighbour(n));
        o.budget = budget;
        o.population = population;
        o.seed = seed;
        o.metric = metric;
        o.fall_penalty = fall_penalty;
        o.engine = engine;
        o.duration = duration;
        o.threads = threads;
        TuneResult t;
        {
          py::gil_scoped_release release;
          t = run_tune(o);
        }
        const py::ssize_t n = t.candidates.size(), k = o.params.size();
        const std::vector<TuneCandidate>& c = t.candidates;
        py::array_t<double> values({n, k});
        for (py::ssize_t i = 0; i < n; ++i) {
          for (py::ssize_t j = 0; j < k; ++j) values.mutable_at(i, j) = c[i].values[j];
        }
        py::dict d;
        d["params"] = params;
        d["values"] = values;
        add_column<double>(d, "robust_score", n, [&](py::ssize_t i) { return c[i].robust_score; });
        add_column<double>(d, "worst_time_up", n,
                           [&](py::ssize_t i) { return c[i].worst_time_up; });
        add_column<double>(d, "mean_metric", n, [&](py::ssize_t i) { return c[i].mean_metric; });
        add_column<int>(d, "generation", n, [&](py::ssize_t i) { return c[i].generation; });
        add_column<int>(d, "failed_runs", n, [&](py::ssize_t i) { return c[i].failed_runs; });
        d["best"] = t.best;
        d["best_sets"] = n ? tune_assignments(o, t.candidates[t.best]) : std::vector<std::string>{};
        d["notes"] = t.notes;
        return d;
      },
      py::arg("path"), py::arg("params"), py::arg("neighbours") = std::vector<std::string>{},
      py::arg("budget") = 40, py::arg("population") = 8, py::arg("seed") = 1,
      py::arg("metric") = "", py::arg("fall_penalty") = 100.0, py::arg("overrides") = py::none(),
      py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("threads") = 0,
      py::arg("method") = "cem",
      R"(`stance tune`: a seeded search over params ("key=lo:hi[:log]"), method "cem" (the
cross-entropy method) or "cmaes" (CMA-ES), each
candidate scored by its worst run over the nominal setting and the neighbours ("k*=0.85,k2=v"),
the GIL released; the same results for any thread count. Returns a dict: values (candidates x
params), robust_score, worst_time_up, mean_metric, generation, failed_runs (numpy arrays in
evaluation order; row 0 is the start), best (an index), best_sets (--set lines), notes.)");
}

void bind_robustness(py::module_& m) {
  m.def(
      "robustness",
      [](const PathArg& path, const std::string& body, int directions, int phases,
         double push_duration, double max_force, double tolerance, double at, double phase_spacing,
         double recovery_window, int max_steps, const std::string& point,
         const py::object& overrides, const std::string& engine, std::optional<double> duration,
         int threads) {
        RobustnessOptions o;
        o.body = body;
        o.directions = directions;
        o.phases = phases;
        o.push_duration = push_duration;
        o.max_force = max_force;
        o.tolerance = tolerance;
        o.at = at;
        o.phase_spacing_s = phase_spacing;
        o.recovery_window_s = recovery_window;
        o.max_recovery_steps = max_steps;
        parse_push_point(point, o.point, o.offset);
        o.engine = engine;
        o.duration = duration;
        o.threads = threads;
        LoadedScenario loaded = load_scenario(path.string(), override_list(overrides));
        RobustnessResult r;
        {
          py::gil_scoped_release release;
          r = run_robustness(loaded, o);
        }
        // thresholds as a directions x phases grid, trials flat in the order they ran
        const py::ssize_t nd = r.directions.size(), np_ = r.phase_fractions.size();
        py::array_t<double> threshold({nd, np_}), fell_at({nd, np_}), angles(nd), starts(np_);
        py::array_t<int> outcome({nd, np_});
        std::vector<const RobustnessTrial*> trials;
        for (py::ssize_t d = 0; d < nd; ++d) {
          angles.mutable_at(d) = r.angles_deg[d];
          for (py::ssize_t p = 0; p < np_; ++p) {
            const RobustnessCell& c = r.cell(d, p);
            threshold.mutable_at(d, p) = c.threshold;
            fell_at.mutable_at(d, p) = time_or_nan(c.fell);
            outcome.mutable_at(d, p) = c.outcome_at_threshold;
            for (const auto& t : c.trials) trials.push_back(&t);
          }
        }
        for (py::ssize_t p = 0; p < np_; ++p) starts.mutable_at(p) = r.push_starts[p];
        const py::ssize_t nt = trials.size();
        const auto& t = trials;
        py::dict trial;
        add_column<int>(trial, "direction", nt, [&](py::ssize_t i) { return t[i]->direction; });
        add_column<int>(trial, "phase", nt, [&](py::ssize_t i) { return t[i]->phase; });
        add_column<double>(trial, "force", nt, [&](py::ssize_t i) { return t[i]->force; });
        add_column<int>(trial, "outcome", nt, [&](py::ssize_t i) { return t[i]->outcome; });
        add_column<double>(trial, "fall_time", nt,
                           [&](py::ssize_t i) { return time_or_nan(t[i]->fall_time); });
        add_column<int>(trial, "recovery_steps", nt,
                        [&](py::ssize_t i) { return t[i]->recovery_steps; });
        add_column<double>(trial, "detour_m", nt, [&](py::ssize_t i) { return t[i]->detour_m; });
        py::dict d;
        d["threshold"] = threshold;
        d["fell_at"] = fell_at;
        d["outcome"] = outcome;
        d["angle_deg"] = angles;
        d["push_start"] = starts;
        d["walker"] = r.walker;
        d["planar"] = r.planar;
        d["feet"] = r.feet;
        d["trials"] = trial;
        d["summary"] = json_to_py(robustness_summary(o, r));
        d["notes"] = r.notes;
        return d;
      },
      py::arg("path"), py::arg("body"), py::arg("directions") = 8, py::arg("phases") = 4,
      py::arg("push_duration") = 0.2, py::arg("max_force") = 800.0, py::arg("tolerance") = 2.0,
      py::arg("at") = 2.0, py::arg("phase_spacing") = 0.25, py::arg("recovery_window") = 3.0,
      py::arg("max_steps") = 3, py::arg("point") = "com", py::arg("overrides") = py::none(),
      py::arg("engine") = "", py::arg("duration") = std::nullopt, py::arg("threads") = 0,
      R"(`stance robustness`: the largest push survived per direction and phase (docs/robustness.md),
the GIL released; the same results for any thread count. Returns a dict: threshold, fell_at (NaN:
max_force survived) and outcome (outcome code at the threshold) as directions x phases numpy
arrays; angle_deg per direction; push_start per phase; walker, planar, feet; trials (numpy arrays
in the order the trials ran: direction, phase, force, outcome, fall_time, recovery_steps,
detour_m); summary (summary.json's content) and notes.)");
}

}  // namespace

void bind_batch(py::module_& m) {
  bind_sweep(m);
  bind_tune(m);
  bind_robustness(m);
}

}  // namespace stance::python
