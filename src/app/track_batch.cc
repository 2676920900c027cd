#include "app/track_batch.h"

#include <fmt/format.h>
#include <glob.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "app/guarded.h"
#include "app/track_batch_text.h"
#include "batch/batch_ranks.h"
#include "batch/sweep.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "params/option_check.h"
#include "sim/planner_params.h"
#include "sim/scenario.h"
#include "sim/simulation.h"

namespace stance {

namespace fs = std::filesystem;

namespace {

constexpr const char* kBatchFile = "track_batch.json";

// ---- finding the clips

bool has_glob_chars(const std::string& s) {
  return s.find_first_of("*?[") != std::string::npos;
}

std::string lowercase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// a path's identity for "named twice": canonical where it exists
std::string path_key(const fs::path& p) {
  std::error_code ec;
  fs::path k = fs::weakly_canonical(p, ec);
  if (ec) k = fs::absolute(p).lexically_normal();
  return k.string();
}

// the clips list being built: each file once, each name once
class ClipList {
 public:
  void add(const fs::path& file, std::string name) {
    if (!files_.insert(path_key(file)).second) return;
    if (name.empty()) name = "clip";
    std::string unique = name;
    for (int k = 2; names_.count(unique); ++k) unique = fmt::format("{}_{}", name, k);
    names_.insert(unique);
    clips_.push_back({file.string(), unique});
  }
  std::vector<TrackClip> take() { return std::move(clips_); }

