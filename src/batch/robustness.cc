#include "batch/robustness.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <sstream>

#include "batch/batch_ranks.h"
#include "batch/push_threshold.h"
#include "batch/sweep.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "sim/simulation.h"

namespace stance {

namespace {

using Horizontal = Eigen::Matrix<double, 2, 3>;  // rows: the plane's axes e1, e2

// e1: world x projected on the plane normal to `up` (world y when x is vertical), e2 = up x e1
Horizontal horizontal_basis(const Eigen::Vector3d& up) {
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX() - up.dot(Eigen::Vector3d::UnitX()) * up;
  if (e1.norm() < 1e-6) e1 = Eigen::Vector3d::UnitY() - up.dot(Eigen::Vector3d::UnitY()) * up;
  e1.normalize();
  Horizontal h;
  h.row(0) = e1.transpose();
  h.row(1) = up.cross(e1).normalized().transpose();
  return h;
}

// exact zeros where a direction's component is rounding noise, so that the +-x directions push
// exactly as push-threshold's --axis x does
Eigen::Vector3d snapped(Eigen::Vector3d d) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(d[i]) < 1e-12) d[i] = 0;
  return d;
}

double snapped(double x) {
  return std::abs(x) < 1e-12 ? 0.0 : x;
}

// feet touching the ground, touchdowns and lift-offs, and the root's detour from a reference run
class GaitObserver final : public StepObserver {
 public:
  GaitObserver(const std::vector<std::vector<int>>& feet, double min_air_s, const Horizontal& h)
      : feet_(&feet), min_air_s_(min_air_s), h_(h) {}

  // record the root at every step (the unpushed run)
  std::vector<Eigen::Vector3d>* record_root = nullptr;
  // compare the root with this run's at the same step, from detour_from_s on
  const std::vector<Eigen::Vector3d>* reference_root = nullptr;
  double detour_from_s = 0;
  // mark every body that touches the ground before a fall (to find the feet)
  std::vector<char>* touched = nullptr;

  std::vector<double> touchdowns;  // s
  std::vector<double> liftoffs;    // s: a foot left the ground (for at least min_air_s)
  double detour_m = 0;

  void on_start(const Simulation& sim) override {
    const Engine& e = sim.engine();
    down_.assign(feet_->size(), 0);
    air_since_.assign(feet_->size(), e.time());
    lift_counted_.assign(feet_->size(), 0);
    for (size_t f = 0; f < feet_->size(); ++f) down_[f] = foot_down(e, f);
    observe_root(sim);
  }

  void on_step(const Simulation& sim) override {
    const Engine& e = sim.engine();
    const double t = e.time();
    for (size_t f = 0; f < feet_->size(); ++f) {
      const bool down = foot_down(e, f);
      if (down && !down_[f]) {
        if (t - air_since_[f] >= min_air_s_) touchdowns.push_back(t);
      } else if (!down && down_[f]) {
        air_since_[f] = t;
        lift_counted_[f] = 0;
      } else if (!down && !lift_counted_[f] && t - air_since_[f] >= min_air_s_) {
        lift_counted_[f] = 1;
        liftoffs.push_back(air_since_[f]);
      }
      down_[f] = down;
    }
    if (touched && !sim.progress().fell)
      for (int i = 0, n = e.num_contacts(); i < n; ++i) {
        const Contact c = e.contact(i);
        if (c.body1 < 0 && c.body2 >= 0) (*touched)[c.body2] = 1;
        if (c.body2 < 0 && c.body1 >= 0) (*touched)[c.body1] = 1;
      }
    observe_root(sim);
  }

 private:
  bool foot_down(const Engine& e, size_t f) const {
    for (int b : (*feet_)[f])
      if (e.body_touches_ground(b)) return true;
    return false;
  }
  void observe_root(const Simulation& sim) {
    const Engine& e = sim.engine();
    if (e.nbody() == 0) return;
    const Eigen::Vector3d root = e.body_pose(0).pos;
    if (record_root) record_root->push_back(root);
    const long k = sim.progress().steps;
    if (reference_root && e.time() >= detour_from_s - 1e-12 && k >= 0 &&
        k < static_cast<long>(reference_root->size()))
      detour_m = std::max(detour_m, (h_ * (root - (*reference_root)[k])).norm());
  }

