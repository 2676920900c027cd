// LQR on the one-leg humanoid: the controller's per-step cost against MuJoCo's step, and the
// design time (set-point search + FD linearisation + DARE). Needs Debian's libmujoco-samples.
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>

#include <filesystem>

#include "control/lqr.h"
#include "engine/mujoco/mujoco_engine.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"

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

// MuJoCo's own step on the same model and state, for scale
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

}  // namespace
