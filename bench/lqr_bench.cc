// LQR on the one-leg humanoid: the controller's per-step cost against MuJoCo's step, and the
// design time (set-point search + FD linearisation + DARE). Needs Debian's libmujoco-samples.
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>

#include <chrono>
#include <filesystem>

#include "batch/sweep.h"
#include "control/lqr.h"
#include "engine/mujoco/mujoco_engine.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace {

using namespace stance;

const std::string kScenario = std::string(STANCE_SOURCE_DIR) + "/scenarios/lqr_one_leg.yaml";

bool humanoid_missing(benchmark::State& state) {
  if (std::filesystem::exists("/usr/share/mujoco/model/humanoid/humanoid.xml")) return false;
  state.SkipWithError("humanoid.xml missing (Debian package libmujoco-samples)");
  return true;
}

std::unique_ptr<Engine> one_leg_engine() {
  LoadedScenario l = load_scenario(kScenario, {"controllers.0.force_plot=false"});
  return make_scenario_engine(l.scenario, "mujoco");
}

// one compute(): tangent difference, K [dq; v] (21 x 54), COM-foot distance
void BM_LqrCompute(benchmark::State& state) {
  if (humanoid_missing(state)) return;
  auto engine = one_leg_engine();
  ControllerContext ctx;
  ctx.scratch_engine = one_leg_engine;  // the design's own engine
  const Lqr lqr(LqrParams{}, ctx, *engine);
  std::unique_ptr<ControllerState> lqr_state = lqr.make_state(*engine);
  ControlOutput out;
  out.resize(engine->nv(), engine->nu());
  engine->forward();
  for (auto _ : state) {
    out.clear();
    lqr.compute(*lqr_state, *engine, out);
    benchmark::DoNotOptimize(out.ctrl.data());
  }
}
BENCHMARK(BM_LqrCompute);

// the bare ctrl0 - K x, without the COM-foot metric
void BM_LqrGainOnly(benchmark::State& state) {
  if (humanoid_missing(state)) return;
  auto engine = one_leg_engine();
  LqrDesign design = design_lqr(LqrParams{}, *engine);
  const int nv = engine->nv();
  Eigen::VectorXd q(engine->nq()), x(2 * nv), u(engine->nu()), ctrl(engine->nu());
  for (auto _ : state) {
    engine->get_positions(q);
    engine->difference_positions(design.setpoint.q0, q, x.head(nv));
    engine->get_velocities(x.tail(nv));
    u.noalias() = design.K * x;
    ctrl = design.setpoint.ctrl0 - u;
    benchmark::DoNotOptimize(ctrl.data());
  }
}
BENCHMARK(BM_LqrGainOnly);

// MuJoCo's own step on the same model and state, for scale: a bare-engine baseline (constant
// set-point controls, no controller), so it calls mj_step rather than Simulation::step
void BM_MjStep(benchmark::State& state) {
  if (humanoid_missing(state)) return;
  auto engine = one_leg_engine();
  auto& mj = dynamic_cast<MujocoEngine&>(*engine);
  LqrDesign design = design_lqr(LqrParams{}, *engine);
  mjData* d = mj.data();
  EngineState start;
  engine->save_state(start);
  long k = 0;
  for (auto _ : state) {
    // restart now and then so the humanoid stays near the pose
    if (++k % 200 == 0) {
      state.PauseTiming();
      engine->restore_state(start);
      state.ResumeTiming();
    }
    Eigen::Map<Eigen::VectorXd>(d->ctrl, engine->nu()) = design.setpoint.ctrl0;
    mj_step(mj.model(), d);
  }
}
BENCHMARK(BM_MjStep);

// the whole design: set-point search, Jacobians, mjd_transitionFD, DARE, K
void BM_LqrDesign(benchmark::State& state) {
  if (humanoid_missing(state)) return;
  auto engine = one_leg_engine();
  double setpoint = 0, linearize = 0, dare = 0;
  for (auto _ : state) {
    LqrDesign design = design_lqr(LqrParams{}, *engine);
    setpoint += design.setpoint_ms;
    linearize += design.linearize_ms;
    dare += design.dare_ms;
    benchmark::DoNotOptimize(design.K.data());
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["setpoint_ms"] = setpoint / n;
  state.counters["linearize_ms"] = linearize / n;
  state.counters["dare_ms"] = dare / n;
}
BENCHMARK(BM_LqrDesign)->Unit(benchmark::kMillisecond);

// the push-force sweep (8 points, 0..40 N on the torso at 1 s, 1.5 s runs, one thread),
// once with the sweep's shared controller models and once with every point designing its own
// LQR. One iteration is both sweeps. Counters:
//   cached_s, rebuilt_s            wall time of one sweep each way
//   rebuilt_over_cached            their ratio
//   cached_designs, rebuilt_designs  LQR designs made per sweep (lqr_designs_made())
void BM_LqrPushSweep(benchmark::State& state) {
  if (humanoid_missing(state)) return;
  SweepOptions options;
  options.scenario = kScenario;
  options.sets = {"controllers.0.force_plot=false",
                  "perturbations=[{body: torso, force: [0, 0, 0], start: 1, duration: 0.1}]"};
  options.param = "perturbations.0.force.0";
  options.values = linspace(0, 40, 8);
  options.duration = 1.5;
  options.threads = 1;
  double seconds[2] = {0, 0};
  long designs[2] = {0, 0};
  for (auto _ : state) {
    for (int rebuilt = 0; rebuilt < 2; ++rebuilt) {
      options.share_models = rebuilt == 0;
      const long designs0 = lqr_designs_made();
      const auto t0 = std::chrono::steady_clock::now();
      std::vector<SweepPoint> points = run_sweep(options);
      seconds[rebuilt] +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      designs[rebuilt] += lqr_designs_made() - designs0;
      for (const SweepPoint& p : points)
        if (!p.error.empty()) state.SkipWithError(p.error.c_str());
      benchmark::DoNotOptimize(points.data());
    }
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["cached_s"] = seconds[0] / n;
  state.counters["rebuilt_s"] = seconds[1] / n;
  state.counters["rebuilt_over_cached"] = seconds[0] > 0 ? seconds[1] / seconds[0] : 0.0;
  state.counters["cached_designs"] = designs[0] / n;
  state.counters["rebuilt_designs"] = designs[1] / n;
  state.SetLabel("8-point push sweep, 1.5 s runs, 1 thread: models cached, then rebuilt");
}
BENCHMARK(BM_LqrPushSweep)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
