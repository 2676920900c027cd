// The CLI's commands, as library functions: apps/stance_main.cc only parses arguments.
// Each returns the process exit code: 0 done, 2 bad input, 3 simulation diverged.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace stance {

inline constexpr int kExitOk = 0;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitDiverged = 3;

struct RunCommand {
  std::string scenario;
  std::string engine;
  std::optional<double> duration;
  std::vector<std::string> sets;
  std::vector<std::string> pushes;
  std::string out_dir = "out";
  bool quiet = false;
};
int run_command(const RunCommand& cmd);

struct InfoCommand {
  std::string model;
  std::string engine = "mujoco";
  bool json = false;
};
int info_command(const InfoCommand& cmd);

int convert_command(const std::string& in_path, const std::string& out_path);

// list scenarios in a folder and the registered controllers
int list_command(const std::string& scenario_dir);

}  // namespace stance
