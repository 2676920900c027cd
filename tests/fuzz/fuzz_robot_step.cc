// A fuzzed URDF or SDF as `stance info` loads it (make_engine), on both engines, each then
// taking one step. Input: byte 0's low bit picks the format (0: URDF .urdf, 1: SDF .sdf), the
// rest is the file.
#include <cstdint>
#include <memory>
#include <string>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "fuzz_support.h"

namespace {

// what `stance info` reads of a loaded model, then a step
void load_and_step(const std::string& engine, const stance::WorldSpec& spec) {
  using namespace stance;
  try {
    std::unique_ptr<Engine> e = make_engine(engine, spec);
    e->total_mass();
    for (int i = 0; i < e->nv(); ++i) e->dof_name(i);
    for (int i = 0; i < e->nbody(); ++i) e->body_name(i);
    e->step();
    e->state_is_finite();
  } catch (const InputError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  if (size < 1) return 0;
  const std::string name = (data[0] & 1) != 0 ? "fuzz.sdf" : "fuzz.urdf";
  WorldSpec spec;
  spec.models.push_back({fuzz::write_scratch(name, fuzz::as_text(data + 1, size - 1))});
  load_and_step("mujoco", spec);
  load_and_step("dart", spec);
  return 0;
}
