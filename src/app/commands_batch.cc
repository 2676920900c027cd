// The commands that run many simulations: sweep, push-threshold, robustness and tune.
#include "app/command_support.h"
#include "app/commands.h"
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

namespace {
// what a resumed sweep must share with the interrupted one
nlohmann::json sweep_fingerprint(const SweepOptions& o) {
  return {{"scenario", std::filesystem::absolute(o.scenario).lexically_normal().string()},
          {"param", o.param},
          {"values", o.values},
          {"engine", o.engine},
          {"duration", o.duration ? nlohmann::json(*o.duration) : nlohmann::json(nullptr)},
          {"sets", o.sets}};
}
constexpr const char* kSweepPartial = "sweep.partial.json";

// the finished entries of an interrupted batch (DIR/<partial>), checked against `fingerprint`:
// saved["done"] maps an index to its JSON; a differing option is bad input naming it
nlohmann::json read_partial(const std::string& dir, const char* partial_name,
                            const nlohmann::json& fingerprint) {
  const std::filesystem::path partial = std::filesystem::path(dir) / partial_name;
  std::ifstream in(partial);
  if (!in)
    throw InputError(
        fmt::format("--resume {}: no {} there (nothing to resume)", dir, partial_name));
  nlohmann::json saved;
  try {
    saved = parse_resume_json(in, partial.string());
    for (auto it = fingerprint.begin(); it != fingerprint.end(); ++it)
      if (saved.at("options").at(it.key()) != it.value())
        throw InputError(
            fmt::format("--resume {}: option '{}' was {} in the interrupted run, now {}", dir,
                        it.key(), saved.at("options").at(it.key()).dump(), it.value().dump()));
    (void)saved.at("done");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(
        fmt::format("{}: not a resume file of this command ({})", partial.string(), e.what()));
  }
  return saved;
}
}  // namespace

int sweep_command(const SweepCommand& command) {
  return guarded([&] {
    SweepCommand cmd = command;
    if (!cmd.resume.empty()) cmd.out_dir = cmd.resume;
    SweepOptions& o = cmd.options;
    o.interrupt = &g_interrupt;
    check_option_number("--duration", o.duration, duration_range());
    check_option_number("--threads", o.threads, threads_range());
    check_utf8_file_name(o.scenario);
    if (!cmd.values.empty()) {
      o.values = parse_value_list(cmd.values);
    } else {
      if (!cmd.from || !cmd.to) throw InputError("sweep: give --from and --to, or --values");
      o.values = linspace(*cmd.from, *cmd.to, cmd.steps);
    }
    const std::filesystem::path partial = std::filesystem::path(cmd.out_dir) / kSweepPartial;
    nlohmann::json saved = {{"options", sweep_fingerprint(o)}, {"done", nlohmann::json::object()}};
    std::map<int, SweepPoint> finished;
    if (!cmd.resume.empty()) {
      saved = read_partial(cmd.resume, kSweepPartial, saved["options"]);
      try {
        for (auto it = saved["done"].begin(); it != saved["done"].end(); ++it)
          finished[std::stoi(it.key())] = sweep_point_from_json(it.value());
      } catch (const std::exception& e) {
        throw InputError(
            fmt::format("{}: a point does not read back ({})", partial.string(), e.what()));
      }
    }
    auto wall0 = std::chrono::steady_clock::now();
    InterruptHandler interrupt_handler;
    std::vector<SweepPoint> points = run_sweep(
        o,
        [&](const SweepPoint& p, int index, int done, int total) {
          // every finished run is kept, for --resume
          saved["done"][std::to_string(index)] = sweep_point_to_json(p);
          std::filesystem::create_directories(cmd.out_dir);
          write_file_atomically(partial, saved.dump() + "\n");
          if (cmd.quiet) return;
          std::string what = !p.error.empty()    ? "error: " + p.error
                             : p.result.diverged ? "diverged"
                             : p.result.fell     ? "fell"
                                                 : "ok";
          std::cout << fmt::format("  [{}/{}] {}={} {}\n", done, total, o.param,
                                   format_sweep_value(p.value), what)
                    << std::flush;
        },
        finished);
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    // under mpirun, rank 0 gathered every result and writes; the others are done
    if (!BatchRanks::get().root()) return kExitOk;
    const long unfinished =
        std::count_if(points.begin(), points.end(), [](const SweepPoint& p) { return !p.done; });
    if (unfinished > 0) {
      std::cerr << fmt::format(
          "interrupted: {} of {} runs done, kept in {}; finish them with the same command and "
          "--resume {}\n",
          points.size() - unfinished, points.size(), partial.string(), cmd.out_dir);
      return kExitInterrupted;
    }
    write_sweep_outputs(cmd.out_dir, o.param, points);
    std::error_code ec;
    std::filesystem::remove(partial, ec);
    std::cout << fmt::format(
        "swept {} over {} values in {:.2f} s wall; wrote {}/sweep.csv and "
        "points.csv\n",
        o.param, points.size(), wall, cmd.out_dir);
    if (cmd.plot) {
      std::string metric = cmd.plot_metric;
      std::vector<std::string> lists = sweep_list_metrics(points);
      if (metric.empty()) {
        // the slope walker's bifurcation points when present, else the first list metric
        auto it = std::find(lists.begin(), lists.end(), "steady_step_lengths_m");
        if (it != lists.end())
          metric = *it;
        else if (!lists.empty())
          metric = lists.front();
        else
          throw InputError("--plot: the runs report no list metric to plot");
      }
      std::string title = fmt::format(
          "{}: {} vs {}",
          points.front().result.scenario.empty() ? o.scenario : points.front().result.scenario,
          metric, o.param);
      std::string png = plot_sweep(cmd.out_dir, o.param, metric, title, metric + ".png");
      std::cout << "wrote " << png << "\n";
    }
    for (const auto& p : points)
      if (!p.error.empty()) {
        std::cerr << fmt::format("error: {}={}: {}\n", o.param, format_sweep_value(p.value),
                                 p.error);
        return kExitBadInput;
      }
    return kExitOk;
  });
}

