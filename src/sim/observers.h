// Observers of the step loop that entry points attach: the log.csv writer and the progress bar.
// (Fall and divergence detection and the metrics belong to the Simulation itself: they are part
// of the run's state and are branched with it.)
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "sim/simulation.h"

namespace stance {

// the log's columns: time, com_x..z, root_x..z (the first mobile body's origin), the
// controllers' signals, tracking_body_error_m when a controller tracks a reference (its mean
// body position error at the row's time, what G-MPJPE averages), push_fx..z, push_tail_x..z,
// push_head_x..z (the force/30, ending at the pushed body, as the seed draws it)
std::vector<std::string> log_columns(const Simulation& sim);
// the values of those columns now; `row` is cleared, then filled (its capacity is kept)
void log_row(const Simulation& sim, std::vector<double>& row);

// the log in memory, at the scenario's log rate: the same rows as log.csv at full precision
// (the Python module's result.log)
class MemoryLog final : public StepObserver {
 public:
  void on_start(const Simulation& sim) override;
  void on_step(const Simulation& sim) override;

  std::vector<std::string> columns;
  std::vector<double> values;  // rows one after another, columns.size() each

 private:
  std::vector<double> row_;
};

// log.csv at the scenario's log rate: time, COM, root, the controllers' signals, the active push
// and its arrow. Written beside as a hidden file and renamed into place when the run finishes.
class CsvLog final : public StepObserver {
 public:
  explicit CsvLog(const std::string& out_dir);
  ~CsvLog() override;
  void on_start(const Simulation& sim) override;
  void on_step(const Simulation& sim) override;
  void on_finish(const Simulation& sim, const RunResult& result) override;

 private:
  void write_row(const Simulation& sim);

  std::unique_ptr<AtomicFile> file_;  // committed by on_finish
  std::vector<double> row_;
};

// a one-line progress bar with an ETA on stderr, drawn only when stderr is a terminal
class ProgressBar final : public StepObserver {
 public:
  // total: the run's length in simulated seconds (0: the scenario's)
  explicit ProgressBar(double total_s = 0);
  void on_start(const Simulation& sim) override;
  void on_step(const Simulation& sim) override;
  void on_finish(const Simulation& sim, const RunResult& result) override;
  // the line drawn for a fraction done after `elapsed_s` of wall time (for tests)
  static std::string line(double fraction, double sim_s, double total_s, double elapsed_s);

 private:
  bool enabled_ = false;
  double total_s_ = 0, t0_sim_ = 0;
  std::chrono::steady_clock::time_point wall0_, last_draw_;
};

}  // namespace stance
