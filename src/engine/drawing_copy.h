// A MuJoCo copy of an engine's world that only draws (Engine::render_model of engines that are
// not MuJoCo): each pose() copies every body pose of the source engine, by body name, into the
// copy's mjData (body, inertial, geom and site frames). No dynamics run in the copy.
#pragma once

#include <memory>
#include <vector>

#include "engine/engine.h"

namespace stance {

class DrawingCopy {
 public:
  // mujoco_copy: a MuJoCo engine of the same world (the factory's make_mujoco_engine)
  DrawingCopy(std::unique_ptr<Engine> mujoco_copy, const Engine& source);
  // the copy posed as `source` is now (after its forward())
  RenderModel pose(const Engine& source);

 private:
  std::unique_ptr<Engine> copy_;
  RenderModel render_;
  std::vector<int> body_ids_;  // source body -> the copy's mj body id, -1: none
};

}  // namespace stance
