#include <fmt/format.h>

#include "core/error.h"
#include "engine/engine.h"
#include "engine/world_spec.h"

namespace stance {

std::unique_ptr<Engine> make_engine(const std::string& engine_name, const WorldSpec& spec) {
  if (engine_name == "mujoco") return make_mujoco_engine(spec);
  if (engine_name == "dart") {
#ifdef STANCE_HAVE_DART
    return make_dart_engine(spec);
#else
    throw InputError("this build of stance has no DART backend");
#endif
  }
  throw InputError(fmt::format("unknown engine '{}' (expected mujoco or dart)", engine_name));
}

}  // namespace stance
