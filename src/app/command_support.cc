#include "app/command_support.h"

#include <fmt/format.h>

#include "core/error.h"
#include "core/text_check.h"
#include "params/option_check.h"
#include "sim/planner_params.h"
#include "sim/scenario.h"

namespace stance::command_support {

std::atomic<bool> g_interrupt{false};

extern "C" void request_interrupt(int) {
  g_interrupt.store(true);
}

ParamMeta duration_range() {
  return param_meta<Scenario>("duration");
}
ParamMeta threads_range() {
  return param_meta<PlannerParams>("threads");
}

// a resume file's JSON, its nesting bounded while it is parsed: nlohmann's dump and comparisons
// recurse once per level, so a file nested 100,000 deep would overflow the stack
nlohmann::json parse_resume_json(std::istream& in, const std::string& path) {
  constexpr int kMaxDepth = 64;
  return nlohmann::json::parse(in, [&](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
    if (depth > kMaxDepth)
      throw InputError(fmt::format("{}: nested more than {} deep: not a resume file of stance",
                                   path, kMaxDepth));
    return true;
  });
}

// a file name that goes into JSON (a resume file's options, a name made from it) must be UTF-8,
// as JSON is
void check_utf8_file_name(const std::string& path) {
  const size_t bad = invalid_utf8_offset(path);
  if (bad == std::string::npos) return;
  throw InputError(
      fmt::format("{}: the file name is not UTF-8 (byte 0x{:02X} at character {}): "
                  "rename the file",
                  printable_text(path), static_cast<unsigned char>(path[bad]), bad + 1));
}

}  // namespace stance::command_support
