// Gait analysis on a sequence of step lengths, free of any engine: the period of the gait after
// its transient (1, 2, 4, ... or aperiodic) and the step-length asymmetry between the legs.
#pragma once

#include <span>
#include <string>
#include <vector>

namespace stance {

struct GaitPeriodOptions {
  int transient_steps = 30;  // steps dropped from the front before analysis
  int max_period = 16;       // longest period looked for
  double tolerance = 2e-3;   // two step lengths this close (same units) count as equal
  int min_cycles = 3;        // a period p must repeat over at least min_cycles * p steps
};

struct GaitPeriod {
  // smallest p with |s[i] - s[i + p]| <= tolerance over the whole analysed window;
  // 0: aperiodic (no p up to max_period fits); -1: too few steps to tell
  int period = -1;
  int analysed_steps = 0;     // steps after the transient
  double max_mismatch = 0;    // max |s[i] - s[i + period]| for the period found (0 if none)
  std::vector<double> cycle;  // one period's step lengths, starting at the window's start
};

// lengths: all steps in order. See GaitPeriod for what is returned.
GaitPeriod detect_gait_period(std::span<const double> lengths, const GaitPeriodOptions& options);

// "period 1", "period 2", "aperiodic", "undetermined"
std::string gait_period_label(int period);

// step-length asymmetry after the transient: |mean(leg 1 steps) - mean(leg 2 steps)| divided by
// the mean of all of them (0: symmetric). lengths and stance_legs (1 or 2) have the same size.
// Returns 0 when either leg has no steps.
double step_length_asymmetry(std::span<const double> lengths, std::span<const int> stance_legs,
                             int transient_steps);

// (max - min) / mean of the step lengths after the transient: 0 for a period-1 gait, large for
// a drunken or chaotic one. 0 when no steps remain.
double step_length_spread(std::span<const double> lengths, int transient_steps);

}  // namespace stance
