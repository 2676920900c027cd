#include "viz/viewer.h"

#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
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
#include "engine/mujoco/mujoco_engine.h"
#include "scenario/live_tuning.h"
#include "scenario/simulation.h"
#include "viz/param_panel.h"
#include "viz/recorder.h"
#include "viz/scene_view.h"

namespace stance {

// a fixed-size ring of samples for ImGui::PlotLines (outside the unnamed namespace: a member
// of Viewer::Impl)
struct RollingSeries {
  std::string name;
  std::vector<float> values;
  int head = 0;  // oldest sample
  void push(float v) {
    values[head] = v;
    head = (head + 1) % static_cast<int>(values.size());
  }
};

namespace {
using Clock = std::chrono::steady_clock;

constexpr double kPushSeconds = 0.1;   // how long a key push lasts (simulated)
constexpr double kPlotWindowS = 10.0;  // rolling plot window
constexpr double kPlotRateHz = 60.0;
constexpr double kHistoryRateHz = 60.0;  // recorded states per simulated second
constexpr int kHistoryLength = 3600;     // states kept: the last minute
// the mouse spring, as MuJoCo's simulate: stiffness per kg of the selected subtree (1/s^2),
// damped by its square root
constexpr double kDragStiffness = 100.0;
constexpr double kDoubleClickS = 0.3;

const char* kHelpText =
    "space   pause / run\n"
    "n       single step (while paused)\n"
    "p       replay from the start\n"
    "r       record an MP4 of the window / stop\n"
    "i       save a PNG of the window\n"
    ", .     push back / forth on the push body\n"
    "a s     skateboard speed down / up\n"
    "- =     slower / faster than real time\n"
    "f       camera: follow the root / free\n"
    "c       contact points and forces\n"
    "m       COM and support markers\n"
    "k       controller markers (SIMBICON circles)\n"
    "g       tracking ghost (reference pose)\n"
    "h       this help\n"
    "Esc     quit\n"
    "mouse   left drag: rotate, right drag: pan, wheel: zoom\n"
    "        double-click: select a body (empty space: release)\n"
    "        ctrl+right drag: pull it in the screen plane\n"
    "        ctrl+left drag: pull it along the ground\n"
    "paused  the history slider scrubs; space runs on from there";
}  // namespace

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
    for (auto& c : run->controllers()) entries.push_back(c->tunable_params());
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
        // the joint forces of the step just taken, before forward() recomputes them. MuJoCo:
        // smooth force less bias and passive forces is what was applied (tau, ctrl, servos;
        // also J^T of a push on a limb). Other engines: the controllers' tau.
        const mjData* d =
            e.engine_name() == "mujoco" ? static_cast<MujocoEngine&>(e).data() : nullptr;
        const Eigen::VectorXd& commanded = run->last_output().tau;
        double sum = 0, largest = 0;
        for (int i : joint_dofs) {
          double tau = d ? d->qfrc_smooth[i] + d->qfrc_bias[i] - d->qfrc_passive[i] : commanded[i];
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
          if (wall > 0.25) {
            achieved_speed = (e.time() - sim0) / wall;
            // fell behind: re-anchor so that the factor shown is what is achieved
            if (target - e.time() > 0.1) anchor_dirty = true;
            if (wall > 2.0) anchor_dirty = true;
          }
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }

  // at most 60 frames a second; while the physics cannot keep pace, the window takes at most a
  // quarter of the wall time (software rendering would otherwise starve the planner's threads)
  void rest_after_frame(double frame_s) const {
    double rest = 1.0 / 60 - frame_s;
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

  void draw_panels();
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

Viewer::Viewer(const LoadedScenario& loaded, const ViewerOptions& options)
    : Viewer(loaded, options, nullptr) {}

Viewer::Viewer(const LoadedScenario& loaded, const ViewerOptions& options,
               std::unique_ptr<Simulation> run)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.loaded = loaded;
  s.options = options;
  RunOptions ro;
  ro.engine = options.engine;
  ro.quiet = true;
  // the viewer runs until closed: the scenario's duration does not stop it
  s.run = run ? std::move(run) : std::make_unique<Simulation>(loaded, ro);

  if (!glfwInit()) throw EnvironmentError("cannot initialise GLFW (no display? try xvfb-run)");
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_SAMPLES, 4);
  s.window =
      glfwCreateWindow(options.width, options.height,
                       fmt::format("stance: {}", loaded.scenario.name).c_str(), nullptr, nullptr);
  if (!s.window) throw EnvironmentError("cannot open a window (no display? try xvfb-run)");
  glfwMakeContextCurrent(s.window);
  glfwSwapInterval(options.threaded ? 1 : 0);
  s.view = std::make_unique<SceneView>(*s.run, 640, 480, options.scene_look);

