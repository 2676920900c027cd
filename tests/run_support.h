// Shared by the tests that run scenarios.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "sim/simulation.h"

namespace stance::test {

// a run without the progress bar, on the scenario's engine or another
inline RunOptions quiet(const std::string& engine = "") {
  RunOptions o;
  o.quiet = true;
  o.engine = engine;
  return o;
}

// steps until the run's time reaches t (to half a step)
inline void step_to(Simulation& run, double t) {
  while (run.time() < t - 0.5 * run.engine().timestep()) ASSERT_TRUE(run.step());
}

inline double metric(const RunResult& r, const char* name) {
  return r.metrics.at(name).get<double>();
}

}  // namespace stance::test
