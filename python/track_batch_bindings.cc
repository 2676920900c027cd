// stance.track on many clips: `stance bvh track A B FOLDER --out OUT` through run_track_batch
// (app/track_batch.h), its results table as numpy arrays and its summary as a dict.
#include <fmt/format.h>

#include <cmath>
#include <cstdlib>

#include "app/track_batch.h"
#include "bindings.h"
#include "core/error.h"

namespace stance::python {
namespace {

struct PyTrackBatchResult {
  TrackBatchResult r;
  py::object out = py::none();  // the folder kept, or None
};

// one value of each row as a numpy array
template <class T, class Get>
py::array_t<T> column(const std::vector<TrackRow>& rows, Get get) {
  py::array_t<T> a(static_cast<py::ssize_t>(rows.size()));
  for (size_t i = 0; i < rows.size(); ++i) a.mutable_at(i) = get(rows[i]);
  return a;
}

// results.csv's columns, in its order: numbers as numpy arrays, the clip names and errors as lists
py::dict rows_table(const std::vector<TrackRow>& rows) {
  std::vector<std::string> clip, error;
  for (const TrackRow& r : rows) clip.push_back(r.clip), error.push_back(r.error);
  using R = const TrackRow&;
  py::dict d;
  d["clip"] = clip;
  d["frames"] = column<int>(rows, [](R r) { return r.frames; });
  d["clip_s"] = column<double>(rows, [](R r) { return r.clip_s; });
  d["sim_s"] = column<double>(rows, [](R r) { return r.sim_s; });
  d["fell"] = column<bool>(rows, [](R r) { return r.fell; });
  d["diverged"] = column<bool>(rows, [](R r) { return r.diverged; });
  d["success"] = column<bool>(rows, [](R r) { return r.success; });
  d["g_mpjpe_m"] = column<double>(rows, [](R r) { return r.g_mpjpe_m; });
  d["root_error_m"] = column<double>(rows, [](R r) { return r.root_error_m; });
  d["joint_error_deg"] = column<double>(rows, [](R r) { return r.joint_error_deg; });
  d["foot_skate_m_per_s"] = column<double>(rows, [](R r) { return r.foot_skate_m_per_s; });
  d["error"] = error;
  d["compute_s_per_sim_s"] = column<double>(rows, [](R r) { return r.compute_s_per_sim_s; });
  d["cpu_s_per_sim_s"] = column<double>(rows, [](R r) { return r.cpu_s_per_sim_s; });
  return d;
}

py::dict summary_dict(const TrackBatchSummary& s) {
  py::dict d;
  d["clips"] = s.clips;
  d["tracked"] = s.tracked;
  d["succeeded"] = s.succeeded;
  d["fell"] = s.fell;
  d["diverged"] = s.diverged;
  d["errors"] = s.errors;
  d["success_rate"] = s.success_rate;
  d["median_g_mpjpe_m"] = s.median_g_mpjpe_m;
  d["p90_g_mpjpe_m"] = s.p90_g_mpjpe_m;
  d["line"] = s.line();
  return d;
}

// results.png as the command draws it; a missing gnuplot or a failed plot is a Python warning
void plot_results(const std::string& out, const TrackBatchResult& r) {
  std::string problem;
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    problem = "gnuplot not found, so no results.png (Debian: apt-get install gnuplot-nox)";
  } else {
    try {
      plot_track_results(out, r);
    } catch (const InputError& e) {
      problem = e.what();
    }
  }
  if (!problem.empty()) PyErr_WarnEx(PyExc_RuntimeWarning, problem.c_str(), 1);
}

}  // namespace

py::object track_batch(const BvhTrackCommand& track, const std::vector<std::string>& inputs,
                       const TrackBatchOptions& options) {
  BvhTrackBatchCommand cmd;
  cmd.track = track;
  cmd.inputs = inputs;
  cmd.jobs = options.jobs;
  cmd.resume = options.resume;
  cmd.plot = options.plot;
  PyTrackBatchResult result;
  // Ctrl-C stops the clips running and keeps the finished ones (resume=True does the rest)
  run_checking_signals([&] { result.r = run_track_batch(cmd, &python_interrupt()); });
  if (cmd.plot) plot_results(track.out_dir, result.r);
  result.out = py::str(track.out_dir);
  return py::cast(std::move(result));
}

void bind_track_batch_result(py::module_& m) {
  py::class_<PyTrackBatchResult>(m, "TrackBatchResult",
                                 "clips tracked at once (stance.track on many): the results "
                                 "table and its summary, as results.csv and results.md hold them")
      .def_property_readonly(
          "rows", [](const PyTrackBatchResult& b) { return rows_table(b.r.rows); },
          "results.csv's columns, one entry per clip in order: numpy arrays (frames, clip_s, "
          "sim_s, fell, diverged, success, g_mpjpe_m, root_error_m, joint_error_deg, "
          "foot_skate_m_per_s, compute_s_per_sim_s, cpu_s_per_sim_s) and lists (clip, error: "
          "non-empty where the clip could not be read)")
      .def_property_readonly(
          "summary", [](const PyTrackBatchResult& b) { return summary_dict(b.r.summary); },
          "clips, tracked, succeeded, fell, diverged, errors, success_rate, median_g_mpjpe_m, "
          "p90_g_mpjpe_m, and the summary line")
      .def_property_readonly(
          "clips",
          [](const PyTrackBatchResult& b) {
            std::vector<std::string> paths;
            for (const TrackClip& c : b.r.clips) paths.push_back(c.path);
            return paths;
          },
          "the clip files, in the rows' order")
      .def_property_readonly(
          "resumed", [](const PyTrackBatchResult& b) { return b.r.resumed; },
          "rows kept from an earlier run of the same batch (resume=True)")
      .def_readonly("out", &PyTrackBatchResult::out,
                    "the batch's folder: a subfolder per clip, results.csv, results.md")
      .def("__repr__", [](const PyTrackBatchResult& b) {
        return fmt::format("<stance.TrackBatchResult {}>", b.r.summary.line());
      });
}

bool is_batch(const std::vector<std::string>& inputs) {
  return is_track_batch(inputs);
}

}  // namespace stance::python
