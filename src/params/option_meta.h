// A command's options are a plain struct with one visit(), as parameter structs are: the visit
// names each field with its default (the field's initialiser), unit, range and help, and
// app/cli_options.h turns it into the options of a CLI11 subcommand, so that each option is
// written once. OptionMeta is a ParamMeta plus how the field is given on the command line; it
// converts to ParamMeta, so visitors of parameter structs (docs, checks) read it too.
#pragma once

#include <limits>
#include <string_view>

#include "params/params.h"

namespace stance {

struct OptionMeta {
  std::string_view help;
  // the CLI11 names when they are not "--<key>" (the key's '_' as '-'): a positional
  // ("scenario"), aliases ("--push-duration,--duration-push"), a negatable flag
  // ("--plot,!--no-plot")
  std::string_view names;
  bool required = false;
  std::string_view unit;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();

  operator ParamMeta() const { return {.unit = unit, .min = min, .max = max, .help = help}; }
};

}  // namespace stance