  const std::vector<std::vector<int>>* feet_;
  double min_air_s_;
  Horizontal h_;
  std::vector<char> down_, lift_counted_;
  std::vector<double> air_since_;
};

// abandons a direction and phase when the run is interrupted
struct Interrupted {};

int count_in(const std::vector<double>& times, double from, double to) {
  return static_cast<int>(
      std::count_if(times.begin(), times.end(), [&](double t) { return t >= from && t <= to; }));
}

void validate(const RobustnessOptions& o) {
  if (o.body.empty()) throw InputError("robustness: --body is required");
  if (o.directions < 1 || o.directions > 360)
    throw InputError(fmt::format("robustness: --directions {} not in 1..360", o.directions));
  if (o.phases < 1 || o.phases > 100)
    throw InputError(fmt::format("robustness: --phases {} not in 1..100", o.phases));
  auto positive = [](double x, const char* what) {
    if (!(std::isfinite(x) && x > 0))
      throw InputError(fmt::format("robustness: {} must be a finite number > 0", what));
  };
  positive(o.push_duration, "--push-duration");
  positive(o.max_force, "--max");
  positive(o.tolerance, "--tolerance");
  positive(o.recovery_window_s, "--recovery-window");
  positive(o.phase_spacing_s, "--phase-spacing");
  if (!(std::isfinite(o.at) && o.at >= 0))
    throw InputError("robustness: --at must be a finite number >= 0");
  if (!(std::isfinite(o.min_air_s) && o.min_air_s >= 0))
    throw InputError("robustness: min_air_s must be >= 0");
  if (o.max_recovery_steps < 0) throw InputError("robustness: --max-steps must be >= 0");
  if (o.duration && !(std::isfinite(*o.duration) && *o.duration > 0))
    throw InputError("robustness: --duration must be a finite number > 0");
  if (!o.offset.allFinite()) throw InputError("--point: the offset must be finite");
  push_point_is_origin(o.point, "--point");
}

}  // namespace

PushOutcome push_outcome(std::optional<double> fall_time, double push_start, bool stepped) {
  if (fall_time)
    return *fall_time < push_start ? PushOutcome::kFellBefore : PushOutcome::kFellAfter;
  return stepped ? PushOutcome::kManySteps : PushOutcome::kSuccess;
}

nlohmann::json RobustnessResult::summary() const {
  nlohmann::json s;
  if (cells.empty()) return s;
  const RobustnessCell* weakest = &cells.front();
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0;
  for (const auto& c : cells) {
    lo = std::min(lo, c.threshold);
    hi = std::max(hi, c.threshold);
    sum += c.threshold;
    if (c.threshold < weakest->threshold) weakest = &c;
  }
  s["threshold_n"] = {{"min", lo}, {"mean", sum / cells.size()}, {"max", hi}};
  s["weakest"] = {{"direction", weakest->direction},
                  {"angle_deg", angles_deg[weakest->direction]},
                  {"phase", weakest->phase},
                  {"phase_fraction", phase_fractions[weakest->phase]},
                  {"push_start_s", push_starts[weakest->phase]},
                  {"threshold_n", weakest->threshold}};
  return s;
}

nlohmann::json cell_to_json(const RobustnessCell& c) {
  nlohmann::json trials = nlohmann::json::array();
  for (const auto& t : c.trials)
    trials.push_back({t.force, t.outcome,
                      t.fall_time ? nlohmann::json(*t.fall_time) : nlohmann::json(nullptr),
                      t.touchdowns, t.recovery_steps, t.detour_m});
  return {{"direction", c.direction},
          {"phase", c.phase},
          {"threshold", c.threshold},
          {"fell", c.fell ? nlohmann::json(*c.fell) : nlohmann::json(nullptr)},
          {"outcome_at_threshold", c.outcome_at_threshold},
          {"falls_unpushed", c.falls_unpushed},
          {"trials", trials}};
}

