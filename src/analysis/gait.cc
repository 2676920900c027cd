#include "analysis/gait.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace stance {

GaitPeriod detect_gait_period(std::span<const double> lengths, const GaitPeriodOptions& options) {
  GaitPeriod out;
  const int skip = std::min<int>(options.transient_steps, static_cast<int>(lengths.size()));
  std::span<const double> s = lengths.subspan(skip);
  const int n = static_cast<int>(s.size());
  out.analysed_steps = n;
  const int cycles = std::max(2, options.min_cycles);
  // the shortest period must be testable at all
  if (n < cycles) return out;
  out.period = 0;
  for (int p = 1; p <= options.max_period && p * cycles <= n; ++p) {
    double worst = 0;
    for (int i = 0; i + p < n; ++i) worst = std::max(worst, std::abs(s[i] - s[i + p]));
    if (worst <= options.tolerance) {
      out.period = p;
      out.max_mismatch = worst;
      out.cycle.assign(s.begin(), s.begin() + p);
      return out;
    }
  }
  return out;
}

std::string gait_period_label(int period) {
  if (period < 0) return "undetermined";
  if (period == 0) return "aperiodic";
  return "period " + std::to_string(period);
}

double step_length_asymmetry(std::span<const double> lengths, std::span<const int> stance_legs,
                             int transient_steps) {
  double sum[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  const size_t n = std::min(lengths.size(), stance_legs.size());
  for (size_t i = std::max(0, transient_steps); i < n; ++i) {
    const int leg = stance_legs[i];
    if (leg != 1 && leg != 2) continue;
    sum[leg] += lengths[i];
    ++count[leg];
  }
  if (count[1] == 0 || count[2] == 0) return 0;
  const double mean = (sum[1] + sum[2]) / (count[1] + count[2]);
  if (mean == 0) return 0;
  return std::abs(sum[1] / count[1] - sum[2] / count[2]) / std::abs(mean);
}

double step_length_spread(std::span<const double> lengths, int transient_steps) {
  const size_t skip = std::min(lengths.size(), static_cast<size_t>(std::max(0, transient_steps)));
  std::span<const double> s = lengths.subspan(skip);
  if (s.empty()) return 0;
  auto [lo, hi] = std::minmax_element(s.begin(), s.end());
  const double mean = std::accumulate(s.begin(), s.end(), 0.0) / s.size();
  return mean == 0 ? 0 : (*hi - *lo) / std::abs(mean);
}

}  // namespace stance
