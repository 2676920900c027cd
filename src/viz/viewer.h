// `stance view`: a GLFW window drawn by MuJoCo's renderer with imgui panels. Physics runs on its
// own thread paced to real time (times a slow-motion / fast-forward factor); the panels show the
// state, a parameter panel generated from each controller's tunable_params() (no per-controller
// GUI code), live plots over a rolling window and the key reference.
//
// Keys: space pause, n single step, p replay, r record MP4 / stop, i save PNG, , and . push back
// and forth, a and s skateboard speed (a controller parameter "speed", stepped by "speed_step"), -
// and = slow down / speed up, f camera follow/free, c contacts, m COM markers, k controller
// markers, g tracking ghost, h help, Esc quit. Mouse: left drag rotates, right drag pans, wheel
// zooms; double-click selects a body, and Ctrl+right drag (screen plane) or Ctrl+left drag (ground
// plane) pulls it towards a target with a spring, as MuJoCo's simulate does, through
// Engine::apply_external_force (both engines).
//
// History: the engine state is kept every 1/60 s of simulated time (the last minute). While
// paused, the panel's slider (or scrub_to) restores any recorded state; running on continues from
// there and drops the later history. Controllers start afresh (reset()) at the restored state:
// their state is not recorded.
//
// Live tuning: most parameters rebuild their controller at once. LQR costs re-solve the DARE on a
// worker thread (scenario/live_tuning.h); the old controller keeps running until the new one is
// swapped in between two steps (param_pending() meanwhile).
//
// Tests drive the same code without a person: key() is what a key press does, frame() is one
// window frame, select_body / drag_to / release are what the mouse does, and with threaded =
// false each frame() advances the physics by frame_dt so that runs are reproducible.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "params/param_list.h"
#include "sim/scenario.h"

namespace stance {

class Controller;
class Simulation;

struct ViewerOptions {
  std::string engine;  // overrides the scenario's
  int width = 1400, height = 900;
  bool visible = true;
  bool threaded = true;        // physics thread paced to real time
  double frame_dt = 1.0 / 60;  // s of simulated time per frame() when not threaded
  std::string save_path;       // scenario file; "save scenario" writes <stem>_tuned.yaml beside it
  std::string capture_dir = ".";  // where the r (MP4) and i (PNG) keys write
  double record_fps = 60;         // frames per simulated second of the r key's MP4
  bool scene_look = true;         // stance's sky, floor and shadows (viz/scene_look.h)
  double quit_after_s = 0;        // run() returns after this much wall time; 0: when closed
  // no shadows and no multisampling: a third of a frame's time in software rendering (Mesa's
  // llvmpipe, e.g. under Xvfb), whose frames would take the planner's cores. Empty: when the
  // renderer is a software one
  std::optional<bool> quick_look;
};

class Viewer {
 public:
  // throws EnvironmentError when no window can be opened (no display)
  Viewer(const LoadedScenario& loaded, const ViewerOptions& options);
  // on a simulation built elsewhere (the Python module's stance.view), `loaded` being what it
  // was built from (for saving the scenario)
  Viewer(const LoadedScenario& loaded, const ViewerOptions& options,
         std::unique_ptr<Simulation> run);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // until the window is closed (or quit_after_s)
  void run();
  // one frame: events, (unthreaded) physics, drawing, panels, swap
  void frame();
  // what pressing a key does (GLFW key codes, e.g. GLFW_KEY_SPACE or 'P')
  void key(int glfw_key);
  // the r key: start or stop an MP4 of the window; the i key: a PNG of the last frame. Files are
  // <capture_dir>/<scenario>_<n>.mp4|png; both print where they went. While recording, each
  // window frame advances the physics by 1/record_fps of simulated time (the physics thread
  // waits), so the video's length is the simulated time recorded, whatever the pace.
  bool recording() const;
  // the file the last r or i key started or wrote; empty: none yet
  const std::string& last_capture() const;
  // the last frame as it was shown (rgb, top row first); false when no frame was drawn yet
  bool screenshot(const std::string& png_path) const;
  const std::vector<unsigned char>& last_frame(int& width, int& height) const;
  // true when drawn without shadows and multisampling (ViewerOptions::quick_look)
  bool quick_look() const;

  // the parameter panel's path: set controller `index`'s parameter `path` (rebuilds it)
  void set_param(int index, const std::string& path, double value);
  const std::vector<std::vector<ParamEntry>>& param_panel() const;
  // the panel's planner block (empty when the run does not plan), and its edit path
  const std::vector<ParamEntry>& planner_panel() const;
  void set_planner_param(const std::string& path, double value);
  // writes the scenario with the tuned parameters; returns the file written
  std::string save_scenario(const std::string& path = "");

  double sim_time() const;
  bool paused() const;
  double speed_factor() const;
  bool follow_camera() const;
  // the character's COM velocity (m/s, world), e.g. to see a push act
  Eigen::Vector3d com_velocity() const;
  // COM height above the scenario's ground, along up (m)
  double com_height() const;
  // a parameter as the panel shows it; NaN when absent
  double param_value(int index, const std::string& path) const;
  const std::string& status() const;
  // the latest sample of the live plot `name` (e.g. "joint torque RMS (N m)"); NaN when absent
  double plot_value(const std::string& name) const;
  Eigen::Vector3d com() const;  // of the character, world (m)
  // a body's frame origin, world (m); throws std::invalid_argument for an unknown name
  Eigen::Vector3d body_position(const std::string& name) const;

  // the mouse perturbation. select_body picks the body's COM as the point pulled; select_at
  // picks what is under window pixel (x, y) (from the top left), as a double-click does, and
  // returns false (and releases) over empty space. drag_to sets the spring's target (world, m);
  // release lets go.
  bool select_body(const std::string& name);
  bool select_at(double x, double y);
  void drag_to(const Eigen::Vector3d& target);
  void release();
  int selected_body() const;  // the running engine's body index; -1: none

  // the recorded history: states every 1/60 s of simulated time
  int history_size() const;
  double history_time(int i) const;
  // pauses, and restores the recorded state nearest to time t (s); returns its time
  double scrub_to(double t);

  // a background rebuild (an LQR cost change) is still waiting to be swapped in
  bool param_pending() const;
  // waits for the pending rebuilds and swaps them in (what "save scenario" does first)
  void finish_pending();
  // the running controller `index` (e.g. to read an LQR gain)
  const Controller& controller(int index) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stance
