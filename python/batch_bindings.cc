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
        py::array_t<double> value(n), sim_time(n), fall_time(n);
        py::array_t<bool> fell(n), diverged(n);
        py::list metrics, errors;
        for (py::ssize_t i = 0; i < n; ++i) {
          const SweepPoint& p = points[i];
          value.mutable_at(i) = p.value;
          sim_time.mutable_at(i) = p.result.sim_time;
          fell.mutable_at(i) = p.result.fell;
          diverged.mutable_at(i) = p.result.diverged;
          fall_time.mutable_at(i) = p.result.fall_time ? *p.result.fall_time : std::nan("");
          metrics.append(json_to_py(without_wall_clock(p.result.metrics)));
          errors.append(p.error);
        }
        py::dict d;
        d["value"] = value;
        d["fell"] = fell;
        d["fall_time"] = fall_time;
        d["diverged"] = diverged;
        d["sim_time"] = sim_time;
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
        py::array_t<double> values({n, k}), score(n), time_up(n), metric_mean(n);
        py::array_t<int> generation(n), failed(n);
        for (py::ssize_t i = 0; i < n; ++i) {
          const TuneCandidate& c = t.candidates[i];
          for (py::ssize_t j = 0; j < k; ++j) values.mutable_at(i, j) = c.values[j];
          score.mutable_at(i) = c.robust_score;
          time_up.mutable_at(i) = c.worst_time_up;
          metric_mean.mutable_at(i) = c.mean_metric;
          generation.mutable_at(i) = c.generation;
          failed.mutable_at(i) = c.failed_runs;
        }
        py::dict d;
        d["params"] = params;
        d["values"] = values;
        d["robust_score"] = score;
        d["worst_time_up"] = time_up;
        d["mean_metric"] = metric_mean;
        d["generation"] = generation;
        d["failed_runs"] = failed;
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
            fell_at.mutable_at(d, p) = c.fell ? *c.fell : std::nan("");
            outcome.mutable_at(d, p) = c.outcome_at_threshold;
            for (const auto& t : c.trials) trials.push_back(&t);
          }
        }
        for (py::ssize_t p = 0; p < np_; ++p) starts.mutable_at(p) = r.push_starts[p];
        const py::ssize_t nt = trials.size();
        py::array_t<int> t_dir(nt), t_phase(nt), t_outcome(nt), t_steps(nt);
        py::array_t<double> t_force(nt), t_fall(nt), t_detour(nt);
        for (py::ssize_t i = 0; i < nt; ++i) {
          const RobustnessTrial& t = *trials[i];
          t_dir.mutable_at(i) = t.direction;
          t_phase.mutable_at(i) = t.phase;
          t_force.mutable_at(i) = t.force;
          t_outcome.mutable_at(i) = t.outcome;
          t_fall.mutable_at(i) = t.fall_time ? *t.fall_time : std::nan("");
          t_steps.mutable_at(i) = t.recovery_steps;
          t_detour.mutable_at(i) = t.detour_m;
        }
        py::dict trial;
        trial["direction"] = t_dir;
        trial["phase"] = t_phase;
        trial["force"] = t_force;
        trial["outcome"] = t_outcome;
        trial["fall_time"] = t_fall;
        trial["recovery_steps"] = t_steps;
        trial["detour_m"] = t_detour;
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
