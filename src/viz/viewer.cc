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
#include <filesystem>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "control/controller.h"
#include "core/error.h"
#include "scenario/live_tuning.h"
#include "scenario/runner.h"
#include "viz/recorder.h"
#include "viz/scene_view.h"

namespace stance {

namespace {
using Clock = std::chrono::steady_clock;

constexpr double kPushSeconds = 0.1;   // how long a key push lasts (simulated)
constexpr double kPlotWindowS = 10.0;  // rolling plot window
constexpr double kPlotRateHz = 60.0;

// a fixed-size ring of samples for ImGui::PlotLines
struct RollingSeries {
  std::string name;
  std::vector<float> values;
  int head = 0;  // oldest sample
  void push(float v) {
    values[head] = v;
    head = (head + 1) % static_cast<int>(values.size());
  }
};

const char* kHelpText =
    "space   pause / run\n"
    "n       single step (while paused)\n"
    "p       replay from the start\n"
    ", .     push back / forth on the push body\n"
    "a s     skateboard speed down / up\n"
    "- =     slower / faster than real time\n"
    "f       camera: follow the root / free\n"
    "c       contact points and forces\n"
    "m       COM and support markers\n"
    "h       this help\n"
    "Esc     quit\n"
    "mouse   left drag: rotate, right drag: pan, wheel: zoom";
}  // namespace

struct Viewer::Impl {
  LoadedScenario loaded;
  ViewerOptions options;
  GLFWwindow* window = nullptr;
  ImGuiContext* imgui = nullptr;  // one per viewer: several may be open (tests)
  std::unique_ptr<ScenarioRun> run;
  std::unique_ptr<SceneView> view;

  // physics thread and what it shares (guarded by mutex)
  mutable std::mutex mutex;
  std::thread physics;
  std::atomic<bool> quit{false};
  bool paused = false;
  int single_steps = 0;
  double speed = 1.0;         // requested sim/wall factor
  double achieved_speed = 0;  // measured
  bool anchor_dirty = true;   // re-anchor sim time to wall time
  struct KeyPush {
    int body = -1;
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    double until = 0;
  };
  std::vector<KeyPush> key_pushes;
  int push_body = 0;
  double push_newtons = 0;
  std::vector<RollingSeries> plots;  // com height, then the controllers' signals
  double next_sample = 0;
  std::vector<std::string> signal_names;
  std::vector<double> signal_values;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double ground = 0;

  // UI state
  std::vector<std::vector<ParamEntry>> entries;  // per controller
  bool show_help = true;
  std::string status;
  std::vector<unsigned char> frame_rgb;
  int frame_w = 0, frame_h = 0;
  // mouse
  bool button_left = false, button_right = false;
  double last_x = 0, last_y = 0;

  void refresh_entries() {
    entries.clear();
    for (auto& c : run->controllers()) entries.push_back(c->tunable_params());
  }

  // one physics step with the viewer's key pushes (mutex held)
  void step_locked() {
    Engine& e = run->engine();
    double t = e.time();
    for (const auto& p : key_pushes)
      if (t < p.until) e.apply_external_force(p.body, p.force, e.body_com(p.body));
    if (!run->step()) {
      paused = true;
      status = "diverged: " + run->result().divergence;
      return;
    }
    // rolling plots
    if (e.time() >= next_sample) {
      next_sample = e.time() + 1.0 / kPlotRateHz;
      e.forward();
      plots[0].push(static_cast<float>(up.dot(e.com()) - ground));
      signal_values.clear();
      for (auto& c : run->controllers()) c->signals(signal_values);
      for (size_t i = 0; i + 1 < plots.size() && i < signal_values.size(); ++i)
        plots[i + 1].push(static_cast<float>(signal_values[i]));
    }
  }