RobustnessCell cell_from_json(const nlohmann::json& j) {
  RobustnessCell c;
  c.done = true;
  c.direction = j.at("direction").get<int>();
  c.phase = j.at("phase").get<int>();
  c.threshold = j.at("threshold").get<double>();
  if (!j.at("fell").is_null()) c.fell = j.at("fell").get<double>();
  c.outcome_at_threshold = j.at("outcome_at_threshold").get<int>();
  c.falls_unpushed = j.at("falls_unpushed").get<bool>();
  for (const auto& row : j.at("trials")) {
    RobustnessTrial t;
    t.direction = c.direction;
    t.phase = c.phase;
    t.force = row.at(0).get<double>();
    t.outcome = row.at(1).get<int>();
    if (!row.at(2).is_null()) t.fall_time = row.at(2).get<double>();
    t.touchdowns = row.at(3).get<int>();
    t.recovery_steps = row.at(4).get<int>();
    t.detour_m = row.at(5).get<double>();
    c.trials.push_back(t);
  }
  return c;
}

namespace {

// what every run of a map shares; not copied or moved (the gait observers point at its feet)
struct RobustnessSetup {
  RobustnessSetup(const LoadedScenario& l, const RobustnessOptions& opts) : loaded(l), o(opts) {}

  const LoadedScenario& loaded;
  const RobustnessOptions& o;
  ControllerCache cache;
  double duration = 0;                 // s, of every run
  Horizontal h;                        // the horizontal plane's axes
  std::vector<std::vector<int>> feet;  // each foot's bodies
  // the unpushed run: its gait, and its root at every step (the detours' reference)
  std::unique_ptr<GaitObserver> baseline;
  std::vector<Eigen::Vector3d> baseline_root;