  Engine& e = s.run->engine();
  Eigen::Vector3d g = e.gravity();
  if (g.norm() > 0) s.up = -g.normalized();
  s.ground = s.run->scenario().fall.ground_height;
  // the push body: the scenario's first perturbation's, else the root
  const auto& perts = s.run->scenario().perturbations;
  s.push_body = perts.empty() ? 0 : std::max(0, e.body_index(perts.front().body));
  s.push_newtons = perts.empty() ? 0.3 * e.total_mass() * g.norm() : perts.front().force.norm();
  if (s.push_newtons <= 0) s.push_newtons = 0.3 * e.total_mass() * g.norm();

  int samples = static_cast<int>(kPlotWindowS * kPlotRateHz);
  s.plots.push_back({"COM height (m)", std::vector<float>(samples, 0.0f)});
  // joint torques: MuJoCo's applied and actuator forces, else the controllers' output
  for (int i = 0; i < e.nv(); ++i)
    if (!e.dof_is_root(i)) s.joint_dofs.push_back(i);
  if (!s.joint_dofs.empty()) {
    s.torque_plot = static_cast<int>(s.plots.size());
    s.plots.push_back({"joint torque RMS (N m)", std::vector<float>(samples, 0.0f)});
    s.plots.push_back({"largest joint torque (N m)", std::vector<float>(samples, 0.0f)});
  }
  for (auto& c : s.run->controllers()) c->signal_names(s.signal_names);
  for (size_t i = 0; i < s.signal_names.size() && i < 8; ++i)
    s.plots.push_back({s.signal_names[i], std::vector<float>(samples, 0.0f)});
  s.refresh_entries();
  s.record_snapshot();
  s.next_snapshot = e.time() + 1.0 / kHistoryRateHz;
  s.frame_target = e.time();
  // the key reference opens by itself when there is room for it
  s.show_help = options.height >= 800;

  // our callbacks first: imgui chains to them
  glfwSetWindowUserPointer(s.window, this);
  glfwSetKeyCallback(s.window, [](GLFWwindow* w, int key, int, int action, int) {
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    if (ImGui::GetCurrentContext() && ImGui::GetIO().WantCaptureKeyboard) return;
    static_cast<Viewer*>(glfwGetWindowUserPointer(w))->key(key);
  });
  glfwSetMouseButtonCallback(s.window, [](GLFWwindow* w, int button, int action, int mods) {
    Viewer& viewer = *static_cast<Viewer*>(glfwGetWindowUserPointer(w));
    Impl& s = *viewer.impl_;
    bool down = action == GLFW_PRESS && !ImGui::GetIO().WantCaptureMouse;
    if (button == GLFW_MOUSE_BUTTON_LEFT) s.button_left = down;
    if (button == GLFW_MOUSE_BUTTON_RIGHT) s.button_right = down;
    glfwGetCursorPos(w, &s.last_x, &s.last_y);
    if (!down) {
      // letting go of the button ends the pull; the selection stays
      if (s.drag_plane != 0) viewer.release();
      s.drag_plane = 0;
      return;
    }
    if (button == GLFW_MOUSE_BUTTON_LEFT) {
      double now = glfwGetTime();
      bool double_click = now - s.last_left_press < kDoubleClickS;
      s.last_left_press = double_click ? -1 : now;
      if (double_click) {
        viewer.select_at(s.last_x, s.last_y);
        return;
      }
    }
    if ((mods & GLFW_MOD_CONTROL) && viewer.selected_body() >= 0) {
      // the pull starts at the selected point
      std::lock_guard<std::mutex> lock(s.mutex);
      s.drag_plane = button == GLFW_MOUSE_BUTTON_RIGHT ? 1 : 2;
      s.run->engine().forward();
      s.drag_target = s.selected_point(s.run->engine());
      s.dragging = true;
    }
  });
  glfwSetCursorPosCallback(s.window, [](GLFWwindow* w, double x, double y) {
    Impl& s = *static_cast<Viewer*>(glfwGetWindowUserPointer(w))->impl_;
    double dx = x - s.last_x, dy = y - s.last_y;
    s.last_x = x;
    s.last_y = y;
    if (!s.button_left && !s.button_right) return;
    int width = 1, height = 1;
    glfwGetWindowSize(w, &width, &height);
    if (s.drag_plane != 0) {
      std::lock_guard<std::mutex> lock(s.mutex);
      s.drag_target +=
          s.view->mouse_motion_in_world(dx, dy, height, s.drag_target, s.drag_plane == 2);
      return;
    }
    int action = s.button_right ? mjMOUSE_MOVE_H : mjMOUSE_ROTATE_H;
    // panning moves the look-at point: that is the free camera
    if (s.button_right) s.view->options.camera = CameraMode::kFree;
    mjv_moveCamera(s.view->draw_model(), action, dx / height, dy / height, &s.view->scene(),
                   &s.view->camera());
  });
  glfwSetScrollCallback(s.window, [](GLFWwindow* w, double, double dy) {
    Impl& s = *static_cast<Viewer*>(glfwGetWindowUserPointer(w))->impl_;
    if (ImGui::GetIO().WantCaptureMouse) return;
    mjv_moveCamera(s.view->draw_model(), mjMOUSE_ZOOM, 0, -0.05 * dy, &s.view->scene(),
                   &s.view->camera());
  });