 private:
  std::set<std::string> files_, names_;
  std::vector<TrackClip> clips_;
};

// a folder's .bvh files at any depth, sorted, named by their path under it; hidden names and the
// folder `skip` (the batch's own output) are left out
void add_folder(const fs::path& folder, const std::string& skip_key, ClipList& list) {
  std::vector<fs::path> found;
  std::error_code ec;
  auto fail = [&](const std::error_code& e) {
    throw InputError(fmt::format("{}: cannot read the folder ({})", folder.string(), e.message()));
  };
  fs::recursive_directory_iterator it(folder, ec), end;
  if (ec) fail(ec);
  for (; it != end; it.increment(ec)) {
    if (ec) fail(ec);
    const fs::path& p = it->path();
    const bool is_dir = it->is_directory(ec);
    const std::string leaf = p.filename().string();
    if ((!leaf.empty() && leaf[0] == '.') || (is_dir && path_key(p) == skip_key)) {
      if (is_dir) it.disable_recursion_pending();
      continue;
    }
    if (!is_dir && it->is_regular_file(ec) && lowercase(p.extension().string()) == ".bvh")
      found.push_back(p);
  }
  if (ec) fail(ec);
  if (found.empty())
    throw InputError(fmt::format("{}: no .bvh file in this folder or below it", folder.string()));
  std::sort(found.begin(), found.end());
  for (const fs::path& p : found)
    list.add(p, p.lexically_relative(folder).replace_extension().generic_string());
}

void add_input(const fs::path& input, const std::string& skip_key, ClipList& list) {
  std::error_code ec;
  if (fs::is_directory(input, ec))
    add_folder(input, skip_key, list);
  else
    list.add(input, input.stem().string());
}

// ---- the batch's options, checked on --resume

nlohmann::json batch_fingerprint(const BvhTrackBatchCommand& cmd,
                                 const std::vector<TrackClip>& clips) {
  const BvhTrackCommand& t = cmd.track;
  nlohmann::json list = nlohmann::json::array();
  for (const TrackClip& c : clips)
    list.push_back({{"name", c.name}, {"path", fs::absolute(c.path).lexically_normal().string()}});
  const auto file = [](const std::string& p) {
    return p.empty() || p.find("://") != std::string::npos ? p : fs::absolute(p).string();
  };
  nlohmann::json options = {
      {"clips", list},
      {"duration", t.duration ? nlohmann::json(*t.duration) : nlohmann::json(nullptr)},
      {"loop", t.loop},
      {"first_frame", t.first_frame},
      {"last_frame", t.last_frame},
      {"map", file(t.map)},
      {"model", file(t.model)},
      {"engine", t.engine},
      {"sets", t.sets},
      {"origin_centred", t.origin_centred},
      {"scale_to_meters", t.scale_to_meters},
      {"human_limits", t.human_limits}};
  // as it reads back from the file (a name that is not UTF-8 is written with U+FFFD)
  return nlohmann::json::parse(
      options.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

std::string dump_json(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

void check_resume(const fs::path& out, const nlohmann::json& now) {
  const fs::path file = out / kBatchFile;
  std::ifstream in(file);
  if (!in)
    throw InputError(
        fmt::format("--resume: {} has no {} (no batch to resume there)", out.string(), kBatchFile));
  nlohmann::json saved;
  try {
    saved = nlohmann::json::parse(in).at("options");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not a batch file of stance ({})", file.string(), e.what()));
  }
  for (auto it = now.begin(); it != now.end(); ++it) {
    const nlohmann::json was = saved.contains(it.key()) ? saved[it.key()] : nlohmann::json();
    if (was == it.value()) continue;
    if (it.key() == "clips")
      throw InputError(fmt::format(
          "--resume {}: the clips differ from the interrupted batch's ({} then, {} now)",
          out.string(), was.is_array() ? was.size() : 0, it.value().size()));
    throw InputError(fmt::format("--resume {}: option '{}' was {} in the interrupted batch, now {}",
                                 out.string(), it.key(), dump_json(was), dump_json(it.value())));
  }
}

// the options every clip shares, checked once before any clip runs
void check_batch_options(const BvhTrackBatchCommand& cmd) {
  const BvhTrackCommand& t = cmd.track;
  if (!cmd.record.empty())
    throw InputError("--record: renders one clip; track that clip alone to record it");
  if (cmd.view) throw InputError("--view: shows one clip; track that clip alone to watch it");
  if (t.out_dir.empty()) throw InputError("--out: give an output folder");
  if (cmd.resume && !is_track_batch(cmd.inputs))
    throw InputError(
        "--resume: finishes a batch (several clips, a folder or a glob); one clip "
        "alone has nothing to resume");
  if (!t.map.empty() && t.model.empty())
    throw InputError("bvh track: --map needs --model (the model it maps the clips onto)");
  check_option_number("--duration", t.duration, param_meta<Scenario>("duration"));
  if (t.duration && !(*t.duration > 0))
    throw InputError("--duration: expected a positive number of seconds");
  check_option_number("--threads", t.threads, param_meta<PlannerParams>("threads"));
  check_option_number("--jobs", cmd.jobs, {.min = 0, .max = 1024});
}

// one clip tracked as `stance bvh track CLIP --out DIR` would (planner_threads: the rollout
// threads of its planner, which do not change its result)
TrackRow track_one_clip(const BvhTrackBatchCommand& cmd, const TrackClip& clip, int planner_threads,
                        const std::atomic<bool>* interrupt) {
  BvhTrackCommand c = cmd.track;
  c.bvh = clip.path;
  c.out_dir = (fs::path(cmd.track.out_dir) / clip.name).string();
  c.quiet = true;
  TrackRow row;
  row.clip = clip.name;
  try {
    std::error_code ec;
    fs::remove(fs::path(c.out_dir) / "summary.json", ec);  // only this run's counts as finished
    const std::string scenario = write_bvh_track_scenario(c);
    RunCommand run = bvh_track_run(c, scenario);
    run.sets.push_back(fmt::format("planner.threads={}", planner_threads));
    run.quiet = true;
    if (make_run_simulation(run, interrupt)->run().interrupted) return row;
    // the row as it reads back from the folder, as a resumed batch reads it
    row = read_track_row(clip.name, c.out_dir);
    if (!row.done) row.error = "the run wrote no summary.json", row.done = true;
  } catch (const InputError& e) {
    row.error = e.what();
    row.done = true;
  } catch (const EnvironmentError& e) {
    row.error = e.what();
    row.done = true;
  } catch (const std::exception& e) {
    row.error = fmt::format("internal error: {} (a bug in stance; please report it)", e.what());
    row.internal_error = true;
    row.done = true;
  }
  return row;
}

// ---- the command's progress: a bar on a terminal, or a line per clip

class ClipProgress {
 public:
  ClipProgress(bool quiet, int rank) : quiet_(quiet), rank_(rank) {
    bar_ = !quiet && rank == 0 && isatty(fileno(stderr));
  }
  void start(int done, int total) {
    start_done_ = done;
    wall0_ = std::chrono::steady_clock::now();
    draw(done, total);
  }
  void clip_done(const TrackRow& row, int done, int total) {
    if (quiet_) return;
    if (bar_) std::fprintf(stderr, "\r\033[K");
    std::cout << (rank_ > 0 ? fmt::format("  rank {} ", rank_)
                            : fmt::format("  [{}/{}] ", done, total))
              << row.clip << ": " << outcome(row) << std::endl;
    draw(done, total);
  }
  void finish() {
    if (bar_ && drawn_) std::fprintf(stderr, "\n");
  }

 private:
  static std::string outcome(const TrackRow& r) {
    if (!r.error.empty()) return "error: " + r.error;
    std::string what = r.diverged  ? "diverged"
                       : r.fell    ? "fell"
                       : r.success ? "held"
                                   : "no success";
    return fmt::format("{}, G-MPJPE {} m, {:.1f} s", what, md_number(r.g_mpjpe_m, 3), r.sim_s);
  }
  void draw(int done, int total) {
    if (!bar_ || total <= 0) return;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(std::lround(kWidth * static_cast<double>(done) / total));
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count();
    const int ran = done - start_done_;
    std::string eta = "--";
    if (ran > 0) {
      const double left = elapsed / ran * (total - done);
      eta = left >= 60 ? fmt::format("{}m{:02d}s", int(left) / 60, int(left) % 60)
                       : fmt::format("{:.0f}s", left);
    }
    std::fprintf(stderr, "\r\033[K[%s%s] %d/%d clips  ETA %s", std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, ' ').c_str(), done, total, eta.c_str());
    std::fflush(stderr);
    drawn_ = true;
  }
  bool quiet_, bar_ = false, drawn_ = false;
  int rank_, start_done_ = 0;
  std::chrono::steady_clock::time_point wall0_;
};

// SIGINT and SIGTERM stop the batch cleanly while it lives; a second one kills at once
std::atomic<bool> g_track_batch_interrupt{false};

extern "C" void on_track_batch_signal(int) {
  g_track_batch_interrupt.store(true);
}

class TrackBatchSignals {
 public:
  TrackBatchSignals() {
    g_track_batch_interrupt.store(false);
    struct sigaction sa {};
    sa.sa_handler = on_track_batch_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~TrackBatchSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  TrackBatchSignals(const TrackBatchSignals&) = delete;
  TrackBatchSignals& operator=(const TrackBatchSignals&) = delete;

 private:
  struct sigaction old_int_ {
  }, old_term_{};
};

}  // namespace

bool is_track_batch(const std::vector<std::string>& inputs) {
  if (inputs.size() != 1) return inputs.size() > 1;
  std::error_code ec;
  const std::string& in = inputs.front();
  return fs::is_directory(in, ec) || (has_glob_chars(in) && !fs::exists(in, ec));
}

std::vector<TrackClip> find_track_clips(const std::vector<std::string>& inputs,
                                        const std::string& skip) {
  ClipList list;
  const std::string skip_key = skip.empty() ? std::string() : path_key(skip);
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (fs::exists(input, ec)) {
      add_input(input, skip_key, list);
      continue;
    }
    if (!has_glob_chars(input)) throw InputError(fmt::format("{}: no such file or folder", input));
    glob_t found{};
    const int code = glob(input.c_str(), 0, nullptr, &found);
    std::vector<std::string> matches(found.gl_pathv, found.gl_pathv + found.gl_pathc);
    globfree(&found);
    if (code != 0 || matches.empty())
      throw InputError(fmt::format("{}: no file or folder matches", input));
    for (const std::string& m : matches) add_input(m, skip_key, list);
  }
  std::vector<TrackClip> clips = list.take();
  if (clips.empty()) throw InputError("bvh track: no clip to track");
  return clips;
}

TrackBatchResult run_track_batch(const BvhTrackBatchCommand& cmd,
                                 const std::atomic<bool>* interrupt, const TrackRowDone& on_done,
                                 const std::function<void(int, int)>& on_start) {
  check_batch_options(cmd);
  const fs::path out = cmd.track.out_dir;
  TrackBatchResult result;
  result.clips = find_track_clips(cmd.inputs, cmd.track.out_dir);
  const int n = static_cast<int>(result.clips.size());
  const nlohmann::json fingerprint = batch_fingerprint(cmd, result.clips);
  BatchRanks& ranks = BatchRanks::get();
  result.rows.resize(n);
  for (int i = 0; i < n; ++i) result.rows[i].clip = result.clips[i].name;
  if (cmd.resume) {
    check_resume(out, fingerprint);
    for (int i = 0; i < n; ++i) {
      result.rows[i] = read_track_row(result.clips[i].name, (out / result.clips[i].name).string());
      result.resumed += result.rows[i].done;
    }
  } else if (ranks.root()) {
    // a fresh batch: no clip of an earlier one in this folder counts as finished
    std::error_code ec;
    fs::create_directories(out, ec);
    if (ec) throw InputError(fmt::format("--out {}: {}", out.string(), ec.message()));
    for (const TrackClip& c : result.clips) fs::remove(out / c.name / "summary.json", ec);
    for (const char* f : {"results.csv", "results.md", "results.png", "results.gp"})
      fs::remove(out / f, ec);
    write_file_atomically(out / kBatchFile, dump_json({{"options", fingerprint}}, 2) + "\n");
  }
  // the threads of this process: `jobs` clips at once, the rest to their planners
  const int todo = n - result.resumed;
  const int threads = cmd.track.threads > 0
                          ? cmd.track.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const int jobs = std::clamp(cmd.jobs > 0 ? cmd.jobs : threads, 1, std::max(1, todo));
  const int planner_threads = std::max(1, threads / jobs);

  std::mutex done_mutex;
  int done = result.resumed;
  bool cut = false;  // a clip of this process was interrupted or not started
  if (on_start) on_start(done, n);
  // every clip is handed out, kept ones too: the rank given a clip decides from what it read of
  // the folder before any clip of this batch ran, so one that another rank has just finished is
  // never taken for an earlier run's
  ranks.distributed_for(
      n, jobs,
      [&](int i) {
        if (result.rows[i].done) return;  // kept from the earlier run
        TrackRow row;
        if (!interrupt || !interrupt->load())
          row = track_one_clip(cmd, result.clips[i], planner_threads, interrupt);
        std::lock_guard<std::mutex> lock(done_mutex);
        cut |= !row.done;
        if (!row.done) return;
        result.rows[i] = std::move(row);
        ++done;
        if (on_done) on_done(result.rows[i], done, n);
      },
      [&](int i) {
        const TrackRow& row = result.rows[i];
        return row.done ? dump_json(track_row_to_json(row)) : std::string();
      },
      [&](int i, const std::string& text) {
        if (text.empty()) return;
        result.rows[i] = track_row_from_json(nlohmann::json::parse(text));
        result.rows[i].clip = result.clips[i].name;
      });
  // rank 0 holds every row; another rank knows its own clips
  result.interrupted = cut;
  if (ranks.root())
    for (const TrackRow& r : result.rows) result.interrupted |= !r.done;
  if (!ranks.root() || result.interrupted) return result;
  result.summary = summarize_track_rows(result.rows);
  write_track_results(out.string(), result);
  return result;
}

int bvh_track_batch_command(const BvhTrackBatchCommand& cmd) {
  return guarded([&] {
    const int rank = BatchRanks::get().rank();
    ClipProgress progress(cmd.track.quiet, rank);
    TrackBatchSignals signals;
    const auto wall0 = std::chrono::steady_clock::now();
    const TrackBatchResult r = run_track_batch(
        cmd, &g_track_batch_interrupt,
        [&](const TrackRow& row, int done, int total) { progress.clip_done(row, done, total); },
        [&](int done, int total) { progress.start(done, total); });
    progress.finish();
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    const std::string out = cmd.track.out_dir;
    // under mpirun, rank 0 gathered every row and writes; the others are done
    if (!BatchRanks::get().root()) return r.interrupted ? kExitInterrupted : kExitOk;
    if (r.interrupted) {
      int done = 0;
      for (const TrackRow& row : r.rows) done += row.done;
      std::cerr << fmt::format(
          "interrupted: {} of {} clips done, kept in {}; finish them with the same command and "
          "--resume\n",
          done, r.rows.size(), out);
      return kExitInterrupted;
    }
    std::cout << fmt::format(
        "tracked {} ({} kept from the earlier run) in {:.1f} s wall; "
        "wrote {}/results.csv and results.md\n",
        clip_count(r.rows.size()), r.resumed, wall, out);
    if (cmd.plot) {
      if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
        std::cerr << "note: gnuplot not found, so no results.png (Debian: apt-get install "
                     "gnuplot-nox)\n";
      } else {
        try {
          std::cout << "wrote " << plot_track_results(out, r) << "\n";
        } catch (const InputError& e) {
          std::cerr << "note: " << e.what() << "\n";
        }
      }
    }
    std::cout << r.summary.line() << "\n";
    bool internal = false;
    for (const TrackRow& row : r.rows)
      if (!row.error.empty()) {
        std::cerr << "error: " << row.clip << ": " << row.error << "\n";
        internal |= row.internal_error;
      }
    if (internal) return kExitInternalError;
    return r.summary.errors > 0 ? kExitBadInput : kExitOk;
  });
}

}  // namespace stance
