// Rotation maths as free functions: Euler angles in any axis order, quaternion slerp, log/exp,
// geodesic distance and angular velocity. All angles are radians unless a name says _deg.
//
// Euler convention (the BVH one): an order lists three distinct axes, e.g. ZXY, and angles
// (a, b, c) mean R = Rz(a) * Rx(b) * Ry(c): intrinsic rotations applied in the listed order
// (equivalently extrinsic in reverse). angles[i] always belongs to the i-th listed axis.
#pragma once

#include <array>
#include <numbers>
#include <optional>
#include <string_view>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace stance {

inline constexpr double kDegToRad = std::numbers::pi / 180.0;
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// the six Tait-Bryan orders, named by their listed axes
enum class RotationOrder { kXYZ, kXZY, kYXZ, kYZX, kZXY, kZYX };

// "XYZ", "ZXY", ...
std::string_view rotation_order_name(RotationOrder order);

// parses "ZXY" (case-insensitive); nullopt for anything that is not three distinct axes
std::optional<RotationOrder> parse_rotation_order(std::string_view name);

// axis indices (0 = x, 1 = y, 2 = z) in listed order
std::array<int, 3> rotation_axes(RotationOrder order);

// the order that lists these three distinct axes; nullopt when they repeat or are out of range
std::optional<RotationOrder> rotation_order_from_axes(int first, int second, int third);

// rotation of `angle` about the unit axis `axis` (0 = x, 1 = y, 2 = z)
Eigen::Quaterniond axis_rotation(int axis, double angle);

// R = R_first(angles[0]) * R_second(angles[1]) * R_third(angles[2]); angles dim 3 in listed order
Eigen::Quaterniond euler_to_quaternion(const Eigen::Vector3d& angles, RotationOrder order);

// inverse of euler_to_quaternion: angles (dim 3, listed order) with the middle angle in
// [-pi/2, pi/2] and the others in [-pi, pi]. Near gimbal lock the split between the first and
// third angle is ill-posed; the result still reproduces q to rounding error, and exactly at the
// lock the third angle is 0. q need not be normalised.
Eigen::Vector3d quaternion_to_euler(const Eigen::Quaterniond& q, RotationOrder order);

// like quaternion_to_euler, but of all equivalent angle triples (both branches, any multiple of
// 2 pi) returns the one closest to `near`: use it to keep angle curves continuous over frames
Eigen::Vector3d quaternion_to_euler_near(const Eigen::Quaterniond& q, RotationOrder order,
                                         const Eigen::Vector3d& near);

// shortest-path spherical interpolation: t = 0 gives a, t = 1 gives b (or -b, the same rotation)
Eigen::Quaterniond slerp(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double t);

// rotation vector (axis * angle, angle in [0, pi]) of a unit quaternion: the log map, scaled to
// the full angle. Accurate for tiny angles.
Eigen::Vector3d quaternion_log(const Eigen::Quaterniond& q);

// unit quaternion of a rotation vector (axis * angle): inverse of quaternion_log
Eigen::Quaterniond quaternion_exp(const Eigen::Vector3d& rotation_vector);

// angle in [0, pi] of the rotation taking a to b; q and -q count as the same rotation
double geodesic_angle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

// constant angular velocity (rad/s, dim 3) that turns q0 into q1 in dt seconds, expressed in
// the world (fixed) frame: q1 = exp(w dt) * q0
Eigen::Vector3d angular_velocity_world(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1,
                                       double dt);

// the same motion expressed in the body frame of q0 (what a ball joint's qvel holds):
// q1 = q0 * exp(w dt)
Eigen::Vector3d angular_velocity_body(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1,
                                      double dt);

}  // namespace stance
