#include "app/commands.h"
#include "app/command_support.h"
#include "app/guarded.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include <signal.h>
#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>

#include "batch/batch_ranks.h"
#include "batch/push_threshold.h"
#include "batch/robustness.h"
#include "batch/sweep.h"
#include "batch/tune.h"
#include "control/auto_joint_map.h"
#include "control/controller.h"
#include "control/mocap_clip.h"
#include "control/mocap_retarget_tracker.h"
#include "control/retarget.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/model_format.h"
#include "core/text_check.h"
#include "core/timestep.h"
#include "engine/engine.h"
#include "engine/world_spec.h"
#include "model/bvh_to_mjcf.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "model/skel_to_mjcf.h"
#include "motion/bvh.h"
#include "motion/reference_motion.h"
#include "params/option_check.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace stance {

using namespace command_support;

void check_run_command(const RunCommand& cmd) {
  check_option_number("--duration", cmd.duration, duration_range());
  check_option_number("--at", cmd.screenshot_at, kTimeRange);
}

int check_run_options(const RunCommand& cmd) {
  return guarded([&] {
    check_run_command(cmd);
    return kExitOk;
  });
}

int check_screenshots_options(const std::string& scenario_dir, double at) {
  return guarded([&] {
    check_option_number("--at", at, kTimeRange);
    if (!std::filesystem::is_directory(scenario_dir))
      throw InputError(fmt::format("--dir {}: no such folder", scenario_dir));
    return kExitOk;
  });
}

std::unique_ptr<Simulation> make_run_simulation(const RunCommand& cmd,
                                                const std::atomic<bool>* interrupt) {
  check_run_command(cmd);
  LoadedScenario loaded = load_scenario(cmd.scenario, cmd.sets);
  if (loaded.scenario.name.empty())
    loaded.scenario.name = std::filesystem::path(cmd.scenario).stem().string();
  RunOptions opt;
  opt.engine = cmd.engine;
  opt.duration = cmd.duration;
  opt.out_dir = cmd.out_dir;
  opt.quiet = cmd.quiet;
  opt.progress = !cmd.quiet;
  if (cmd.past_fall) opt.stop_after_fall_s = -1;
  for (const auto& p : cmd.pushes) opt.extra_pushes.push_back(parse_push(p));
  opt.interrupt = interrupt ? interrupt : &g_interrupt;  // a batch passes its own
  opt.check_expect_names = true;
  if (cmd.check && !loaded.scenario.expect.given)
    throw InputError(cmd.scenario + ": --check: the scenario has no 'expect' block to check");
  return std::make_unique<Simulation>(loaded, opt);
}

int run_command(const RunCommand& cmd, const RunObserverMaker& observe) {
  return guarded([&] {
    const std::unique_ptr<Simulation> simulation = make_run_simulation(cmd);
    Simulation& run = *simulation;
    std::unique_ptr<StepObserver> observer = observe ? observe(run) : nullptr;
    if (observer) run.add_observer(observer.get());
    InterruptHandler interrupt_handler;
    RunResult r = run.run();
    if (!cmd.quiet) {
      std::cout << fmt::format(
          "{} on {}: {:.3f} s simulated in {:.3f} s wall ({:.1f}x real time)\n", r.scenario,
          r.engine, r.sim_time, r.wall_time_s,
          r.wall_time_s > 0 ? r.sim_time / r.wall_time_s : 0.0);
      if (r.diverged)
        std::cout << "  DIVERGED: " << r.divergence << "\n";
      else if (r.fell)
        std::cout << fmt::format("  fell at t={:.3f} s: {}\n", *r.fall_time, r.fall_reason);
      else
        std::cout << "  did not fall\n";
      for (auto it = r.metrics.begin(); it != r.metrics.end(); ++it)
        std::cout << "  " << it.key() << ": " << it.value().dump() << "\n";
      if (!cmd.out_dir.empty())
        std::cout << "  wrote " << (std::filesystem::path(cmd.out_dir) / "summary.json").string()
                  << " and log.csv\n";
    }
    // one line: on stderr when --check turns a miss into the exit code
    const bool missed = !r.expectation.is_null() && !r.expectation.at("held").get<bool>();
    if (cmd.check && missed)
      std::cerr << expectation_line(r.expectation) << "\n";
    else if (!cmd.quiet && !r.expectation.is_null())
      std::cout << "  " << expectation_line(r.expectation) << "\n";
    if (r.diverged) {
      std::cerr << "error: simulation diverged: " << r.divergence << "\n";
      return kExitDiverged;
    }
    if (r.interrupted) {
      std::cerr << fmt::format("interrupted at t={:.6f} s{}\n", r.sim_time,
                               cmd.out_dir.empty() ? "" : "; summary.json and log.csv written");
      return kExitInterrupted;
    }
    if (cmd.check && missed) return kExitExpectationNotHeld;
    return kExitOk;
  });
}

