#include "core/text_check.h"

#include <gtest/gtest.h>

#include <string>

namespace stance {
namespace {

using namespace std::string_literals;

TEST(TextCheck, Utf8ValidatorFollowsTheStandard) {
  constexpr size_t kNone = std::string::npos;
  EXPECT_EQ(invalid_utf8_offset("plain ascii\n"), kNone);
  EXPECT_EQ(invalid_utf8_offset("caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80"), kNone);
  EXPECT_EQ(invalid_utf8_offset("ab\xFF\xFE"), 2u);
  EXPECT_EQ(invalid_utf8_offset("a\xC0\x80"), 1u);          // overlong NUL
  EXPECT_EQ(invalid_utf8_offset("a\xE0\x80\x80"), 1u);      // overlong 3-byte form
  EXPECT_EQ(invalid_utf8_offset("a\xED\xA0\x80"), 1u);      // a surrogate
  EXPECT_EQ(invalid_utf8_offset("a\xF4\x90\x80\x80"), 1u);  // past U+10FFFF
  EXPECT_EQ(invalid_utf8_offset("ab\xC3"), 2u);             // cut short
  EXPECT_EQ(invalid_utf8_offset("\x80"), 0u);               // a continuation alone
}

std::string problem_of(const std::string& text) {
  const auto p = find_text_problem(text);
  return p ? std::to_string(p->line) + ": " + p->message : "";
}

TEST(TextCheck, ProblemsAreNamedWithTheirLine) {
  EXPECT_EQ(problem_of("a: 1\nb: 2\n"), "");
  EXPECT_EQ(problem_of("\xEF\xBB\xBF"
                       "a: 1\n"),
            "");  // a UTF-8 byte order mark
  EXPECT_EQ(problem_of("a: 1\nname: \"x\xFF\xFE\"\n"), "2: not UTF-8 text (byte 0xFF at column 9)");
  EXPECT_EQ(problem_of("a: 1\nb: 2\0\n"s), "2: a NUL byte at column 5");
}

TEST(TextCheck, Utf16AndBinaryFilesAreSaidToBeSo) {
  EXPECT_EQ(problem_of("\xFF\xFE"
                       "a\0:\0"s),
            "0: UTF-16 text (byte order mark FF FE): save it as UTF-8");
  EXPECT_EQ(problem_of("\xFE\xFF\0a"s), "0: UTF-16 text (byte order mark FE FF): save it as UTF-8");
  EXPECT_EQ(problem_of("a\0:\0 \0"s),
            "0: UTF-16 text (little-endian, no byte order mark): save it as UTF-8");
  EXPECT_EQ(problem_of("\0a\0:\0 "s),
            "0: UTF-16 text (big-endian, no byte order mark): save it as UTF-8");
  EXPECT_EQ(problem_of("\xFF\xFE\0\0"s), "0: UTF-32 text (a byte order mark): save it as UTF-8");
  EXPECT_EQ(problem_of("\x7F"
                       "ELF\x02\x01\x01\0\0\0\0\0\0\0\0\0\x03\0"s),
            "0: a binary file, not text (a NUL byte at line 1)");
}

TEST(TextCheck, PrintableTextEscapesWhatATerminalWouldGarble) {
  EXPECT_EQ(printable_text("name=\xFF\xFE"), "name=\\xFF\\xFE");
  EXPECT_EQ(printable_text("a\tb\x1B[2J caf\xC3\xA9"), "a\tb\\x1B[2J caf\xC3\xA9");
}

}  // namespace
}  // namespace stance
