// Shared by the URDF/SDF reader (robot_model.cc, with robot_mesh.cc and robot_mass_check.cc)
// and its MJCF translation (robot_to_mjcf.cc); not for other code.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace stance {
struct RobotModel;
struct RobotOptions;
}  // namespace stance

namespace stance::robot_detail {

// the box (full extents, centre in the mesh frame) fitted to a mesh; flat sides raised to 1 mm
struct FittedBox {
  Eigen::Vector3d size, centre;
};
FittedBox fit_box(const std::string& shown_name, int line, const std::string& mesh,
                  const Eigen::Vector3d& scale);

// a path's extension, lowercase, with its dot (".stl")
std::string lower_extension(const std::string& path);

// the folders of package:// and model:// references: RobotOptions::package_path, then
// STANCE_PACKAGE_PATH (robot_mesh.cc)
std::vector<std::string> package_folders(const RobotOptions& options);

// throws InputError, with the joint's line, when a joint moves nothing with inertia
// (robot_mass_check.cc)
void check_robot_masses(const RobotModel& m);

}  // namespace stance::robot_detail
