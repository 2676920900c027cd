// `stance bvh track` over a dataset: several clips, folders and globs tracked in one command.
//
// Every clip runs as `stance bvh track CLIP --out OUT/<clip>` would, into its own subfolder, with
// the same files byte for byte (summary.json's wall-clock fields aside): the planner's result does
// not depend on its thread count, so a batch splits its threads between clips freely. Clips are
// handed out one at a time to the threads of each process and, under mpirun or srun, to the MPI
// ranks (scenario/batch_ranks.h); rank 0 gathers the rows and writes
//  - OUT/results.csv: one row per clip (clip, frames, clip_s, sim_s, fell, diverged, success,
//    g_mpjpe_m, root_error_m, joint_error_deg, foot_skate_m_per_s, error, compute_s_per_sim_s,
//    cpu_s_per_sim_s); every column but the last two (wall clock, the run's own CPU time) is
//    reproducible;
//  - OUT/results.md: the same as a table, and the summary line (success rate, median and
//    90th-percentile G-MPJPE);
//  - OUT/results.png (and results.gp, its gnuplot script with the data): the G-MPJPE distribution
//    and each clip's body position error (log.csv's tracking_body_error_m) over time as a strip;
//  - OUT/track_batch.json: the clips and options, which `--resume` checks.
// A clip's folder holds a summary.json only once its run has finished, so a killed batch keeps
// its finished clips and `--resume` runs the rest.
#pragma once

#include <nlohmann/json.hpp>

#include <atomic>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "app/commands.h"

namespace stance {

// one clip of a batch
struct TrackClip {
  std::string path;  // the BVH file, as named or found
  std::string name;  // its subfolder of OUT: the path under a folder argument (no .bvh), or the
                     // file's stem; made unique with _2, _3... in input order
};

// true when the inputs make a batch: more than one, a folder, or a glob pattern that is not the
// name of a file (one file is the single run, its outputs in OUT itself)
bool is_track_batch(const std::vector<std::string>& inputs);

// the clips the inputs name, in input order: a file as given; a folder's *.bvh files at any
// depth (hidden names and the folder `skip` left out), sorted by path; a glob's matches, sorted,
// each a file or a folder. A file named twice counts once. Throws InputError naming the input
// for a path that does not exist, a folder that cannot be read, no clip at all.
std::vector<TrackClip> find_track_clips(const std::vector<std::string>& inputs,
                                        const std::string& skip = "");

// one clip's row of the results
struct TrackRow {
  static constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();
  std::string clip;
  int frames = 0;            // the clip's frames in the tracked range
  double clip_s = kNoValue;  // their duration
  double sim_s = kNoValue;   // simulated (less than the clip's after a fall)
  bool fell = false, diverged = false, success = false;
  // NaN where the clip has no result
  double g_mpjpe_m = kNoValue, root_error_m = kNoValue, joint_error_deg = kNoValue;
  double foot_skate_m_per_s = kNoValue;
  // the columns that are not reproducible: wall seconds and the run's own CPU seconds per
  // simulated second
  double compute_s_per_sim_s = kNoValue, cpu_s_per_sim_s = kNoValue;
  std::string error;            // not empty: the clip was not tracked, and why
  bool internal_error = false;  // the error is a bug in stance, not the clip's
  // the body position error over time (m): the mean over each strip_bin_s from t = 0 (NaN: no
  // sample)
  double strip_bin_s = 0;
  std::vector<double> strip;
  bool done = false;  // finished (false: interrupted or not started)
};
nlohmann::json track_row_to_json(const TrackRow& row);  // numbers round-trip exactly
TrackRow track_row_from_json(const nlohmann::json& j);
// the row of a finished clip's folder (its summary.json and log.csv); done = false when the
// folder has no finished run
TrackRow read_track_row(const std::string& clip, const std::string& dir);

struct TrackBatchSummary {
  int clips = 0;      // rows
  int tracked = 0;    // rows with a result (no error)
  int succeeded = 0;  // PHC's success: no fall, the body stayed near the clip
  int fell = 0, diverged = 0, errors = 0;
  double success_rate = 0;  // succeeded / clips (a clip that cannot be read counts as a failure)
  // over the tracked clips, linear between ranks; NaN when none was tracked
  double median_g_mpjpe_m = 0, p90_g_mpjpe_m = 0;
  std::string line() const;  // "6 clips: 5 succeeded (83.3%), ... G-MPJPE median ..."
};
TrackBatchSummary summarize_track_rows(const std::vector<TrackRow>& rows);

struct BvhTrackBatchCommand {
  // every clip's options; track.out_dir is the batch's folder OUT (track.bvh is not used), and
  // track.threads the threads of each process, shared between its clips (0: every core)
  BvhTrackCommand track;
  std::vector<std::string> inputs;  // files, folders, globs
  // clips tracked at once in each process, each with threads / jobs planner threads;
  // 0: as many as there are threads (and clips)
  int jobs = 0;
  bool resume = false;  // keep OUT's finished clips (same clips and options) and run the rest
  bool plot = true;     // OUT/results.png (gnuplot)
  std::string record;   // --record: refused (one clip only)
  bool view = false;    // --view: refused (one clip only)
};

struct TrackBatchResult {
  std::vector<TrackClip> clips;
  std::vector<TrackRow> rows;  // one per clip, in order (complete on MPI rank 0 only)
  TrackBatchSummary summary;
  bool interrupted = false;  // stopped by `interrupt`: the unfinished rows are not done
  int resumed = 0;           // rows kept from OUT (--resume)
};

// called as each clip of this process finishes (under a lock): its row, the rows finished so far
// in this process (resumed ones included) and the clips in all
using TrackRowDone = std::function<void(const TrackRow&, int done, int total)>;

// runs the batch into cmd.track.out_dir: every clip's folder and, when not interrupted,
// results.csv and results.md (not the plot: plot_track_results). Bad input for the whole batch
// (no clip, a bad option, --resume of another batch) throws InputError before any clip runs; a
// clip that cannot be read is its row's error. interrupt: set by a signal handler (no new clip
// starts; the running ones stop and are not done). on_start(rows kept by --resume, clips) is
// called once the clips are known.
TrackBatchResult run_track_batch(const BvhTrackBatchCommand& cmd,
                                 const std::atomic<bool>* interrupt = nullptr,
                                 const TrackRowDone& on_done = {},
                                 const std::function<void(int, int)>& on_start = {});

// results.csv and results.md of the rows into dir
void write_track_results(const std::string& dir, const TrackBatchResult& result);
// results.png and results.gp into dir; throws InputError when gnuplot is missing or fails.
// Returns the PNG's path.
std::string plot_track_results(const std::string& dir, const TrackBatchResult& result);

// the command: progress (a bar on a terminal's stderr, else a line per clip), the outputs, the
// summary line. Exit 0 when every clip was tracked (a fall or a divergence is a result), 2 when
// a clip could not be read (its row says why) or for bad input, 70 for a bug in a clip's run,
// 130 when interrupted (finished clips kept for --resume)
int bvh_track_batch_command(const BvhTrackBatchCommand& cmd);

}  // namespace stance