  Perturbation push(const Eigen::Vector3d& force, double start) const {
    Perturbation p;
    p.body = o.body;
    p.force = force;
    p.start = start;
    p.duration = o.push_duration;
    p.point = o.point;
    p.offset = o.offset;
    return p;
  }
  // the options of one run, sharing the cache
  RunOptions run_options() {
    RunOptions r;
    r.engine = o.engine;
    r.duration = duration;
    r.quiet = true;
    r.cache = &cache;
    return r;
  }
};

// the directions: the plane's, or the two senses of the one a planar model can move along
void find_directions(const RobustnessSetup& s, Engine& e, const ResolvedPush& pushed,
                     RobustnessResult& result) {
  const RobustnessOptions& o = s.o;
  const Horizontal& h = s.h;
  Eigen::MatrixXd jac(3, e.nv()), none(3, 0);
  e.point_jacobian(pushed.body, push_point(e, pushed), jac, none);
  const Eigen::Matrix2d reach = (h * jac) * (h * jac).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(reach);
  const double big = eig.eigenvalues()[1], small = eig.eigenvalues()[0];
  if (!(big > 1e-12))
    throw InputError(fmt::format(
        "robustness: body '{}' cannot move horizontally (a fixed base?): nothing to push", o.body));
  result.planar = small < 1e-9 * big;
  if (result.planar) {
    Eigen::Vector2d a = eig.eigenvectors().col(1);
    for (int i = 0; i < 2; ++i) a[i] = snapped(a[i]);
    if (a[0] < 0 || (a[0] == 0 && a[1] < 0)) a = -a;
    const double angle = std::atan2(a[1], a[0]) * 180 / std::numbers::pi;
    for (double sign : {1.0, -1.0}) {
      result.directions.push_back(snapped(Eigen::Vector3d(sign * h.transpose() * a)));
      result.angles_deg.push_back(sign > 0 ? angle : angle + 180);
    }
    if (o.directions != 2)
      result.notes.push_back(fmt::format(
          "planar model: '{}' moves along one horizontal direction only, so the map has its "
          "two senses ({} and {} degrees) instead of {} directions",
          o.body, result.angles_deg[0], result.angles_deg[1], o.directions));
    return;
  }
  for (int k = 0; k < o.directions; ++k) {
    const double deg = 360.0 * k / o.directions;
    const double rad = deg * std::numbers::pi / 180;
    const double c = snapped(std::cos(rad)), sn = snapped(std::sin(rad));
    result.directions.push_back(snapped(Eigen::Vector3d(c * h.row(0) + sn * h.row(1))));
    result.angles_deg.push_back(deg);
  }
}

// the feet: the allowed contacts, else what touches the ground in the unpushed run; a foot is
// a topmost such body with the such bodies below it
void find_feet(RobustnessSetup& s, const Simulation& probe, RobustnessResult& result) {
  const Engine& e = probe.engine();
  std::vector<char> is_foot(probe.model().allowed_contact.begin(),
                            probe.model().allowed_contact.end());
  is_foot.resize(e.nbody(), 0);
  if (std::find(is_foot.begin(), is_foot.end(), 1) == is_foot.end()) {
    std::vector<std::vector<int>> none;
    GaitObserver finder(none, s.o.min_air_s, s.h);
    finder.touched = &is_foot;
    Simulation sim(s.loaded, s.run_options());
    sim.add_observer(&finder);
    sim.run();
    result.notes.push_back(
        "feet: the bodies that touch the ground in the unpushed run (no fall.allowed_contacts)");
  }
  std::vector<int> top(e.nbody(), -1);
  for (int b = 0; b < e.nbody(); ++b) {
    if (!is_foot[b]) continue;
    top[b] = b;
    for (int p = e.body_parent(b); p >= 0; p = e.body_parent(p))
      if (is_foot[p]) top[b] = p;
  }
  for (int b = 0; b < e.nbody(); ++b) {
    if (top[b] != b) continue;
    s.feet.push_back({});
    for (int c = 0; c < e.nbody(); ++c)
      if (top[c] == b) s.feet.back().push_back(c);
    result.feet.push_back(e.body_name(b));
  }
}

// the unpushed run, to the end even after a fall: the gait and the root to measure detours by
void run_baseline(RobustnessSetup& s, RobustnessResult& result) {
  s.baseline = std::make_unique<GaitObserver>(s.feet, s.o.min_air_s, s.h);
  s.baseline_root.clear();
  s.baseline->record_root = &s.baseline_root;
  RunOptions ro = s.run_options();
  ro.stop_after_fall_s = -1;
  Simulation sim(s.loaded, ro);
  sim.add_observer(s.baseline.get());
  RunResult r = sim.run();
  result.unpushed_fall_time.reset();
  if (r.fell) result.unpushed_fall_time = r.fall_time;
  if (r.diverged) result.unpushed_fall_time = r.sim_time;
}

// the phases' push times: a walker's over the step after `at`, else `phase_spacing_s` apart;
// runs are lengthened (and the baseline run again) to hold the last push's recovery window
void find_phases(RobustnessSetup& s, RobustnessResult& result) {
  const RobustnessOptions& o = s.o;
  std::vector<double> after;
  for (double t : s.baseline->touchdowns)
    if (t >= o.at) after.push_back(t);
  result.walker =
      after.size() >= 2 && !(result.unpushed_fall_time && *result.unpushed_fall_time < after[1]);
  for (int j = 0; j < o.phases; ++j) {
    const double fraction = static_cast<double>(j) / o.phases;
    result.phase_fractions.push_back(fraction);
    if (result.walker)
      result.push_starts.push_back(after[0] + fraction * (after[1] - after[0]));
    else
      result.push_starts.push_back(o.at + j * o.phase_spacing_s);
  }
  if (result.walker) result.step_period_s = after[1] - after[0];
  const double needed = *std::max_element(result.push_starts.begin(), result.push_starts.end()) +
                        o.push_duration + o.recovery_window_s;
  if (needed > s.duration + 1e-9) {
    result.notes.push_back(
        fmt::format("runs lengthened from {} s to {} s: the last push and its {} s recovery window",
                    s.duration, needed, o.recovery_window_s));
    s.duration = needed;
    run_baseline(s, result);
  }
  result.duration_s = s.duration;
}

// one pushed run of a cell's bisection, recorded in the cell; true when it survived
bool push_trial(RobustnessSetup& s, const RobustnessResult& result, RobustnessCell& cell,
                double force) {
  const RobustnessOptions& o = s.o;
  const double start = result.push_starts[cell.phase];
  const double window_from = start + o.push_duration, window_to = window_from + o.recovery_window_s;
  RobustnessTrial t;
  t.direction = cell.direction;
  t.phase = cell.phase;
  t.force = force;
  RunOptions ro = s.run_options();
  ro.interrupt = o.interrupt;
  ro.extra_pushes.push_back(s.push(force * result.directions[cell.direction], start));
  GaitObserver gait(s.feet, o.min_air_s, s.h);
  gait.reference_root = &s.baseline_root;
  gait.detour_from_s = start;
  Simulation sim(s.loaded, ro);
  sim.add_observer(&gait);
  const RunResult r = sim.run();
  if (r.interrupted) throw Interrupted{};
  if (r.fell) t.fall_time = r.fall_time;
  if (r.diverged) t.fall_time = r.sim_time;
  t.touchdowns = count_in(gait.touchdowns, window_from, window_to);
  t.recovery_steps = t.touchdowns - count_in(s.baseline->touchdowns, window_from, window_to);
  t.detour_m = gait.detour_m;
  const bool stepped = result.walker ? t.recovery_steps > o.max_recovery_steps
                                     : count_in(gait.liftoffs, start, s.duration) > 0;
  t.outcome = static_cast<int>(push_outcome(t.fall_time, start, stepped));
  cell.trials.push_back(t);
  return t.survived();
}

// one direction and phase (cell `index`): the largest push survived, by bisection
void search_cell(RobustnessSetup& s, RobustnessResult& result, int index) {
  RobustnessCell& cell = result.cells[index];
  const int np = s.o.phases;
  cell.direction = index / np;
  cell.phase = index % np;
  const PushBracket b =
      bisect_push([&](double force) { return push_trial(s, result, cell, force); }, s.o.max_force,
                  s.o.tolerance);
  cell.threshold = b.survived;
  cell.fell = b.fell;
  cell.falls_unpushed = b.falls_unpushed;
  for (const auto& t : cell.trials)
    if (t.force == (b.falls_unpushed ? 0.0 : b.survived)) cell.outcome_at_threshold = t.outcome;
  cell.done = true;
}

// the cells of an interrupted map, in place; returns how many there were
int keep_finished(const std::vector<RobustnessCell>& finished, int nd, int np,
                  RobustnessResult& result) {
  int done = 0;
  for (const auto& c : finished) {
    if (c.direction < 0 || c.direction >= nd || c.phase < 0 || c.phase >= np)
      throw InputError(
          fmt::format("--resume: direction {} phase {} is not in this map", c.direction, c.phase));
    RobustnessCell& cell = result.cells[c.direction * np + c.phase];
    if (!cell.done) ++done;
    cell = c;
    cell.done = true;
  }
  return done;
}

// every cell not yet done, over threads and MPI ranks; on_cell reports each (on rank 0)
void search_cells(RobustnessSetup& s, RobustnessResult& result, int done,
                  const std::function<void(const RobustnessCell&, int done, int total)>& on_cell) {
  const RobustnessOptions& o = s.o;
  const int total = static_cast<int>(result.cells.size());
  std::mutex report;
  BatchRanks& ranks = BatchRanks::get();
  // an interrupted search leaves its cell as it was (not done); the others stop starting
  std::atomic<bool> stopped{false};
  ranks.distributed_for(
      total, o.threads,
      [&](int index) {
        try {
          if (result.cells[index].done) return;
          if (o.interrupt && o.interrupt->load()) throw Interrupted{};
          search_cell(s, result, index);
          if (!ranks.root()) return;
          std::lock_guard<std::mutex> lock(report);
          ++done;
          if (on_cell) on_cell(result.cells[index], done, total);
        } catch (const Interrupted&) {
          result.cells[index] = RobustnessCell{};
          stopped = true;
        }
      },
      [&](int index) {
        const RobustnessCell& c = result.cells[index];
        return c.done ? cell_to_json(c).dump() : std::string();
      },
      [&](int index, const std::string& text) {
        if (text.empty()) return;
        result.cells[index] = cell_from_json(nlohmann::json::parse(text));
        ++done;
        if (on_cell) on_cell(result.cells[index], done, total);
      });
  for (const auto& c : result.cells) result.interrupted = result.interrupted || !c.done;
  if (!result.interrupted && stopped) result.interrupted = true;
}

}  // namespace

