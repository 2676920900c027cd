// The CLI's error boundary: every error becomes one line on stderr and its exit code. Bad input
// is an InputError thrown where the file, line or parameter is known; anything else that escapes
// a command is a bug and says so.
#pragma once

#include <cstdlib>
#include <exception>
#include <iostream>
#include <new>
#include <stdexcept>

#include "app/commands.h"
#include "core/error.h"

namespace stance {

template <class F>
int guarded(F&& body) {
  try {
    // testing only (tests/cli/exit_codes.sh): a bug's path, taken through this same boundary
    if (std::getenv("STANCE_TEST_INTERNAL_ERROR"))
      throw std::logic_error("STANCE_TEST_INTERNAL_ERROR is set");
    return body();
  } catch (const InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const EnvironmentError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitEnvironment;
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory\n";
    return kExitEnvironment;
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << " (a bug in stance; please report it)\n";
    return kExitInternalError;
  } catch (...) {
    std::cerr << "internal error: an unknown exception (a bug in stance; please report it)\n";
    return kExitInternalError;
  }
}

}  // namespace stance
