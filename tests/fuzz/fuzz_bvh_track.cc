// `stance bvh track` on a fuzzed clip, through the functions the CLI calls: the clip read, its
// character built and the scenario written (write_bvh_track_scenario, which loads all of it
// once), then the run's first steps with the planner on. Bounded so that one input takes well
// under a second: a few steps, two candidates over a short horizon, one thread.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "app/commands.h"
#include "core/error.h"
#include "fuzz_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  BvhTrackCommand cmd;
  cmd.bvh = fuzz::write_scratch("fuzz.bvh", fuzz::as_text(data, size));
  cmd.out_dir = (fuzz::scratch_dir() / "track").string();
  cmd.threads = 1;
  cmd.quiet = true;
  // the planner's rollouts cost steps: a tenth of its default horizon, two candidates
  cmd.sets = {"planner.samples=2", "planner.horizon_s=0.02", "planner.interval_s=0.01",
              "planner.rescue_rounds=0"};
  try {
    const std::string scenario = write_bvh_track_scenario(cmd);
    RunOptions options;
    options.quiet = true;
    Simulation sim(load_scenario(scenario, cmd.sets), options);
    for (int k = 0; k < 8 && sim.step(); ++k) {
    }
  } catch (const InputError&) {
  }
  return 0;
}
