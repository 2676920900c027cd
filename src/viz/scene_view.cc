#include "viz/scene_view.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <stdexcept>

#include "core/error.h"
#include "plan/planner.h"

namespace stance {

namespace {
constexpr float kPushColor[4] = {0.95f, 0.15f, 0.1f, 1.0f};
constexpr float kContactColor[4] = {0.1f, 0.5f, 1.0f, 1.0f};
constexpr float kComColor[4] = {1.0f, 0.85f, 0.1f, 1.0f};
constexpr float kSupportColor[4] = {1.0f, 0.55f, 0.0f, 0.8f};
constexpr float kGhostColor[4] = {0.3f, 0.8f, 1.0f, 0.3f};
constexpr int kMaxGeoms = 5000;
constexpr int kCircleSegments = 32;
// the follow camera's filter (simulated time): slow enough to drop a gait's sway and bob
constexpr double kFollowTauS = 0.5;
// the framed height is this many times the character's: room to move and to fall
constexpr double kFramingMargin = 1.4;
}  // namespace

double SceneView::framing_distance(double size_m, double fovy_deg) {
  double half_fov = 0.5 * fovy_deg * M_PI / 180;
  return std::max(1.2, 0.5 * kFramingMargin * size_m / std::tan(half_fov));
}

SceneView::SceneView(Simulation& run, int offscreen_width, int offscreen_height, bool look,
                     bool draft) {
  Engine& engine = run.engine();
  engine.forward();
  {
    // a DART run's first drawing loads its MuJoCo copy
    std::lock_guard<std::mutex> lock(model_load_mutex());
    render_ = engine.render_model();
  }
  if (!render_.model || !render_.body_ids)
    throw EnvironmentError(fmt::format("the {} engine cannot be drawn", engine.engine_name()));
  model_ = render_.model;
  // the offscreen buffer must hold the largest frame asked for
  model_->vis.global.offwidth = std::max(model_->vis.global.offwidth, offscreen_width);
  model_->vis.global.offheight = std::max(model_->vis.global.offheight, offscreen_height);

  // the clip planes scale with the model's extent, which a long floor makes huge (500 m: the
  // near plane 5 m away would cut the character): near within 3 cm, far at least 150 m
  double extent = std::max(1e-6, double(model_->stat.extent));
  model_->vis.map.znear = std::min<float>(model_->vis.map.znear, 0.03 / extent);
  model_->vis.map.zfar = std::max<float>(model_->vis.map.zfar, 150 / extent);
  // a brighter headlight than MuJoCo's default: many models bring no lights of their own
  // (with stance's look, a key light with shadows adds to a softer one)
  bool own_look = !look || model_has_own_look(model_);
  // the key light's shadow covers a few metres: 2048 texels are plenty, and half the default's
  // side keeps software rendering (llvmpipe, CI) quick
  if (!own_look) model_->vis.quality.shadowsize = std::min(model_->vis.quality.shadowsize, 2048);
  for (int i = 0; i < 3; ++i) {
    model_->vis.headlight.ambient[i] = own_look ? 0.35f : 0.3f;
    model_->vis.headlight.diffuse[i] = own_look ? 0.6f : 0.3f;
    model_->vis.headlight.specular[i] = own_look ? model_->vis.headlight.specular[i] : 0.1f;
  }

  engine_body_.assign(model_->nbody, -1);
  for (int b = 0; b < engine.nbody(); ++b)
    if ((*render_.body_ids)[b] >= 0) engine_body_[(*render_.body_ids)[b]] = b;

  // a ghost when a controller tracks a pose: its own engine of the scenario (the same dof
  // layout as the run's) turns the reference q into body poses
  for (size_t i = 0; i < run.controllers().size(); ++i) {
    const Tracking* tracking = run.controllers()[i]->as<Tracking>();
    if (!tracking || !tracking->reference_qpos(run.controller_state(i), engine, ghost_q_)) continue;
    std::lock_guard<std::mutex> lock(model_load_mutex());
    ghost_engine_ = make_scenario_engine(run.scenario(), std::string(engine.engine_name()));
    if (!ghost_engine_->render_model().model) ghost_engine_.reset();
    break;
  }

  Eigen::Vector3d g = engine.gravity();
  if (g.norm() > 0) up_ = -g.normalized();
  view_rot_ = Eigen::Quaterniond::FromTwoVectors(up_, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  body_weight_n_ = std::max(1e-6, engine.total_mass() * std::max(1e-6, g.norm()));
  ground_height_ = run.scenario().fall.ground_height;

  // the shadow pass and 4x multisampling are most of a software-rendered frame
  if (draft) model_->vis.quality.offsamples = 0;
  mjv_defaultScene(&scn_);
  mjv_makeScene(model_, &scn_, kMaxGeoms);
  if (draft) scn_.flags[mjRND_SHADOW] = 0;
  mjv_defaultOption(&opt_);
  mjr_defaultContext(&con_);
  mjr_makeContext(model_, &con_, mjFONTSCALE_150);
  if (look) look_.attach(model_, con_);
  mjv_defaultCamera(&cam_);
  camera_params_ = run.scenario().camera;
  options.camera = camera_params_.mode == "fixed" ? CameraMode::kFree : CameraMode::kFollow;
  measure_character(engine);
  track_root(engine);
  reset_camera();
  update(run);
}

void SceneView::measure_character(Engine& engine) {
  const mjData* d = render_.data;
  // the moving geoms' extent in the view frame (bounding spheres: a little generous)
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (int g = 0; g < model_->ngeom; ++g) {
    if (model_->body_weldid[model_->geom_bodyid[g]] == 0) continue;
    Eigen::Vector3d p = to_view(Eigen::Map<const Eigen::Vector3d>(d->geom_xpos + 3 * g));
    double r = std::min<double>(model_->geom_rbound[g], 1.0);
    lo = lo.cwiseMin(p - Eigen::Vector3d::Constant(r));
    hi = hi.cwiseMax(p + Eigen::Vector3d::Constant(r));
  }
  Eigen::Vector3d root = to_view(engine.nbody() > 0 ? engine.body_pose(0).pos : engine.com());
  if (lo.x() > hi.x()) {
    character_size_ = 1;
    focus_offset_.setZero();
    return;
  }
  // tall characters by their height; long ones (an arm, a board) by their length, which the
  // wide picture (at least 4:3) shows
  character_size_ = std::max({0.3, hi.z() - lo.z(), 0.75 * (hi - lo).head<2>().maxCoeff()});
  // the middle of the character, from the root (a fixed arm's root is at one end)
  focus_offset_ = 0.5 * (lo + hi) - root;
}

void SceneView::track_root(Engine& engine) {
  double t = engine.time();
  Eigen::Vector3d root = to_view(engine.nbody() > 0 ? engine.body_pose(0).pos : engine.com());
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if (engine.nbody() > 0) v = view_rot_ * engine.body_velocity(0).tail<3>();
  if (!v.allFinite()) v.setZero();
  // the start, a replay, a scrub or a single picture: no filtering across the jump, and the
  // focus on the root as if the filter had followed a steady walk there
  if (focus_time_ < 0 || t < focus_time_ || t > focus_time_ + 1.0) {
    velocity_filtered_ = v;
    root_filtered_ = root - kFollowTauS * Eigen::Vector3d(v.x(), v.y(), 0);
  } else {
    double a = 1 - std::exp(-(t - focus_time_) / kFollowTauS);
    root_filtered_ += a * (root - root_filtered_);
    velocity_filtered_ += a * (v - velocity_filtered_);
  }
  focus_time_ = t;
  // a first-order filter lags a steady walk by v tau: made up in the horizontal plane only,
  // where the gait's bob does not reach
  Eigen::Vector3d lead = kFollowTauS * velocity_filtered_;
  lead.z() = 0;
  focus_ = root_filtered_ + lead + focus_offset_;
}

SceneView::~SceneView() {
  mjr_freeContext(&con_);
  mjv_freeScene(&scn_);
}

void SceneView::reset_camera() {
  cam_.type = mjCAMERA_FREE;
  // the whole character in view: from its size, not the model's extent (long floors)
  cam_.distance = camera_params_.distance > 0
                      ? camera_params_.distance
                      : framing_distance(character_size_, model_->vis.global.fovy);
  cam_.azimuth = camera_params_.azimuth;
  cam_.elevation = camera_params_.elevation;
  for (int i = 0; i < 3; ++i) cam_.lookat[i] = focus_[i];
}

void SceneView::add_arrow(const Eigen::Vector3d& tail, const Eigen::Vector3d& head,
                          const float rgba[4], double width) {
  if (scn_.ngeom >= scn_.maxgeom || (head - tail).norm() < 1e-6) return;
  mjvGeom* g = scn_.geoms + scn_.ngeom++;
  mjv_initGeom(g, mjGEOM_ARROW, nullptr, nullptr, nullptr, rgba);
  Eigen::Vector3d a = to_view(tail), b = to_view(head);
  mjv_makeConnector(g, mjGEOM_ARROW, width, a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
  // mjr_render draws an arrow (shaft and head) over half of size[2]: double it, so that the
  // head ends at `head`
  g->size[2] *= 2;
  g->category = mjCAT_DECOR;
}

void SceneView::add_sphere(const Eigen::Vector3d& pos, double radius, const float rgba[4]) {
  if (scn_.ngeom >= scn_.maxgeom) return;
  mjvGeom* g = scn_.geoms + scn_.ngeom++;
  mjtNum size[3] = {radius, radius, radius};
  Eigen::Vector3d p = to_view(pos);
  mjtNum pos3[3] = {p.x(), p.y(), p.z()};
  mjv_initGeom(g, mjGEOM_SPHERE, size, pos3, nullptr, rgba);
  g->category = mjCAT_DECOR;
}

void SceneView::add_capsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius,
                            const float rgba[4]) {
  if (scn_.ngeom >= scn_.maxgeom || (b - a).norm() < 1e-9) return;
  mjvGeom* g = scn_.geoms + scn_.ngeom++;
  mjv_initGeom(g, mjGEOM_CAPSULE, nullptr, nullptr, nullptr, rgba);
  Eigen::Vector3d va = to_view(a), vb = to_view(b);
  mjv_makeConnector(g, mjGEOM_CAPSULE, radius, va.x(), va.y(), va.z(), vb.x(), vb.y(), vb.z());
  g->category = mjCAT_DECOR;
}

void SceneView::add_marker(const Marker& m) {
  int first = scn_.ngeom;
  const float* rgba = m.rgba.data();
  switch (m.shape) {
    case Marker::Shape::kSphere:
      add_sphere(m.pos, m.radius, rgba);
      break;
    case Marker::Shape::kCircle: {
      // a ring of short capsules, flat on the ground unless the marker says otherwise
      Eigen::Vector3d n = m.normal.norm() > 1e-9 ? m.normal.normalized() : up_;
      Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
      double width = std::max(0.004, 0.08 * m.radius);
      for (int i = 0; i < kCircleSegments; ++i) {
        double a0 = 2 * M_PI * i / kCircleSegments, a1 = 2 * M_PI * (i + 1) / kCircleSegments;
        add_capsule(m.pos + m.radius * (std::cos(a0) * u + std::sin(a0) * w),
                    m.pos + m.radius * (std::cos(a1) * u + std::sin(a1) * w), width, rgba);
      }
      break;
    }
    case Marker::Shape::kLine:
      add_capsule(m.pos, m.end, m.radius, rgba);
      break;
    case Marker::Shape::kArrow:
      add_arrow(m.pos, m.end, rgba, m.radius);
      break;
  }
  if (!m.label.empty() && scn_.ngeom > first)
    std::snprintf(scn_.geoms[first].label, sizeof(scn_.geoms[first].label), "%s", m.label.c_str());
}

void SceneView::add_ghost(Simulation& run) {
  for (size_t i = 0; i < run.controllers().size(); ++i) {
    const Tracking* tracking = run.controllers()[i]->as<Tracking>();
    if (!tracking || !tracking->reference_qpos(run.controller_state(i), run.engine(), ghost_q_))
      continue;
    if (ghost_q_.size() != ghost_engine_->nq()) return;
    ghost_engine_->set_positions(ghost_q_);
    ghost_engine_->forward();
    const RenderModel ghost = ghost_engine_->render_model();
    // the moving bodies only, in one translucent colour
    int first = scn_.ngeom;
    mjv_addGeoms(ghost.model, ghost.data, &opt_, nullptr, mjCAT_DYNAMIC, &scn_);
    for (int i = first; i < scn_.ngeom; ++i) {
      mjvGeom& g = scn_.geoms[i];
      for (int k = 0; k < 4; ++k) g.rgba[k] = kGhostColor[k];
      g.category = mjCAT_DECOR;
      g.segid = -1;
      g.objtype = mjOBJ_UNKNOWN;
      g.objid = -1;
      g.reflectance = 0;
      g.transparent = 1;
      g.texid = -1;
    }
    return;
  }
}

int SceneView::pick_body(double relx, double rely, double aspect,
                         Eigen::Vector3d& point_world) const {
  // the ray through the pixel, in the view frame, then in the world
  mjvGLCamera cam = mjv_averageCamera(scn_.camera, scn_.camera + 1);
  Eigen::Vector3d pos(cam.pos[0], cam.pos[1], cam.pos[2]);
  Eigen::Vector3d fwd(cam.forward[0], cam.forward[1], cam.forward[2]);
  Eigen::Vector3d up(cam.up[0], cam.up[1], cam.up[2]);
  Eigen::Vector3d right = fwd.cross(up);
  double near = cam.frustum_near;
  double x = cam.frustum_center + (relx - 0.5) * aspect * (cam.frustum_top - cam.frustum_bottom);
  double y = cam.frustum_bottom + rely * (cam.frustum_top - cam.frustum_bottom);
  Eigen::Vector3d dir = (near * fwd + x * right + y * up).normalized();
  Eigen::Vector3d p = view_rot_.transpose() * pos, v = view_rot_.transpose() * dir;
  int geom = -1;
  mjtNum dist = mj_ray(model_, render_.data, p.data(), v.data(), nullptr, 0, -1, &geom);
  if (geom < 0 || dist < 0) return -1;
  point_world = p + dist * v;
  return engine_body_[model_->geom_bodyid[geom]];
}

Eigen::Vector2d SceneView::project(const Eigen::Vector3d& world, double aspect) const {
  mjvGLCamera cam = mjv_averageCamera(scn_.camera, scn_.camera + 1);
  Eigen::Vector3d pos(cam.pos[0], cam.pos[1], cam.pos[2]);
  Eigen::Vector3d fwd(cam.forward[0], cam.forward[1], cam.forward[2]);
  Eigen::Vector3d up(cam.up[0], cam.up[1], cam.up[2]);
  Eigen::Vector3d right = fwd.cross(up);
  Eigen::Vector3d r = to_view(world) - pos;
  double depth = r.dot(fwd);
  if (depth <= 0) return Eigen::Vector2d::Constant(std::nan(""));
  // on the near plane, as the frustum is given
  double x = r.dot(right) * cam.frustum_near / depth;
  double y = r.dot(up) * cam.frustum_near / depth;
  double height = cam.frustum_top - cam.frustum_bottom;
  return {0.5 + (x - cam.frustum_center) / (aspect * height), (y - cam.frustum_bottom) / height};
}

double SceneView::subtree_mass(int engine_body) const {
  const std::vector<int>& ids = *render_.body_ids;
  int id = engine_body >= 0 && engine_body < static_cast<int>(ids.size()) ? ids[engine_body] : -1;
  return id >= 0 ? model_->body_subtreemass[id] : 0.0;
}

Eigen::Vector3d SceneView::mouse_motion_in_world(double dx, double dy, int height,
                                                 const Eigen::Vector3d& at, bool horizontal) const {
  mjvGLCamera cam = mjv_averageCamera(scn_.camera, scn_.camera + 1);
  Eigen::Vector3d pos(cam.pos[0], cam.pos[1], cam.pos[2]);
  Eigen::Vector3d fwd(cam.forward[0], cam.forward[1], cam.forward[2]);
  Eigen::Vector3d up(cam.up[0], cam.up[1], cam.up[2]);
  Eigen::Vector3d right = fwd.cross(up);
  // metres per pixel at the depth of `at`
  double depth = std::max(0.05, fwd.dot(to_view(at) - pos));
  double scale = depth * mjv_frustumHeight(&scn_) / std::max(1, height);
  Eigen::Vector3d away = up;
  if (horizontal) {
    // the ground plane: the camera's forward direction flattened
    away = fwd - fwd.z() * Eigen::Vector3d::UnitZ();
    if (away.norm() < 1e-6) away = up;
    away.normalize();
  }
  Eigen::Vector3d move_view = scale * (dx * right - dy * away);
  return view_rot_.transpose() * move_view;
}

void SceneView::update(Simulation& run, const std::vector<ForceArrow>& extra_forces,
                       const std::vector<Marker>& extra_markers) {
  Engine& engine = run.engine();
  engine.forward();
  render_ = engine.render_model();
  time_ = engine.time();

  // the follow camera looks at the filtered root, in the view frame
  track_root(engine);
  if (options.camera == CameraMode::kFollow)
    for (int i = 0; i < 3; ++i) cam_.lookat[i] = focus_[i];
  // mjv_updateScene reads the poses in mjData and computes no kinematics
  mjv_updateScene(model_, render_.data, &opt_, nullptr, &cam_, mjCAT_ALL, &scn_);
  if (options.ghost && ghost_engine_) add_ghost(run);

  // turn the model's geoms and lights so that up is +z
  Eigen::Matrix3f r = view_rot_.cast<float>();
  for (int i = 0; i < scn_.ngeom; ++i) {
    mjvGeom& g = scn_.geoms[i];
    Eigen::Map<Eigen::Vector3f> pos(g.pos);
    pos = r * Eigen::Vector3f(pos);
    Eigen::Map<Eigen::Matrix<float, 3, 3, Eigen::RowMajor>> mat(g.mat);
    mat = r * Eigen::Matrix3f(mat);
  }
  for (int i = 0; i < scn_.nlight; ++i) {
    mjvLight& l = scn_.lights[i];
    if (l.headlight) continue;
    Eigen::Map<Eigen::Vector3f> pos(l.pos), dir(l.dir);
    pos = r * Eigen::Vector3f(pos);
    dir = r * Eigen::Vector3f(dir);
  }
  // stance's floor, sky and lights (unless the model brings its own); the key light's shadow
  // covers the character wherever the camera looks
  look_.dress(model_, scn_, con_, focus_, std::max(2.5, 1.6 * character_size_));

  // pushes: arrows ending at the pushed point, one body weight = 1 m
  auto draw_force = [&](const Eigen::Vector3d& point, const Eigen::Vector3d& f) {
    Eigen::Vector3d len = f / body_weight_n_;
    // small pushes still show: at least 0.35 m (a 50 N push on a 60 kg biped is 8.5 cm)
    if (len.norm() < 0.35) len = 0.35 * f.normalized();
    add_arrow(point - len, point, kPushColor, 0.03);
  };
  if (options.pushes) {
    for (const auto& push : run.model().pushes)
      if (push.p.active_at(time_) && push.p.force.norm() > 0)
        draw_force(push_point(engine, push), push.p.force);
    for (const auto& a : extra_forces)
      if (a.force.norm() > 0) draw_force(a.point, a.force);
  }
  if (options.contacts) {
    for (int i = 0, n = engine.num_contacts(); i < n; ++i) {
      Contact c = engine.contact(i);
      add_sphere(c.pos, 0.02, kContactColor);
      // the force on body2, scaled as the pushes: one body weight = 1 m
      if (c.force.norm() > 1e-6)
        add_arrow(c.pos, c.pos + c.force / body_weight_n_, kContactColor, 0.012);
    }
  }
  if (options.markers) {
    markers_.clear();
    for (size_t i = 0; i < run.controllers().size(); ++i)
      if (const Drawable* drawn = run.controllers()[i]->as<Drawable>())
        drawn->markers(run.controller_state(i), engine, markers_);
    for (const auto& m : markers_) add_marker(m);
    // the planner's chosen rollout: where the root goes over the horizon
    if (const Planner* planner = planner_of(run)) {
      const auto& path = planner->best_path();
      for (size_t k = 1; k < path.size(); ++k) {
        Marker line;
        line.shape = Marker::Shape::kLine;
        line.pos = path[k - 1];
        line.end = path[k];
        line.radius = 0.008;
        line.rgba = {0.2f, 0.85f, 0.3f, 0.9f};
        add_marker(line);
      }
    }
  }
  for (const auto& m : extra_markers) add_marker(m);
  if (options.com) {
    Eigen::Vector3d com = engine.com();
    add_sphere(com, 0.045, kComColor);
    // support marker: the COM's projection onto the ground along up
    double h = up_.dot(com) - ground_height_;
    add_sphere(com - h * up_, 0.03, kSupportColor);
  }
}

void SceneView::render_window(int width, int height, const std::string& overlay) {
  mjrRect vp = {0, 0, width, height};
  mjr_setBuffer(mjFB_WINDOW, &con_);
  look_.begin_render();
  mjr_render(vp, &scn_, &con_);
  look_.end_render();
  if (!overlay.empty())
    mjr_overlay(mjFONT_NORMAL, mjGRID_TOPRIGHT, vp, overlay.c_str(), nullptr, &con_);
}

void SceneView::render_offscreen(int width, int height, std::vector<unsigned char>& rgb,
                                 const std::string& overlay) {
  if (width > con_.offWidth || height > con_.offHeight)
    throw std::runtime_error("frame larger than the offscreen buffer");
  mjrRect vp = {0, 0, width, height};
  mjr_setBuffer(mjFB_OFFSCREEN, &con_);
  look_.begin_render();
  mjr_render(vp, &scn_, &con_);
  look_.end_render();
  if (!overlay.empty())
    mjr_overlay(mjFONT_NORMAL, mjGRID_TOPRIGHT, vp, overlay.c_str(), nullptr, &con_);
  std::vector<unsigned char> bottom_up(static_cast<size_t>(width) * height * 3);
  mjr_readPixels(bottom_up.data(), nullptr, vp, &con_);
  // OpenGL rows start at the bottom; images start at the top
  rgb.resize(bottom_up.size());
  size_t row = static_cast<size_t>(width) * 3;
  for (int y = 0; y < height; ++y)
    std::copy_n(bottom_up.data() + (height - 1 - y) * row, row, rgb.data() + y * row);
}

}  // namespace stance