  IMGUI_CHECKVERSION();
  s.imgui = ImGui::CreateContext();
  ImGui::SetCurrentContext(s.imgui);
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the working folder
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(s.window, true);
  ImGui_ImplOpenGL3_Init("#version 130");

  if (options.threaded) s.physics = std::thread([this] { impl_->physics_loop(); });
}

Viewer::~Viewer() {
  Impl& s = *impl_;
  s.quit = true;
  if (s.physics.joinable()) s.physics.join();
  s.stop_recording();
  glfwMakeContextCurrent(s.window);
  ImGui::SetCurrentContext(s.imgui);
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext(s.imgui);
  s.view.reset();  // frees GL objects while the context exists
  if (s.window) glfwDestroyWindow(s.window);
}

void Viewer::run() {
  const auto start = Clock::now();
  const double quit_after_s = impl_->options.quit_after_s;
  while (!glfwWindowShouldClose(impl_->window)) {
    const auto frame_start = Clock::now();
    frame();
    if (quit_after_s > 0 &&
        std::chrono::duration<double>(Clock::now() - start).count() >= quit_after_s)
      break;
    impl_->rest_after_frame(std::chrono::duration<double>(Clock::now() - frame_start).count());
  }
}

void Viewer::key(int k) {
  Impl& s = *impl_;
  std::lock_guard<std::mutex> lock(s.mutex);
  Engine& e = s.run->engine();
  switch (k) {
    case GLFW_KEY_SPACE:
      s.paused = !s.paused;
      if (!s.paused) s.resume_from_scrub();
      s.anchor_dirty = true;
      break;
    case GLFW_KEY_N:
      if (!s.paused) s.paused = true;
      if (s.options.threaded)
        ++s.single_steps;
      else
        s.step_locked();
      break;
    case GLFW_KEY_P:
      s.replay();
      s.status = "replay from the start";
      break;
    case GLFW_KEY_R:
      try {
        if (s.recording) {
          s.stop_recording();
        } else {
          int width = 0, height = 0;
          glfwGetFramebufferSize(s.window, &width, &height);
          s.start_recording(width, height);
        }
      } catch (const std::exception& err) {
        s.recording.reset();
        s.status = err.what();
        std::cout << s.status << std::endl;
      }
      break;
    case GLFW_KEY_I:
      if (s.frame_rgb.empty()) {
        s.status = "no frame drawn yet";
        break;
      }
      try {
        std::string path = s.next_capture_path(".png");
        write_png(path, s.frame_w, s.frame_h, s.frame_rgb.data());
        s.last_capture = path;
        s.status =
            fmt::format("wrote {} ({}x{}, t = {:.3f} s)", path, s.frame_w, s.frame_h, e.time());
      } catch (const std::exception& err) {
        s.status = err.what();
      }
      std::cout << s.status << std::endl;
      break;
    case GLFW_KEY_COMMA:
    case GLFW_KEY_PERIOD: {
      // back (-x) or forth (+x) in the view's horizontal frame
      Eigen::Vector3d forth = Eigen::Vector3d::UnitX() - s.up.dot(Eigen::Vector3d::UnitX()) * s.up;
      if (forth.norm() < 1e-6) forth = Eigen::Vector3d::UnitY();
      forth.normalize();
      double sign = k == GLFW_KEY_PERIOD ? 1.0 : -1.0;
      s.add_key_push(e, sign * s.push_newtons * forth);
      s.status = fmt::format("push {:.0f} N {} on {}", s.push_newtons, sign > 0 ? "forth" : "back",
                             e.body_name(s.push_body));
      break;
    }
    case GLFW_KEY_A:
    case GLFW_KEY_S: {
      // the skateboard speed: the first parameter named "speed" (or "..._speed"), changed by
      // its "<name>_step" sibling when there is one (the seed's speed increment), else 0.1
      double sign = k == GLFW_KEY_S ? 1.0 : -1.0;
      auto ends_with = [](const std::string& a, const std::string& b) {
        return a.size() >= b.size() && a.compare(a.size() - b.size(), b.size(), b) == 0;
      };
      for (size_t i = 0; i < s.entries.size(); ++i)
        for (const auto& entry : s.entries[i]) {
          if (entry.path != "speed" && !ends_with(entry.path, "_speed") &&
              !ends_with(entry.path, ".speed"))
            continue;
          double step = 0.1;
          for (const auto& other : s.entries[i])
            if (other.path == entry.path + "_step" && other.value > 0) step = other.value;
          double value = entry.value + sign * step;
          std::string path = entry.path;
          try {
            s.retune(static_cast<int>(i), path, value);
          } catch (const std::exception& err) {
            s.status = err.what();
          }
          return;
        }
      s.status = "this scenario has no speed parameter";
      break;
    }
    case GLFW_KEY_MINUS:
      s.speed = std::max(1.0 / 64, s.speed / 2);
      s.anchor_dirty = true;
      break;
    case GLFW_KEY_EQUAL:
      s.speed = std::min(16.0, s.speed * 2);
      s.anchor_dirty = true;
      break;
    case GLFW_KEY_F:
      s.view->options.camera =
          s.view->options.camera == CameraMode::kFollow ? CameraMode::kFree : CameraMode::kFollow;
      break;
    case GLFW_KEY_C:
      s.view->options.contacts = !s.view->options.contacts;
      break;
    case GLFW_KEY_M:
      s.view->options.com = !s.view->options.com;
      break;
    case GLFW_KEY_K:
      s.view->options.markers = !s.view->options.markers;
      break;
    case GLFW_KEY_G:
      s.view->options.ghost = !s.view->options.ghost;
      break;
    case GLFW_KEY_H:
      s.show_help = !s.show_help;
      break;
    case GLFW_KEY_ESCAPE:
      glfwSetWindowShouldClose(s.window, GLFW_TRUE);
      break;
    default:
      break;
  }
}