RobustnessResult run_robustness(
    const LoadedScenario& loaded, const RobustnessOptions& options,
    const std::function<void(const RobustnessCell&, int done, int total)>& on_cell,
    const std::vector<RobustnessCell>& finished) {
  const RobustnessOptions& o = options;
  validate(o);
  RobustnessResult result;
  result.scenario = loaded.scenario.name;
  RobustnessSetup s(loaded, o);
  s.duration = o.duration.value_or(loaded.scenario.duration);

  // a probe: the body, the engine and the point resolve here, on this thread
  RunOptions probe_options = s.run_options();
  probe_options.extra_pushes.push_back(s.push(Eigen::Vector3d::Zero(), 0));
  Simulation probe(loaded, probe_options);
  Engine& e = probe.engine();
  result.engine = std::string(e.engine_name());
  e.forward();
  s.h = horizontal_basis(probe.model().up);
  find_directions(s, e, probe.model().pushes.back(), result);
  find_feet(s, probe, result);
  run_baseline(s, result);
  find_phases(s, result);

  // every direction and phase: an independent bisection
  const int nd = static_cast<int>(result.directions.size()), np = o.phases;
  result.cells.resize(nd * np);
  const int done = keep_finished(finished, nd, np, result);
  search_cells(s, result, done, on_cell);
  return result;
}

