// The cross-entropy method: it converges on quadratics (both elite rules), a seed fixes every
// point, and the ask/tell contract holds (points in the box, the refit is the elites' mean and
// deviation, bad tells throw, a saved state continues to the same points).
#include "math/cem.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

namespace stance {
namespace {

double quadratic(const Eigen::VectorXd& x, const Eigen::VectorXd& centre) {
  Eigen::VectorXd d = x - centre;
  double f = 0;
  for (int i = 0; i < d.size(); ++i) f += (i + 1) * d[i] * d[i];  // unequal curvatures
  return f;
}

// generations of `population` points; returns the best value found
double minimise(Cem& cem, const Eigen::VectorXd& centre, int population, int generations,
                unsigned long long seed) {
  std::mt19937_64 rng(seed);
  Eigen::MatrixXd points(cem.dimension(), population);
  std::vector<double> values(population);
  double best = INFINITY;
  for (int g = 0; g < generations; ++g) {
    cem.ask(rng, points);
    for (int c = 0; c < population; ++c) {
      values[c] = quadratic(points.col(c), centre);
      best = std::min(best, values[c]);
    }
    cem.tell(points, values);
  }
  return best;
}

CemParams tight(bool elites_from_all) {
  CemParams p;
  p.elites = 10;
  p.initial_spread = 0.3;
  p.min_spread = 1e-9;
  p.spread_memory = 0.5;  // against the early collapse of a plain CEM
  p.elites_from_all = elites_from_all;
  return p;
}

TEST(Cem, ConvergesOnAQuadraticInTheUnitBox) {
  const int n = 4;
  Eigen::VectorXd centre(n);
  centre << 0.3, 0.7, 0.55, 0.2;
  for (bool from_all : {false, true})
    for (unsigned long long seed : {1, 2, 3}) {
      Cem cem(Eigen::VectorXd::Constant(n, 0.5), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Ones(n),
              tight(from_all));
      const double best = minimise(cem, centre, 40, 80, seed);
      EXPECT_LT(best, 1e-8) << "from_all " << from_all << " seed " << seed;
      EXPECT_LT((cem.state().mean - centre).cwiseAbs().maxCoeff(), 1e-4)
          << "from_all " << from_all << " seed " << seed;
    }
}

TEST(Cem, FindsAnOptimumOnTheBoundary) {
  // the centre lies outside the box: the best point of the box is its corner (1, 0)
  Eigen::VectorXd centre(2);
  centre << 1.5, -0.5;
  Cem cem(Eigen::VectorXd::Constant(2, 0.5), Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2),
          tight(false));
  minimise(cem, centre, 40, 80, 7);
  EXPECT_NEAR(cem.state().mean[0], 1.0, 1e-6);
  EXPECT_NEAR(cem.state().mean[1], 0.0, 1e-6);
}

TEST(Cem, ASeedFixesEveryPoint) {
  auto run = [](unsigned long long seed) {
    Cem cem(Eigen::VectorXd::Constant(3, 0.5), Eigen::VectorXd::Zero(3), Eigen::VectorXd::Ones(3));
    std::mt19937_64 rng(seed);
    Eigen::MatrixXd all(3, 0), points(3, 5);
    cem.ask_latin_hypercube(rng, points);
    for (int g = 0; g < 4; ++g) {
      if (g > 0) cem.ask(rng, points);
      std::vector<double> v(5);
      for (int c = 0; c < 5; ++c) v[c] = quadratic(points.col(c), Eigen::VectorXd::Zero(3));
      cem.tell(points, v);
      all.conservativeResize(3, all.cols() + 5);
      all.rightCols(5) = points;
    }
    return all;
  };
  EXPECT_EQ(run(5), run(5));  // bit for bit
  EXPECT_NE(run(5), run(6));
}

TEST(Cem, PointsStayInTheBox) {
  Eigen::VectorXd lo(2), hi(2);
  lo << -1, 2;
  hi << 1, 2.5;
  CemParams p;
  p.initial_spread = 5;  // far wider than the box: most draws fall outside
  p.redraws = 0;
  Cem cem(Eigen::VectorXd::Zero(2) + Eigen::VectorXd(lo), lo, hi, p);
  std::mt19937_64 rng(1);
  Eigen::MatrixXd points(2, 200);
  cem.ask(rng, points);
  for (int c = 0; c < points.cols(); ++c) {
    EXPECT_TRUE((points.col(c).array() >= lo.array()).all());
    EXPECT_TRUE((points.col(c).array() <= hi.array()).all());
  }
  cem.ask_latin_hypercube(rng, points);
  for (int c = 0; c < points.cols(); ++c) {
    EXPECT_TRUE((points.col(c).array() >= lo.array()).all());
    EXPECT_TRUE((points.col(c).array() <= hi.array()).all());
  }
}

TEST(Cem, LatinHypercubePutsOnePointInEachStratum) {
  const int n = 3, m = 7;
  Cem cem(Eigen::VectorXd::Constant(n, 0.5), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Ones(n));
  std::mt19937_64 rng(3);
  Eigen::MatrixXd points(n, m);
  cem.ask_latin_hypercube(rng, points);
  for (int k = 0; k < n; ++k) {
    std::vector<int> hits(m, 0);
    for (int c = 0; c < m; ++c) ++hits[static_cast<int>(points(k, c) * m)];
    for (int s = 0; s < m; ++s) EXPECT_EQ(hits[s], 1) << "coordinate " << k << " stratum " << s;
  }
  Cem unbounded(Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, -INFINITY),
                Eigen::VectorXd::Constant(1, INFINITY));
  Eigen::MatrixXd one(1, 3);
  EXPECT_THROW(unbounded.ask_latin_hypercube(rng, one), std::invalid_argument);
}