void Viewer::Impl::draw_param_group(
    const ParamGroup& group, std::vector<ParamEntry>& list, int depth,
    const std::function<void(const std::string&, double)>& changed) {
  for (int index : group.entries) {
    ParamEntry& entry = list[index];
    std::string label = fmt::format("{}##{}", param_label(entry), entry.path);
    if (entry.kind == ParamEntry::Kind::kBool) {
      bool b = entry.value != 0;
      if (ImGui::Checkbox(label.c_str(), &b)) changed(entry.path, b ? 1 : 0);
    } else {
      double v = entry.value;
      bool bounded = std::isfinite(entry.meta.min) && std::isfinite(entry.meta.max);
      double lo = std::isfinite(entry.meta.min) ? entry.meta.min : -1e9;
      double hi = std::isfinite(entry.meta.max) ? entry.meta.max : 1e9;
      // unbounded or wide ranges: drag around the value; narrow ones: a slider
      if (bounded && hi - lo <= 100) {
        ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &v, &lo, &hi, "%.4g");
      } else {
        float speed = static_cast<float>(std::max(1e-3, 0.01 * std::abs(v)));
        ImGui::DragScalar(label.c_str(), ImGuiDataType_Double, &v, speed, &lo, &hi, "%.4g");
      }
      if (v != entry.value) entry.value = v;  // shown while dragging
      if (ImGui::IsItemDeactivatedAfterEdit()) changed(entry.path, v);
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", param_tooltip(entry).c_str());
  }
  bool filtering = param_filter[0] != 0;
  for (const auto& sub : group.groups) {
    // the controller's own structs open; the lists' elements (FSM states) start closed
    bool element = sub.name.find(' ') != std::string::npos;
    if (filtering) ImGui::SetNextItemOpen(true);
    ImGuiTreeNodeFlags flags = element || depth > 1 ? 0 : ImGuiTreeNodeFlags_DefaultOpen;
    if (ImGui::TreeNodeEx(sub.name.c_str(), flags)) {
      draw_param_group(sub, list, depth + 1, changed);
      ImGui::TreePop();
    }
  }
}

