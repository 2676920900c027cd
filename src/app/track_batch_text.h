// number formats that the batch's progress lines and its result tables share
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <cstddef>
#include <string>

namespace stance {

// "-" for no value (NaN)
inline std::string md_number(double v, int digits) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, digits) : "-";
}

inline std::string clip_count(size_t n) {
  return fmt::format("{} clip{}", n, n == 1 ? "" : "s");
}

}  // namespace stance
