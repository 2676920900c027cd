// The sampling planner's parameters: the scenario's `planner:` block (docs/planner.md).
#pragma once

#include <string>
#include <vector>

namespace stance {

// the rollout cost: a time average of weighted squared residuals, plus a fall penalty
struct PlannerCostWeights {
  // while a controller tracks a reference (Controller::tracking_error)
  double joint = 4;      // per rad^2 of mean joint error
  double root = 4;       // per m^2 of root position error
  double body = 20;      // per m^2 of mean body position error
  double root_tilt = 2;  // per rad^2 of root tilt against the reference
  // while nothing is tracked: keep balance where the run started
  double capture = 20;      // per m^2 of the capture point's horizontal offset from the start
  double com_velocity = 1;  // per (m/s)^2 of horizontal COM velocity
  double upright = 5;       // per rad^2 of the root's tilt from its start
  double height = 50;       // per m^2 of COM height below its start
  // always
  double effort = 0.01;  // per squared unit of noise, mean over dimensions
  double change = 0;     // per squared unit of departure from the warm-started plan, mean
  double fall = 100;     // a fall in the horizon: this, times 1 + the share of the horizon left

  template <class V>
  void visit(V& v) {
    v("joint", joint, {.unit = "1/rad^2", .min = 0, .help = "tracking: mean joint error"});
    v("root", root, {.unit = "1/m^2", .min = 0, .help = "tracking: root position error"});
    v("body", body, {.unit = "1/m^2", .min = 0, .help = "tracking: mean body position error"});
    v("root_tilt", root_tilt, {.unit = "1/rad^2", .min = 0, .help = "tracking: root tilt"});
    v("capture", capture,
      {.unit = "1/m^2", .min = 0, .help = "no tracking: capture point's offset from the start"});
    v("com_velocity", com_velocity,
      {.unit = "s^2/m^2", .min = 0, .help = "no tracking: horizontal COM velocity"});
    v("upright", upright, {.unit = "1/rad^2", .min = 0, .help = "no tracking: root tilt"});
    v("height", height, {.unit = "1/m^2", .min = 0, .help = "no tracking: COM height lost"});
    v("effort", effort, {.min = 0, .help = "squared correction, in noise units"});
    v("change", change,
      {.min = 0, .help = "squared departure from the previous plan, in noise units"});
    v("fall", fall, {.min = 0, .help = "a fall within the horizon"});
  }
};

// the rollouts' constraint solver, when cheaper than the run's (MuJoCo's mjOption; DART keeps
// its own): each field at its default keeps the run's
struct PlannerSolverParams {
  int iterations = 0;          // 0: the run's
  double tolerance = -1;       // < 0: the run's
  int noslip_iterations = -1;  // -1: the run's
  std::string type;            // pgs, cg or newton; empty: the run's
  std::string cone;            // pyramidal or elliptic; empty: the run's

  template <class V>
  void visit(V& v) {
    v("iterations", iterations, {.min = 0, .max = 1000, .help = "solver iterations; 0: the run's"});
    v("tolerance", tolerance, {.min = -1, .max = 1, .help = "solver tolerance; -1: the run's"});
    v("noslip_iterations", noslip_iterations,
      {.min = -1, .max = 1000, .help = "noslip iterations (0: off); -1: the run's"});
    v("type", type, {.help = "pgs, cg or newton; empty: the run's"});
    v("cone", cone, {.help = "pyramidal or elliptic; empty: the run's"});
  }
};

struct PlannerParams {
  bool enabled = false;
  int samples = 32;                 // candidates per planning step, the current plan included
  double horizon_s = 0.5;           // s
  double interval_s = 0.04;         // s between planning steps
  int knots = 4;                    // spline knots over the horizon (piecewise linear)
  double noise = 1;                 // standard deviation, in units of each dimension's scale
  double limit = 3;                 // knots are clamped to +-limit units
  std::string method = "sampling";  // sampling (predictive sampling) or cem
  // what a rollout is scored by: a name in src/plan/objective.cc's registry
  std::string objective = "track_or_balance";
  int iterations = 2;             // cem: refits of the mean and deviation
  int elites = 4;                 // cem: candidates the refit keeps
  double timestep = 0;            // s, the rollouts' step if coarser than the run's; 0: the run's
  PlannerSolverParams solver;     // the rollouts' constraint solver
  double cost_interval_s = 0.01;  // s between cost samples in a rollout
  int threads = 0;                // rollout threads; 0: every core
  // in trouble, plan harder: while the run is at least `rescue_error_m` off (a tracked
  // reference's mean body error, else the capture point's offset; 0: never), `rescue_rounds`
  // more rounds of `samples` around the best
  double rescue_error_m = 0.15;  // m
  int rescue_rounds = 2;
  // on track, plan with fewer candidates: while a tracked reference's mean body error is under
  // `steady_error_m` (0: never; nothing tracked: never), `steady_samples` of them
  double steady_error_m = 0;  // m (off: measured, it cost more accuracy than it saved)
  int steady_samples = 16;
  // on track, stop a rollout once its cost so far trails the best's at the same time by more
  // than this share of the best's cost (0: only once it cannot win; off: measured, it cost
  // accuracy on some clips)
  double race_margin = 0;
  // stop drawing batches of candidates once a batch of 4 or more lowers the best cost by less
  // than this share of it (0: draw every sample; off: measured, it cost accuracy)
  double stop_margin = 0;
  // spend by need: once `calm_plans` planning steps in a row ran no rescue round, were under
  // `calm_error_m` and chose a plan that does not fall, plan cheaply (`calm_samples`
  // candidates, rollouts racing at `calm_race_margin`) until the first step that is not calm
  // (0: never; off: an option, measured in docs/planner.md#compute)
  int calm_plans = 0;
  double calm_error_m = 0.1;  // m
  int calm_samples = 32;
  double calm_race_margin = 0.1;
  // while calm, cheaper still (each off at its default): rollouts at a coarser step
  // (`calm_timestep`, s; 0: the rollouts' own), over the first `calm_horizon_s` of the horizon
  // (0: all of it), a new plan every `calm_every`-th interval (the plan kept in between); and a
  // step is not calm once its chosen rollout ends `calm_predicted_error_m` off (0: not read)
  double calm_timestep = 0;
  double calm_horizon_s = 0;
  int calm_every = 1;
  double calm_predicted_error_m = 0;
  // where no controller offers a correction: residual torques on these dofs (empty: every dof
  // of a hinge, slide or ball joint), `residual_torque` N m per unit
  std::vector<std::string> residual_dofs;
  double residual_torque = 10;
  // the rollouts' controllers run every this many steps and hold their output in between
  int control_every = 1;
  PlannerCostWeights cost;