void Viewer::Impl::draw_panels() {
  Engine& e = run->engine();
  // panels take at most 30% of the width each, so that the character stays in view
  float panel_w = std::min(360.0f, 0.3f * options.width);
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(panel_w, 0.6f * options.height), ImGuiCond_FirstUseEver);
  ImGui::Begin("stance");
  ImGui::Text("%s on %s", loaded.scenario.name.c_str(), std::string(e.engine_name()).c_str());
  ImGui::Text("t = %.3f s  %s", e.time(), paused ? "(paused)" : "");
  ImGui::Text("speed x%.3g requested, x%.2f achieved", speed, achieved_speed);
  float sp = static_cast<float>(speed);
  if (ImGui::SliderFloat("speed", &sp, 1.0f / 64, 16.0f, "x%.3f", ImGuiSliderFlags_Logarithmic)) {
    speed = sp;
    anchor_dirty = true;
  }
  if (ImGui::Button(paused ? "run" : "pause")) {
    paused = !paused;
    if (!paused) resume_from_scrub();
    anchor_dirty = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("step")) {
    paused = true;
    step_locked();
  }
  ImGui::SameLine();
  if (ImGui::Button("replay")) replay();
  ImGui::SameLine();
  if (ImGui::Button("save scenario")) {
    try {
      status = "wrote " + write_tuned("");
    } catch (const std::exception& err) {
      status = err.what();
    }
  }
  bool follow = view->options.camera == CameraMode::kFollow;
  if (ImGui::Checkbox("follow", &follow))
    view->options.camera = follow ? CameraMode::kFollow : CameraMode::kFree;
  ImGui::SameLine();
  ImGui::Checkbox("contacts", &view->options.contacts);
  ImGui::SameLine();
  ImGui::Checkbox("COM", &view->options.com);
  ImGui::SameLine();
  ImGui::Checkbox("help", &show_help);
  ImGui::Checkbox("markers", &view->options.markers);
  ImGui::SameLine();
  ImGui::Checkbox("ghost", &view->options.ghost);
  if (selected >= 0) {
    ImGui::SameLine();
    ImGui::Text("selected: %s", e.body_name(selected).c_str());
  }
  // the timeline: while paused, any recorded state
  if (paused && history.size() > 1) {
    int n = static_cast<int>(history.size());
    int shown = scrubbed >= 0 ? scrubbed : n - 1;
    std::string label = fmt::format("t = {:.3f} s", history[shown].time);
    if (ImGui::SliderInt("history", &shown, 0, n - 1, label.c_str())) {
      e.restore_state(history[shown]);
      e.forward();
      scrubbed = shown;
    }
  }
  if (!pending.empty())
    ImGui::Text("rebuilding %d controller(s) in the background", int(pending.size()));
  if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());

  // live plots over the rolling window
  if (ImGui::CollapsingHeader("plots", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (const auto& p : plots) {
      float last = p.values[(p.head + p.values.size() - 1) % p.values.size()];
      std::string label = fmt::format("{}\n{:.3g}", p.name, last);
      ImGui::PlotLines(fmt::format("##{}", p.name).c_str(), p.values.data(),
                       static_cast<int>(p.values.size()), p.head, label.c_str(), FLT_MAX, FLT_MAX,
                       ImVec2(panel_w - 30, 45));
    }
  }
  ImGui::End();

  // parameters, generated from the controllers' visits: grouped by controller and by their
  // structs (FSM states collapse), labelled from the visit, full path and help on hover
  // wide enough for the longest label (at the deepest indent) and a 120 px field
  float label_w = 0;
  for (const auto& list : entries)
    for (const auto& entry : list)
      label_w = std::max(label_w, ImGui::CalcTextSize(param_label(entry).c_str()).x);
  for (const auto& entry : planner_entries)
    label_w = std::max(label_w, ImGui::CalcTextSize(param_label(entry).c_str()).x);
  label_w += 4 * ImGui::GetStyle().IndentSpacing;
  float params_w = std::clamp(label_w + 150.0f, panel_w, 0.45f * options.width);
  ImGui::SetNextWindowPos(ImVec2(options.width - params_w - 10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(params_w, 0.7f * options.height), ImGuiCond_FirstUseEver);
  ImGui::Begin("parameters");
  ImGui::SetNextItemWidth(-1);
  ImGui::InputTextWithHint("##filter", "filter (name, unit, help)", param_filter,
                           sizeof(param_filter));
  // the value fields take what the labels leave: labels are short now
  ImGui::PushItemWidth(-std::min(label_w, ImGui::GetWindowWidth() - 120.0f));
  int changed_controller = -1;
  std::string changed_path;
  double changed_value = 0;
  bool filtering = param_filter[0] != 0;
  for (size_t i = 0; i < entries.size(); ++i) {
    ParamGroup tree = build_param_tree(entries[i], param_filter);
    if (filtering && tree.size() == 0) continue;
    std::string header = fmt::format("{} [{}]", run->controllers()[i]->type(), i);
    if (filtering) ImGui::SetNextItemOpen(true);
    if (!ImGui::CollapsingHeader(header.c_str(), ImGuiTreeNodeFlags_DefaultOpen)) continue;
    ImGui::PushID(static_cast<int>(i));
    draw_param_group(tree, entries[i], 0, [&](const std::string& path, double value) {
      changed_controller = static_cast<int>(i);
      changed_path = path;
      changed_value = value;
    });
    ImGui::PopID();
  }
  // the planner block, when the run plans: its edits take effect at the next step
  constexpr int kPlanner = -2;
  ParamGroup planner_tree = build_param_tree(planner_entries, param_filter);
  if (!planner_entries.empty() && !(filtering && planner_tree.size() == 0)) {
    if (filtering) ImGui::SetNextItemOpen(true);
    if (ImGui::CollapsingHeader("planner", ImGuiTreeNodeFlags_DefaultOpen)) {
      ImGui::PushID(kPlanner);
      draw_param_group(planner_tree, planner_entries, 0,
                       [&](const std::string& path, double value) {
                         changed_controller = kPlanner;
                         changed_path = path;
                         changed_value = value;
                       });
      ImGui::PopID();
    }
  }
  ImGui::PopItemWidth();
  ImGui::End();
  if (changed_controller != -1) {
    try {
      if (changed_controller == kPlanner) {
        retune_planner(*run, changed_path, changed_value);
        status = fmt::format("planner.{} = {:.4g}", changed_path, changed_value);
        refresh_entries();
      } else {
        retune(changed_controller, changed_path, changed_value);
      }
    } catch (const std::exception& err) {
      status = err.what();
      refresh_entries();
    }
  }

  if (show_help) {
    // at the bottom left, tall enough for every line
    int lines =
        1 + static_cast<int>(std::count(kHelpText, kHelpText + std::strlen(kHelpText), '\n'));
    float help_h = lines * ImGui::GetTextLineHeight() + 35.0f;
    ImGui::SetNextWindowPos(ImVec2(10, options.height - help_h), ImGuiCond_FirstUseEver);
    ImGui::Begin("keys", &show_help, ImGuiWindowFlags_AlwaysAutoResize);
    ImGui::TextUnformatted(kHelpText);
    ImGui::End();
  }
}

void Viewer::frame() {
  Impl& s = *impl_;
  glfwMakeContextCurrent(s.window);
  ImGui::SetCurrentContext(s.imgui);
  glfwPollEvents();
  int width = 0, height = 0;
  glfwGetFramebufferSize(s.window, &width, &height);
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  bool record_frame = false;
  std::string overlay;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (!s.pending.empty()) s.swap_ready();
    overlay = s.pace_warning();
    if (s.recording && !s.paused) {
      // a fixed step of simulated time per recorded frame, whatever the wall-clock pace
      Engine& e = s.run->engine();
      // on the grid t0 + k / fps (steps taken meanwhile, e.g. single steps, move it on)
      s.record_next += 1.0 / s.options.record_fps;
      if (s.record_next < e.time()) s.record_next = e.time() + 1.0 / s.options.record_fps;
      while (e.time() < s.record_next - 0.5 * e.timestep() && !s.paused) s.step_locked();
      record_frame = true;
    } else if (!s.options.threaded && !s.paused) {
      // reproducible: a fixed amount of simulated time per frame
      Engine& e = s.run->engine();
      // on the history's grid of times, unless single steps went past it
      if (s.frame_target < e.time() - e.timestep()) s.frame_target = e.time();
      s.frame_target += s.options.frame_dt * s.speed;
      while (e.time() < s.frame_target - 0.5 * e.timestep() && !s.paused) s.step_locked();
      s.achieved_speed = s.speed;
    }
    std::vector<ForceArrow> arrows;
    std::vector<Marker> markers;
    Engine& e = s.run->engine();
    for (const auto& p : s.run->external_forces().pushes)
      if (e.time() < p.until_s)
        arrows.push_back({e.body_com(p.body), Eigen::Vector3d(p.force.data())});
    if (s.selected >= 0) {
      // the selected point, and the pull as an arrow to the target
      e.forward();
      Eigen::Vector3d p = s.selected_point(e);
      Marker sel;
      sel.pos = p;
      sel.radius = 0.03;
      sel.rgba = {1.0f, 0.5f, 0.0f, 1.0f};
      sel.label = e.body_name(s.selected);
      markers.push_back(sel);
      if (s.dragging) {
        Marker pull;
        pull.shape = Marker::Shape::kArrow;
        pull.pos = p;
        pull.end = s.drag_target;
        pull.radius = 0.02;
        pull.rgba = {1.0f, 0.5f, 0.0f, 1.0f};
        markers.push_back(pull);
        Marker target = sel;
        target.pos = s.drag_target;
        target.radius = 0.02;
        target.label.clear();
        markers.push_back(target);
      }
    }
    s.view->update(*s.run, arrows, markers);
    s.draw_panels();
  }
  ImGui::Render();
  s.view->render_window(width, height, overlay);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  // keep what is shown, for screenshots
  s.frame_w = width;
  s.frame_h = height;
  std::vector<unsigned char> bottom_up(static_cast<size_t>(width) * height * 3);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, bottom_up.data());
  s.frame_rgb.resize(bottom_up.size());
  size_t row = static_cast<size_t>(width) * 3;
  for (int y = 0; y < height; ++y)
    std::copy_n(bottom_up.data() + (height - 1 - y) * row, row, s.frame_rgb.data() + y * row);
  if (record_frame) {
    std::lock_guard<std::mutex> lock(s.mutex);
    try {
      if (s.recording) s.write_record_frame();
    } catch (const std::exception& err) {
      s.recording.reset();
      s.status = err.what();
    }
  }
  glfwSwapBuffers(s.window);
}

