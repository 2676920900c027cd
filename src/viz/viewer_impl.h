// the viewer's private state and the helpers its files share (viewer.cc: construction, the
// frame and the queries; viewer_input.cc: keys and mouse; viewer_panels.cc: the imgui panels)
#pragma once

#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "control/controller.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "sim/live_tuning.h"
#include "sim/simulation.h"
#include "viz/param_panel.h"
#include "viz/recorder.h"
#include "viz/scene_view.h"
#include "viz/viewer.h"

namespace stance {

// a fixed-size ring of samples for ImGui::PlotLines (a member of Viewer::Impl)
struct RollingSeries {
  std::string name;
  std::vector<float> values;
  int head = 0;  // oldest sample
  void push(float v) {
    values[head] = v;
    head = (head + 1) % static_cast<int>(values.size());
  }
};

// shared by the viewer's files
using Clock = std::chrono::steady_clock;

inline constexpr double kPushSeconds = 0.1;   // how long a key push lasts (simulated)
inline constexpr double kPlotWindowS = 10.0;  // rolling plot window
inline constexpr double kPlotRateHz = 60.0;
inline constexpr double kHistoryRateHz = 60.0;  // recorded states per simulated second
inline constexpr int kHistoryLength = 3600;     // states kept: the last minute
// the mouse spring, as MuJoCo's simulate: stiffness per kg of the selected subtree (1/s^2),
// damped by its square root
inline constexpr double kDragStiffness = 100.0;

struct Viewer::Impl {
  LoadedScenario loaded;
  ViewerOptions options;
  GLFWwindow* window = nullptr;
  ImGuiContext* imgui = nullptr;  // one per viewer: several may be open (tests)
  std::unique_ptr<Simulation> run;
  std::unique_ptr<SceneView> view;

  // physics thread and what it shares (guarded by mutex)
  mutable std::mutex mutex;
  std::thread physics;
  std::atomic<bool> quit{false};
  bool paused = false;
  bool fall_reported = false;  // the status line told of this run's fall
  int single_steps = 0;
  double speed = 1.0;         // requested sim/wall factor
  double achieved_speed = 0;  // measured
  bool anchor_dirty = true;   // re-anchor sim time to wall time
  int push_body = 0;
  double push_newtons = 0;
  std::vector<RollingSeries> plots;  // com height, torques, then the controllers' signals
  int torque_plot = -1;              // index of the joint torque RMS plot; -1: none
  std::vector<int> joint_dofs;       // the non-root dofs, for the torque plot
  Eigen::VectorXd applied_tau;       // scratch: the engine's applied joint forces
  double next_sample = 0;
  std::vector<std::string> signal_names;
  std::vector<double> signal_values;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double ground = 0;

  // UI state
  std::vector<std::vector<ParamEntry>> entries;  // per controller
  std::vector<ParamEntry> planner_entries;       // the planner block's, when the run plans
  bool show_help = true;
  std::string status;
  std::vector<unsigned char> frame_rgb;
  int frame_w = 0, frame_h = 0;
  bool quick_look = false;           // no shadows, no multisampling (ViewerOptions::quick_look)
  double frame_period_s = 1.0 / 60;  // the display's refresh period, at least 1/60 s (1/30 quick)
  bool capture_png = false;          // the i key on a running window: save the next frame
  // mouse
  bool button_left = false, button_right = false;
  double last_x = 0, last_y = 0;
  double last_left_press = -1;  // glfwGetTime() of the last left press, for double-clicks
  int drag_plane = 0;           // 0: camera; 1: screen plane; 2: ground plane

  // the mouse perturbation (guarded by mutex)
  int selected = -1;                                         // running engine body
  Eigen::Vector3d selected_local = Eigen::Vector3d::Zero();  // pulled point, body frame
  bool dragging = false;
  Eigen::Vector3d drag_target = Eigen::Vector3d::Zero();  // world

  // recorded history (guarded by mutex)
  std::deque<EngineState> history;
  double next_snapshot = 0;
  int scrubbed = -1;        // history index shown while paused; -1: live
  double frame_target = 0;  // unthreaded frames step to this simulated time

  // the r key's video: frames at fixed simulated times (guarded by mutex)
  std::unique_ptr<VideoWriter> recording;
  int record_w = 0, record_h = 0;  // the window's size when it started, made even
  double record_next = 0;          // simulated time of the next frame
  std::vector<unsigned char> record_rgb;
  std::string last_capture;

