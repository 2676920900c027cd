#include "viz/viewer.h"

#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include "viz/viewer_impl.h"

namespace stance {

namespace {
// Mesa's software rasterisers: no GPU (Xvfb, CI, containers)
bool software_renderer() {
  const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const std::string renderer = name ? name : "";
  for (const char* software : {"llvmpipe", "softpipe", "swrast"})
    if (renderer.find(software) != std::string::npos) return true;
  return false;
}

// a window with its context current; throws EnvironmentError
GLFWwindow* open_window(const ViewerOptions& o, const std::string& title, bool multisample) {
  glfwWindowHint(GLFW_VISIBLE, o.visible ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_SAMPLES, multisample ? 4 : 0);
  GLFWwindow* window = glfwCreateWindow(o.width, o.height, title.c_str(), nullptr, nullptr);
  if (!window) throw EnvironmentError("cannot open a window (no display? try xvfb-run)");
  glfwMakeContextCurrent(window);
  return window;
}
}  // namespace

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
  const std::string title = fmt::format("stance: {}", loaded.scenario.name);
  s.window = open_window(options, title, !options.quick_look.value_or(false));
  s.quick_look = options.quick_look.value_or(software_renderer());
  if (s.quick_look && !options.quick_look) {
    // the renderer is known once a context exists: again, without multisampling
    glfwDestroyWindow(s.window);
    s.window = open_window(options, title, false);
  }
  glfwSwapInterval(options.threaded ? 1 : 0);
  // frames at most at the display's rate, and at most 60 a second (30 in software rendering,
  // where each frame takes CPU from the physics)
  GLFWmonitor* monitor = glfwGetPrimaryMonitor();
  const GLFWvidmode* mode = monitor ? glfwGetVideoMode(monitor) : nullptr;
  const int refresh_hz = mode && mode->refreshRate > 0 ? mode->refreshRate : 60;
  s.frame_period_s = 1.0 / std::clamp(refresh_hz, 1, s.quick_look ? 30 : 60);
  s.view = std::make_unique<SceneView>(*s.run, 640, 480, options.scene_look, s.quick_look);

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
  for (auto& c : s.run->controllers())
    if (const Reporting* r = c->as<Reporting>()) r->signal_names(s.signal_names);
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
  s.install_input_callbacks();

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
  // keep what is shown when it is asked for (a running window's frames only then: a read-back
  // of every frame costs a software renderer a few ms)
  if (!s.options.threaded || record_frame || s.capture_png) s.keep_frame(width, height);
  if (s.capture_png) {
    std::lock_guard<std::mutex> lock(s.mutex);
    s.save_png();
  }
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

bool Viewer::quick_look() const {
  return impl_->quick_look;
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
