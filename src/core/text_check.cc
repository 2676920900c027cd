#include "core/text_check.h"

#include <fmt/format.h>

#include <algorithm>

namespace stance {

namespace {
// the length of the UTF-8 sequence starting at text[i], or 0 when none starts there
size_t utf8_sequence_length(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) return 1;
  size_t n = 0;
  unsigned lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    n = 2;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    n = 3;
    if (b0 == 0xE0) lo = 0xA0;  // overlong
    if (b0 == 0xED) hi = 0x9F;  // surrogates
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    n = 4;
    if (b0 == 0xF0) lo = 0x90;  // overlong
    if (b0 == 0xF4) hi = 0x8F;  // past U+10FFFF
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  return n;
}

// 1-based line and column of a byte offset
TextProblem at_offset(std::string_view text, size_t offset, std::string message) {
  const std::string_view before = text.substr(0, offset);
  const size_t line_start = before.rfind('\n');
  TextProblem p;
  p.line = 1 + static_cast<int>(std::count(before.begin(), before.end(), '\n'));
  p.column =
      static_cast<int>(offset - (line_start == std::string_view::npos ? 0 : line_start + 1)) + 1;
  p.message = std::move(message);
  return p;
}

// UTF-16 without a byte order mark: every other byte of the start is NUL, the others not
std::optional<std::string> utf16_without_bom(std::string_view text) {
  const size_t n = std::min<size_t>(text.size(), 64) & ~size_t{1};
  if (n < 2) return std::nullopt;
  bool even_nul = true, odd_nul = true;
  for (size_t i = 0; i < n; ++i) {
    const bool nul = text[i] == '\0';
    if (i % 2 == 0) {
      even_nul = even_nul && nul;
      odd_nul = odd_nul && !nul;
    } else {
      odd_nul = odd_nul && nul;
      even_nul = even_nul && !nul;
    }
  }
  if (odd_nul) return "UTF-16 text (little-endian, no byte order mark): save it as UTF-8";
  if (even_nul) return "UTF-16 text (big-endian, no byte order mark): save it as UTF-8";
  return std::nullopt;
}

// more than a tenth of the start is control bytes (other than tab and line ends)
bool looks_binary(std::string_view text) {
  const std::string_view start = text.substr(0, 512);
  const auto control = std::count_if(start.begin(), start.end(), [](char c) {
    const auto b = static_cast<unsigned char>(c);
    return b < 0x20 && c != '\t' && c != '\n' && c != '\r';
  });
  return control * 10 > static_cast<long>(start.size());
}
}  // namespace

size_t invalid_utf8_offset(std::string_view text) {
  for (size_t i = 0; i < text.size();) {
    const size_t n = utf8_sequence_length(text, i);
    if (n == 0) return i;
    i += n;
  }
  return std::string_view::npos;
}

std::optional<TextProblem> find_text_problem(std::string_view text) {
  const auto starts = [&](std::string_view prefix) {
    return text.substr(0, prefix.size()) == prefix;
  };
  using namespace std::string_view_literals;
  if (starts("\xFF\xFE\0\0"sv) || starts("\0\0\xFE\xFF"sv))
    return TextProblem{0, 0, "UTF-32 text (a byte order mark): save it as UTF-8"};
  if (starts("\xFF\xFE"sv))
    return TextProblem{0, 0, "UTF-16 text (byte order mark FF FE): save it as UTF-8"};
  if (starts("\xFE\xFF"sv))
    return TextProblem{0, 0, "UTF-16 text (byte order mark FE FF): save it as UTF-8"};
  if (auto utf16 = utf16_without_bom(text)) return TextProblem{0, 0, *utf16};
  const size_t nul = text.find('\0');
  if (nul != std::string_view::npos) {
    TextProblem p = at_offset(text, nul, "");
    if (looks_binary(text))
      return TextProblem{0, 0,
                         fmt::format("a binary file, not text (a NUL byte at line {})", p.line)};
    p.message = fmt::format("a NUL byte at column {}", p.column);
    return p;
  }
  const size_t bad = invalid_utf8_offset(text);
  if (bad != std::string_view::npos) {
    TextProblem p = at_offset(text, bad, "");
    p.message = fmt::format("not UTF-8 text (byte 0x{:02X} at column {})",
                            static_cast<unsigned char>(text[bad]), p.column);
    return p;
  }
  return std::nullopt;
}

std::string printable_text(std::string_view text) {
  std::string out;
  for (size_t i = 0; i < text.size();) {
    const size_t n = utf8_sequence_length(text, i);
    const auto b = static_cast<unsigned char>(text[i]);
    if (n == 0 || (b < 0x20 && b != '\t') || b == 0x7F) {
      out += fmt::format("\\x{:02X}", b);
      ++i;
    } else {
      out.append(text.substr(i, n));
      i += n;
    }
  }
  return out;
}

}  // namespace stance
