// Shared by the URDF/SDF reader (robot_model.cc) and its MJCF translation (robot_to_mjcf.cc);
// not for other code.
#pragma once

#include <Eigen/Core>
#include <string>

namespace stance::robot_detail {

// the box (full extents, centre in the mesh frame) fitted to a mesh; flat sides raised to 1 mm
struct FittedBox {
  Eigen::Vector3d size, centre;
};
FittedBox fit_box(const std::string& shown_name, int line, const std::string& mesh,
                  const Eigen::Vector3d& scale);

// a path's extension, lowercase, with its dot (".stl")
std::string lower_extension(const std::string& path);

}  // namespace stance::robot_detail
