// A command's options struct (its visit() with OptionMeta, params/option_meta.h) as the options
// of a CLI11 subcommand: add_cli_options(cmd, options) adds one option per visited field, in
// visit order, bound to the field, so that parsing fills the struct. A bool is a flag; a list
// option takes one value per occurrence (`--set a=1 --set b=2`), a positional list takes the
// remaining words. CLI11 is header-only: only the programs that parse arguments include this.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "params/option_meta.h"

namespace stance {

class CliOptionAdder {
 public:
  explicit CliOptionAdder(CLI::App& cmd) : cmd_(cmd) {}

  template <class T>
  void operator()(std::string_view key, T& value, const OptionMeta& meta) {
    const std::string names = meta.names.empty() ? option_name(key) : std::string(meta.names);
    const std::string help(meta.help);
    CLI::Option* option = nullptr;
    if constexpr (std::is_same_v<T, bool>) {
      option = cmd_.add_flag(names, value, help);
    } else {
      option = cmd_.add_option(names, value, help);
      if constexpr (is_vector<T>::value)
        if (names.front() == '-') option->allow_extra_args(false);
    }
    if (meta.required) option->required();
  }

  // "--" + the key with '_' as '-': "plot_metric" -> "--plot-metric"
  static std::string option_name(std::string_view key) {
    std::string name = "--" + std::string(key);
    for (char& c : name)
      if (c == '_') c = '-';
    return name;
  }

 private:
  template <class T>
  struct is_vector : std::false_type {};
  template <class T>
  struct is_vector<std::vector<T>> : std::true_type {};

  CLI::App& cmd_;
};

// the options of `options` (a struct with visit(V&)) on `cmd`, bound to its fields
template <class Options>
void add_cli_options(CLI::App& cmd, Options& options) {
  CliOptionAdder adder(cmd);
  options.visit(adder);
}

}  // namespace stance
