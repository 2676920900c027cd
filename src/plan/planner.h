// The sampling planner (predictive sampling, Howell et al. 2022, with an optional cross-entropy
// refinement). Every interval it draws candidate corrections as spline knots over a horizon,
// rolls each out from the simulation's state on an engine of its own with the scenario's
// controllers running inside, scores the rollouts and applies the cheapest. The current plan,
// shifted in time, is always a candidate, and so is no correction at all.
//
// The correction is low-dimensional: offsets that controllers offer through
// Correctable::correction_dims() (a tracker's swing-hip, pelvis and ankle targets), else residual
// torques on joint dofs (src/sim/correction.h). The rollouts are scored by planner.objective
// (plan/objective.h) and drawn from the one CEM (math/cem.h). Candidate i of planning step k draws
// its noise from a stream seeded by (scenario seed, k, i), so the plan is the same for any thread
// count.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "control/controller.h"
#include "core/executor.h"
#include "math/cem.h"
#include "plan/objective.h"
#include "sim/correction.h"

namespace stance {

class Simulation;
struct SimulationModel;
struct SimulationState;

// what the planner resolves once per planning model: where the runs start (the anchors of
// balance costs). Shared by every run of the model; makes each run's Planner.
struct PlannerModel : CorrectionSourceMaker, std::enable_shared_from_this<PlannerModel> {
  RunStart start;

  std::unique_ptr<CorrectionSource> make_source(
      std::shared_ptr<const CorrectionModel> correction) const override;
};

// one run's planner: the worker pool, a rollout simulation per worker and the candidates
class Planner : public CorrectionSource {
 public:
  Planner(std::shared_ptr<const CorrectionModel> correction,
          std::shared_ptr<const PlannerModel> model);
  ~Planner() override;
  // choose the plan from the simulation's current state; sets its CorrectionPlan
  void plan(Simulation& sim) override;
  // its rollout workers' CPU seconds besides the stepping thread (Executor's started threads)
  double own_threads_cpu_seconds() const override { return pool_->started_threads_cpu_seconds(); }
  // the chosen rollout's root path in the world, for drawing (empty before the first plan)
  const std::vector<Eigen::Vector3d>& best_path() const { return best_path_; }
  const PlannerModel& model() const { return *model_; }
  const CorrectionModel& correction() const { return *correction_; }
  // what planning cost so far: rollout steps taken, and wall seconds in plan() (benchmarks)
  long rollout_steps() const { return rollout_steps_; }
  double plan_seconds() const { return plan_seconds_; }

 private:
  // a rollout's cost as it went: the knots' terms and the stage costs summed at each sample
  struct CostProfile {
    double knots_cost = 0;
    std::vector<double> stage_sums;
    bool complete = false;  // rolled out over the whole horizon, no fall
  };
  struct Candidate {
    Eigen::MatrixXd knots;
    double cost = 0;
    long steps = 0;
    bool stopped = false;  // stopped early: `cost` is a lower bound above the best's, or infinite
    double end_error = 0;  // the run's balance error where a complete rollout ended (m; read
                           // only for planner.calm_predicted_error_m)
    std::vector<Eigen::Vector3d> path;
    CostProfile profile;
  };
  // candidate `index` of a round, drawn from the CEM's mean and spread
  void draw(long plan, int round, int index, Eigen::MatrixXd& knots) const;
  // the CEM's mean back at `knots` (dims x knots), its spread at planner.noise
  void restart_cem(const Eigen::MatrixXd& knots);
  // cem: refit the mean and spread to the elites of the round's k candidates
  void refit_cem(int k);
  // the candidate's cost from start_; stopped early (at a lower bound of it) once it exceeds
  // `bound`, and (at an infinite cost) once it trails `leader`'s profile by `race_margin` of
  // `bound`
  double rollout(Simulation& sim, Candidate& c, double bound, const CostProfile* leader,
                 double race_margin) const;
  // the controllers' references over `horizon_s` from the current start for the rollouts of
  // `workers`, once per planning step
  void sample_horizons(const std::vector<std::unique_ptr<Simulation>>& workers,
                       std::vector<std::unique_ptr<ReferenceHorizon>>& horizons, double horizon_s);
  // the rollouts of this step: calm (at planner.calm_timestep and calm_horizon_s) or full
  void use_rollouts(bool calm);

  std::shared_ptr<const CorrectionModel> correction_;
  std::shared_ptr<const PlannerModel> model_;
  std::unique_ptr<const PlannerObjective> objective_;  // planner.objective, at these weights
  std::unique_ptr<Executor> pool_;                     // made once per planning simulation
  std::vector<std::unique_ptr<Simulation>> workers_;
  // per rollout controller: its reference over the horizon, sampled once per planning step for
  // every rollout of the step (null: the controller has none)
  std::vector<std::unique_ptr<ReferenceHorizon>> horizons_;
  // calm steps' rollouts at planner.calm_timestep and their references (made at the first)
  std::vector<std::unique_ptr<Simulation>> calm_workers_;
  std::vector<std::unique_ptr<ReferenceHorizon>> calm_horizons_;
  // what this step rolls out: one of the two, over this much of the horizon
  std::vector<std::unique_ptr<Simulation>>* active_workers_ = &workers_;
  const std::vector<std::unique_ptr<ReferenceHorizon>>* active_horizons_ = &horizons_;
  double active_horizon_s_ = 0;
  std::unique_ptr<SimulationState> start_;
  std::vector<Candidate> candidates_;
  // the candidates' distribution (math/cem.h, flattened dims x knots, column-major); null when
  // planner.limit is 0 (every knot is 0)
  std::unique_ptr<Cem> cem_;
  Eigen::MatrixXd points_;     // flattened candidates, one a column, for the CEM's refit
  std::vector<double> costs_;  // their costs
  Eigen::MatrixXd nominal_, best_;
  std::vector<Eigen::Vector3d> best_path_;
  CostProfile best_profile_;
  double best_end_error_ = 0;
  uint64_t seed_ = 0;
  long rollout_steps_ = 0;
  double plan_seconds_ = 0;
};

// the planner's model of a run's model (its correction resolved), from an engine of its world at
// the start. Installed as the step loop's CorrectionSourceMakerFactory (sim/correction.h).
std::shared_ptr<const CorrectionSourceMaker> make_planner_model(const SimulationModel& run,
                                                                const Engine& start);

// the run's planner (for its drawing and counters); null when the run does not plan
const Planner* planner_of(const Simulation& run);

}  // namespace stance
