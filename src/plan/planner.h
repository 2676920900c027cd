// The sampling planner (predictive sampling, Howell et al. 2022, with an optional cross-entropy
// refinement). Every interval it draws candidate corrections as spline knots over a horizon,
// rolls each out from the simulation's state on an engine of its own with the scenario's
// controllers running inside, scores the rollouts and applies the cheapest. The current plan,
// shifted in time, is always a candidate, and so is no correction at all.
//
// The correction is low-dimensional: offsets that controllers offer through
// Controller::correction_dims() (a tracker's swing-hip, pelvis and ankle targets), else residual
// torques on joint dofs. Candidate i of planning step k draws its noise from a stream seeded by
// (scenario seed, k, i), so the plan is the same for any thread count.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "control/controller.h"
#include "core/executor.h"
#include "sim/planner_params.h"

namespace stance {

class Simulation;
struct SimulationModel;
struct SimulationState;

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

  // the correction at time t in plan units (dim knots.rows()); beyond the last knot it holds
  void evaluate(double t, Eigen::Ref<Eigen::VectorXd> out) const;

  template <class A>
  void serialize(A& a) {
    a(knots), a(t0), a(knot_dt), a(next_plan), a(plans), a(cost_sum), a(kept_nominal), a(rescues);
    a(steady), a(rollout_steps);
  }
};

// what a scenario's planner resolves to once: the dimensions, and the model rollouts run on
struct PlannerModel {
  PlannerParams params;
  std::vector<PlanDimension> dimensions;
  std::vector<int> controller_first;  // per controller: its first dimension, or -1
  int root_body = -1;                 // the first mobile body: its path and tilt
  Eigen::Vector3d root_up_local = Eigen::Vector3d::UnitZ();  // `up` in the root's frame at start
  // standing keeps the COM where it started over the feet (fall.allowed_contacts), so a step
  // moves the balance target with the feet; without feet, where it started in the world
  std::vector<int> support_bodies;
  Eigen::Vector3d com_over_support0 = Eigen::Vector3d::Zero();  // horizontal, at the start
  // the model rollouts step (the scenario's, at the planner's timestep, planning off)
  std::shared_ptr<const SimulationModel> rollout;
};

// one run's planner: the worker pool, a rollout simulation per worker and the candidates
class Planner {
 public:
  explicit Planner(std::shared_ptr<const PlannerModel> model);
  ~Planner();
  // choose the plan from the simulation's current state; sets its CorrectionPlan
  void plan(Simulation& sim);
  // the chosen rollout's root path in the world, for drawing (empty before the first plan)
  const std::vector<Eigen::Vector3d>& best_path() const { return best_path_; }
  const PlannerModel& model() const { return *model_; }
  // what planning cost so far: rollout steps taken, and wall seconds in plan() (benchmarks)
  long rollout_steps() const { return rollout_steps_; }
  double plan_seconds() const { return plan_seconds_; }

 private:
  struct Candidate {
    Eigen::MatrixXd knots;
    double cost = 0;
    long steps = 0;
    bool stopped = false;  // stopped early: `cost` is a lower bound above the best's
    std::vector<Eigen::Vector3d> path;
  };
  void draw(const Eigen::MatrixXd& mean, const Eigen::MatrixXd& deviation, long plan, int round,
            int index, Eigen::MatrixXd& knots) const;
  // the candidate's cost from start_; stopped early (at a lower bound of it) once it exceeds
  // `bound`
  double rollout(Simulation& sim, Candidate& c, double bound) const;
  // the controllers' references over the horizon from the current start, once per planning step
  void sample_horizons();
  // how far off the run is: a tracked reference's mean body error, or with nothing tracked, the
  // capture point's horizontal offset from where it started over the feet (m)
  double balance_error(const Simulation& sim) const;
  Eigen::Vector3d capture_offset(const Simulation& sim) const;

  std::shared_ptr<const PlannerModel> model_;
  std::unique_ptr<Executor> pool_;  // made once per planning simulation
  std::vector<std::unique_ptr<Simulation>> workers_;
  // per rollout controller: its reference over the horizon, sampled once per planning step for
  // every rollout of the step (null: the controller has none)
  std::vector<std::unique_ptr<ReferenceHorizon>> horizons_;
  std::unique_ptr<SimulationState> start_;
  std::vector<Candidate> candidates_;
  std::vector<int> order_;
  Eigen::MatrixXd nominal_, mean_, deviation_, best_;
  std::vector<Eigen::Vector3d> best_path_;
  uint64_t seed_ = 0;
  long rollout_steps_ = 0;
  double plan_seconds_ = 0;
};

// resolve a scenario's planner on a simulation model built without one: the dimensions from the
// controllers (or residual torques), the rollout model. Throws InputError naming planner.* keys.
// the checks between parameters (method, elites, interval against horizon); throws InputError
// prefixed with `where` (the scenario file) when not empty
void check_planner_params(const PlannerParams& params, const std::string& where);

std::shared_ptr<const PlannerModel> make_planner_model(
    const PlannerParams& params, const SimulationModel& model,
    std::shared_ptr<const SimulationModel> rollout);

}  // namespace stance
