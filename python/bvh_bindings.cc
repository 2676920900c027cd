// BVH clips from Python: stance.read_bvh (the parsed clip, its frames as numpy arrays and what
// `stance bvh info` measures) and stance.track (`stance bvh track` on one clip, through the same
// library calls: write_bvh_track_scenario, bvh_track_run, make_run_simulation).
#include <fmt/format.h>

#include <cstdlib>
#include <optional>
#include <system_error>

#include "app/commands.h"
#include "bindings.h"
#include "core/error.h"
#include "motion/bvh.h"

namespace stance::python {
namespace {

namespace fs = std::filesystem;

// a parsed clip with `stance bvh info --json`'s summary of it
struct PyBvhClip {
  BvhClip clip;
  nlohmann::json info;
};

PyBvhClip read_clip(const PathArg& path) {
  PyBvhClip c{read_bvh(path.string()), {}};
  c.info = bvh_info_json(c.clip);
  return c;
}

// a measure of info["character"] (null, where nothing tells the heading: NaN)
double measure(const PyBvhClip& c, const char* key) {
  const nlohmann::json& v = c.info.at("character").at(key);
  return v.is_null() ? std::nan("") : v.get<double>();
}

py::array frames_array(const BvhClip& clip) {
  py::array_t<double> a({clip.frame_count, clip.channel_count});
  auto w = a.mutable_unchecked<2>();
  for (int f = 0; f < clip.frame_count; ++f)
    for (int c = 0; c < clip.channel_count; ++c) w(f, c) = clip.raw(f, c);
  return make_read_only(a);
}

// frames x joints x 4 (w, x, y, z): each joint's rotation relative to its parent
py::array rotations_array(const BvhClip& clip) {
  py::array_t<double> a({clip.frame_count, clip.joint_count(), 4});
  auto w = a.mutable_unchecked<3>();
  for (int f = 0; f < clip.frame_count; ++f)
    for (int j = 0; j < clip.joint_count(); ++j) {
      const Eigen::Quaterniond& q = clip.rotation(f, j);
      w(f, j, 0) = q.w(), w(f, j, 1) = q.x(), w(f, j, 2) = q.y(), w(f, j, 3) = q.z();
    }
  return make_read_only(a);
}

// frames x joints x 3: each joint's translation in its parent (file units)
py::array translations_array(const BvhClip& clip) {
  py::array_t<double> a({clip.frame_count, clip.joint_count(), 3});
  auto w = a.mutable_unchecked<3>();
  for (int f = 0; f < clip.frame_count; ++f)
    for (int j = 0; j < clip.joint_count(); ++j) {
      const Eigen::Vector3d t = clip.translation(f, j);
      for (int k = 0; k < 3; ++k) w(f, j, k) = t[k];
    }
  return make_read_only(a);
}

std::vector<std::string> channel_names(const BvhJoint& j) {
  std::vector<std::string> names;
  for (BvhChannel c : j.channels) names.emplace_back(bvh_channel_name(c));
  return names;
}

// "Hips.Xposition", ...: one per column of frames
std::vector<std::string> column_names(const BvhClip& clip) {
  std::vector<std::string> names;
  for (const BvhJoint& j : clip.joints)
    for (const std::string& c : channel_names(j)) names.push_back(j.name + "." + c);
  return names;
}

void bind_bvh_joint(py::module_& m) {
  py::class_<BvhJoint>(m, "BvhJoint", "a ROOT or JOINT entry of a BVH file (End Sites folded in)")
      .def_readonly("name", &BvhJoint::name)
      .def_readonly("parent", &BvhJoint::parent, "index into BvhClip.joints; -1 for the root")
      .def_readonly("offset", &BvhJoint::offset, "from the parent, file units")
      .def_property_readonly("channels", &channel_names, "as listed: 'Xposition', ...")
      .def_readonly("first_column", &BvhJoint::first_column, "its first column in frames")
      .def_property_readonly(
          "rotation_order",
          [](const BvhJoint& j) { return std::string(rotation_order_name(j.order)); },
          "'ZXY' for Z X Y rotation channels: R = Rz Rx Ry")
      .def_readonly("has_end_site", &BvhJoint::has_end_site)
      .def_readonly("end_site_offset", &BvhJoint::end_site_offset, "file units")
      .def("__repr__", [](const BvhJoint& j) {
        return fmt::format("<BvhJoint {} parent={} channels={}>", j.name, j.parent,
                           j.channels.size());
      });
}

// the clip's parse: sizes, joints and the frames as arrays
void add_clip_arrays(py::class_<PyBvhClip>& c) {
  c.def_property_readonly("source", [](const PyBvhClip& p) { return p.clip.source; })
      .def_property_readonly("frame_count", [](const PyBvhClip& p) { return p.clip.frame_count; })
      .def_property_readonly(
          "frame_time", [](const PyBvhClip& p) { return p.clip.frame_time_s; }, "s")
      .def_property_readonly(
          "duration", [](const PyBvhClip& p) { return p.info.at("duration_s").get<double>(); },
          "s: frame_count x frame_time")
      .def_property_readonly("channel_count",
                             [](const PyBvhClip& p) { return p.clip.channel_count; })
      .def_property_readonly(
          "joints", [](const PyBvhClip& p) { return p.clip.joints; }, "list of BvhJoint")
      .def_property_readonly("joint_names",
                             [](const PyBvhClip& p) {
                               std::vector<std::string> names;
                               for (const BvhJoint& j : p.clip.joints) names.push_back(j.name);
                               return names;
                             })
      .def_property_readonly(
          "channel_names", [](const PyBvhClip& p) { return column_names(p.clip); },
          "'Joint.Xrotation' for each column of frames")
      .def_property_readonly(
          "frames", [](const PyBvhClip& p) { return frames_array(p.clip); },
          "frame_count x channel_count, the motion rows as read (degrees, file units)")
      .def_property_readonly(
          "rotations", [](const PyBvhClip& p) { return rotations_array(p.clip); },
          "frame_count x joints x 4: each joint's rotation in its parent (w, x, y, z)")
      .def_property_readonly(
          "translations", [](const PyBvhClip& p) { return translations_array(p.clip); },
          "frame_count x joints x 3: each joint's translation in its parent (file units; the "
          "position channels where it has them, else its OFFSET)");
}

// what `stance bvh info` makes of the clip
void add_clip_measures(py::class_<PyBvhClip>& c) {
  auto text = [](const char* key) {
    return [key](const PyBvhClip& p) { return p.info.at(key).get<std::string>(); };
  };
  auto character = [](const char* key) {
    return [key](const PyBvhClip& p) { return measure(p, key); };
  };
  c.def_property_readonly("units", text("units"), "'centimeters', 'cmu', ... or 'unknown'")
      .def_property_readonly(
          "scale_to_meters",
          [](const PyBvhClip& p) { return p.info.at("scale_to_meters").get<double>(); },
          "metres per file unit, detected")
      .def_property_readonly("up_axis", text("up_axis"), "'y' or 'z'")
      .def_property_readonly(
          "first_motion_frame",
          [](const PyBvhClip& p) { return p.info.at("first_motion_frame").get<int>(); },
          "after leading frames that jump to the motion (a T-pose); 0 without")
      .def_property_readonly("standing_height_m", character("standing_height_m"),
                             "the joints' span standing, m")
      .def_property_readonly("leg_m", character("leg_m"), "m")
      .def_property_readonly("mean_speed_mps", character("mean_speed_mps"),
                             "the root's horizontal speed over 0.25 s windows, m/s")
      .def_property_readonly("peak_speed_mps", character("peak_speed_mps"), "m/s")
      .def_property_readonly("facing_deg", character("facing_deg"),
                             "heading at the first motion frame (heading_axes); NaN: unknown")
      .def_property_readonly("travel_deg", character("travel_deg"),
                             "heading of the root's travel; NaN: it does not travel")
      .def_property_readonly("heading_axes",
                             [](const PyBvhClip& p) {
                               return p.info.at("character").at("heading_axes").get<std::string>();
                             })
      .def_property_readonly(
          "warnings",
          [](const PyBvhClip& p) {
            return p.info.at("character").at("warnings").get<std::vector<std::string>>();
          },
          "one line per measure outside a person's range (the character's size, its speed)")
      .def_property_readonly(
          "info", [](const PyBvhClip& p) { return json_to_py(p.info); },
          "the dict `stance bvh info --json` prints (without the tracker's legs)");
}

void bind_bvh_clip(py::module_& m) {
  py::class_<PyBvhClip> c(m, "BvhClip", R"(A parsed BVH file (stance.read_bvh).

The skeleton (joints, joint_names), the channels (channel_names, one per column of frames), the
frame time, the motion as read (frames) and as rotations and translations per joint, and what
`stance bvh info` measures: units, scale_to_meters, up_axis, standing_height_m, speeds, headings
and warnings. Arrays are read-only float64.)");
  add_clip_arrays(c);
  add_clip_measures(c);
  c.def("__len__", [](const PyBvhClip& p) {
     return p.clip.frame_count;
   }).def("__repr__", [](const PyBvhClip& p) {
    return fmt::format("<stance.BvhClip {}: {} frames at {:.6g} s, {} joints>", p.clip.source,
                       p.clip.frame_count, p.clip.frame_time_s, p.clip.joint_count());
  });
  m.def("read_bvh", &read_clip, py::arg("path"),
        R"(Read and parse a BVH file (str or pathlib.Path) into a BvhClip. Bad input raises
stance.InputError with the file and line, as `stance bvh info` exits 2.)");
}

// ---- track

struct PyTrackResult {
  PyRunResult run;
  py::object tracked = py::none();  // BvhClip of tracked.bvh, or None
  py::object out = py::none();      // the folder kept, or None
};

// a fresh folder under the system's temporary folder, removed with its files when it goes
class TemporaryFolder {
 public:
  TemporaryFolder() {
    std::string pattern = (fs::temp_directory_path() / "stance-track-XXXXXX").string();
    if (!mkdtemp(pattern.data()))
      throw EnvironmentError(fmt::format("cannot make a temporary folder {}", pattern));
    path_ = pattern;
  }
  ~TemporaryFolder() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// the clip argument: a path, or a BvhClip (its file)
std::string clip_path(const py::object& clip) {
  if (py::isinstance<PyBvhClip>(clip)) return clip.cast<const PyBvhClip&>().clip.source;
  try {
    return clip.cast<PathArg>().string();
  } catch (const py::cast_error&) {
    throw py::type_error(
        fmt::format("track: clip is a {}: expected a path (str or pathlib.Path) "
                    "or a BvhClip",
                    py::str(clip.get_type().attr("__name__")).cast<std::string>()));
  }
}

PyTrackResult track_clip(const BvhTrackCommand& cmd, bool keep_out) {
  std::optional<TemporaryFolder> scratch;
  BvhTrackCommand c = cmd;
  if (!keep_out) c.out_dir = scratch.emplace().path().string();
  PyTrackResult result;
  std::unique_ptr<Simulation> sim;
  {
    py::gil_scoped_release release;
    sim = make_run_simulation(bvh_track_run(c, write_bvh_track_scenario(c)), &python_interrupt());
  }
  result.run = run_simulation(*sim, -1);
  const fs::path tracked = fs::path(c.out_dir) / "tracked.bvh";
  if (fs::exists(tracked)) result.tracked = py::cast(read_clip(tracked));
  if (keep_out) result.out = py::str(c.out_dir);
  return result;
}

// the clips argument: one path or BvhClip, or a list or tuple of them
std::vector<std::string> clip_inputs(const py::object& clips) {
  std::vector<std::string> inputs;
  if (py::isinstance<py::list>(clips) || py::isinstance<py::tuple>(clips))
    for (py::handle c : clips) inputs.push_back(clip_path(py::reinterpret_borrow<py::object>(c)));
  else
    inputs.push_back(clip_path(clips));
  return inputs;
}

py::object track(const py::object& clip, const std::optional<PathArg>& out,
                 std::optional<double> duration, bool loop, int first_frame, int last_frame,
                 const std::optional<PathArg>& map, const std::optional<PathArg>& model,
                 const std::string& engine, int threads, const py::object& overrides,
                 bool origin_centred, double scale_to_meters, int jobs, bool resume, bool plot) {
  const std::vector<std::string> inputs = clip_inputs(clip);
  BvhTrackCommand cmd;
  if (out) cmd.out_dir = out->string();
  cmd.duration = duration;
  cmd.loop = loop;
  cmd.first_frame = first_frame;
  cmd.last_frame = last_frame;
  if (map) cmd.map = map->string();
  // a model's name (mujoco://..., dart://...) is a path to the library's resolver too
  if (model) cmd.model = model->string();
  cmd.engine = engine;
  cmd.threads = threads;
  cmd.sets = override_list(overrides);
  cmd.quiet = true;
  cmd.origin_centred = origin_centred;
  cmd.scale_to_meters = scale_to_meters;
  if (inputs.size() != 1 || resume || is_batch(inputs)) {
    if (!out)
      throw InputError(
          "track: several clips (a list, a folder or a glob) need out, the folder "
          "for their results");
    return track_batch(cmd, inputs, {jobs, resume, plot});
  }
  cmd.bvh = inputs[0];
  return py::cast(track_clip(cmd, out.has_value()));
}

void bind_track_result(py::module_& m) {
  py::class_<PyTrackResult>(m, "TrackResult",
                            "a tracked clip: the run's result (summary.json's fields and the "
                            "log), the tracked motion and where the files are")
      .def_property_readonly("fell", [](const PyTrackResult& t) { return t.run.r.fell; })
      .def_property_readonly(
          "fall_time", [](const PyTrackResult& t) { return t.run.r.fall_time; }, "s, or None")
      .def_property_readonly("sim_time", [](const PyTrackResult& t) { return t.run.r.sim_time; })
      .def_property_readonly(
          "success",
          [](const PyTrackResult& t) {
            const nlohmann::json& m = t.run.r.metrics;
            return m.contains("mocap") && m["mocap"].value("success", false);
          },
          "PHC's success: no fall and the body near the clip throughout (metrics['mocap'])")
      .def_property_readonly(
          "g_mpjpe_m",
          [](const PyTrackResult& t) {
            const nlohmann::json& m = t.run.r.metrics;
            return m.contains("mocap")
                       ? m["mocap"].value("mean_body_position_error_m", std::nan(""))
                       : std::nan("");
          },
          "G-MPJPE: the mean body position error, m (metrics['mocap'])")
      .def_property_readonly(
          "metrics", [](const PyTrackResult& t) { return json_to_py(t.run.r.metrics); },
          "a dict: summary.json's metrics, with metrics['mocap'] the tracking's")
      .def_property_readonly(
          "summary", [](const PyTrackResult& t) { return json_to_py(t.run.r.to_json()); },
          "the dict summary.json holds")
      .def_property_readonly(
          "log", [](const PyTrackResult& t) { return t.run.log; },
          "dict of numpy arrays keyed by log.csv's columns (full precision)")
      .def_readonly("tracked", &PyTrackResult::tracked,
                    "the simulated motion on the clip's skeleton (tracked.bvh) as a BvhClip")
      .def_readonly("out", &PyTrackResult::out,
                    "the folder with track.yaml, summary.json, log.csv and tracked.bvh; None "
                    "when track() was given no out (the files were temporary)")
      .def("__repr__", [](const PyTrackResult& t) {
        return fmt::format("<stance.TrackResult {}: {:.3f} s, fell={}>", t.run.r.scenario,
                           t.run.r.sim_time, t.run.r.fell ? "True" : "False");
      });
}

}  // namespace

void bind_bvh(py::module_& m) {
  bind_bvh_joint(m);
  bind_bvh_clip(m);
  bind_track_result(m);
  bind_track_batch_result(m);
  m.def("track", &track, py::arg("clip"), py::arg("out") = py::none(), py::kw_only(),
        py::arg("duration") = std::nullopt, py::arg("loop") = false, py::arg("first_frame") = 0,
        py::arg("last_frame") = -1, py::arg("map") = py::none(), py::arg("model") = py::none(),
        py::arg("engine") = "mujoco", py::arg("threads") = 0, py::arg("overrides") = py::none(),
        py::arg("origin_centred") = false, py::arg("scale_to_meters") = 0.0, py::arg("jobs") = 0,
        py::arg("resume") = false, py::arg("plot") = true,
        R"(`stance bvh track CLIP --out OUT`: the clip (a path or a BvhClip) tracked in free mode
with the sampling planner, on a character built from the clip or, with model (and optionally a
joint map), on that model. The same files and metrics as the command; out=None keeps none of
the files (tracked.bvh is read back into the result first). Returns a TrackResult. The options
are the command's: duration (s; default the clip once), loop, first_frame (0: the first frame
of the motion), last_frame (-1: the last), map, model, engine, threads (planner rollouts, 0:
every core; results do not depend on it), overrides ({"controllers.0.kp": 300}: --set on the
generated scenario), origin_centred, scale_to_meters (m per file unit; 0: detected). Bad input
raises stance.InputError before anything is written; DivergenceError as the command's exit 3.
The GIL is released while C++ runs.

Many clips (a list, a folder or a glob, as the command takes them) make a batch into out: a
folder per clip, results.csv and results.md, and with plot results.png (gnuplot; a warning
without it); jobs clips at once (0: as many as threads), resume keeps out's finished clips.
Returns a TrackBatchResult: the results table (rows) and its summary. A clip that cannot be read
is a row with its error.)");
}

}  // namespace stance::python