int push_threshold_command(const PushThresholdCommand& cmd) {
  return guarded([&] {
    PushThresholdOptions o = cmd.options;
    if (cmd.axis == "x")
      o.axis = 0;
    else if (cmd.axis == "y")
      o.axis = 1;
    else if (cmd.axis == "z")
      o.axis = 2;
    else
      throw InputError(fmt::format("--axis '{}': use x, y or z", cmd.axis));
    check_option_number("--duration", o.duration, duration_range());
    check_option_number("--at", o.at, kTimeRange);
    check_option_number("--threads", o.threads, threads_range());
    parse_push_point(cmd.options.point, o.point, o.offset);
    LoadedScenario loaded = load_scenario(cmd.scenario, cmd.sets);
    auto wall0 = std::chrono::steady_clock::now();
    PushThresholdResult r = find_push_threshold(loaded, o, [&](double f, bool survived) {
      if (!cmd.quiet)
        std::cout << fmt::format("  {:+.1f} N along {}: {}\n", f, cmd.axis,
                                 survived ? "survived" : "fell")
                  << std::flush;
    });
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    std::string engine = o.engine.empty() ? loaded.scenario.engine : o.engine;
    std::cout << fmt::format("{} on {}: {} s push on {} at t = {} s, bisection on 0..{} N\n",
                             loaded.scenario.name, engine, o.push_duration, o.body, o.at,
                             o.max_force);
    for (const PushBracket* b : {&r.positive, &r.negative}) {
      std::string dir = fmt::format("{}{}", b->sign > 0 ? '+' : '-', cmd.axis);
      if (b->falls_unpushed)
        std::cout << fmt::format("  {}: falls without the push\n", dir);
      else if (!b->fell)
        std::cout << fmt::format("  {}: survives the maximum, {:.1f} N\n", dir, b->survived);
      else
        std::cout << fmt::format("  {}: survives {:.1f} N, falls at {:.1f} N ({} trials)\n", dir,
                                 b->survived, *b->fell, b->trials);
    }
    std::cout << fmt::format("{} trials in {:.2f} s wall\n", r.positive.trials + r.negative.trials,
                             wall);
    return kExitOk;
  });
}

namespace {
// what a resumed robustness run must share with the interrupted one (not threads, nor where
// and how it reports)
nlohmann::json robustness_fingerprint(const RobustnessCommand& c) {
  const RobustnessOptions& o = c.options;
  return {{"scenario", std::filesystem::absolute(c.scenario).lexically_normal().string()},
          {"sets", c.sets},
          {"body", o.body},
          {"directions", o.directions},
          {"phases", o.phases},
          {"push_duration", o.push_duration},
          {"max", o.max_force},
          {"tolerance", o.tolerance},
          {"at", o.at},
          {"phase_spacing", o.phase_spacing_s},
          {"recovery_window", o.recovery_window_s},
          {"max_steps", o.max_recovery_steps},
          {"point", o.point},
          {"engine", o.engine},
          {"duration", o.duration ? nlohmann::json(*o.duration) : nlohmann::json(nullptr)}};
}
constexpr const char* kRobustnessPartial = "robustness.partial.json";
}  // namespace