  // <capture_dir>/<scenario>_<n><ext>, the first n not taken
  // the window's back buffer (rgb, top row first) into frame_rgb
  void keep_frame(int width, int height) {
    frame_w = width;
    frame_h = height;
    std::vector<unsigned char> bottom_up(static_cast<size_t>(width) * height * 3);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, bottom_up.data());
    frame_rgb.resize(bottom_up.size());
    const size_t row = static_cast<size_t>(width) * 3;
    for (int y = 0; y < height; ++y)
      std::copy_n(bottom_up.data() + (height - 1 - y) * row, row, frame_rgb.data() + y * row);
  }

  // the i key: the kept frame as <capture_dir>/<scenario>_<n>.png, said in the status line
  void save_png() {
    capture_png = false;
    if (frame_rgb.empty()) {
      status = "no frame drawn yet";
      return;
    }
    try {
      std::string path = next_capture_path(".png");
      write_png(path, frame_w, frame_h, frame_rgb.data());
      last_capture = path;
      status = fmt::format("wrote {} ({}x{}, t = {:.3f} s)", path, frame_w, frame_h,
                           run->engine().time());
    } catch (const std::exception& err) {
      status = err.what();
    }
    std::cout << status << std::endl;
  }

  std::string next_capture_path(const std::string& ext) const {
    std::filesystem::path dir(options.capture_dir.empty() ? "." : options.capture_dir);
    std::string stem = loaded.scenario.name.empty() ? "stance" : loaded.scenario.name;
    for (int n = 1;; ++n) {
      std::filesystem::path p = dir / fmt::format("{}_{:03d}{}", stem, n, ext);
      if (!std::filesystem::exists(p)) return p.string();
    }
  }

  void start_recording(int width, int height) {
    record_w = width - width % 2;
    record_h = height - height % 2;
    std::string path = next_capture_path(".mp4");
    recording = std::make_unique<VideoWriter>(path, record_w, record_h, options.record_fps);
    record_next = run->engine().time();
    last_capture = path;
    status = fmt::format("recording {} ({}x{}, r stops)", path, record_w, record_h);
    std::cout << status << std::endl;
  }

  void stop_recording() {
    if (!recording) return;
    std::unique_ptr<VideoWriter> done = std::move(recording);
    long frames = done->frames();
    try {
      done->close();
      status = fmt::format("wrote {}: {} frames, {:.3f} s of simulated time", done->path(), frames,
                           frames / options.record_fps);
    } catch (const std::exception& err) {
      status = err.what();
    }
    std::cout << status << std::endl;
  }

  // the shown frame (frame_rgb) into the video, cut to its even size
  void write_record_frame() {
    if (frame_w < record_w || frame_h < record_h) {
      status = "the window shrank: recording stopped";
      stop_recording();
      return;
    }
    record_rgb.resize(static_cast<size_t>(record_w) * record_h * 3);
    for (int y = 0; y < record_h; ++y)
      std::copy_n(frame_rgb.data() + static_cast<size_t>(y) * frame_w * 3, record_w * 3,
                  record_rgb.data() + static_cast<size_t>(y) * record_w * 3);
    recording->write(record_rgb.data());
  }

  // LQR rebuilds on worker threads, swapped in order (guarded by mutex)
  std::vector<std::unique_ptr<BackgroundRetune>> pending;

  Eigen::Vector3d selected_point(const Engine& e) const {
    BodyPose pose = e.body_pose(selected);
    return pose.pos + pose.quat * selected_local;
  }

  // the mouse spring into the run's state (the planner's rollouts feel it): from the selected
  // point to the target, damped by the point's velocity, scaled by the pulled subtree's mass
  void set_spring(const Engine& e) {
    ExternalForces::Spring& spring = run->external_forces().spring;
    if (!dragging || selected < 0) {
      spring.body = -1;
      return;
    }
    const double mass = std::max(view->subtree_mass(selected), e.body_mass(selected));
    spring.body = selected;
    for (int i = 0; i < 3; ++i) {
      spring.point_in_body[i] = selected_local[i];
      spring.target[i] = drag_target[i];
    }
    spring.stiffness = mass * kDragStiffness;
    spring.damping = mass * std::sqrt(kDragStiffness);
  }

  // a key push into the run's state, for kPushSeconds from now; finished ones are dropped
  void add_key_push(const Engine& e, const Eigen::Vector3d& force) {
    auto& pushes = run->external_forces().pushes;
    std::erase_if(pushes, [&](const ExternalForces::Push& p) { return p.until_s <= e.time(); });
    pushes.push_back({push_body, {force.x(), force.y(), force.z()}, e.time() + kPushSeconds});
  }