TEST(Cem, TellRefitsToTheElites) {
  // four points in one dimension; the two best (values 1 and 2) are at 0.2 and 0.4
  CemParams p;
  p.elites = 2;
  p.spread_memory = 0.5;
  p.min_spread = 0.01;
  p.elites_from_all = false;
  Eigen::MatrixXd points(1, 4);
  points << 0.9, 0.2, 0.4, 0.1;
  const std::vector<double> values = {5, 1, 2, 3};
  Cem sample(Eigen::VectorXd::Constant(1, 0.5), Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1),
             p);
  sample.tell(points, values);
  EXPECT_DOUBLE_EQ(sample.state().mean[0], 0.3);
  // deviation over n - 1: sqrt(0.02); the spread keeps half of the old 0.3
  EXPECT_DOUBLE_EQ(sample.state().spread[0], 0.5 * 0.3 + 0.5 * std::sqrt(0.02));

  p.sample_deviation = false;
  p.spread_memory = 0;
  Cem population(Eigen::VectorXd::Constant(1, 0.5), Eigen::VectorXd::Zero(1),
                 Eigen::VectorXd::Ones(1), p);
  population.tell(points, values);
  EXPECT_DOUBLE_EQ(population.state().spread[0], std::sqrt(0.01));
  // the floor
  Eigen::MatrixXd same(1, 2);
  same << 0.6, 0.6;
  population.tell(same, {1, 1});
  EXPECT_DOUBLE_EQ(population.state().mean[0], 0.6);
  EXPECT_DOUBLE_EQ(population.state().spread[0], 0.01);
}

TEST(Cem, ElitesFromAllRememberEarlierPoints) {
  CemParams p;
  p.elites = 1;
  p.elites_from_all = true;
  Cem cem(Eigen::VectorXd::Constant(1, 0.5), Eigen::VectorXd::Zero(1), Eigen::VectorXd::Ones(1), p);
  Eigen::MatrixXd first(1, 2), second(1, 2);
  first << 0.25, 0.75;
  second << 0.1, 0.9;
  cem.tell(first, {1, 2});
  cem.tell(second, {3, 4});  // worse than the first tell's best
  EXPECT_DOUBLE_EQ(cem.state().mean[0], 0.25);
  EXPECT_EQ(cem.state().told.size(), 4u);
  cem.tell(second, {1, 0.5});  // a tie with 0.25 keeps the earlier point; 0.9 is now best
  EXPECT_DOUBLE_EQ(cem.state().mean[0], 0.9);
  cem.restart(Eigen::VectorXd::Constant(1, 0.4));
  EXPECT_TRUE(cem.state().told.empty());
  EXPECT_DOUBLE_EQ(cem.state().spread[0], p.initial_spread);
}

TEST(Cem, ASavedStateContinuesToTheSamePoints) {
  Cem a(Eigen::VectorXd::Constant(2, 0.5), Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2));
  std::mt19937_64 rng(11);
  Eigen::MatrixXd points(2, 5);  // an odd count: the normal stream holds a spare value
  for (int g = 0; g < 3; ++g) {
    a.ask(rng, points);
    std::vector<double> v(5);
    for (int c = 0; c < 5; ++c) v[c] = quadratic(points.col(c), Eigen::VectorXd::Zero(2));
    a.tell(points, v);
  }
  Cem b(Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2));
  b.set_state(a.state());
  std::mt19937_64 rng_b = rng;
  Eigen::MatrixXd pa(2, 5), pb(2, 5);
  a.ask(rng, pa);
  b.ask(rng_b, pb);
  EXPECT_EQ(pa, pb);
}

