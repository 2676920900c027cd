#include "batch/push_threshold.h"

#include <fmt/format.h>

#include <mutex>

#include "core/error.h"
#include "core/executor.h"
#include "sim/simulation.h"

namespace stance {

namespace {
RunOptions trial_options(const PushThresholdOptions& o, double signed_force) {
  RunOptions r;
  r.engine = o.engine;
  r.duration = o.duration;
  r.quiet = true;
  Perturbation p;
  p.body = o.body;
  p.force[o.axis] = signed_force;
  p.start = o.at;
  p.duration = o.push_duration;
  p.point = o.point;
  p.offset = o.offset;
  r.extra_pushes.push_back(p);
  return r;
}
}  // namespace

PushBracket bisect_push(const std::function<bool(double)>& survives, double max_force,
                        double tolerance) {
  PushBracket b;
  auto trial = [&](double f) {
    ++b.trials;
    return survives(f);
  };
  if (trial(max_force)) {
    b.survived = max_force;
    return b;
  }
  b.fell = max_force;
  if (!trial(0.0)) {
    b.falls_unpushed = true;
    b.fell = 0.0;
    return b;
  }
  while (*b.fell - b.survived > tolerance) {
    double mid = 0.5 * (b.survived + *b.fell);
    if (trial(mid))
      b.survived = mid;
    else
      b.fell = mid;
  }
  return b;
}

bool survives_push(const LoadedScenario& loaded, const PushThresholdOptions& options,
                   double signed_force, ControllerCache* cache) {
  RunOptions ro = trial_options(options, signed_force);
  ro.cache = cache;
  RunResult r = Simulation(loaded, ro).run();
  return !r.fell && !r.diverged;
}

PushThresholdResult find_push_threshold(
    const LoadedScenario& loaded, const PushThresholdOptions& options,
    const std::function<void(double signed_force, bool survived)>& on_trial) {
  const PushThresholdOptions& o = options;
  if (o.axis < 0 || o.axis > 2)
    throw InputError(fmt::format("push-threshold: axis {} not 0..2", o.axis));
  if (!(o.max_force > 0)) throw InputError("push-threshold: --max must be > 0");
  if (!(o.tolerance > 0)) throw InputError("push-threshold: --tolerance must be > 0");
  if (!(o.push_duration > 0)) throw InputError("push-threshold: --push-duration must be > 0");
  const double run_end = o.duration.value_or(loaded.scenario.duration);
  if (o.at + o.push_duration > run_end)
    throw InputError(fmt::format("push-threshold: the push ({} s + {} s) ends after the run ({} s)",
                                 o.at, o.push_duration, run_end));
  if (o.body.empty()) throw InputError("push-threshold: --body is required");
  // every trial changes only the push: the controllers' models are built once
  ControllerCache cache;
  {
    // a probe build: an unknown body or engine fails here, on this thread
    RunOptions ro = trial_options(o, 0.0);
    ro.cache = &cache;
    Simulation probe(loaded, ro);
  }

  std::mutex report_mutex;
  auto direction = [&](double sign) {
    PushBracket b = bisect_push(
        [&](double f) {
          bool ok = survives_push(loaded, o, sign * f, &cache);
          if (on_trial) {
            std::lock_guard<std::mutex> lock(report_mutex);
            on_trial(sign * f, ok);
          }
          return ok;
        },
        o.max_force, o.tolerance);
    b.sign = sign;
    return b;
  };

  // the two directions are independent: on two workers when asked, positive first otherwise
  PushThresholdResult result;
  run_parallel(2, o.threads >= 2 ? 2 : 1, [&](int task) {
    if (task == 0)
      result.positive = direction(+1);
    else
      result.negative = direction(-1);
  });
  return result;
}

}  // namespace stance
