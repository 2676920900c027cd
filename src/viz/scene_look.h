// The look of a drawn scenario: a sky gradient, a checker floor in metres, a soft headlight and a
// key light with shadows, as MuJoCo's `simulate` shows models that bring default assets.
//
// One place for every drawing model (the MuJoCo engine's own, the SKEL translation, DART's drawing
// copy, bvh2mjcf characters, URDF): nothing is added to the model or its XML. The two textures are
// made in the renderer's context (mjrContext) after mjr_makeContext, and each frame the scene's
// floor geoms point at the floor texture and the key light follows the character. A model that
// brings its own sky (a skybox texture, e.g. humanoid.xml) keeps its whole look.
#pragma once

#include <mujoco/mujoco.h>

#include <Eigen/Core>

namespace stance {

// true when the model has a skybox texture of its own: then it keeps its look
bool model_has_own_look(const mjModel* m);

// the model geoms drawn with the checker floor: static planes, and static boxes wider than 1 m
// in two directions (SKEL grounds), that have no textured material of their own
bool is_floor_geom(const mjModel* m, int geom);

class SceneLook {
 public:
  // the sky (a cube map) and the floor (a 2D checker of 1 m squares) are added to `con`; needs
  // its OpenGL context current. Nothing is done for a model with its own look.
  void attach(const mjModel* m, mjrContext& con);
  bool active() const { return active_; }
  // around mjr_render: the texture matrix that scales the floor's texture to metres
  void begin_render() const;
  void end_render() const;
  // after mjv_updateScene and the turn to the view frame (up = +z): floor geoms get the checker
  // (drawn at least `min_floor_half_m` wide), the model's lights make way for the key light,
  // whose shadow covers `shadow_radius_m` around `focus` (view frame, m)
  void dress(const mjModel* m, mjvScene& scn, mjrContext& con, const Eigen::Vector3d& focus,
             double shadow_radius_m) const;

 private:
  bool active_ = false;
  int floor_texture_ = -1;  // index into mjrContext::texture
};

}  // namespace stance