  template <class V>
  void visit(V& v) {
    v("enabled", enabled, {.help = "plan corrections by sampling rollouts"});
    v("samples", samples, {.min = 1, .max = 4096, .help = "candidates per planning step"});
    v("horizon_s", horizon_s, {.unit = "s", .min = 0.001, .max = 10});
    v("interval_s", interval_s,
      {.unit = "s", .min = 0.0001, .max = 10, .help = "time between planning steps"});
    v("knots", knots, {.min = 1, .max = 64, .help = "spline knots over the horizon"});
    v("noise", noise, {.min = 0, .max = 100, .help = "sampling deviation, in scale units"});
    v("limit", limit, {.min = 0, .max = 100, .help = "knot clamp, in scale units"});
    v("method", method, {.help = "sampling or cem"});
    v("objective", objective, {.help = "the rollouts' cost terms (docs/planner.md)"});
    v("iterations", iterations, {.min = 1, .max = 100, .help = "cem iterations"});
    v("elites", elites, {.min = 1, .max = 4096, .help = "cem: candidates kept per refit"});
    v("timestep", timestep,
      {.unit = "s", .min = 0, .max = 1, .help = "rollout step, if coarser; 0: the run's"});
    v("solver", solver);
    v("control_every", control_every,
      {.min = 1, .max = 16, .help = "rollouts: controllers every n-th step, held between"});
    v("cost_interval_s", cost_interval_s, {.unit = "s", .min = 0, .max = 1});
    v("threads", threads, {.min = 0, .max = 1024, .help = "rollout threads; 0: every core"});
    v("rescue_error_m", rescue_error_m,
      {.unit = "m", .min = 0, .max = 10, .help = "error that brings rescue rounds; 0: never"});
    v("rescue_rounds", rescue_rounds,
      {.min = 0, .max = 100, .help = "extra rounds of samples around the best, in trouble"});
    v("steady_error_m", steady_error_m,
      {.unit = "m", .min = 0, .max = 10, .help = "error under which fewer samples; 0: never"});
    v("steady_samples", steady_samples,
      {.min = 1, .max = 4096, .help = "candidates per planning step while on track"});
    v("race_margin", race_margin,
      {.min = 0, .max = 100, .help = "on track, stop a rollout trailing the best by this share"});
    v("stop_margin", stop_margin,
      {.min = 0, .max = 1, .help = "stop sampling once a batch gains less than this share"});
    v("calm_plans", calm_plans,
      {.min = 0, .max = 100000, .help = "calm steps in a row before planning cheaply; 0: never"});
    v("calm_error_m", calm_error_m,
      {.unit = "m", .min = 0, .max = 10, .help = "a calm step's error is under this"});
    v("calm_samples", calm_samples,
      {.min = 1, .max = 4096, .help = "candidates per planning step while calm"});
    v("calm_race_margin", calm_race_margin,
      {.min = 0, .max = 100, .help = "while calm, stop a rollout trailing the best by this"});
    v("calm_timestep", calm_timestep,
      {.unit = "s", .min = 0, .max = 1, .help = "while calm, the rollouts' step; 0: theirs"});
    v("calm_horizon_s", calm_horizon_s,
      {.unit = "s", .min = 0, .max = 10, .help = "while calm, the rollouts' length; 0: horizon"});
    v("calm_every", calm_every,
      {.min = 1, .max = 100, .help = "while calm, plan every n-th interval, the plan kept"});
    v("calm_predicted_error_m", calm_predicted_error_m,
      {.unit = "m",
       .min = 0,
       .max = 10,
       .help = "not calm once the chosen rollout ends this far off; 0: not read"});
    v("residual_dofs", residual_dofs, {.help = "dofs of residual torques; empty: all joints"});
    v("residual_torque", residual_torque,
      {.unit = "N m", .min = 0, .max = 1e5, .help = "residual torque per unit of noise"});
    v("cost", cost);
  }
};

}  // namespace stance
