// Error tiers (see CONVENTIONS): load-time errors throw InputError with file:line or the
// parameter path; the CLI turns them into one line and exit code 2. EnvironmentError is the
// machine lacking what a command needs (exit 71); any other exception is a bug (exit 70).
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace stance {

// bad user input: a file, a parameter, a name. what() is the whole one-line message.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// the machine, not the input: no display or OpenGL context, no ffmpeg, a helper process that
// failed. what() is the whole one-line message.
class EnvironmentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "file:line: message" (line <= 0 omits it)
std::string located(std::string_view file, int line, std::string_view message);

// the candidate closest to `name` by edit distance, or "" when nothing is close
std::string nearest_name(std::string_view name, const std::vector<std::string>& candidates);

// " (did you mean 'x'?)" or ""
std::string did_you_mean(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace stance
