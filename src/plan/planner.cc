#include "plan/planner.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include "core/error.h"
#include "engine/engine.h"
#include "sim/simulation.h"

namespace stance {

namespace {

uint64_t splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

}  // namespace

// ---- the model

std::shared_ptr<const CorrectionSourceMaker> make_planner_model(const SimulationModel& model,
                                                                const Engine& e) {
  check_objective(model.scenario.planner.objective, model.source);
  auto pm = std::make_shared<PlannerModel>();
  pm->start = resolve_run_start(model, e);
  return pm;
}

std::unique_ptr<CorrectionSource> PlannerModel::make_source(
    std::shared_ptr<const CorrectionModel> correction) const {
  return std::make_unique<Planner>(std::move(correction), shared_from_this());
}

const Planner* planner_of(const Simulation& run) {
  return dynamic_cast<const Planner*>(run.planner());
}

// the step loop plans through this layer without including it: installed before main. The
// linker keeps this file in every program that links the plan layer (CMakeLists.txt asks for
// stance_plan_linked), so no client has to remember to install it.
extern "C" const int stance_plan_linked = 1;
namespace {
const bool kPlannerInstalled = (install_correction_source(&make_planner_model), true);
}  // namespace

// ---- planning

Planner::Planner(std::shared_ptr<const CorrectionModel> correction,
                 std::shared_ptr<const PlannerModel> model)
    : correction_(std::move(correction)), model_(std::move(model)) {
  const PlannerParams& p = correction_->params;
  objective_ = find_objective(p.objective)->make(p, model_->start);
  pool_ = std::make_unique<Executor>(executor_threads(p.threads, p.samples));
  seed_ = splitmix64(static_cast<uint64_t>(correction_->rollout->scenario.seed) + 0x5eedull);
  const int dims = static_cast<int>(correction_->dimensions.size());
  candidates_.resize(p.samples);
  const size_t path_points =
      static_cast<size_t>(p.horizon_s / std::max(p.cost_interval_s, 1e-4)) + 4;
  for (Candidate& c : candidates_) {
    c.knots.setZero(dims, p.knots);
    c.path.reserve(path_points);
    c.profile.stage_sums.reserve(path_points);
  }
  best_profile_.stage_sums.reserve(path_points);
  best_path_.reserve(path_points);
  // the planner's CEM: streams of its own per candidate (draw), clamped at once, elites of
  // the last round, their deviation over n with a floor of a tenth of the noise
  const int n = dims * p.knots;
  CemParams cem;
  cem.elites = p.elites;
  cem.initial_spread = p.noise;
  cem.min_spread = 0.1 * p.noise;
  cem.spread_memory = 0;
  cem.sample_deviation = false;
  cem.redraws = 0;
  cem.elites_from_all = false;
  if (p.limit > 0)
    cem_ = std::make_unique<Cem>(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Constant(n, -p.limit),
                                 Eigen::VectorXd::Constant(n, p.limit), cem);
  points_.setZero(n, p.samples);
}

Planner::~Planner() = default;

void Planner::draw(long plan, int round, int index, Eigen::MatrixXd& knots) const {
  // one stream per (scenario seed, planning step, round, candidate): any thread may draw it
  uint64_t s = splitmix64(seed_ ^ splitmix64(static_cast<uint64_t>(plan) * 0x100000001b3ull +
                                             static_cast<uint64_t>(round) * 65537ull +
                                             static_cast<uint64_t>(index)));
  std::mt19937_64 rng(s);
  std::normal_distribution<double> normal(0.0, 1.0);
  if (!cem_) {
    knots.setZero();
    return;
  }
  cem_->sample(rng, normal, Eigen::Map<Eigen::VectorXd>(knots.data(), knots.size()));
}

void Planner::restart_cem(const Eigen::MatrixXd& knots) {
  if (cem_) cem_->restart(Eigen::Map<const Eigen::VectorXd>(knots.data(), knots.size()));
}

void Planner::refit_cem(int k) {
  if (!cem_) return;
  costs_.resize(k);
  for (int i = 0; i < k; ++i) {
    const Eigen::MatrixXd& knots = candidates_[i].knots;
    points_.col(i) = Eigen::Map<const Eigen::VectorXd>(knots.data(), knots.size());
    costs_[i] = candidates_[i].cost;
  }
  cem_->tell(points_.leftCols(k), costs_);
}

double Planner::rollout(Simulation& sim, Candidate& c, double bound, const CostProfile* leader,
                        double race_margin) const {
  const PlannerParams& p = correction_->params;
  const PlannerCostWeights& w = p.cost;
  // the knots' terms are known before the rollout; with the stage costs (>= 0) averaged over at
  // most `most_samples`, they bound the final cost from below: once that bound passes `bound`
  // (a cost already rolled out), the candidate cannot win and is stopped
  const double size = static_cast<double>(std::max<Eigen::Index>(1, c.knots.size()));
  const double effort = c.knots.squaredNorm() / size;
  // what holding a correction costs (effort) apart from what changing it costs (change): a
  // stance the planner stepped into needs its offsets kept, not pulled back to none
  const double change = w.change > 0 ? (c.knots - nominal_).squaredNorm() / size : 0.0;
  const double knots_cost = w.effort * effort + w.change * change;
  // at most one cost sample a step (a margin of two for the clock's rounding)
  const double horizon_s = active_horizon_s_;
  const double sample_dt = std::max(p.cost_interval_s, sim.engine().timestep());
  const double most_samples = std::floor(horizon_s / sample_dt) + 2;
  c.stopped = false;
  c.profile.knots_cost = knots_cost;
  c.profile.stage_sums.clear();
  c.profile.complete = false;
  // racing the leader: the stage costs averaged over the leader's samples
  const bool race = leader && leader->complete && race_margin > 0 && std::isfinite(bound);
  const double race_samples = race ? static_cast<double>(leader->stage_sums.size()) : 1.0;
  if (knots_cost > bound) {
    c.stopped = true;
    c.steps = 0;
    c.path.clear();
    return knots_cost;
  }
  sim.restore(*start_);
  const auto& horizons = *active_horizons_;
  for (size_t i = 0; i < horizons.size(); ++i)
    if (const HorizonSampling* h = sim.controllers()[i]->as<HorizonSampling>())
      h->use_reference_horizon(sim.controller_state(i), horizons[i].get());
  CorrectionPlan& plan = sim.correction_plan();
  const double t0 = plan.t0, t_end = t0 + horizon_s;
  plan.knots = c.knots;
  plan.next_plan = std::numeric_limits<double>::infinity();
  c.path.clear();
  c.steps = 0;
  double stage = 0, penalty = 0;
  bool fell = false;
  int samples = 0;
  double next_cost = t0 + p.cost_interval_s;
  while (sim.time() < t_end - 1e-9) {
    ++c.steps;
    if (!sim.step()) {  // diverged: the worst fall
      penalty = 2 * w.fall;
      fell = true;
      break;
    }
    const double t = sim.time();
    if (sim.progress().fell) {
      penalty = w.fall * (1 + std::max(0.0, t_end - t) / horizon_s);
      fell = true;
      break;
    }
    if (t + 1e-9 < next_cost) continue;
    next_cost += p.cost_interval_s;
    const double cost = objective_->stage_cost(sim);
    stage += cost;
    ++samples;
    if (model_->start.root_body >= 0 && c.path.size() < c.path.capacity())
      c.path.push_back(sim.engine().body_pose(model_->start.root_body).pos);
    c.profile.stage_sums.push_back(stage);
    const double lower = knots_cost + stage / most_samples;
    if (lower > bound) {
      c.stopped = true;
      return lower;
    }
    // behind the leader at the same time by more than the margin: not a bound, a bet that it
    // will not catch up; it is never chosen
    if (race && samples <= static_cast<int>(leader->stage_sums.size()) &&
        knots_cost + stage / race_samples > leader->knots_cost +
                                                leader->stage_sums[samples - 1] / race_samples +
                                                race_margin * bound) {
      c.stopped = true;
      return std::numeric_limits<double>::infinity();
    }
  }
  c.profile.complete = !fell;
  c.end_error = !fell && p.calm_predicted_error_m > 0 ? objective_->balance_error(sim) : 0.0;
  return (samples ? stage / samples : 0.0) + penalty + knots_cost;
}

void Planner::sample_horizons(const std::vector<std::unique_ptr<Simulation>>& workers,
                              std::vector<std::unique_ptr<ReferenceHorizon>>& horizons,
                              double horizon_s) {
  const Simulation& sim = *workers[0];
  const auto& controllers = sim.controllers();
  if (horizons.empty())
    for (const auto& c : controllers) {
      const HorizonSampling* h = c->as<HorizonSampling>();
      horizons.push_back(h ? h->make_reference_horizon() : nullptr);
    }
  // every step a rollout may take, and one more for the rounding of its clock
  const Engine& e = sim.engine();
  const int steps = static_cast<int>(std::ceil(horizon_s / e.timestep())) + 2;
  for (size_t i = 0; i < controllers.size(); ++i)
    if (horizons[i])
      controllers[i]->as<HorizonSampling>()->sample_reference_horizon(*horizons[i], e,
                                                                      start_->engine.time, steps);
}

void Planner::use_rollouts(bool calm) {
  const PlannerParams& p = correction_->params;
  const bool coarse = calm && correction_->calm_rollout;
  if (coarse && calm_workers_.empty())
    for (int w = 0; w < pool_->size(); ++w)
      calm_workers_.push_back(std::make_unique<Simulation>(correction_->calm_rollout));
  active_workers_ = coarse ? &calm_workers_ : &workers_;
  active_horizons_ = coarse ? &calm_horizons_ : &horizons_;
  active_horizon_s_ = calm && p.calm_horizon_s > 0 ? p.calm_horizon_s : p.horizon_s;
  // the full model's references span the whole horizon (their storage keeps one size)
  if (coarse)
    sample_horizons(calm_workers_, calm_horizons_, active_horizon_s_);
  else
    sample_horizons(workers_, horizons_, p.horizon_s);
}

void Planner::plan(Simulation& sim) {
  const PlannerParams& p = correction_->params;
  CorrectionPlan& plan = sim.correction_plan();
  const double now = sim.time();
  const int dims = static_cast<int>(correction_->dimensions.size());
  const int n = p.knots;
  const double knot_dt = n > 1 ? p.horizon_s / (n - 1) : p.horizon_s;
  // the current plan, shifted to start now (warm start)
  nominal_.resize(dims, n);
  for (int j = 0; j < n; ++j) plan.evaluate(now + j * knot_dt, nominal_.col(j));
  plan.next_plan = now + p.interval_s;
  if (sim.progress().fell || sim.progress().diverged) {
    // nothing left to save: hold the plan
    plan.knots = nominal_;
    plan.t0 = now;
    plan.knot_dt = knot_dt;
    return;
  }
  const double balance_error = objective_->balance_error(sim);
  const bool in_trouble = p.rescue_error_m > 0 && balance_error >= p.rescue_error_m;
  // calm for long enough (and still now): the cheap budget, the full one at the first sign of
  // trouble. It reads the run's state only, so it is the same for any thread count.
  const bool calm = p.calm_plans > 0 && plan.calm_streak >= p.calm_plans &&
                    balance_error < p.calm_error_m && !in_trouble;
  // while calm, a new plan every calm_every-th interval; in between the plan is kept as it is
  if (calm && p.calm_every > 1 && (plan.calm_streak - p.calm_plans) % p.calm_every != 0) {
    ++plan.calm_streak;
    return;
  }
  plan.knots = nominal_;
  plan.t0 = now;
  plan.knot_dt = knot_dt;
  const auto wall0 = std::chrono::steady_clock::now();
  if (workers_.empty())
    for (int w = 0; w < pool_->size(); ++w)
      workers_.push_back(std::make_unique<Simulation>(correction_->rollout));
  if (!start_) start_ = std::make_unique<SimulationState>();
  sim.save(*start_);
  use_rollouts(calm);

  // tracking on track, fewer candidates: the shifted plan mostly holds there
  TrackingError error;
  const bool steady =
      p.steady_error_m > 0 && tracking_error(sim, error) && error.body_m < p.steady_error_m;
  int k = steady ? std::clamp(p.steady_samples, 1, p.samples) : p.samples;
  if (calm) k = std::clamp(p.calm_samples, 1, p.samples);
  if (steady) ++plan.steady;
  if (calm) ++plan.calm;
  // racing rollouts is a bet: taken while the run is on track, not while it is in trouble
  double race_margin = calm ? p.calm_race_margin : in_trouble ? 0.0 : p.race_margin;
  // calm rollouts on a model of their own (coarser or shorter): their costs are not the full
  // ones', so a calm draw that finds no plan that stays up is redone in full, not completed
  bool calm_model = calm && (active_workers_ != &workers_ || active_horizon_s_ < p.horizon_s);
  const int rounds = p.method == "cem" ? p.iterations : 1;
  restart_cem(nominal_);
  best_ = nominal_;
  double best_cost = std::numeric_limits<double>::infinity();
  int best_round = -1, best_index = -1;
  // one round's candidates [from, to): candidate 0 is the plan so far (rolled out again only in
  // round 0), the others are drawn from the CEM; rollouts race at `margin`
  auto run_round = [&](int round, int from, int to, double margin) {
    for (int i = from; i < to; ++i) {
      Eigen::MatrixXd& knots = candidates_[i].knots;
      if (i == 0)
        knots = round == 0 ? nominal_ : best_;  // the plan so far is always a candidate
      else if (i == 1 && round == 0 && to > 2)
        knots.setZero();  // so is no correction at all
      else
        draw(plan.plans, round, i, knots);
    }
    // after round 0, candidate 0 is best_, whose cost is known (rollouts are deterministic)
    const int first = round == 0 || from > 0 ? from : 1;
    if (first == 1) candidates_[0].cost = best_cost;
    // batches of 2, 4, 8, ... candidates: a batch's rollouts stop once they cannot beat the
    // cheapest of the batches before it. The batches are fixed, so the bound (and the plan) is
    // the same for any thread count. CEM refits to every cost: it rolls all out in one batch.
    const bool stop_early = p.method == "sampling";
    for (int begin = first, size = std::max(2, from); begin < to; size *= 2) {
      const int end = stop_early ? std::min(to, begin + size) : to;
      const double bound = stop_early ? best_cost : std::numeric_limits<double>::infinity();
      pool_->run(end - begin, [&](int worker, int task) {
        Candidate& c = candidates_[begin + task];
        c.cost = rollout(*(*active_workers_)[worker], c, bound, &best_profile_, margin);
      });
      // the cheapest, the lower index on a tie: the same for any thread count
      const double before = best_cost;
      for (int i = begin; i < end; ++i) {
        rollout_steps_ += candidates_[i].steps;
        plan.rollout_steps += candidates_[i].steps;
        if (candidates_[i].cost < best_cost) {
          best_cost = candidates_[i].cost;
          best_ = candidates_[i].knots;
          best_round = round;
          best_index = i;
          best_path_.assign(candidates_[i].path.begin(), candidates_[i].path.end());
          best_profile_.knots_cost = candidates_[i].profile.knots_cost;
          best_profile_.stage_sums.assign(candidates_[i].profile.stage_sums.begin(),
                                          candidates_[i].profile.stage_sums.end());
          best_profile_.complete = candidates_[i].profile.complete;
          best_end_error_ = candidates_[i].end_error;
        }
      }
      // sampling that stopped paying: a batch of 4 or more drew nothing clearly cheaper than the
      // batches before it. It reads costs only, so it stops alike for any thread count.
      if (stop_early && p.stop_margin > 0 && end - begin >= 4 &&
          !(best_cost < before * (1 - p.stop_margin)))
        break;
      begin = end;
    }
  };
  for (int round = 0; round < rounds; ++round) {
    run_round(round, 0, k, race_margin);
    // calm, but the best of the cheap budget falls within the horizon: the rest of the full one
    int rolled = k;
    if (calm_model && !best_profile_.complete) {
      // the whole draw again on the full model, at the full budget from here on
      use_rollouts(false);
      calm_model = false;
      best_cost = std::numeric_limits<double>::infinity();
      best_ = nominal_;
      k = p.samples;
      race_margin = p.race_margin;
      run_round(round, 0, k, race_margin);
      rolled = k;
    } else if (calm && k < p.samples && !best_profile_.complete) {
      run_round(round, k, p.samples, p.race_margin);
      rolled = p.samples;
    }
    if (round + 1 == rounds) break;
    refit_cem(rolled);
  }
  // in trouble (the reference slipping away, or a push), more rounds around the best: the
  // budget goes where a miss would cost the run, not to every step of a walk that goes well
  const bool rescue = p.rescue_rounds > 0 && in_trouble;
  if (rescue) {
    ++plan.rescues;
    for (int r = 0; r < p.rescue_rounds; ++r) {
      restart_cem(best_);
      run_round(rounds + r, 0, k, 0.0);
    }
  }
  // a calm step: no rescue round, under calm_error_m, and a plan that does not fall
  // and, when read, a chosen rollout that ends under calm_predicted_error_m: trouble it foresees
  // ends the streak before the run is in it
  const bool foreseen = p.calm_predicted_error_m > 0 && best_end_error_ >= p.calm_predicted_error_m;
  const bool calm_step =
      !rescue && balance_error < p.calm_error_m && best_profile_.complete && !foreseen;
  plan.calm_streak = calm_step ? plan.calm_streak + 1 : 0;
  plan.knots = best_;
  ++plan.plans;
  plan.cost_sum += best_cost;
  if (best_round == 0 && best_index <= 1) ++plan.kept_nominal;
  plan_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

}  // namespace stance