  void physics_loop() {
    Clock::time_point wall0;
    double sim0 = 0;
    while (!quit) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        Engine& e = run->engine();
        if (anchor_dirty || paused) {
          wall0 = Clock::now();
          sim0 = e.time();
          anchor_dirty = false;
        }
        if (paused) {
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

  void reset_plots() {
    for (auto& p : plots) std::fill(p.values.begin(), p.values.end(), 0.0f);
    next_sample = 0;
  }

  void draw_panels();

  // the scenario with the running controllers' parameters; default path <stem>_tuned.yaml
  std::string write_tuned(const std::string& path) {
    YAML::Node doc = tuned_scenario_yaml(*run, loaded);
    std::string out = path;
    if (out.empty()) {
      std::filesystem::path p(options.save_path.empty() ? loaded.scenario.name + ".yaml"
                                                        : options.save_path);
      out = (p.parent_path() / (p.stem().string() + "_tuned.yaml")).string();
    }
    std::ofstream f(out);
    if (!f) throw std::runtime_error("cannot write " + out);
    f << doc << "\n";
    return out;
  }
};

Viewer::Viewer(const LoadedScenario& loaded, const ViewerOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.loaded = loaded;
  s.options = options;
  RunOptions ro;
  ro.engine = options.engine;
  ro.quiet = true;
  // the viewer runs until closed: the scenario's duration does not stop it
  s.run = std::make_unique<ScenarioRun>(loaded, ro);

  if (!glfwInit()) throw std::runtime_error("cannot initialise GLFW (no display? try xvfb-run)");
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_SAMPLES, 4);
  s.window =
      glfwCreateWindow(options.width, options.height,
                       fmt::format("stance: {}", loaded.scenario.name).c_str(), nullptr, nullptr);
  if (!s.window) throw std::runtime_error("cannot open a window (no display? try xvfb-run)");
  glfwMakeContextCurrent(s.window);
  glfwSwapInterval(options.threaded ? 1 : 0);
  s.view = std::make_unique<SceneView>(*s.run, 640, 480);

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
  for (auto& c : s.run->controllers()) c->signal_names(s.signal_names);
  for (size_t i = 0; i < s.signal_names.size() && i < 8; ++i)
    s.plots.push_back({s.signal_names[i], std::vector<float>(samples, 0.0f)});
  s.refresh_entries();
  // the key reference opens by itself when there is room for it
  s.show_help = options.height >= 800;

  // our callbacks first: imgui chains to them
  glfwSetWindowUserPointer(s.window, this);
  glfwSetKeyCallback(s.window, [](GLFWwindow* w, int key, int, int action, int) {
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    if (ImGui::GetCurrentContext() && ImGui::GetIO().WantCaptureKeyboard) return;
    static_cast<Viewer*>(glfwGetWindowUserPointer(w))->key(key);
  });
  glfwSetMouseButtonCallback(s.window, [](GLFWwindow* w, int button, int action, int) {
    Impl& s = *static_cast<Viewer*>(glfwGetWindowUserPointer(w))->impl_;
    bool down = action == GLFW_PRESS && !ImGui::GetIO().WantCaptureMouse;
    if (button == GLFW_MOUSE_BUTTON_LEFT) s.button_left = down;
    if (button == GLFW_MOUSE_BUTTON_RIGHT) s.button_right = down;
    glfwGetCursorPos(w, &s.last_x, &s.last_y);
  });
  glfwSetCursorPosCallback(s.window, [](GLFWwindow* w, double x, double y) {
    Impl& s = *static_cast<Viewer*>(glfwGetWindowUserPointer(w))->impl_;
    double dx = x - s.last_x, dy = y - s.last_y;
    s.last_x = x;
    s.last_y = y;
    if (!s.button_left && !s.button_right) return;
    int width = 1, height = 1;
    glfwGetWindowSize(w, &width, &height);
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
  glfwMakeContextCurrent(s.window);
  ImGui::SetCurrentContext(s.imgui);
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext(s.imgui);
  s.view.reset();  // frees GL objects while the context exists
  if (s.window) glfwDestroyWindow(s.window);
}

void Viewer::run() {
  while (!glfwWindowShouldClose(impl_->window)) frame();
}

void Viewer::key(int k) {
  Impl& s = *impl_;
  std::lock_guard<std::mutex> lock(s.mutex);
  Engine& e = s.run->engine();
  switch (k) {
    case GLFW_KEY_SPACE:
      s.paused = !s.paused;
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
      s.run->reset();
      s.key_pushes.clear();
      s.reset_plots();
      s.anchor_dirty = true;
      s.status = "replay from the start";
      break;
    case GLFW_KEY_COMMA:
    case GLFW_KEY_PERIOD: {
      // back (-x) or forth (+x) in the view's horizontal frame
      Eigen::Vector3d forth = Eigen::Vector3d::UnitX() - s.up.dot(Eigen::Vector3d::UnitX()) * s.up;
      if (forth.norm() < 1e-6) forth = Eigen::Vector3d::UnitY();
      forth.normalize();
      double sign = k == GLFW_KEY_PERIOD ? 1.0 : -1.0;
      s.key_pushes.push_back({s.push_body, sign * s.push_newtons * forth, e.time() + kPushSeconds});
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
            retune_controller(*s.run, s.loaded, static_cast<int>(i), path, value);
            s.status = fmt::format("{} = {:.3g}", path, value);
          } catch (const std::exception& err) {
            s.status = err.what();
          }
          s.refresh_entries();
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
    anchor_dirty = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("step")) {
    paused = true;
    step_locked();
  }
  ImGui::SameLine();
  if (ImGui::Button("replay")) {
    run->reset();
    key_pushes.clear();
    reset_plots();
    anchor_dirty = true;
  }
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

  // parameters, generated from the controllers' visits
  ImGui::SetNextWindowPos(ImVec2(options.width - panel_w - 10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(panel_w, 0.7f * options.height), ImGuiCond_FirstUseEver);
  ImGui::Begin("parameters");
  // long key paths: give the labels more room than imgui's default two thirds for the value
  ImGui::PushItemWidth(ImGui::GetWindowWidth() * 0.35f);
  int changed_controller = -1;
  std::string changed_path;
  double changed_value = 0;
  for (size_t i = 0; i < entries.size(); ++i) {
    std::string header = fmt::format("{} [{}]", run->controllers()[i]->type(), i);
    if (!ImGui::CollapsingHeader(header.c_str(), ImGuiTreeNodeFlags_DefaultOpen)) continue;
    for (auto& entry : entries[i]) {
      std::string label = fmt::format("{}##{}", entry.path, i);
      if (entry.kind == ParamEntry::Kind::kBool) {
        bool b = entry.value != 0;
        if (ImGui::Checkbox(label.c_str(), &b)) {
          changed_controller = static_cast<int>(i);
          changed_path = entry.path;
          changed_value = b ? 1 : 0;
        }
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
        if (!entry.meta.help.empty() || !entry.meta.unit.empty())
          if (ImGui::IsItemHovered())
            ImGui::SetTooltip("%s [%s]", std::string(entry.meta.help).c_str(),
                              std::string(entry.meta.unit).c_str());
        if (v != entry.value) entry.value = v;  // shown while dragging
        if (ImGui::IsItemDeactivatedAfterEdit()) {
          changed_controller = static_cast<int>(i);
          changed_path = entry.path;
          changed_value = v;
        }
      }
    }
  }
  ImGui::PopItemWidth();
  ImGui::End();
  if (changed_controller >= 0) {
    try {
      retune_controller(*run, loaded, changed_controller, changed_path, changed_value);
      status = fmt::format("{} = {:.4g}", changed_path, changed_value);
    } catch (const std::exception& err) {
      status = err.what();
    }
    refresh_entries();
  }

  if (show_help) {
    ImGui::SetNextWindowPos(ImVec2(10, options.height - 235.0f), ImGuiCond_FirstUseEver);
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
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    if (!s.options.threaded && !s.paused) {
      // reproducible: a fixed amount of simulated time per frame
      Engine& e = s.run->engine();
      double target = e.time() + s.options.frame_dt * s.speed;
      while (e.time() < target - 0.5 * e.timestep() && !s.paused) s.step_locked();
      s.achieved_speed = s.speed;
    }
    std::vector<ForceArrow> arrows;
    Engine& e = s.run->engine();
    for (const auto& p : s.key_pushes)
      if (e.time() < p.until) arrows.push_back({e.body_com(p.body), p.force});
    s.view->update(*s.run, arrows);
    s.draw_panels();
  }
  ImGui::Render();
  s.view->render_window(width, height, "");
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
  glfwSwapBuffers(s.window);
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
  retune_controller(*impl_->run, impl_->loaded, index, path, value);
  impl_->refresh_entries();
}

const std::vector<std::vector<ParamEntry>>& Viewer::param_panel() const {
  return impl_->entries;
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

}  // namespace stance
