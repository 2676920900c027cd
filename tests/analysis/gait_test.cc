// Gait analysis on synthetic step sequences: periods 1, 2, 4, aperiodic, and asymmetry.
#include "analysis/gait.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace stance {
namespace {

// a transient that decays into the given cycle
std::vector<double> settle_into(const std::vector<double>& cycle, int transient, int steady) {
  std::vector<double> out;
  for (int i = 0; i < transient; ++i) out.push_back(0.6 + 0.3 * std::exp(-0.1 * i) * (i % 3));
  for (int i = 0; i < steady; ++i) out.push_back(cycle[i % cycle.size()]);
  return out;
}

GaitPeriodOptions options(int transient) {
  GaitPeriodOptions o;
  o.transient_steps = transient;
  o.tolerance = 1e-3;
  return o;
}

TEST(GaitPeriod, FindsPeriodOneTwoAndFourAfterTheTransient) {
  GaitPeriod p1 = detect_gait_period(settle_into({0.4}, 20, 40), options(20));
  EXPECT_EQ(p1.period, 1);
  ASSERT_EQ(p1.cycle.size(), 1u);
  EXPECT_DOUBLE_EQ(p1.cycle[0], 0.4);
  EXPECT_EQ(p1.analysed_steps, 40);

  GaitPeriod p2 = detect_gait_period(settle_into({0.3, 0.5}, 20, 40), options(20));
  EXPECT_EQ(p2.period, 2);
  EXPECT_DOUBLE_EQ(p2.cycle[1], 0.5);

  GaitPeriod p4 = detect_gait_period(settle_into({0.3, 0.5, 0.32, 0.48}, 20, 40), options(20));
  EXPECT_EQ(p4.period, 4);
  EXPECT_EQ(gait_period_label(p4.period), "period 4");
}

TEST(GaitPeriod, TransientIsIgnoredOnlyWhenSkipped) {
  std::vector<double> s = settle_into({0.4}, 20, 40);
  // without skipping, the transient's distinct lengths prevent a short period
  EXPECT_NE(detect_gait_period(s, options(0)).period, 1);
}

TEST(GaitPeriod, ToleranceAcceptsSmallNoise) {
  std::vector<double> s;
  for (int i = 0; i < 60; ++i) s.push_back((i % 2 ? 0.5 : 0.3) + 2e-4 * std::sin(1.7 * i));
  EXPECT_EQ(detect_gait_period(s, options(0)).period, 2);
  GaitPeriodOptions strict = options(0);
  strict.tolerance = 1e-5;
  EXPECT_EQ(detect_gait_period(s, strict).period, 0);
}

TEST(GaitPeriod, ChaoticSequenceIsAperiodic) {
  // logistic map at r = 3.9: chaotic
  std::vector<double> s;
  double x = 0.3;
  for (int i = 0; i < 200; ++i) {
    x = 3.9 * x * (1 - x);
    s.push_back(0.2 + 0.3 * x);
  }
  GaitPeriod p = detect_gait_period(s, options(50));
  EXPECT_EQ(p.period, 0);
  EXPECT_EQ(gait_period_label(p.period), "aperiodic");
  EXPECT_TRUE(p.cycle.empty());
}

TEST(GaitPeriod, TooFewStepsIsUndetermined) {
  GaitPeriod p = detect_gait_period(std::vector<double>{0.4, 0.4}, options(0));
  EXPECT_EQ(p.period, -1);
  EXPECT_EQ(gait_period_label(p.period), "undetermined");
  EXPECT_EQ(detect_gait_period(std::vector<double>(10, 0.4), options(30)).period, -1);
}

TEST(StepAsymmetry, ZeroWhenLegsMatchAndRelativeDifferenceOtherwise) {
  std::vector<double> sym(40, 0.4), drunk;
  std::vector<int> legs;
  for (int i = 0; i < 40; ++i) {
    legs.push_back(i % 2 ? 2 : 1);
    drunk.push_back(i % 2 ? 0.5 : 0.3);
  }
  EXPECT_DOUBLE_EQ(step_length_asymmetry(sym, legs, 10), 0.0);
  // |0.3 - 0.5| / 0.4
  EXPECT_NEAR(step_length_asymmetry(drunk, legs, 10), 0.5, 1e-12);
  // one leg only: no comparison possible
  std::vector<int> one(40, 1);
  EXPECT_EQ(step_length_asymmetry(drunk, one, 0), 0.0);
}

TEST(StepSpread, MeasuresRangeOverMean) {
  std::vector<double> s = {9, 9, 0.3, 0.5, 0.3, 0.5};
  EXPECT_NEAR(step_length_spread(s, 2), 0.5, 1e-12);
  EXPECT_EQ(step_length_spread(s, 10), 0.0);
}

}  // namespace
}  // namespace stance
