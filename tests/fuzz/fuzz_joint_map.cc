// joint-map reading (YAML), as `bvh retarget --map` reads it
#include <cstdint>

#include "core/error.h"
#include "fuzz_support.h"
#include "motion/joint_map.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  const std::string path = fuzz::write_scratch("map.yaml", fuzz::as_text(data, size));
  try {
    read_joint_map(path);
  } catch (const InputError&) {
  }
  return 0;
}
