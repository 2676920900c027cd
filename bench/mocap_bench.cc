// Motion-capture tracking per engine step: the bare step against the step with the tracker, for
// the tracker in free mode on its bvh2mjcf character and the retargeting tracker on MuJoCo's
// humanoid.xml and on fullbody1 (both engines). Counters as in step_share.h; one iteration is
// 100 bare + 100 tracked steps from the clip's first frame.
#include <benchmark/benchmark.h>

#include <string>

#include "step_share.h"

namespace {

std::string scenario(const char* name) {
  return std::string(STANCE_SOURCE_DIR) + "/scenarios/" + name;
}

void BM_MocapFreeMujoco(benchmark::State& state) {
  stance::bench::measure_step_share(state, scenario("mocap_track.yaml"), "mujoco", 0, true,
                                    {"controllers.0.mode=free"});
  state.SetLabel("mocap_retarget free mode (balance layer), synthetic walk, dt 2 ms");
}
BENCHMARK(BM_MocapFreeMujoco)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MocapRetargetHumanoidMujoco(benchmark::State& state) {
  stance::bench::measure_step_share(state, scenario("mocap_retarget.yaml"), "mujoco", 0);
  state.SetLabel("mocap_retarget assisted on humanoid.xml, dt 2 ms");
}
BENCHMARK(BM_MocapRetargetHumanoidMujoco)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MocapRetargetFullbody1Mujoco(benchmark::State& state) {
  stance::bench::measure_step_share(state, scenario("mocap_retarget_fullbody1.yaml"), "mujoco", 0);
  state.SetLabel("mocap_retarget assisted on fullbody1, dt 1 ms");
}
BENCHMARK(BM_MocapRetargetFullbody1Mujoco)->Unit(benchmark::kMillisecond)->UseRealTime();

#ifdef STANCE_HAVE_DART
void BM_MocapRetargetFullbody1Dart(benchmark::State& state) {
  stance::bench::measure_step_share(state, scenario("mocap_retarget_fullbody1.yaml"), "dart", 0);
  state.SetLabel("mocap_retarget assisted on fullbody1, dt 1 ms");
}
BENCHMARK(BM_MocapRetargetFullbody1Dart)->Unit(benchmark::kMillisecond)->UseRealTime();
#endif

}  // namespace