  void record_snapshot() {
    Engine& e = run->engine();
    history.emplace_back();
    e.save_state(history.back());
    while (static_cast<int>(history.size()) > kHistoryLength) history.pop_front();
  }

  // back to live running from a scrubbed state: later history goes, the run and its
  // controllers start afresh at the restored physics state
  void resume_from_scrub() {
    if (scrubbed < 0) return;
    history.erase(history.begin() + scrubbed + 1, history.end());
    EngineState state = history.back();
    run->reset();  // clears a divergence, a fall and the velocity servos
    fall_reported = false;
    Engine& e = run->engine();
    e.restore_state(state);
    e.forward();
    run->reset_controllers();
    next_snapshot = e.time() + 1.0 / kHistoryRateHz;
    frame_target = e.time();
    scrubbed = -1;
    anchor_dirty = true;
  }

  void replay() {
    run->reset();
    fall_reported = false;
    reset_plots();
    history.clear();
    record_snapshot();
    next_snapshot = 1.0 / kHistoryRateHz;
    frame_target = 0;
    scrubbed = -1;
    anchor_dirty = true;
  }

  // swap in the background rebuilds that are ready, in the order they were asked for
  void swap_ready() {
    bool swapped = false;
    while (!pending.empty() && pending.front()->ready()) {
      std::unique_ptr<BackgroundRetune> job = std::move(pending.front());
      pending.erase(pending.begin());
      try {
        job->swap_into(*run);
        status = fmt::format("{} = {:.4g} (swapped in)", job->path(), job->value());
      } catch (const std::exception& err) {
        status = err.what();
      }
      swapped = true;
    }
    if (swapped) refresh_entries();
  }

  // the panel's path: slow rebuilds go to a worker, the others rebuild at once
  void retune(int index, const std::string& path, double value) {
    auto& controllers = run->controllers();
    if (index < 0 || index >= static_cast<int>(controllers.size()))
      throw InputError(fmt::format("controller {} does not exist", index));
    const YAML::Node* base = nullptr;
    for (const auto& job : pending)
      if (job->index() == index) base = &job->params();
    if (base || rebuild_is_slow(*controllers[index])) {
      pending.push_back(std::make_unique<BackgroundRetune>(*run, loaded, index, path, value, base));
      status = fmt::format("{} = {:.4g}: rebuilding in the background", path, value);
      return;
    }
    retune_controller(*run, loaded, index, path, value);
    status = fmt::format("{} = {:.4g}", path, value);
    refresh_entries();
  }

  void refresh_entries() {
    entries.clear();
    for (auto& c : run->controllers()) entries.push_back(tunable_params(*c));
    planner_entries = planner_params(*run);
  }

  // one physics step; the key pushes and the mouse spring act through the run's state
  // (mutex held)
  void step_locked() {
    resume_from_scrub();
    if (!pending.empty()) swap_ready();
    Engine& e = run->engine();
    set_spring(e);
    if (!run->step()) {
      paused = true;
      status = "diverged: " + run->progress().divergence;
      return;
    }
    // a fall is reported once and the run goes on
    if (run->progress().fell && !fall_reported) {
      fall_reported = true;
      status = fmt::format("fell at t={:.3f} s: {}", run->progress().fall_time,
                           run->progress().fall_reason);
    }
    if (e.time() >= next_snapshot - 0.5 * e.timestep()) {
      record_snapshot();
      next_snapshot += 1.0 / kHistoryRateHz;
    }
    // rolling plots
    if (e.time() >= next_sample) {
      next_sample = e.time() + 1.0 / kPlotRateHz;
      if (torque_plot >= 0) {
        // the joint forces of the step just taken, before forward() recomputes them: what the
        // engine applied (tau, ctrl, servos; J^T of a push on a limb), else the controllers' tau
        applied_tau.resize(e.nv());
        const Eigen::VectorXd& taus =
            e.applied_joint_forces(applied_tau) ? applied_tau : run->last_output().tau;
        double sum = 0, largest = 0;
        for (int i : joint_dofs) {
          double tau = taus[i];
          sum += tau * tau;
          largest = std::max(largest, std::abs(tau));
        }
        plots[torque_plot].push(static_cast<float>(std::sqrt(sum / joint_dofs.size())));
        plots[torque_plot + 1].push(static_cast<float>(largest));
      }
      e.forward();
      plots[0].push(static_cast<float>(up.dot(e.com()) - ground));
      signal_values.clear();
      run->signals(signal_values);
      int first_signal = torque_plot >= 0 ? torque_plot + 2 : 1;
      for (size_t i = 0; first_signal + i < plots.size() && i < signal_values.size(); ++i)
        plots[first_signal + i].push(static_cast<float>(signal_values[i]));
    }
  }

