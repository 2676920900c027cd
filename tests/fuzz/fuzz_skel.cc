// SKEL reader: the checks DART's path runs, and the MJCF translation of the MuJoCo path.
#include <cstdint>

#include "core/error.h"
#include "fuzz_support.h"
#include "model/skel_to_mjcf.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  const std::string path = fuzz::write_scratch("fuzz.skel", fuzz::as_text(data, size));
  try {
    check_skel_for_dart(path);
  } catch (const InputError&) {
  }
  try {
    skel_to_mjcf({SkelInput{path}});
  } catch (const InputError&) {
  }
  return 0;
}
