// stance: the command-line front end. Argument parsing only; the work is in the library.
#include <CLI/CLI.hpp>

#include "app/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"stance: physics-based biped balance and locomotion control"};
  app.require_subcommand(1);

  stance::RunCommand run;
  auto* run_cmd = app.add_subcommand("run", "run a scenario headless");
  run_cmd->add_option("scenario", run.scenario, "scenario YAML")->required();
  run_cmd->add_option("--engine", run.engine, "mujoco or dart (default: the scenario's)");
  run_cmd->add_option("--duration", run.duration, "simulated seconds");
  run_cmd->add_option("--set", run.sets, "override a parameter: key.path=value")
      ->allow_extra_args(false);
  run_cmd->add_option("--push", run.pushes, "body,fx,fy,fz,start,duration (repeatable)")
      ->allow_extra_args(false);
  run_cmd->add_option("--out", run.out_dir, "output folder (summary.json, log.csv)");
  run_cmd->add_flag("--quiet", run.quiet, "no summary on stdout");

  stance::InfoCommand info;
  auto* info_cmd = app.add_subcommand("info", "model sizes and mass");
  info_cmd->add_option("model", info.model, "MJCF, URDF or SKEL file")->required();
  info_cmd->add_option("--engine", info.engine, "mujoco or dart");
  info_cmd->add_flag("--json", info.json, "print JSON");

  std::string convert_in, convert_out;
  auto* convert_cmd = app.add_subcommand("convert", "translate a DART .skel to MJCF");
  convert_cmd->add_option("input", convert_in, ".skel file")->required();
  convert_cmd->add_option("output", convert_out, "MJCF file to write")->required();

  std::string list_dir = "scenarios";
  auto* list_cmd = app.add_subcommand("list", "controllers and scenarios");
  list_cmd->add_option("dir", list_dir, "scenario folder");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);
    return code == 0 ? 0 : stance::kExitBadInput;
  }
  if (*run_cmd) return stance::run_command(run);
  if (*info_cmd) return stance::info_command(info);
  if (*convert_cmd) return stance::convert_command(convert_in, convert_out);
  if (*list_cmd) return stance::list_command(list_dir);
  return stance::kExitBadInput;
}
