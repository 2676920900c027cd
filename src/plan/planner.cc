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

Eigen::Vector3d horizontal(const Eigen::Vector3d& x, const Eigen::Vector3d& up) {
  return x - up.dot(x) * up;
}

// the mean origin of the feet
Eigen::Vector3d support_center(const PlannerModel& m, const Engine& e) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int b : m.support_bodies) sum += e.body_pose(b).pos;
  return sum / static_cast<double>(m.support_bodies.size());
}

// the controllers' tracking errors, summed; false when none tracks a reference
bool tracking_error(const Simulation& sim, TrackingError& total) {
  total = TrackingError{};
  bool tracked = false;
  TrackingError one;
  for (size_t i = 0; i < sim.controllers().size(); ++i) {
    one = TrackingError{};
    const Tracking* tracking = sim.controllers()[i]->as<Tracking>();
    if (!tracking || !tracking->tracking_error(sim.controller_state(i), sim.engine(), one))
      continue;
    tracked = true;
    total.joint_rad += one.joint_rad;
    total.root_m += one.root_m;
    total.body_m += one.body_m;
    total.root_tilt_rad += one.root_tilt_rad;
  }
  return tracked;
}

}  // namespace

// ---- the plan

void CorrectionPlan::evaluate(double t, Eigen::Ref<Eigen::VectorXd> out) const {
  const int n = static_cast<int>(knots.cols());
  if (n == 0 || knots.rows() != out.size()) {
    out.setZero();
    return;
  }
  if (n == 1 || knot_dt <= 0) {
    out = knots.col(0);
    return;
  }
  const double s = std::max(0.0, (t - t0) / knot_dt);
  const int j = static_cast<int>(std::floor(s));
  if (j >= n - 1) {
    out = knots.col(n - 1);
    return;
  }
  const double a = s - j;
  out = (1 - a) * knots.col(j) + a * knots.col(j + 1);
}

// ---- the model

void check_planner_params(const PlannerParams& params, const std::string& where) {
  auto fail = [&](const std::string& msg) {
    throw InputError(where.empty() ? msg : fmt::format("{}: {}", where, msg));
  };
  if (params.method != "sampling" && params.method != "cem")
    fail(fmt::format("planner.method: expected sampling or cem, found '{}'", params.method));
  if (params.method == "cem" && params.elites > params.samples)
    fail(fmt::format("planner.elites: {} is more than planner.samples ({})", params.elites,
                     params.samples));
  if (params.interval_s > params.horizon_s)
    fail(fmt::format("planner.interval_s: {} s is longer than planner.horizon_s ({} s)",
                     params.interval_s, params.horizon_s));
}

std::shared_ptr<const PlannerModel> make_planner_model(
    const PlannerParams& params, const SimulationModel& model,
    std::shared_ptr<const SimulationModel> rollout) {
  const std::string& where = model.source;
  auto fail = [&](const std::string& msg) {
    throw InputError(where.empty() ? msg : fmt::format("{}: {}", where, msg));
  };
  check_planner_params(params, where);
  auto pm = std::make_shared<PlannerModel>();
  pm->params = params;
  pm->rollout = std::move(rollout);
  std::unique_ptr<Engine> engine = model.make_engine();
  engine->restore_state(model.initial);
  engine->forward();
  const Engine& e = *engine;
  // the controllers' own corrections
  pm->controller_first.assign(model.controllers.size(), -1);
  std::vector<CorrectionDim> dims;
  for (size_t i = 0; i < model.controllers.size(); ++i) {
    dims.clear();
    if (const Correctable* c = model.controllers[i]->as<Correctable>()) c->correction_dims(dims);
    if (dims.empty()) continue;
    pm->controller_first[i] = static_cast<int>(pm->dimensions.size());
    for (const CorrectionDim& d : dims)
      pm->dimensions.push_back(
          {fmt::format("controllers[{}].{}", i, d.name), static_cast<int>(i), -1, d.scale});
  }
  // else residual torques
  if (pm->dimensions.empty()) {
    std::vector<int> dofs;
    for (const std::string& name : params.residual_dofs) {
      int dof = e.dof_index(name);
      if (dof < 0)
        fail(fmt::format("planner.residual_dofs: unknown dof '{}'{}", name,
                         did_you_mean(name, e.dof_names())));
      dofs.push_back(dof);
    }
    if (dofs.empty())
      for (int dof = 0; dof < e.nv(); ++dof)
        if (e.joint(e.dof_joint(dof)).type != JointType::kFree) dofs.push_back(dof);
    for (int dof : dofs)
      pm->dimensions.push_back({"residual." + e.dof_name(dof), -1, dof, params.residual_torque});
  }
  if (pm->dimensions.empty()) fail("planner: the model has no joint to correct");
  if (e.nbody() > 0) {
    pm->root_body = 0;
    pm->root_up_local = e.body_pose(0).quat.conjugate() * model.up;
  }
  for (int b = 0; b < static_cast<int>(model.allowed_contact.size()); ++b)
    if (model.allowed_contact[b]) pm->support_bodies.push_back(b);
  if (!pm->support_bodies.empty())
    pm->com_over_support0 = horizontal(e.com() - support_center(*pm, e), model.up);
  return pm;
}

