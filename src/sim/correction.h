// The correction a run applies on top of its controllers: low-dimensional offsets of the
// controllers' targets (Correctable::correction_dims) or, when no controller offers any,
// residual torques on joint dofs. Its plan is part of the run's state; what chooses the plan
// (the sampling planner, src/plan/) is a CorrectionSource the layer above attaches, so the step
// loop never sees how a plan is made.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

#include "sim/planner_params.h"

namespace stance {

class Engine;
class Simulation;
struct SimulationModel;

// one dimension of the correction: an offset a controller applies, or a residual torque
struct PlanDimension {
  std::string name;     // "controllers[0].swing_hip_pitch", "residual.j_thigh_left_z"
  int controller = -1;  // the controller applying it; -1: a residual torque
  int dof = -1;         // the residual torque's dof
  double scale = 0;     // what one unit of the plan means, in the dimension's unit
};

// the correction a run applies: a piecewise-linear spline in units of each dimension's scale.
// Part of the run's state (it is saved, restored and written to the state file with it).
struct CorrectionPlan {
  Eigen::MatrixXd knots;   // dims x knots; empty: no correction
  double t0 = 0;           // s, time of the first knot
  double knot_dt = 0;      // s between knots
  double next_plan = 0;    // s, when the planner plans again
  long plans = 0;          // planning steps so far: the noise streams' index
  double cost_sum = 0;     // the chosen candidates' costs, summed (a metric)
  long kept_nominal = 0;   // planning steps whose choice was the shifted plan or no correction
  long rescues = 0;        // planning steps that ran rescue rounds
  long steady = 0;         // planning steps on track (with steady_samples candidates)
  long rollout_steps = 0;  // model steps the rollouts took (the planner's compute)
  long calm_streak = 0;    // calm planning steps in a row so far (planner.calm_plans)
  long calm = 0;           // planning steps planned cheaply while calm

  // the correction at time t in plan units (dim knots.rows()); beyond the last knot it holds
  void evaluate(double t, Eigen::Ref<Eigen::VectorXd> out) const;

  template <class A>
  void serialize(A& a) {
    a(knots), a(t0), a(knot_dt), a(next_plan), a(plans), a(cost_sum), a(kept_nominal), a(rescues);
    a(steady), a(rollout_steps), a(calm_streak), a(calm);
  }
};

// what a scenario's `planner:` block resolves to once: the parameters, the dimensions the runs
// apply, and the model the planner's rollouts step (the scenario's, at the planner's timestep,
// planning off; null in that rollout model itself)
struct CorrectionModel {
  PlannerParams params;
  std::vector<PlanDimension> dimensions;
  std::vector<int> controller_first;  // per controller: its first dimension, or -1
  std::shared_ptr<const SimulationModel> rollout;
  // the model calm steps roll out at planner.calm_timestep; null when that is off
  std::shared_ptr<const SimulationModel> calm_rollout;
};

// what chooses a run's correction plan (the planner): the step loop calls plan() before a
// step's controls whenever the plan's next_plan is due. It reaches the run through its public
// rollout interface: save, restore, correction_plan() and step().
class CorrectionSource {
 public:
  virtual ~CorrectionSource() = default;
  // set sim.correction_plan() (knots, t0, next_plan, its counters) from the run's state now
  virtual void plan(Simulation& sim) = 0;
  // CPU seconds used so far by threads of its own (a planner's rollout workers; the share run on
  // the stepping thread is on that thread's clock)
  virtual double own_threads_cpu_seconds() const { return 0; }
};

// what the plan layer resolves once per planning model (its objective's data at the start) and
// that makes each run's CorrectionSource; shared, immutable
class CorrectionSourceMaker {
 public:
  virtual ~CorrectionSourceMaker() = default;
  virtual std::unique_ptr<CorrectionSource> make_source(
      std::shared_ptr<const CorrectionModel> correction) const = 0;
};

// the plan layer's maker of makers, given the run's model (its correction resolved). It is
// installed once, before main, by src/plan/ when that is linked (every stance target is):
// the step loop plans without including the planner, and every client that makes a run of a
// planning scenario (CLI, viewer, Python, batch) gets its planner without a line of its own.
// `start` is an engine of the run's world at its initial state.
using CorrectionSourceMakerFactory = std::shared_ptr<const CorrectionSourceMaker> (*)(
    const SimulationModel& run, const Engine& start);
void install_correction_source(CorrectionSourceMakerFactory factory);
// the installed factory; null when no plan layer is linked
CorrectionSourceMakerFactory correction_source_factory();

// the checks between planner parameters (method, elites, interval against horizon); throws
// InputError prefixed with `where` (the scenario file) when not empty
void check_planner_params(const PlannerParams& params, const std::string& where);

// the dimensions of a scenario's correction on the run's model (its controllers', else residual
// torques on `engine` at the start). Throws InputError naming planner.* keys, prefixed with the
// model's source.
void resolve_correction_dims(const SimulationModel& model, const Engine& engine,
                             CorrectionModel& correction);

}  // namespace stance
