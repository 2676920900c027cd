// Markers a controller asks the viewer and the recorder to draw (Controller::markers): what the
// controller is looking at, such as SIMBICON's stance ankle and hip circles. Plain data, world
// frame, no renderer types.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>

namespace stance {

struct Marker {
  enum class Shape {
    kSphere,  // at pos, of radius
    kCircle,  // a flat ring at pos, of radius, in the plane normal to `normal`
    kLine,    // pos to end
    kArrow,   // pos (tail) to end (head)
  };
  Shape shape = Shape::kSphere;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();     // m, world
  Eigen::Vector3d end = Eigen::Vector3d::Zero();     // m, world; lines and arrows
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // circles; zero: the up axis (flat)
  double radius = 0.05;                              // m; width of lines and arrows
  std::array<float, 4> rgba = {1, 1, 1, 1};
  std::string label;  // drawn beside the marker; may be empty
};

}  // namespace stance