int info_command(const InfoCommand& cmd) {
  return guarded([&] {
    WorldSpec spec;
    spec.models.push_back({cmd.model, Eigen::Vector3d::Zero()});
    std::unique_ptr<Engine> e = make_engine(cmd.engine, spec);
    nlohmann::json j;
    j["nbody"] = e->nbody();
    j["nq"] = e->nq();
    j["nv"] = e->nv();
    j["nu"] = e->nu();
    j["mass"] = e->total_mass();
    if (cmd.json) {
      std::cout << j.dump() << "\n";
    } else {
      std::cout << fmt::format("{} on {}: {} mobile bodies, nq {}, nv {}, nu {}, mass {:.6f} kg\n",
                               cmd.model, cmd.engine, e->nbody(), e->nq(), e->nv(), e->nu(),
                               e->total_mass());
      std::cout << "dofs:";
      for (int i = 0; i < e->nv(); ++i) std::cout << ' ' << e->dof_name(i);
      std::cout << "\nbodies:";
      for (int i = 0; i < e->nbody(); ++i) std::cout << ' ' << e->body_name(i);
      std::cout << "\n";
    }
    return kExitOk;
  });
}

int convert_command(const std::string& in_path, const std::string& out_path) {
  return guarded([&] {
    write_mjcf_file(in_path, out_path);
    std::cout << "wrote " << out_path << "\n";
    return kExitOk;
  });
}

namespace {
// a controller type's parameters, one line each: path, default, unit, range, help
void print_controller_params(const ControllerType& type) {
  std::cout << fmt::format("{}: {}\n", type.name, type.summary);
  const std::vector<ParamDoc> docs = type.params ? type.params() : std::vector<ParamDoc>{};
  if (docs.empty()) {
    std::cout << "  (no parameters)\n";
    return;
  }
  // long defaults (lists, tables) are cut: the column is for the value a user would change
  auto shown = [](const std::string& text) {
    return text.size() <= 16 ? text : text.substr(0, 13) + "...";
  };
  size_t path_width = 9, value_width = 7, unit_width = 4, range_width = 5;
  for (const auto& d : docs) {
    path_width = std::max(path_width, d.path.size());
    value_width = std::max(value_width, shown(d.default_value).size());
    unit_width = std::max(unit_width, d.meta.unit.size());
    range_width = std::max(range_width, range_text(d.meta).size());
  }
  auto line = [&](std::string_view path, std::string_view value, std::string_view unit,
                  std::string_view range, std::string_view help) {
    std::string text = fmt::format("  {:<{}}  {:<{}}  {:<{}}  {:<{}}  {}", path, path_width, value,
                                   value_width, unit, unit_width, range, range_width, help);
    text.erase(text.find_last_not_of(' ') + 1);
    std::cout << text << "\n";
  };
  line("parameter", "default", "unit", "range", "help");
  for (const auto& d : docs)
    line(d.path, shown(d.default_value), d.meta.unit, range_text(d.meta), d.meta.help);
}
}  // namespace

int list_command(const std::string& what) {
  return guarded([&] {
    // "controllers", or one controller type: their parameters
    if (what == "controllers") {
      for (const auto& t : controller_registry()) {
        print_controller_params(t);
        std::cout << "\n";
      }
      return kExitOk;
    }
    std::vector<std::string> names;
    for (const auto& t : controller_registry()) {
      if (t.name == what) {
        print_controller_params(t);
        return kExitOk;
      }
      names.push_back(t.name);
    }
    // else a scenario folder (the default: scenarios)
    const std::string scenario_dir = what.empty() ? "scenarios" : what;
    if (!what.empty() && !std::filesystem::is_directory(what)) {
      names.push_back("controllers");
      std::string hint = did_you_mean(what, names);
      if (hint.empty()) hint = " (`stance list` shows the types)";
      throw InputError(fmt::format(
          "list: '{}' is neither a controller type nor a scenario folder{}", what, hint));
    }
    std::cout << "controllers (stance list NAME prints one's parameters, with units and "
                 "ranges):\n";
    for (const auto& t : controller_registry())
      std::cout << fmt::format("  {:<16} {}\n", t.name, t.summary);
    std::cout << "scenarios in " << scenario_dir << ":\n";
    std::vector<std::string> files;
    if (std::filesystem::is_directory(scenario_dir))
      for (const auto& f : std::filesystem::directory_iterator(scenario_dir))
        if (f.path().extension() == ".yaml") files.push_back(f.path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) std::cout << "  " << f << "\n";
    return kExitOk;
  });
}

}  // namespace stance