int robustness_command(const RobustnessCommand& command) {
  return guarded([&] {
    RobustnessCommand cmd = command;
    if (!cmd.resume.empty()) cmd.out_dir = cmd.resume;
    check_option_number("--duration", cmd.options.duration, duration_range());
    check_option_number("--threads", cmd.options.threads, threads_range());
    check_utf8_file_name(cmd.scenario);
    RobustnessOptions o = cmd.options;
    parse_push_point(cmd.options.point, o.point, o.offset);
    o.interrupt = &g_interrupt;
    if (cmd.out_dir.empty()) throw InputError("--out: give an output folder");
    const std::filesystem::path partial = std::filesystem::path(cmd.out_dir) / kRobustnessPartial;
    const nlohmann::json fingerprint = robustness_fingerprint(cmd);
    nlohmann::json saved = {{"options", fingerprint}, {"done", nlohmann::json::array()}};
    std::vector<RobustnessCell> finished;
    if (!cmd.resume.empty()) {
      saved = read_partial(cmd.resume, kRobustnessPartial, fingerprint);
      try {
        for (const auto& c : saved.at("done")) finished.push_back(cell_from_json(c));
      } catch (const std::exception& e) {
        throw InputError(fmt::format("{}: a direction and phase do not read back ({})",
                                     partial.string(), e.what()));
      }
    }
    LoadedScenario loaded = load_scenario(cmd.scenario, cmd.sets);
    auto wall0 = std::chrono::steady_clock::now();
    InterruptHandler interrupt_handler;
    RobustnessResult r = run_robustness(
        loaded, o,
        [&](const RobustnessCell& c, int done, int total) {
          // every finished direction and phase is kept, for --resume
          saved["done"].push_back(cell_to_json(c));
          std::filesystem::create_directories(cmd.out_dir);
          write_file_atomically(partial, saved.dump() + "\n");
          if (cmd.quiet) return;
          std::cout << fmt::format(
                           "  [{}/{}] direction {} phase {}: {} N ({} trials, outcome {} at it)\n",
                           done, total, c.direction, c.phase, c.threshold, c.trials.size(),
                           c.outcome_at_threshold)
                    << std::flush;
        },
        finished);
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    // under mpirun, rank 0 gathered every result and writes; the others are done
    if (!BatchRanks::get().root()) return kExitOk;
    if (r.interrupted) {
      int done = 0;
      for (const auto& c : r.cells) done += c.done;
      std::cerr << fmt::format(
          "interrupted: {} of {} directions x phases done, kept in {}; finish them with the same "
          "command and --resume {}\n",
          done, r.cells.size(), partial.string(), cmd.out_dir);
      return kExitInterrupted;
    }
    for (const auto& note : r.notes) std::cout << "note: " << note << "\n";
    write_robustness_outputs(cmd.out_dir, o, r);
    const nlohmann::json s = r.summary();
    int trials = 0;
    for (const auto& c : r.cells) trials += static_cast<int>(c.trials.size());
    std::cout << fmt::format(
        "{} on {} ({}{}): {} directions x {} phases, {} s pushes on {}; {} trials in {:.1f} s "
        "wall\n",
        r.scenario, r.engine, r.walker ? "walker" : "standing", r.planar ? ", planar" : "",
        r.directions.size(), r.phase_fractions.size(), o.push_duration, o.body, trials, wall);
    std::cout << fmt::format(
        "threshold min {} N, mean {:.1f} N, max {} N; weakest: {} degrees at phase {}\n",
        s["threshold_n"]["min"].get<double>(), s["threshold_n"]["mean"].get<double>(),
        s["threshold_n"]["max"].get<double>(), s["weakest"]["angle_deg"].get<double>(),
        s["weakest"]["phase"].get<int>());
    std::cout << fmt::format("wrote {}/robustness.csv, thresholds.csv and summary.json\n",
                             cmd.out_dir);
    if (cmd.plot) std::cout << "wrote " << plot_robustness(cmd.out_dir, r) << "\n";
    std::error_code ec;
    std::filesystem::remove(partial, ec);
    return kExitOk;
  });
}

namespace {
constexpr const char* kTunePartial = "tune.partial.json";
}  // namespace