// ---- planning

Planner::Planner(std::shared_ptr<const PlannerModel> model) : model_(std::move(model)) {
  const PlannerParams& p = model_->params;
  pool_ = std::make_unique<Executor>(executor_threads(p.threads, p.samples));
  seed_ = splitmix64(static_cast<uint64_t>(model_->rollout->scenario.seed) + 0x5eedull);
  const int dims = static_cast<int>(model_->dimensions.size());
  candidates_.resize(p.samples);
  const size_t path_points =
      static_cast<size_t>(p.horizon_s / std::max(p.cost_interval_s, 1e-4)) + 4;
  for (Candidate& c : candidates_) {
    c.knots.setZero(dims, p.knots);
    c.path.reserve(path_points);
  }
  best_path_.reserve(path_points);
  order_.resize(p.samples);
}

Planner::~Planner() = default;

void Planner::draw(const Eigen::MatrixXd& mean, const Eigen::MatrixXd& deviation, long plan,
                   int round, int index, Eigen::MatrixXd& knots) const {
  // one stream per (scenario seed, planning step, round, candidate): any thread may draw it
  uint64_t s = splitmix64(seed_ ^ splitmix64(static_cast<uint64_t>(plan) * 0x100000001b3ull +
                                             static_cast<uint64_t>(round) * 65537ull +
                                             static_cast<uint64_t>(index)));
  std::mt19937_64 rng(s);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double limit = model_->params.limit;
  for (int j = 0; j < knots.cols(); ++j)
    for (int d = 0; d < knots.rows(); ++d)
      knots(d, j) = std::clamp(mean(d, j) + deviation(d, j) * normal(rng), -limit, limit);
}

Eigen::Vector3d Planner::capture_offset(const Simulation& sim) const {
  // the capture point (COM + v sqrt(h / g)) against the start: where the COM would have to be
  // to come to rest, so a push shows before the COM has moved
  const Engine& e = sim.engine();
  const Eigen::Vector3d up = sim.model().up;
  const Eigen::Vector3d com = e.com();
  const Eigen::Vector3d vel = horizontal(e.com_velocity(), up);
  const double h = std::max(1e-3, up.dot(com) - sim.model().scenario.fall.ground_height);
  const double g = std::max(1e-6, e.gravity().norm());
  const Eigen::Vector3d anchor = model_->support_bodies.empty()
                                     ? sim.progress().com0
                                     : support_center(*model_, e) + model_->com_over_support0;
  return horizontal(com - anchor, up) + std::sqrt(h / g) * vel;
}

double Planner::balance_error(const Simulation& sim) const {
  TrackingError e;
  return tracking_error(sim, e) ? e.body_m : capture_offset(sim).norm();
}

