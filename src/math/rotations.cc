#include "math/rotations.h"

#include <cctype>
#include <cmath>
#include <numbers>

namespace stance {

namespace {

constexpr double kPi = std::numbers::pi;

struct OrderInfo {
  RotationOrder order;
  std::string_view name;
  std::array<int, 3> axes;
};

constexpr std::array<OrderInfo, 6> kOrders = {{
    {RotationOrder::kXYZ, "XYZ", {0, 1, 2}},
    {RotationOrder::kXZY, "XZY", {0, 2, 1}},
    {RotationOrder::kYXZ, "YXZ", {1, 0, 2}},
    {RotationOrder::kYZX, "YZX", {1, 2, 0}},
    {RotationOrder::kZXY, "ZXY", {2, 0, 1}},
    {RotationOrder::kZYX, "ZYX", {2, 1, 0}},
}};

const OrderInfo& info(RotationOrder order) {
  return kOrders[static_cast<int>(order)];
}

// x + 2 pi n closest to target
double wrap_near(double x, double target) {
  return x + 2.0 * kPi * std::round((target - x) / (2.0 * kPi));
}

}  // namespace

std::string_view rotation_order_name(RotationOrder order) {
  return info(order).name;
}

std::optional<RotationOrder> parse_rotation_order(std::string_view name) {
  if (name.size() != 3) return std::nullopt;
  std::array<int, 3> axes{};
  for (int i = 0; i < 3; ++i) {
    char c = static_cast<char>(std::toupper(static_cast<unsigned char>(name[i])));
    if (c < 'X' || c > 'Z') return std::nullopt;
    axes[i] = c - 'X';
  }
  return rotation_order_from_axes(axes[0], axes[1], axes[2]);
}

std::array<int, 3> rotation_axes(RotationOrder order) {
  return info(order).axes;
}

std::optional<RotationOrder> rotation_order_from_axes(int first, int second, int third) {
  for (const auto& o : kOrders) {
    if (o.axes[0] == first && o.axes[1] == second && o.axes[2] == third) return o.order;
  }
  return std::nullopt;
}

Eigen::Quaterniond axis_rotation(int axis, double angle) {
  Eigen::Quaterniond q(std::cos(0.5 * angle), 0.0, 0.0, 0.0);
  q.vec()[axis] = std::sin(0.5 * angle);
  return q;
}

Eigen::Quaterniond euler_to_quaternion(const Eigen::Vector3d& angles, RotationOrder order) {
  const auto& ax = info(order).axes;
  return axis_rotation(ax[0], angles[0]) * axis_rotation(ax[1], angles[1]) *
         axis_rotation(ax[2], angles[2]);
}

Eigen::Vector3d quaternion_to_euler(const Eigen::Quaterniond& q, RotationOrder order) {
  const auto& ax = info(order).axes;
  const int i = ax[0], j = ax[1], k = ax[2];
  // s = +1 when (i, j, k) is a cyclic permutation of (x, y, z); row i of R is then
  // (cos b cos c) e_i - s (cos b sin c) e_j + s (sin b) e_k
  const double s = (j == (i + 1) % 3) ? 1.0 : -1.0;
  const Eigen::Matrix3d r = q.normalized().toRotationMatrix();

  // third angle first; at the lock (cos b = 0) it is arbitrary and we pick 0
  double c = 0.0;
  if (std::hypot(r(i, i), r(i, j)) > 1e-12) c = std::atan2(-s * r(i, j), r(i, i));

  // peel off Rk(c): M = Ri(a) Rj(b), whose column j is Ri(a) e_j. Solving a and b from the
  // exact remainder keeps R = Ri(a) Rj(b) Rk(c) to rounding even when c is ill-conditioned.
  const Eigen::Matrix3d m = r * axis_rotation(k, -c).toRotationMatrix();
  const double a = std::atan2(s * m(k, j), m(j, j));
  const Eigen::Matrix3d n = axis_rotation(i, -a).toRotationMatrix() * m;  // = Rj(b)
  const double b = std::atan2(-s * n(k, i), n(i, i));
  return {a, b, c};
}

Eigen::Vector3d quaternion_to_euler_near(const Eigen::Quaterniond& q, RotationOrder order,
                                         const Eigen::Vector3d& near) {
  const Eigen::Vector3d first = quaternion_to_euler(q, order);
  // the other branch of a Tait-Bryan decomposition: (a + pi, pi - b, c + pi)
  const Eigen::Vector3d second(first[0] + kPi, kPi - first[1], first[2] + kPi);
  Eigen::Vector3d best = first;
  double best_d = INFINITY;
  for (const Eigen::Vector3d& cand : {first, second}) {
    Eigen::Vector3d w;
    for (int i = 0; i < 3; ++i) w[i] = wrap_near(cand[i], near[i]);
    double d = (w - near).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = w;
    }
  }
  return best;
}

Eigen::Quaterniond slerp(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double t) {
  // via log/exp of the relative rotation: accurate for tiny angles, always the short way
  const Eigen::Quaterniond rel = a.conjugate() * b;
  return (a * quaternion_exp(t * quaternion_log(rel))).normalized();
}

Eigen::Vector3d quaternion_log(const Eigen::Quaterniond& q) {
  // q and -q are the same rotation; use w >= 0 so the angle lands in [0, pi]
  const double sign = q.w() < 0.0 ? -1.0 : 1.0;
  const Eigen::Vector3d v = sign * q.vec();
  const double w = sign * q.w();
  const double n = v.norm();
  if (n == 0.0) return Eigen::Vector3d::Zero();
  const double angle = 2.0 * std::atan2(n, w);
  return v * (angle / n);
}

Eigen::Quaterniond quaternion_exp(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  // sin(angle / 2) / angle, with its series below where the division loses precision
  const double scale = angle < 1e-6 ? 0.5 - angle * angle / 48.0 : std::sin(0.5 * angle) / angle;
  Eigen::Quaterniond q;
  q.w() = std::cos(0.5 * angle);
  q.vec() = scale * rotation_vector;
  return q;
}

double geodesic_angle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const Eigen::Quaterniond rel = a.conjugate() * b;
  // atan2 is accurate at both ends, unlike acos of the dot product near 0
  return 2.0 * std::atan2(rel.vec().norm(), std::abs(rel.w()));
}

Eigen::Vector3d angular_velocity_world(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1,
                                       double dt) {
  return quaternion_log(q1.normalized() * q0.normalized().conjugate()) / dt;
}

Eigen::Vector3d angular_velocity_body(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1,
                                      double dt) {
  return quaternion_log(q0.normalized().conjugate() * q1.normalized()) / dt;
}

}  // namespace stance
