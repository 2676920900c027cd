// The CLI's error boundary: every error becomes one line on stderr and exit code 2.
#pragma once

#include <yaml-cpp/yaml.h>

#include <exception>
#include <iostream>

#include "app/commands.h"
#include "core/error.h"

namespace stance {

template <class F>
int guarded(F&& body) {
  try {
    return body();
  } catch (const YAML::Exception& e) {
    std::cerr << "error: YAML: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {  // InputError, invalid_argument, and the rest
    std::cerr << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
}

}  // namespace stance
