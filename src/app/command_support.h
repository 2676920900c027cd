// Private to src/app/commands*.cc: what the commands share (the interrupt handler, the ranges
// of the numeric options, the checks of resume files and file names).
#pragma once

#include <nlohmann/json.hpp>

#include <signal.h>

#include <atomic>
#include <istream>
#include <string>

#include "params/params.h"

namespace stance::command_support {

// set by SIGINT or SIGTERM while an InterruptHandler lives
extern std::atomic<bool> g_interrupt;

extern "C" void request_interrupt(int);

// while a run writes its outputs, SIGINT and SIGTERM end it cleanly: the log is flushed and
// summary.json says "interrupted": true. The handler is reset on its first call, so a second
// Ctrl-C kills at once.
class InterruptHandler {
 public:
  InterruptHandler() {
    g_interrupt.store(false);
    struct sigaction sa {};
    sa.sa_handler = request_interrupt;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~InterruptHandler() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};

// the ranges of the numeric options: those of the parameters they set, where there is one
ParamMeta duration_range();
ParamMeta threads_range();
inline constexpr ParamMeta kFirstFrameRange{.min = 0};
inline constexpr ParamMeta kLastFrameRange{.min = -1};  // -1: the clip's end
inline constexpr ParamMeta kTimeRange{.min = 0};        // s from the start of a run
inline constexpr ParamMeta kScaleRange{.min = 0};  // m per file unit; 0: detected from the legs

// a resume file's JSON, its nesting bounded while it is parsed: nlohmann's dump and comparisons
// recurse once per level, so a file nested 100,000 deep would overflow the stack
nlohmann::json parse_resume_json(std::istream& in, const std::string& path);

// a file name that goes into JSON (a resume file's options, a name made from it) must be UTF-8,
// as JSON is
void check_utf8_file_name(const std::string& path);

}  // namespace stance::command_support
