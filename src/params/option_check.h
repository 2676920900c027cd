// Command-line options checked as the parameters they set: `--duration` takes the range of the
// scenario's `duration`, as its visit declares it, so that the CLI accepts what the YAML accepts.
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <string>
#include <string_view>

#include "core/error.h"
#include "params/params.h"

namespace stance {

// the ParamMeta that a visit gives the parameter at a dotted path ("duration", "log.rate_hz")
class ParamMetaFinder {
 public:
  explicit ParamMetaFinder(std::string_view path, std::string prefix = "")
      : path_(path), prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(std::string_view key, T& value, const ParamMeta& meta = {}) {
    const std::string here = prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
    if (here == path_) {
      found_ = meta;
    } else if constexpr (Visitable<T, ParamMetaFinder>) {
      if (path_.substr(0, here.size() + 1) != here + ".") return;
      ParamMetaFinder sub(path_, here);
      value.visit(sub);
      found_ = sub.found_;
    }
  }
  const std::optional<ParamMeta>& found() const { return found_; }

 private:
  std::string path_;
  std::string prefix_;
  std::optional<ParamMeta> found_;
};

// the range of Params' parameter at `path`; a path the struct lacks is a bug
template <class Params>
ParamMeta param_meta(std::string_view path) {
  Params params{};
  ParamMetaFinder finder(path);
  params.visit(finder);
  if (!finder.found()) throw std::logic_error(fmt::format("no parameter '{}'", path));
  return *finder.found();
}

// an option's value refused as a YAML value would be: "--duration: must be a finite number,
// found nan", "--duration: -1 is outside [0, inf]"
inline void check_option_number(std::string_view option, double value, const ParamMeta& meta) {
  if (!std::isfinite(value))
    throw InputError(fmt::format("{}: must be a finite number, found {}", option, value));
  if (value < meta.min || value > meta.max)
    throw InputError(fmt::format("{}: {} is outside [{}, {}]", option, value, meta.min, meta.max));
}

inline void check_option_number(std::string_view option, const std::optional<double>& value,
                                const ParamMeta& meta) {
  if (value) check_option_number(option, *value, meta);
}

}  // namespace stance