nlohmann::json robustness_summary(const RobustnessOptions& o, const RobustnessResult& r) {
  nlohmann::json s = r.summary();
  s["scenario"] = r.scenario;
  s["engine"] = r.engine;
  s["body"] = o.body;
  s["point"] = o.point;
  s["offset_m"] = {o.offset.x(), o.offset.y(), o.offset.z()};
  s["kind"] = r.walker ? "walker" : "standing";
  s["planar"] = r.planar;
  if (r.walker) s["step_period_s"] = r.step_period_s;
  s["feet"] = r.feet;
  s["duration_s"] = r.duration_s;
  s["push_duration_s"] = o.push_duration;
  s["max_force_n"] = o.max_force;
  s["tolerance_n"] = o.tolerance;
  s["recovery_window_s"] = o.recovery_window_s;
  s["max_recovery_steps"] = o.max_recovery_steps;
  s["directions"] = r.directions.size();
  s["phases"] = r.phase_fractions.size();
  s["push_starts_s"] = r.push_starts;
  s["unpushed_fall_time_s"] =
      r.unpushed_fall_time ? nlohmann::json(*r.unpushed_fall_time) : nlohmann::json(nullptr);
  int trials = 0;
  for (const auto& c : r.cells) trials += static_cast<int>(c.trials.size());
  s["trials"] = trials;
  s["notes"] = r.notes;
  return s;
}

void write_robustness_outputs(const std::string& dir, const RobustnessOptions& o,
                              const RobustnessResult& r) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  const fs::path folder(dir);
  {
    AtomicFile file(folder / "robustness.csv");
    std::ostream& out = file.stream();
    out << "direction,angle_deg,phase,phase_fraction,push_start_s,force_n,outcome,fall_time_s,"
           "touchdowns,recovery_steps,detour_m\n";
    for (const auto& c : r.cells)
      for (const auto& t : c.trials)
        out << fmt::format("{},{},{},{},{},{},{},{},{},{},{}\n", t.direction,
                           r.angles_deg[t.direction], t.phase, r.phase_fractions[t.phase],
                           r.push_starts[t.phase], t.force, t.outcome,
                           t.fall_time ? fmt::format("{}", *t.fall_time) : "", t.touchdowns,
                           t.recovery_steps, t.detour_m);
    file.commit();
  }
  {
    AtomicFile file(folder / "thresholds.csv");
    std::ostream& out = file.stream();
    out << "direction,angle_deg,phase,phase_fraction,push_start_s,threshold_n,"
           "outcome_at_threshold,fell_at_n,trials\n";
    for (const auto& c : r.cells)
      out << fmt::format("{},{},{},{},{},{},{},{},{}\n", c.direction, r.angles_deg[c.direction],
                         c.phase, r.phase_fractions[c.phase], r.push_starts[c.phase], c.threshold,
                         c.outcome_at_threshold, c.fell ? fmt::format("{}", *c.fell) : "",
                         c.trials.size());
    file.commit();
  }
  write_file_atomically(folder / "summary.json", robustness_summary(o, r).dump(2) + "\n");
}

