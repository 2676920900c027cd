#include "engine/drawing_copy.h"

#include <mujoco/mujoco.h>

#include "core/error.h"

namespace stance {

DrawingCopy::DrawingCopy(std::unique_ptr<Engine> mujoco_copy, const Engine& source)
    : copy_(std::move(mujoco_copy)) {
  render_ = copy_->render_model();
  if (!render_.model || !render_.body_ids)
    throw EnvironmentError("the drawing copy of a world must be a MuJoCo engine");
  body_ids_.assign(source.nbody(), -1);
  for (int b = 0; b < source.nbody(); ++b) {
    const int cb = copy_->body_index(source.body_name(b));
    if (cb >= 0) body_ids_[b] = (*render_.body_ids)[cb];
  }
  render_.body_ids = &body_ids_;
}

namespace {

// a frame fixed to body `id` at local (pos, quat): its world position and orientation matrix
void place_on_body(const mjData* d, int id, const mjtNum* pos, const mjtNum* quat, mjtNum* xpos,
                   mjtNum* xmat) {
  mju_rotVecMat(xpos, pos, d->xmat + 9 * id);
  mju_addTo3(xpos, d->xpos + 3 * id);
  mjtNum q[4];
  mju_mulQuat(q, d->xquat + 4 * id, quat);
  mju_quat2Mat(xmat, q);
}

}  // namespace

RenderModel DrawingCopy::pose(const Engine& source) {
  const mjModel* m = render_.model;
  mjData* d = render_.data;
  for (int b = 0; b < source.nbody(); ++b) {
    const int id = body_ids_[b];
    if (id < 0) continue;
    const BodyPose pose = source.body_pose(b);
    for (int k = 0; k < 3; ++k) d->xpos[3 * id + k] = pose.pos[k];
    const mjtNum q[4] = {pose.quat.w(), pose.quat.x(), pose.quat.y(), pose.quat.z()};
    mju_copy4(d->xquat + 4 * id, q);
    mju_quat2Mat(d->xmat + 9 * id, q);
    // the body's COM frame follows from its frame
    place_on_body(d, id, m->body_ipos + 3 * id, m->body_iquat + 4 * id, d->xipos + 3 * id,
                  d->ximat + 9 * id);
  }
  for (int g = 0; g < m->ngeom; ++g)
    place_on_body(d, m->geom_bodyid[g], m->geom_pos + 3 * g, m->geom_quat + 4 * g,
                  d->geom_xpos + 3 * g, d->geom_xmat + 9 * g);
  // sites are drawn too: left at the origin they would gather there
  for (int i = 0; i < m->nsite; ++i)
    place_on_body(d, m->site_bodyid[i], m->site_pos + 3 * i, m->site_quat + 4 * i,
                  d->site_xpos + 3 * i, d->site_xmat + 9 * i);
  d->time = source.time();
  return render_;
}

}  // namespace stance