bool Viewer::recording() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->recording != nullptr;
}

const std::string& Viewer::last_capture() const {
  return impl_->last_capture;
}

bool Viewer::screenshot(const std::string& png_path) const {
  if (impl_->frame_rgb.empty()) return false;
  write_png(png_path, impl_->frame_w, impl_->frame_h, impl_->frame_rgb.data());
  return true;
}

const std::vector<unsigned char>& Viewer::last_frame(int& width, int& height) const {
  width = impl_->frame_w;
  height = impl_->frame_h;
  return impl_->frame_rgb;
}

void Viewer::set_param(int index, const std::string& path, double value) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->retune(index, path, value);
}

const std::vector<std::vector<ParamEntry>>& Viewer::param_panel() const {
  return impl_->entries;
}

const std::vector<ParamEntry>& Viewer::planner_panel() const {
  return impl_->planner_entries;
}

void Viewer::set_planner_param(const std::string& path, double value) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  retune_planner(*impl_->run, path, value);
  impl_->refresh_entries();
}

std::string Viewer::save_scenario(const std::string& path) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->write_tuned(path);
}

double Viewer::sim_time() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->run->engine().time();
}
bool Viewer::paused() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->paused;
}
double Viewer::speed_factor() const {
  return impl_->speed;
}
bool Viewer::follow_camera() const {
  return impl_->view->options.camera == CameraMode::kFollow;
}
double Viewer::com_height() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->run->engine().forward();
  return impl_->up.dot(impl_->run->engine().com()) - impl_->ground;
}
double Viewer::param_value(int index, const std::string& path) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  for (const auto& e : impl_->entries.at(index))
    if (e.path == path) return e.value;
  return std::nan("");
}
Eigen::Vector3d Viewer::com_velocity() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->run->engine().forward();
  return impl_->run->engine().com_velocity();
}
const std::string& Viewer::status() const {
  return impl_->status;
}
double Viewer::plot_value(const std::string& name) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  for (const auto& p : impl_->plots)
    if (p.name == name) return p.values[(p.head + p.values.size() - 1) % p.values.size()];
  return std::nan("");
}
Eigen::Vector3d Viewer::com() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->run->engine().forward();
  return impl_->run->engine().com();
}
Eigen::Vector3d Viewer::body_position(const std::string& name) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Engine& e = impl_->run->engine();
  int b = e.require_body(name);
  e.forward();
  return e.body_pose(b).pos;
}