namespace {
// two directions (a planar model's senses, or --directions 2): a polar plot of two points says
// little, so bars: the threshold per phase, one bar per direction
std::string plot_two_directions(const std::filesystem::path& folder, const RobustnessResult& r) {
  {
    AtomicFile file(folder / "robustness_bars.dat");
    std::ostream& out = file.stream();
    for (size_t p = 0; p < r.phase_fractions.size(); ++p) {
      const std::string label = r.walker ? fmt::format("phase {:g}", r.phase_fractions[p])
                                         : fmt::format("push at {:g} s", r.push_starts[p]);
      out << fmt::format("\"{}\" {} {}\n", label, r.cell(0, p).threshold, r.cell(1, p).threshold);
    }
    file.commit();
  }
  double top = 1;
  for (const auto& c : r.cells) top = std::max(top, c.threshold);
  const std::string script = fmt::format(
      "set terminal pngcairo size 800,520 enhanced font 'sans,11'\n"
      "set output png\n"
      "set title \"{} on {}: largest push survived{}\" noenhanced\n"
      "set style data histograms\nset style histogram clustered gap 1\n"
      "set style fill solid 0.85 border -1\nset boxwidth 0.9\n"
      "set yrange [0:{}]\nset ylabel 'N'\nset grid ytics\nset key top right\n"
      "plot 'robustness_bars.dat' using 2:xtic(1) title '{:g} degrees' lc rgb '#1f77b4', "
      "'' using 3 title '{:g} degrees' lc rgb '#ff7f0e'\n",
      r.scenario, r.engine, r.planar ? " (planar: its two senses)" : "", std::ceil(top * 1.15),
      r.angles_deg[0], r.angles_deg[1]);
  return render_gnuplot(folder.string(), "robustness.gp", script, "robustness.png");
}
}  // namespace

std::string plot_robustness(const std::string& dir, const RobustnessResult& r) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::absolute(dir);
  fs::create_directories(folder);
  if (r.directions.size() == 2) return plot_two_directions(folder, r);
  // one block per phase, the first direction repeated to close the curve
  {
    AtomicFile file(folder / "robustness_polar.dat");
    std::ostream& out = file.stream();
    const int np = static_cast<int>(r.phase_fractions.size());
    const int nd = static_cast<int>(r.directions.size());
    for (int p = 0; p < np; ++p) {
      out << "# phase " << p << "\n";
      for (int k = 0; k <= nd; ++k) {
        const int d = k % nd;
        out << fmt::format("{} {}\n", r.angles_deg[d] + (k == nd ? 360 : 0),
                           r.cell(d, p).threshold);
      }
      out << "\n\n";
    }
    file.commit();
  }
  double top = 1;
  for (const auto& c : r.cells) top = std::max(top, c.threshold);
  std::string script = fmt::format(
      "set terminal pngcairo size 800,760 enhanced font 'sans,11'\n"
      "set output png\n"
      "set title \"{} on {}: largest push survived (N) against direction\" noenhanced\n"
      "set polar\nset angles degrees\nset size square\n"
      "unset border\nunset xtics\nunset ytics\nunset raxis\n"
      "set rrange [0:{}]\nset rtics format '%g N'\n"
      "set grid polar 45 lt 1 lc rgb '#cccccc'\n"
      "set ttics 0,45 format '%g°'\n"
      "set key outside right top\n",
      r.scenario, r.engine, std::ceil(top * 1.1));
  script += "plot ";
  for (size_t p = 0; p < r.phase_fractions.size(); ++p) {
    const std::string label = r.walker ? fmt::format("phase {:g}", r.phase_fractions[p])
                                       : fmt::format("push at {:g} s", r.push_starts[p]);
    script += fmt::format(
        "{}'robustness_polar.dat' index {} using 1:2 with linespoints lw 2 pt 7 "
        "title '{}'",
        p ? ", " : "", p, label);
  }
  script += "\n";
  return render_gnuplot(folder.string(), "robustness.gp", script, "robustness.png");
}

}  // namespace stance