int tune_command(const TuneCommand& command) {
  return guarded([&] {
    TuneCommand cmd = command;
    if (!cmd.resume.empty()) cmd.out_dir = cmd.resume;
    TuneOptions& o = cmd.options;
    check_option_number("--duration", o.duration, duration_range());
    check_option_number("--threads", o.threads, threads_range());
    check_option_number("--seed", static_cast<double>(cmd.seed), {.min = 0});
    check_utf8_file_name(o.scenario);
    for (const auto& p : cmd.params) o.params.push_back(parse_tune_param(p));
    for (const auto& n : cmd.neighbours) o.neighbours.push_back(parse_neighbour(n));
    o.seed = static_cast<unsigned long long>(cmd.seed);
    o.interrupt = &g_interrupt;
    if (cmd.out_dir.empty()) throw InputError("--out: give an output folder");
    // a resumed tune: the checkpoint of the interrupted one, made with the same options
    const std::filesystem::path partial = std::filesystem::path(cmd.out_dir) / kTunePartial;
    nlohmann::json saved;
    if (!cmd.resume.empty()) {
      std::ifstream in(partial);
      if (!in)
        throw InputError(
            fmt::format("--resume {}: no {} there (nothing to resume)", cmd.resume, kTunePartial));
      try {
        saved = parse_resume_json(in, partial.string());
      } catch (const nlohmann::json::exception& e) {
        throw InputError(
            fmt::format("{}: not a stance tune resume file ({})", partial.string(), e.what()));
      }
      check_tune_resume(o, saved, "--resume " + cmd.resume);
    }
    auto wall0 = std::chrono::steady_clock::now();
    InterruptHandler interrupt_handler;
    bool notes_shown = false;
    TuneResult r = run_tune(
        o,
        [&](const TuneResult& so_far, int g) {
          // under mpirun every rank holds the same result; rank 0 writes and reports
          if (!BatchRanks::get().root()) return;
          // every finished generation is kept: the outputs so far, then the state to resume
          write_tune_outputs(cmd.out_dir, o, so_far);
          write_file_atomically(partial, so_far.checkpoint.dump() + "\n");
          if (cmd.quiet) return;
          if (!notes_shown)
            for (const auto& note : so_far.notes) std::cout << "note: " << note << "\n";
          notes_shown = true;
          const TuneCandidate& best = so_far.candidates[so_far.best];
          double gen_best = std::numeric_limits<double>::infinity();
          for (const auto& c : so_far.candidates)
            if (c.generation == g) gen_best = std::min(gen_best, c.robust_score);
          std::string metric =
              o.metric.empty() ? "" : fmt::format(", mean {} {:.4g}", o.metric, best.mean_metric);
          std::cout << fmt::format(
                           "generation {}/{}: {} candidates; best robust score {:.6g} (worst time "
                           "up {:.3f} of {:.3f} s{}); this generation's best {:.6g}\n",
                           g + 1, so_far.generations, so_far.candidates.size(), best.robust_score,
                           best.worst_time_up, so_far.duration, metric, gen_best)
                    << std::flush;
        },
        cmd.resume.empty() ? nullptr : &saved);
    double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    if (!BatchRanks::get().root()) return r.interrupted ? kExitInterrupted : kExitOk;
    if (r.interrupted) {
      if (r.finished_generations == 0)
        std::cerr << "interrupted before the first generation finished; nothing kept\n";
      else
        std::cerr << fmt::format(
            "interrupted: {} of {} generations done, kept in {}; finish them with the same "
            "command and --resume {}\n",
            r.finished_generations, r.generations, partial.string(), cmd.out_dir);
      return kExitInterrupted;
    }
    write_tune_outputs(cmd.out_dir, o, r);
    const TuneCandidate& start = r.candidates.front();
    const TuneCandidate& best = r.candidates[r.best];
    int failed = 0;
    for (const auto& c : r.candidates) failed += c.failed_runs;
    std::cout << fmt::format(
        "tuned {} parameters over {} candidates x {} runs in {:.1f} s wall; wrote "
        "{}/tune.csv, best.yaml and best_scenario.yaml\n",
        o.params.size(), r.candidates.size(), 1 + o.neighbours.size(), wall, cmd.out_dir);
    std::cout << fmt::format("start: robust score {:.6g}, worst time up {:.3f} s\n",
                             start.robust_score, start.worst_time_up);
    std::cout << fmt::format("best:  robust score {:.6g}, worst time up {:.3f} s",
                             best.robust_score, best.worst_time_up);
    if (!o.metric.empty()) std::cout << fmt::format(", mean {} {:.4g}", o.metric, best.mean_metric);
    std::cout << "\n";
    if (failed > 0)
      std::cout << fmt::format("{} runs diverged or failed (counted as down at t = 0)\n", failed);
    for (const auto& a : tune_assignments(o, best)) std::cout << "  --set " << a << "\n";
    std::error_code ec;
    std::filesystem::remove(partial, ec);
    return kExitOk;
  });
}

}  // namespace stance
