// The cross-entropy method (CEM) as an ask/tell optimiser over a box: points are drawn from an
// axis-aligned Gaussian (a mean and a spread per coordinate), and each tell() refits the mean
// and spread to the best points (the elites).
//
// The caller owns the loop and the random generator, as with Cmaes (math/cmaes.h): ask() draws
// on the calling thread from the generator it is given; the caller evaluates the points however
// it likes and hands their values back to tell(). sample() draws one point from a generator and
// a normal stream the caller gives, so that each point can have its own stream (and thread).
//
// Refit over the elites (the `elites` best points, lower value first, ties in the order told):
//     mean_k   = their mean
//     spread_k = max(min_spread, spread_memory * spread_k + (1 - spread_memory) * s_k)
// with s_k their standard deviation (over n - 1 when sample_deviation, over n otherwise; with a
// single elite and sample_deviation, the old spread). A coordinate drawn outside the box is drawn
// again up to `redraws` times, then clamped.
#pragma once

#include <Eigen/Core>
#include <random>
#include <vector>

namespace stance {

struct CemParams {
  int elites = 4;                // points the refit keeps (all told points when fewer)
  double initial_spread = 0.3;   // per coordinate, before the first tell and after restart()
  double min_spread = 0.02;      // the refit's floor per coordinate
  double spread_memory = 0.5;    // weight of the old spread in the refit; 0: the elites' alone
  bool sample_deviation = true;  // the elites' deviation over n - 1 (else over n)
  int redraws = 8;               // draws again of a coordinate outside the box, then clamped
  bool elites_from_all = true;   // elites among every point told so far, else the last tell's

  template <class V>
  void visit(V& v) {
    v("elites", elites, {.min = 1, .help = "best points the refit keeps"});
    v("initial_spread", initial_spread,
      {.min = 0, .help = "deviation per coordinate before the first refit"});
    v("min_spread", min_spread, {.min = 0, .help = "floor of the refitted deviation"});
    v("spread_memory", spread_memory,
      {.min = 0, .max = 1, .help = "weight of the old deviation in the refit"});
    v("sample_deviation", sample_deviation, {.help = "the elites' deviation over n - 1"});
    v("redraws", redraws, {.min = 0, .help = "draws again of a coordinate outside the box"});
    v("elites_from_all", elites_from_all,
      {.help = "elites among every point told so far (else the last generation's)"});
  }
};

struct CemState {
  Eigen::VectorXd mean;    // dim n
  Eigen::VectorXd spread;  // dim n, the deviation per coordinate
  // the normal stream ask() draws from: it keeps a spare value between calls
  std::normal_distribution<double> normal{0.0, 1.0};
  // elites_from_all: every point told so far and its value, in the order told
  std::vector<Eigen::VectorXd> told;
  std::vector<double> told_values;
};

class Cem {
 public:
  // mean (dim n >= 1) and the box [lower, upper] (dim n each, lower < upper, infinite bounds
  // allowed). Throws std::invalid_argument.
  Cem(const Eigen::VectorXd& mean, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
      const CemParams& params = {});

  int dimension() const { return static_cast<int>(state_.mean.size()); }
  const CemParams& params() const { return params_; }

  // one point per column of `points` (n x count), coordinate by coordinate, from rng and the
  // state's normal stream. Allocates nothing.
  void ask(std::mt19937_64& rng, Eigen::Ref<Eigen::MatrixXd> points);
  // one point (dim n) from rng and the given normal stream; const, so that points with streams
  // of their own may be drawn on any thread. Allocates nothing.
  void sample(std::mt19937_64& rng, std::normal_distribution<double>& normal,
              Eigen::Ref<Eigen::VectorXd> point) const;
  // a Latin-hypercube sample of the box (a first generation that covers it) into the columns of
  // points (n x count): per coordinate, the range cut into count strata, one point in each, in
  // a random order. Needs finite bounds (throws std::invalid_argument).
  void ask_latin_hypercube(std::mt19937_64& rng, Eigen::Ref<Eigen::MatrixXd> points);
  // refits the mean and spread from the columns of points (n x count) and their values (lower
  // is better). Throws std::invalid_argument on a size mismatch or a NaN value. Allocates
  // nothing without elites_from_all, once a tell of this count has been made.
  void tell(const Eigen::Ref<const Eigen::MatrixXd>& points, const std::vector<double>& values);
  // starts again around `mean` with the initial spread, forgetting the told points
  void restart(const Eigen::Ref<const Eigen::VectorXd>& mean);

  const CemState& state() const { return state_; }
  // restores a saved state (dimensions checked; throws std::invalid_argument)
  void set_state(const CemState& state);

 private:
  // the mean and spread of the points point(order_[0]), ..., point(order_[elites - 1])
  template <class PointAt>
  void refit(const PointAt& point, int elites);

  CemParams params_;
  Eigen::VectorXd lower_, upper_;
  CemState state_;
  std::vector<int> order_, strata_;  // work vectors
};

}  // namespace stance
