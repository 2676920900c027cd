// Writing MJCF text: the numbers, vectors and poses of the URDF/SDF and SKEL translations.
#pragma once

#include <tinyxml2.h>

#include <Eigen/Geometry>
#include <limits>
#include <string>

namespace stance::mjcf {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
// contype bits used, keeping the masks positive ints
inline constexpr int kCollisionBits = 31;
// MuJoCo 2.2.2 reads XML at most 100 elements deep: <mujoco><worldbody>, the bodies, and the
// innermost body's <geom> leave 96 nested bodies
inline constexpr int kMaxMujocoBodyDepth = 96;

// a number written so that it reads back exactly
std::string num(double v);
std::string vec(const Eigen::Vector3d& v);
// "w x y z"
std::string quat_text(const Eigen::Quaterniond& q);
std::string quat_text(const Eigen::Matrix3d& r);  // of the rotation, normalized
// pos, and quat unless the rotation is exactly the identity
void set_pose(tinyxml2::XMLElement* el, const Eigen::Isometry3d& t);

}  // namespace stance::mjcf