  void physics_loop() {
    Clock::time_point wall0;
    double sim0 = 0;
    while (!quit) {
      bool behind = false;  // behind real time: a short rest, just for the window to draw
      {
        std::lock_guard<std::mutex> lock(mutex);
        Engine& e = run->engine();
        // the r key's recording steps the physics from the window's frames
        if (anchor_dirty || paused || recording) {
          wall0 = Clock::now();
          sim0 = e.time();
          anchor_dirty = false;
        }
        if (recording) {
          if (paused)
            for (; single_steps > 0; --single_steps) step_locked();
        } else if (paused) {
          for (; single_steps > 0; --single_steps) step_locked();
        } else {
          double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
          double target = sim0 + wall * speed;
          // never spend more than ~30 ms of wall time per batch: slower machines fall behind
          auto batch0 = Clock::now();
          while (e.time() < target && !paused &&
                 Clock::now() - batch0 < std::chrono::milliseconds(30))
            step_locked();
          behind = e.time() < target;
          if (wall > 0.25) {
            achieved_speed = (e.time() - sim0) / wall;
            // fell behind: re-anchor so that the factor shown is what is achieved
            if (target - e.time() > 0.1) anchor_dirty = true;
            if (wall > 2.0) anchor_dirty = true;
          }
        }
      }
      std::this_thread::sleep_for(behind ? std::chrono::microseconds(200)
                                         : std::chrono::microseconds(2000));
    }
  }

  // at most the display's rate; while the physics cannot keep pace, the window takes at most a
  // quarter of the wall time (software rendering would otherwise starve the planner's threads)
  void rest_after_frame(double frame_s) const {
    double rest = frame_period_s - frame_s;
    bool behind;
    {
      std::lock_guard<std::mutex> lock(mutex);
      behind = !pace_warning().empty();
    }
    // (a frame that waited for a long plan to release the state is no drawing cost: at most
    // 0.2 s of rest, so that the window keeps showing the run)
    if (behind) rest = std::max(rest, std::min(3 * frame_s, 0.2));
    if (rest > 0) std::this_thread::sleep_for(std::chrono::duration<double>(rest));
  }

  // said on the picture when the physics cannot keep the requested pace (compute is slower than
  // real time), so that a slow run is never mistaken for the motion's own speed
  std::string pace_warning() const {
    if (!options.threaded || paused || recording || achieved_speed <= 0) return "";
    if (achieved_speed >= 0.9 * speed) return "";
    return fmt::format("{:.2f}x real time (compute-bound)", achieved_speed);
  }

  void reset_plots() {
    for (auto& p : plots) std::fill(p.values.begin(), p.values.end(), 0.0f);
    next_sample = 0;
  }

  // the window's key, mouse button, cursor and wheel callbacks (viewer_input.cc)
  void install_input_callbacks();

  void draw_panels();
  // the state, history, perturbation and plots; the parameter panel; the key reference
  void draw_state_panel(float panel_w);
  void draw_param_panel(float panel_w);
  void draw_help();
  // one group of the parameter panel, its entries and its subgroups as tree nodes
  void draw_param_group(const ParamGroup& group, std::vector<ParamEntry>& list, int depth,
                        const std::function<void(const std::string&, double)>& changed);
  char param_filter[128] = "";

  // waits for the background rebuilds and swaps them in
  void finish_pending() {
    for (auto& job : pending) job->wait();
    swap_ready();
  }

  // the scenario with the running controllers' parameters; default path <stem>_tuned.yaml
  std::string write_tuned(const std::string& path) {
    finish_pending();
    YAML::Node doc = tuned_scenario_yaml(*run, loaded);
    std::string out = path;
    if (out.empty()) {
      std::filesystem::path p(options.save_path.empty() ? loaded.scenario.name + ".yaml"
                                                        : options.save_path);
      out = (p.parent_path() / (p.stem().string() + "_tuned.yaml")).string();
    }
    std::ostringstream text;
    text << doc << "\n";
    write_file_atomically(out, text.str());
    return out;
  }
};

}  // namespace stance
