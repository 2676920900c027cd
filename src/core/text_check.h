// What makes a byte string unfit to read as UTF-8 text: UTF-16/32, a binary file, a NUL byte,
// bytes that are not UTF-8. Readers check their input with this before a parser sees it, so that
// a message says what the file is rather than what a parser made of it.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace stance {

struct TextProblem {
  int line = 0;    // 1-based; 0: the whole text (UTF-16, binary)
  int column = 0;  // 1-based byte column
  std::string message;
};

// the first problem of `text`, or none. A UTF-8 byte order mark is fine. Messages, e.g.:
//   "UTF-16 text (byte order mark FF FE): save it as UTF-8"
//   "a binary file, not text (a NUL byte at line 1)"
//   "a NUL byte at column 7"
//   "not UTF-8 text (byte 0xFF at column 7)"
std::optional<TextProblem> find_text_problem(std::string_view text);

// the first byte offset of `text` that starts no valid UTF-8 sequence (overlong forms,
// surrogates and code points past U+10FFFF included), or npos
size_t invalid_utf8_offset(std::string_view text);

// `text` with every byte that is not valid UTF-8, and every control character but tab, as
// \xHH: safe to print in a one-line message
std::string printable_text(std::string_view text);

}  // namespace stance