bool Viewer::select_body(const std::string& name) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Impl& s = *impl_;
  Engine& e = s.run->engine();
  int b = e.body_index(name);
  if (b < 0) return false;
  e.forward();
  BodyPose pose = e.body_pose(b);
  s.selected = b;
  s.selected_local = pose.quat.conjugate() * (e.body_com(b) - pose.pos);
  s.dragging = false;
  s.status = "selected " + name;
  return true;
}

bool Viewer::select_at(double x, double y) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Impl& s = *impl_;
  int width = 1, height = 1;
  glfwGetWindowSize(s.window, &width, &height);
  Engine& e = s.run->engine();
  Eigen::Vector3d point;
  int b = s.view->pick_body(x / width, 1.0 - y / height, double(width) / height, point);
  s.dragging = false;
  if (b < 0) {
    s.selected = -1;
    s.status = "released";
    return false;
  }
  e.forward();
  BodyPose pose = e.body_pose(b);
  s.selected = b;
  s.selected_local = pose.quat.conjugate() * (point - pose.pos);
  s.status = "selected " + e.body_name(b) + " (ctrl+drag pulls it)";
  return true;
}

void Viewer::drag_to(const Eigen::Vector3d& target) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->selected < 0) return;
  impl_->drag_target = target;
  impl_->dragging = true;
}

void Viewer::release() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->dragging = false;
}

int Viewer::selected_body() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->selected;
}

int Viewer::history_size() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return static_cast<int>(impl_->history.size());
}

double Viewer::history_time(int i) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->history.at(i).time;
}

double Viewer::scrub_to(double t) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Impl& s = *impl_;
  s.paused = true;
  // the nearest recorded state (times increase along the history)
  int best = 0;
  for (int i = 0; i < static_cast<int>(s.history.size()); ++i)
    if (std::abs(s.history[i].time - t) < std::abs(s.history[best].time - t)) best = i;
  Engine& e = s.run->engine();
  e.restore_state(s.history[best]);
  e.forward();
  s.scrubbed = best;
  return e.time();
}

bool Viewer::param_pending() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return !impl_->pending.empty();
}

void Viewer::finish_pending() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->finish_pending();
}

const Controller& Viewer::controller(int index) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return *impl_->run->controllers().at(index);
}

}  // namespace stance