double Planner::rollout(Simulation& sim, Candidate& c, double bound) const {
  const PlannerParams& p = model_->params;
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
  const double sample_dt = std::max(p.cost_interval_s, sim.engine().timestep());
  const double most_samples = std::floor(p.horizon_s / sample_dt) + 2;
  c.stopped = false;
  if (knots_cost > bound) {
    c.stopped = true;
    c.steps = 0;
    c.path.clear();
    return knots_cost;
  }
  sim.restore(*start_);
  for (size_t i = 0; i < horizons_.size(); ++i)
    if (const HorizonSampling* h = sim.controllers()[i]->as<HorizonSampling>())
      h->use_reference_horizon(sim.controller_state(i), horizons_[i].get());
  CorrectionPlan& plan = sim.correction_plan();
  const double t0 = plan.t0, t_end = t0 + p.horizon_s;
  plan.knots = c.knots;
  plan.next_plan = std::numeric_limits<double>::infinity();
  c.path.clear();
  c.steps = 0;
  const SimulationModel& m = sim.model();
  const Eigen::Vector3d up = m.up;
  double stage = 0, penalty = 0;
  int samples = 0;
  double next_cost = t0 + p.cost_interval_s;
  while (sim.time() < t_end - 1e-9) {
    ++c.steps;
    if (!sim.step()) {  // diverged: the worst fall
      penalty = 2 * w.fall;
      break;
    }
    const double t = sim.time();
    if (sim.progress().fell) {
      penalty = w.fall * (1 + std::max(0.0, t_end - t) / p.horizon_s);
      break;
    }
    if (t + 1e-9 < next_cost) continue;
    next_cost += p.cost_interval_s;
    const Engine& e = sim.engine();
    TrackingError total;
    const bool tracked = tracking_error(sim, total);
    double cost;
    if (tracked) {
      cost = w.joint * total.joint_rad * total.joint_rad + w.root * total.root_m * total.root_m +
             w.body * total.body_m * total.body_m +
             w.root_tilt * total.root_tilt_rad * total.root_tilt_rad;
    } else {
      const Eigen::Vector3d com = e.com();
      const Eigen::Vector3d vel = horizontal(e.com_velocity(), up);
      const Eigen::Vector3d offset = capture_offset(sim);
      double tilt = 0;
      if (model_->root_body >= 0) {
        const Eigen::Vector3d root_up = e.body_pose(model_->root_body).quat * model_->root_up_local;
        tilt = std::acos(std::clamp(root_up.dot(up), -1.0, 1.0));
      }
      const double drop = std::max(0.0, up.dot(sim.progress().com0 - com));
      cost = w.capture * offset.squaredNorm() + w.com_velocity * vel.squaredNorm() +
             w.upright * tilt * tilt + w.height * drop * drop;
    }
    stage += cost;
    ++samples;
    if (model_->root_body >= 0 && c.path.size() < c.path.capacity())
      c.path.push_back(e.body_pose(model_->root_body).pos);
    const double lower = knots_cost + stage / most_samples;
    if (lower > bound) {
      c.stopped = true;
      return lower;
    }
  }
  return (samples ? stage / samples : 0.0) + penalty + knots_cost;
}

void Planner::sample_horizons() {
  const Simulation& sim = *workers_[0];
  const auto& controllers = sim.controllers();
  if (horizons_.empty())
    for (const auto& c : controllers) {
      const HorizonSampling* h = c->as<HorizonSampling>();
      horizons_.push_back(h ? h->make_reference_horizon() : nullptr);
    }
  // every step a rollout may take, and one more for the rounding of its clock
  const Engine& e = sim.engine();
  const int steps = static_cast<int>(std::ceil(model_->params.horizon_s / e.timestep())) + 2;
  for (size_t i = 0; i < controllers.size(); ++i)
    if (horizons_[i])
      controllers[i]->as<HorizonSampling>()->sample_reference_horizon(*horizons_[i], e,
                                                                     start_->engine.time, steps);
}

