#include "sim/observers.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>

#include "core/atomic_file.h"
#include "core/error.h"

namespace stance {

CsvLog::CsvLog(const std::string& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) throw InputError(fmt::format("--out {}: {}", out_dir, ec.message()));
  file_ = std::make_unique<AtomicFile>(std::filesystem::path(out_dir) / "log.csv");
}

namespace {

// the first tracking controller's mean body position error now (the per-step quantity its
// G-MPJPE averages); false when no controller tracks a reference
bool tracked_body_error(const Simulation& sim, double& body_m) {
  TrackingError error;
  for (size_t i = 0; i < sim.controllers().size(); ++i) {
    const auto* tracking = sim.controllers()[i]->as<Tracking>();
    if (tracking && tracking->tracking_error(sim.controller_state(i), sim.engine(), error)) {
      body_m = error.body_m;
      return true;
    }
  }
  return false;
}

}  // namespace

std::vector<std::string> log_columns(const Simulation& sim) {
  std::vector<std::string> c = {"time", "com_x", "com_y", "com_z", "root_x", "root_y", "root_z"};
  for (const auto& n : sim.model().signal_names) c.push_back(n);
  double body_m = 0;
  if (tracked_body_error(sim, body_m)) c.push_back("tracking_body_error_m");
  for (const char* n : {"push_fx", "push_fy", "push_fz", "push_tail_x", "push_tail_y",
                        "push_tail_z", "push_head_x", "push_head_y", "push_head_z"})
    c.push_back(n);
  return c;
}

void log_row(const Simulation& sim, std::vector<double>& row) {
  const Engine& e = sim.engine();
  Eigen::Vector3d c = e.com();
  Eigen::Vector3d root = e.nbody() > 0 ? e.body_pose(0).pos : Eigen::Vector3d::Zero();
  row.clear();
  row.insert(row.end(), {e.time(), c.x(), c.y(), c.z(), root.x(), root.y(), root.z()});
  sim.signals(row);
  if (double body_m = 0; tracked_body_error(sim, body_m)) row.push_back(body_m);
  // pushes: the force and the seed's arrow (force/30, ending at the body)
  Eigen::Vector3d f = Eigen::Vector3d::Zero(), head = Eigen::Vector3d::Zero();
  bool any = false;
  for (const auto& push : sim.model().pushes)
    if (push.p.active_at(e.time())) {
      f += push.p.force;
      if (!any) head = push_point(e, push);
      any = true;
    }
  Eigen::Vector3d tail = any ? Eigen::Vector3d(head - f / 30.0) : head;
  row.insert(row.end(),
             {f.x(), f.y(), f.z(), tail.x(), tail.y(), tail.z(), head.x(), head.y(), head.z()});
}

void MemoryLog::on_start(const Simulation& sim) {
  columns = log_columns(sim);
  values.clear();
  log_row(sim, row_);
  values.insert(values.end(), row_.begin(), row_.end());
}

void MemoryLog::on_step(const Simulation& sim) {
  if (sim.progress().steps % sim.model().log_every != 0) return;
  log_row(sim, row_);
  values.insert(values.end(), row_.begin(), row_.end());
}

CsvLog::~CsvLog() = default;

void CsvLog::on_start(const Simulation& sim) {
  std::ostream& out_ = file_->stream();
  std::vector<std::string> columns = log_columns(sim);
  for (size_t i = 0; i < columns.size(); ++i) out_ << (i ? "," : "") << columns[i];
  out_ << "\n";
  row_.reserve(columns.size());
  write_row(sim);
}

void CsvLog::on_step(const Simulation& sim) {
  if (sim.progress().steps % sim.model().log_every == 0) write_row(sim);
}

void CsvLog::on_finish(const Simulation& sim, const RunResult& result) {
  file_->commit();
}

void CsvLog::write_row(const Simulation& sim) {
  std::ostream& out_ = file_->stream();
  log_row(sim, row_);
  // time to the microsecond, the rest to 9 significant digits
  out_ << fmt::format("{:.6f}", row_[0]);
  for (size_t i = 1; i < row_.size(); ++i) out_ << fmt::format(",{:.9g}", row_[i]);
  out_ << "\n";
}

ProgressBar::ProgressBar(double total_s) : total_s_(total_s) {}

std::string ProgressBar::line(double fraction, double sim_s, double total_s, double elapsed_s) {
  constexpr int kWidth = 30;
  fraction = std::clamp(fraction, 0.0, 1.0);
  int filled = static_cast<int>(std::lround(fraction * kWidth));
  std::string eta = "--";
  if (fraction > 0.001) {
    double left = elapsed_s * (1 - fraction) / fraction;
    eta = left >= 60 ? fmt::format("{}m{:02d}s", int(left) / 60, int(left) % 60)
                     : fmt::format("{:.0f}s", left);
  }
  return fmt::format("[{}{}] {:3.0f}%  {:.1f}/{:.1f} s  ETA {}", std::string(filled, '#'),
                     std::string(kWidth - filled, ' '), 100 * fraction, sim_s, total_s, eta);
}

void ProgressBar::on_start(const Simulation& sim) {
  enabled_ = isatty(fileno(stderr));
  if (total_s_ <= 0) total_s_ = sim.scenario().duration;
  t0_sim_ = sim.time();
  wall0_ = last_draw_ = std::chrono::steady_clock::now();
}

void ProgressBar::on_step(const Simulation& sim) {
  if (!enabled_ || total_s_ <= 0) return;
  auto now = std::chrono::steady_clock::now();
  if (now - last_draw_ < std::chrono::milliseconds(200)) return;
  last_draw_ = now;
  double elapsed = std::chrono::duration<double>(now - wall0_).count();
  double done = sim.time() - t0_sim_;
  std::fprintf(stderr, "\r%s", line(done / total_s_, done, total_s_, elapsed).c_str());
  std::fflush(stderr);
}

void ProgressBar::on_finish(const Simulation& sim, const RunResult& result) {
  if (!enabled_) return;
  std::fprintf(stderr, "\r%s\n",
               line(1.0, result.sim_time - t0_sim_, total_s_, result.wall_time_s).c_str());
}

}  // namespace stance
