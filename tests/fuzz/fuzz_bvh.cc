// BVH reader, then everything built from a clip: the info summaries, the writer (whose text
// must read back), the motion skeleton, the reference motion and the MJCF character.
#include <cstdint>
#include <string>

#include "core/error.h"
#include "fuzz_support.h"
#include "model/bvh_to_mjcf.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  BvhClip clip;
  try {
    clip = parse_bvh(fuzz::as_text(data, size), "fuzz.bvh");
  } catch (const InputError&) {
    return 0;
  }
  bvh_info_json(clip).dump();
  bvh_info_text(clip);
  // what the writer writes, the reader reads
  const std::string written = format_bvh(clip);
  BvhClip again = parse_bvh(written, "written.bvh");
  if (again.joint_count() != clip.joint_count() || again.frame_count != clip.frame_count)
    __builtin_trap();
  try {
    MotionSkeleton skeleton = make_motion_skeleton(clip, MotionSkeletonOptions{});
    ReferenceMotion reference(clip, skeleton, ReferenceOptions{});
    make_bvh_character(clip, BvhCharacterOptions{});
  } catch (const InputError&) {
  }
  return 0;
}
