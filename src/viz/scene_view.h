// Draws a running scenario with MuJoCo's renderer (mjv_/mjr_), on either engine.
//
// What is drawn comes from the engine interface (Engine::render_model): a MuJoCo run's own
// mjModel/mjData, or for other engines (DART) a MuJoCo copy of the same world that only draws,
// posed body by body by the engine itself (engine/drawing_copy.h).
//
// The scene is turned so that "up" (against gravity) points up on screen: Y-up models and tilted
// slopes are shown as a person standing on the floor would see them.
#pragma once

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "control/marker.h"
#include "sim/simulation.h"
#include "viz/scene_look.h"

namespace stance {

enum class CameraMode { kFree, kFollow };

// a force arrow to draw: force (N, world) applied at a world point
struct ForceArrow {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
};

struct SceneOptions {
  bool contacts = true;  // contact points and forces
  bool com = true;       // COM marker and its ground projection (support marker)
  bool pushes = true;    // arrows for the scenario's active pushes and extra forces
  bool markers = true;   // the controllers' markers (Controller::markers)
  bool ghost = true;     // the tracked reference pose as a translucent copy of the model
  CameraMode camera = CameraMode::kFollow;
};

class SceneView {
 public:
  // needs a current OpenGL context. offscreen_size: the largest frame render_offscreen() makes.
  // look: stance's sky, floor and shadows (scene_look.h) on models that bring no look of their
  // own; false draws the model as it is (quicker in software rendering: tests). draft: no
  // shadows and no multisampling offscreen, a third of a frame's time in software rendering
  SceneView(Simulation& run, int offscreen_width = 1280, int offscreen_height = 720,
            bool look = true, bool draft = false);
  ~SceneView();
  SceneView(const SceneView&) = delete;
  SceneView& operator=(const SceneView&) = delete;

  // copy the run's state into the scene; call while the physics is not stepping.
  // extra_forces: forces applied outside the scenario's pushes (the viewer's keys);
  // extra_markers: drawn as the controllers' markers are (the viewer's mouse drag)
  void update(Simulation& run, const std::vector<ForceArrow>& extra_forces = {},
              const std::vector<Marker>& extra_markers = {});
  // draw into the current (window) framebuffer
  void render_window(int width, int height, const std::string& overlay = "");
  // draw offscreen and read back rgb, dim width*height*3, top row first
  void render_offscreen(int width, int height, std::vector<unsigned char>& rgb,
                        const std::string& overlay = "");

  // the scenario's camera again (distance, azimuth, elevation), looking at the character
  void reset_camera();
  // the point the follow camera looks at: the root's position, filtered in simulated time, at
  // the height of the character's middle (view frame, up = +z, m)
  const Eigen::Vector3d& focus() const { return focus_; }
  // the character's height along up at the start, feet to head (m)
  double character_size() const { return character_size_; }
  // the camera distance that frames a character of `size_m` whole, feet included, with this
  // vertical field of view (deg)
  static double framing_distance(double size_m, double fovy_deg);
  // the running engine's body under the pixel (relx, rely) of the last drawn scene (0..1, from
  // the bottom left; aspect = width / height), and the world point hit; -1 when none. Static
  // geoms (the floor) are not picked. Call while the physics is not stepping.
  int pick_body(double relx, double rely, double aspect, Eigen::Vector3d& point_world) const;
  // the mass the mouse spring scales with: the body's subtree, as MuJoCo's mjv_perturb does (kg)
  double subtree_mass(int engine_body) const;
  // the world displacement of a mouse move of (dx, dy) pixels (dy down) in a window `height`
  // pixels high, at the depth of `at`: in the screen plane, or with horizontal = true in the
  // ground plane (dy moves away from the camera)
  Eigen::Vector3d mouse_motion_in_world(double dx, double dy, int height, const Eigen::Vector3d& at,
                                        bool horizontal) const;
  // where a world point lands in the last drawn scene: (relx, rely) from the bottom left, 0..1
  // inside the image (aspect = width / height); the inverse of pick_body's ray. Points behind
  // the camera give NaN.
  Eigen::Vector2d project(const Eigen::Vector3d& world, double aspect) const;
  // the drawn poses (geom_xpos etc., world frame) of the drawing model
  const mjData* draw_data() const { return render_.data; }
  mjvCamera& camera() { return cam_; }
  const mjvCamera& camera() const { return cam_; }
  const mjModel* draw_model() const { return model_; }
  mjvScene& scene() { return scn_; }
  SceneOptions options;

 private:
  void add_arrow(const Eigen::Vector3d& tail, const Eigen::Vector3d& head, const float rgba[4],
                 double width);
  void add_sphere(const Eigen::Vector3d& pos, double radius, const float rgba[4]);
  void add_capsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius,
                   const float rgba[4]);
  void add_marker(const Marker& marker);
  // the reference pose of the first controller that gives one, as translucent geoms
  void add_ghost(Simulation& run);
  Eigen::Vector3d to_view(const Eigen::Vector3d& p) const { return view_rot_ * p; }
  // the character's extent at the start, from its geoms: sets character_size_ and focus_offset_
  void measure_character(Engine& engine);
  // the follow camera's target at the engine's time: low-pass filtered root position with its
  // velocity's lag made up horizontally
  void track_root(Engine& engine);

  // the running engine's drawing model and data (Engine::render_model)
  RenderModel render_;
  mjModel* model_ = nullptr;
  std::vector<int> engine_body_;  // mj body id in the drawing model -> running engine body
  // the ghost: an engine of the scenario set to the reference pose, drawn from its own drawing
  // model (made when a controller gives a reference pose)
  std::unique_ptr<Engine> ghost_engine_;
  Eigen::VectorXd ghost_q_;
  std::vector<Marker> markers_;  // scratch
  mjvScene scn_;
  mjrContext con_;
  mjvCamera cam_;
  mjvOption opt_;
  Eigen::Matrix3d view_rot_ = Eigen::Matrix3d::Identity();  // world -> view (up = +z)
  double body_weight_n_ = 1;
  double ground_height_ = 0;
  Eigen::Vector3d up_ = Eigen::Vector3d::UnitZ();
  double time_ = 0;
  SceneLook look_;
  CameraParams camera_params_;
  double character_size_ = 1;
  Eigen::Vector3d focus_ = Eigen::Vector3d::Zero();         // view frame
  Eigen::Vector3d focus_offset_ = Eigen::Vector3d::Zero();  // from the root, view frame
  Eigen::Vector3d root_filtered_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_filtered_ = Eigen::Vector3d::Zero();
  double focus_time_ = -1;  // simulated time of the last tracking update; < 0: none yet
};

}  // namespace stance
