// model loading through stance's own path (make_engine), on both engines, then a step (MuJoCo)
// or the forward kinematics and dynamics (DART). Input: byte 0 picks
// the engine (even: mujoco, odd: dart), byte 1's two low bits the format (0: MJCF .xml, 1: SKEL
// .skel, 2: URDF .urdf, 3: SDF .sdf), the rest is the file.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  if (size < 2) return 0;
  // STANCE_FUZZ_MODEL_ENGINE=mujoco or dart pins the engine (to fuzz one engine's path alone)
  static const char* const kPinned = std::getenv("STANCE_FUZZ_MODEL_ENGINE");
  const std::string engine = kPinned ? kPinned : (data[0] & 1) != 0 ? "dart" : "mujoco";
  static const char* const kNames[4] = {"fuzz.xml", "fuzz.skel", "fuzz.urdf", "fuzz.sdf"};
  const std::string name = kNames[data[1] & 3];
  WorldSpec spec;
  spec.models.push_back({fuzz::write_scratch(name, fuzz::as_text(data + 2, size - 2))});
  try {
    std::unique_ptr<Engine> e = make_engine(engine, spec);
    // loading is what is fuzzed. DART is only forwarded: stance's DART backend built by clang
    // against Debian's gcc-built DART steps some models differently from the release tree (its
    // LCP then asserts inside DART; Makefile, test-sanitize), so a step there finds no bug of
    // stance's
    if (engine == "mujoco")
      e->step();
    else
      e->forward();
  } catch (const InputError&) {
  }
  return 0;
}
