// Loads and runs a scenario through an installed stance, then checks its own result: the run
// reaches the asked time without falling or diverging, and the summary says so.
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "app/commands.h"
#include "sim/scenario.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: run_pd_hold SCENARIO OUT_DIR\n";
    return 2;
  }
  const stance::LoadedScenario loaded = stance::load_scenario(argv[1]);
  std::cout << "loaded " << loaded.scenario.name << " on " << loaded.scenario.engine << "\n";

  stance::RunCommand run;
  run.scenario = argv[1];
  run.duration = 0.5;
  run.out_dir = argv[2];
  run.quiet = true;
  const int code = stance::run_command(run);
  if (code != stance::kExitOk) {
    std::cerr << "run exited " << code << "\n";
    return 1;
  }
  std::ifstream in(std::filesystem::path(argv[2]) / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(in);
  std::cout << "sim_time " << summary["sim_time"] << " fell " << summary["fell"] << " steps "
            << summary["steps"] << "\n";
  const bool ok = std::abs(summary["sim_time"].get<double>() - 0.5) < 1e-9 &&
                  !summary["fell"].get<bool>() && !summary["diverged"].get<bool>() &&
                  summary["steps"].get<long>() == 500;
  std::cout << (ok ? "ok" : "FAILED") << "\n";
  return ok ? 0 : 1;
}