TEST(Cem, SampleWithItsOwnStreamLeavesTheStateAlone) {
  Cem cem(Eigen::VectorXd::Constant(2, 0.5), Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(2));
  const CemState before = cem.state();
  Eigen::VectorXd x(2), y(2);
  for (Eigen::VectorXd* out : {&x, &y}) {
    std::mt19937_64 rng(42);
    std::normal_distribution<double> normal(0.0, 1.0);
    cem.sample(rng, normal, *out);
  }
  EXPECT_EQ(x, y);  // one stream, one point, whatever came before
  EXPECT_EQ(cem.state().mean, before.mean);
  EXPECT_EQ(cem.state().spread, before.spread);
}

// the settings the sampling planner's CEM needs (planner.cc: one stream per candidate, clamped
// at once, elites of the last round, deviation over n, floor 0.1 noise) reproduce its draw and
// refit bit for bit; written out here as the planner has them, dims x knots column-major
TEST(Cem, PlannerSettingsReproduceThePlannersCem) {
  const int dims = 5, knots = 4, n = dims * knots, k = 16, elites = 4;
  const double noise = 1.3, limit = 3;
  Eigen::MatrixXd mean = Eigen::MatrixXd::Constant(dims, knots, 0.2);
  Eigen::MatrixXd deviation = Eigen::MatrixXd::Constant(dims, knots, noise);
  CemParams p;
  p.elites = elites;
  p.initial_spread = noise;
  p.min_spread = 0.1 * noise;
  p.spread_memory = 0;
  p.sample_deviation = false;
  p.redraws = 0;
  p.elites_from_all = false;
  Cem cem(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Constant(n, -limit),
          Eigen::VectorXd::Constant(n, limit), p);
  cem.restart(Eigen::Map<const Eigen::VectorXd>(mean.data(), n));
  for (int round = 0; round < 5; ++round) {
    std::vector<Eigen::MatrixXd> planned(k, Eigen::MatrixXd(dims, knots));
    Eigen::MatrixXd points(n, k);
    std::vector<double> cost(k);
    for (int i = 0; i < k; ++i) {
      std::mt19937_64 rng(1000 * round + i), rng_cem(1000 * round + i);
      std::normal_distribution<double> normal(0.0, 1.0), normal_cem(0.0, 1.0);
      for (int j = 0; j < knots; ++j)
        for (int d = 0; d < dims; ++d)
          planned[i](d, j) = std::clamp(mean(d, j) + deviation(d, j) * normal(rng), -limit, limit);
      cem.sample(rng_cem, normal_cem, points.col(i));
      ASSERT_EQ(Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(planned[i].data(), n)), points.col(i));
      cost[i] = (planned[i].array() - 0.7).square().sum();
    }
    std::vector<int> order(k);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cost[a] < cost[b]; });
    mean.setZero();
    for (int e = 0; e < elites; ++e) mean += planned[order[e]];
    mean /= elites;
    deviation.setZero();
    for (int e = 0; e < elites; ++e) deviation += (planned[order[e]] - mean).cwiseAbs2();
    deviation = (deviation / elites).cwiseSqrt().cwiseMax(0.1 * noise);
    cem.tell(points, cost);
    EXPECT_EQ(Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(mean.data(), n)), cem.state().mean);
    EXPECT_EQ(Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(deviation.data(), n)),
              cem.state().spread);
  }
}

TEST(Cem, RejectsBadArguments) {
  Eigen::VectorXd m = Eigen::VectorXd::Constant(2, 0.5), lo = Eigen::VectorXd::Zero(2),
                  hi = Eigen::VectorXd::Ones(2);
  EXPECT_THROW(Cem(Eigen::VectorXd(), lo, hi), std::invalid_argument);
  EXPECT_THROW(Cem(m, hi, lo), std::invalid_argument);
  EXPECT_THROW(Cem(m, lo, Eigen::VectorXd::Ones(3)), std::invalid_argument);
  CemParams p;
  p.elites = 0;
  EXPECT_THROW(Cem(m, lo, hi, p), std::invalid_argument);
  p = {};
  p.spread_memory = 1.5;
  EXPECT_THROW(Cem(m, lo, hi, p), std::invalid_argument);
  Cem cem(m, lo, hi);
  EXPECT_THROW(cem.tell(Eigen::MatrixXd::Zero(2, 3), {1, 2}), std::invalid_argument);
  EXPECT_THROW(cem.tell(Eigen::MatrixXd::Zero(3, 2), {1, 2}), std::invalid_argument);
  EXPECT_THROW(cem.tell(Eigen::MatrixXd::Zero(2, 2), {1, NAN}), std::invalid_argument);
  std::mt19937_64 rng(1);
  Eigen::MatrixXd wrong(3, 2);
  EXPECT_THROW(cem.ask(rng, wrong), std::invalid_argument);
  CemState bad = cem.state();
  bad.mean = Eigen::VectorXd::Zero(3);
  EXPECT_THROW(cem.set_state(bad), std::invalid_argument);
}

}  // namespace
}  // namespace stance