void Planner::plan(Simulation& sim) {
  const PlannerParams& p = model_->params;
  CorrectionPlan& plan = sim.correction_plan();
  const double now = sim.time();
  const int dims = static_cast<int>(model_->dimensions.size());
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
  plan.knots = nominal_;
  plan.t0 = now;
  plan.knot_dt = knot_dt;
  const auto wall0 = std::chrono::steady_clock::now();
  if (workers_.empty())
    for (int w = 0; w < pool_->size(); ++w)
      workers_.push_back(std::make_unique<Simulation>(model_->rollout));
  if (!start_) start_ = std::make_unique<SimulationState>();
  sim.save(*start_);
  sample_horizons();

  // tracking on track, fewer candidates: the shifted plan mostly holds there
  TrackingError error;
  const bool steady =
      p.steady_error_m > 0 && tracking_error(sim, error) && error.body_m < p.steady_error_m;
  const int k = steady ? std::clamp(p.steady_samples, 1, p.samples) : p.samples;
  if (steady) ++plan.steady;
  order_.resize(k);
  const int rounds = p.method == "cem" ? p.iterations : 1;
  mean_ = nominal_;
  deviation_.setConstant(dims, n, p.noise);
  best_ = nominal_;
  double best_cost = std::numeric_limits<double>::infinity();
  int best_round = -1, best_index = -1;
  // one round: candidate 0 is the plan so far (rolled out again only in round 0), the others
  // are drawn around mean_ with deviation_
  auto run_round = [&](int round) {
    for (int i = 0; i < k; ++i) {
      Eigen::MatrixXd& knots = candidates_[i].knots;
      if (i == 0)
        knots = round == 0 ? nominal_ : best_;  // the plan so far is always a candidate
      else if (i == 1 && round == 0 && k > 2)
        knots.setZero();  // so is no correction at all
      else
        draw(mean_, deviation_, plan.plans, round, i, knots);
    }
    // after round 0, candidate 0 is best_, whose cost is known (rollouts are deterministic)
    const int first = round == 0 ? 0 : 1;
    if (first == 1) candidates_[0].cost = best_cost;
    // batches of 2, 4, 8, ... candidates: a batch's rollouts stop once they cannot beat the
    // cheapest of the batches before it. The batches are fixed, so the bound (and the plan) is
    // the same for any thread count. CEM refits to every cost: it rolls all out in one batch.
    const bool stop_early = p.method == "sampling";
    for (int begin = first, size = 2; begin < k; size *= 2) {
      const int end = stop_early ? std::min(k, begin + size) : k;
      const double bound = stop_early ? best_cost : std::numeric_limits<double>::infinity();
      pool_->run(end - begin, [&](int worker, int task) {
        Candidate& c = candidates_[begin + task];
        c.cost = rollout(*workers_[worker], c, bound);
      });
      // the cheapest, the lower index on a tie: the same for any thread count
      for (int i = begin; i < end; ++i) {
        rollout_steps_ += candidates_[i].steps;
        plan.rollout_steps += candidates_[i].steps;
        if (candidates_[i].cost < best_cost) {
          best_cost = candidates_[i].cost;
          best_ = candidates_[i].knots;
          best_round = round;
          best_index = i;
          best_path_.assign(candidates_[i].path.begin(), candidates_[i].path.end());
        }
      }
      begin = end;
    }
  };
  for (int round = 0; round < rounds; ++round) {
    run_round(round);
    if (round + 1 == rounds) break;
    // cem: refit the mean and deviation to the elites
    std::iota(order_.begin(), order_.end(), 0);
    std::stable_sort(order_.begin(), order_.end(),
                     [&](int a, int b) { return candidates_[a].cost < candidates_[b].cost; });
    const int elites = std::min(p.elites, k);
    mean_.setZero();
    for (int e = 0; e < elites; ++e) mean_ += candidates_[order_[e]].knots;
    mean_ /= elites;
    deviation_.setZero();
    for (int e = 0; e < elites; ++e)
      deviation_ += (candidates_[order_[e]].knots - mean_).cwiseAbs2();
    deviation_ = (deviation_ / elites).cwiseSqrt().cwiseMax(0.1 * p.noise);
  }
  // in trouble (the reference slipping away, or a push), more rounds around the best: the
  // budget goes where a miss would cost the run, not to every step of a walk that goes well
  if (p.rescue_rounds > 0 && p.rescue_error_m > 0 && balance_error(sim) >= p.rescue_error_m) {
    ++plan.rescues;
    for (int r = 0; r < p.rescue_rounds; ++r) {
      mean_ = best_;
      deviation_.setConstant(dims, n, p.noise);
      run_round(rounds + r);
    }
  }
  plan.knots = best_;
  ++plan.plans;
  plan.cost_sum += best_cost;
  if (best_round == 0 && best_index <= 1) ++plan.kept_nominal;
  plan_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
}

}  // namespace stance
