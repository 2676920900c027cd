#include "math/rotations.h"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

namespace stance {
namespace {

constexpr double kPi = std::numbers::pi;

const std::array<RotationOrder, 6> kAllOrders = {RotationOrder::kXYZ, RotationOrder::kXZY,
                                                 RotationOrder::kYXZ, RotationOrder::kYZX,
                                                 RotationOrder::kZXY, RotationOrder::kZYX};

Eigen::Vector3d unit_axis(int axis) {
  return Eigen::Vector3d::Unit(axis);
}

// the same rotation built from Eigen's own AngleAxis products
Eigen::Quaterniond angle_axis_product(const Eigen::Vector3d& angles, RotationOrder order) {
  auto ax = rotation_axes(order);
  return Eigen::Quaterniond(Eigen::AngleAxisd(angles[0], unit_axis(ax[0])) *
                            Eigen::AngleAxisd(angles[1], unit_axis(ax[1])) *
                            Eigen::AngleAxisd(angles[2], unit_axis(ax[2])));
}

TEST(RotationOrder, NamesParseAndAxes) {
  for (RotationOrder o : kAllOrders) {
    auto name = rotation_order_name(o);
    auto parsed = parse_rotation_order(name);
    ASSERT_TRUE(parsed.has_value()) << name;
    EXPECT_EQ(*parsed, o);
    auto ax = rotation_axes(o);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(ax[i], name[i] - 'X');
  }
  EXPECT_EQ(parse_rotation_order("zxy"), RotationOrder::kZXY);
  EXPECT_FALSE(parse_rotation_order("ZZY").has_value());
  EXPECT_FALSE(parse_rotation_order("ZX").has_value());
  EXPECT_FALSE(parse_rotation_order("ZXW").has_value());
  EXPECT_FALSE(rotation_order_from_axes(0, 1, 1).has_value());
}

TEST(EulerToQuaternion, MatchesAngleAxisProductsInEveryOrder) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  for (RotationOrder o : kAllOrders) {
    for (int trial = 0; trial < 200; ++trial) {
      Eigen::Vector3d e(angle(rng), angle(rng), angle(rng));
      Eigen::Quaterniond q = euler_to_quaternion(e, o);
      EXPECT_NEAR(q.norm(), 1.0, 1e-15);
      EXPECT_LT(geodesic_angle(q, angle_axis_product(e, o)), 1e-12) << rotation_order_name(o);
    }
  }
}

TEST(EulerToQuaternion, BvhIntrinsicMeaning) {
  // ZXY with (90, 0, 0) deg: a pure 90 deg turn about z maps x to y
  Eigen::Quaterniond q = euler_to_quaternion(Eigen::Vector3d(kPi / 2, 0, 0), RotationOrder::kZXY);
  EXPECT_LT((q * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-15);
  // ZXY with z = 90, x = 90: intrinsic, so x turns about the already-turned x axis (= world y)
  q = euler_to_quaternion(Eigen::Vector3d(kPi / 2, kPi / 2, 0), RotationOrder::kZXY);
  Eigen::Matrix3d expected = (Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX()))
                                 .toRotationMatrix();
  EXPECT_LT((q.toRotationMatrix() - expected).norm(), 1e-15);
  // the local z axis (after Rz then Rx) points along world x... z -> (Rx) -y -> (Rz) +x
  EXPECT_LT((q * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitX()).norm(), 1e-15);
}

TEST(QuaternionToEuler, RoundTripAllOrdersRandomAngles) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> outer(-kPi + 1e-6, kPi - 1e-6);
  std::uniform_real_distribution<double> middle(-kPi / 2 + 1e-3, kPi / 2 - 1e-3);
  for (RotationOrder o : kAllOrders) {
    for (int trial = 0; trial < 1000; ++trial) {
      Eigen::Vector3d e(outer(rng), middle(rng), outer(rng));
      Eigen::Vector3d back = quaternion_to_euler(euler_to_quaternion(e, o), o);
      EXPECT_LT((back - e).cwiseAbs().maxCoeff(), 1e-12)
          << rotation_order_name(o) << " " << e.transpose() << " -> " << back.transpose();
    }
  }
}

TEST(QuaternionToEuler, RandomQuaternionsReproduceRotation) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (RotationOrder o : kAllOrders) {
    for (int trial = 0; trial < 500; ++trial) {
      Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));  // not normalised on purpose
      Eigen::Vector3d e = quaternion_to_euler(q, o);
      EXPECT_LE(std::abs(e[1]), kPi / 2 + 1e-15);
      EXPECT_LT(geodesic_angle(q.normalized(), euler_to_quaternion(e, o)), 1e-12);
    }
  }
}

TEST(QuaternionToEuler, GimbalLockStillReproducesRotation) {
  // middle angle at and near +-90 deg: the first/third split is ambiguous, the rotation is not
  for (RotationOrder o : kAllOrders) {
    for (double mid : {kPi / 2, -kPi / 2, kPi / 2 - 1e-9, -kPi / 2 + 1e-7, kPi / 2 - 1e-5}) {
      for (double a : {0.0, 0.3, -2.5}) {
        for (double c : {0.0, 1.1, -0.7}) {
          Eigen::Vector3d e(a, mid, c);
          Eigen::Quaterniond q = euler_to_quaternion(e, o);
          Eigen::Vector3d back = quaternion_to_euler(q, o);
          EXPECT_TRUE(back.allFinite());
          EXPECT_LT(geodesic_angle(q, euler_to_quaternion(back, o)), 1e-12)
              << rotation_order_name(o) << " " << e.transpose();
          EXPECT_NEAR(back[1], mid, 1e-4);
        }
      }
      // exactly at the lock the third angle is 0 and the first absorbs both
      if (std::abs(mid) == kPi / 2) {
        Eigen::Vector3d back = quaternion_to_euler(euler_to_quaternion({0.4, mid, 0.0}, o), o);
        EXPECT_NEAR(back[2], 0.0, 1e-7);
        EXPECT_NEAR(back[0], 0.4, 1e-7);
      }
    }
  }
}

TEST(QuaternionToEuler, NearChoosesContinuousBranch) {
  for (RotationOrder o : kAllOrders) {
    // previous frame close to +180 on the first axis; the canonical answer would jump to -179
    Eigen::Vector3d prev(kPi - 0.01, 0.2, 0.1);
    Eigen::Vector3d now(kPi + 0.01, 0.2, 0.1);
    Eigen::Quaterniond q = euler_to_quaternion(now, o);
    Eigen::Vector3d canonical = quaternion_to_euler(q, o);
    EXPECT_NEAR(canonical[0], -kPi + 0.01, 1e-12);
    Eigen::Vector3d near = quaternion_to_euler_near(q, o, prev);
    EXPECT_LT((near - now).norm(), 1e-12);
    // the other branch (a + pi, pi - b, c + pi) is picked when it is the closer one
    Eigen::Vector3d other(0.3 + kPi, kPi - 0.2, -0.4 + kPi);
    Eigen::Vector3d got = quaternion_to_euler_near(euler_to_quaternion(other, o), o, other);
    EXPECT_LT((got - other).norm(), 1e-12);
  }
}

TEST(QuaternionLogExp, RoundTripAndKnownValues) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  for (int trial = 0; trial < 500; ++trial) {
    Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    double angle = std::uniform_real_distribution<double>(0.0, kPi - 1e-6)(rng);
    Eigen::Vector3d r = axis * angle;
    Eigen::Quaterniond q = quaternion_exp(r);
    EXPECT_NEAR(q.norm(), 1.0, 1e-15);
    EXPECT_LT(geodesic_angle(q, Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis))), 1e-12);
    EXPECT_LT((quaternion_log(q) - r).norm(), 1e-12);
  }
  // tiny angles keep full relative precision
  Eigen::Vector3d tiny(1e-12, -2e-12, 3e-13);
  EXPECT_LT((quaternion_log(quaternion_exp(tiny)) - tiny).norm(), 1e-26);
  EXPECT_EQ(quaternion_log(Eigen::Quaterniond::Identity()), Eigen::Vector3d::Zero());
  // -q gives the same rotation vector
  Eigen::Quaterniond q = quaternion_exp(Eigen::Vector3d(0.1, 0.2, 0.3));
  Eigen::Quaterniond neg(-q.w(), -q.x(), -q.y(), -q.z());
  EXPECT_LT((quaternion_log(neg) - Eigen::Vector3d(0.1, 0.2, 0.3)).norm(), 1e-15);
  // half turn about z
  EXPECT_LT((quaternion_log(Eigen::Quaterniond(0, 0, 0, 1)) - Eigen::Vector3d(0, 0, kPi)).norm(),
            1e-15);
}

TEST(GeodesicAngle, KnownCases) {
  Eigen::Quaterniond id = Eigen::Quaterniond::Identity();
  EXPECT_EQ(geodesic_angle(id, id), 0.0);
  EXPECT_NEAR(geodesic_angle(id, axis_rotation(0, 0.5)), 0.5, 1e-15);
  EXPECT_NEAR(geodesic_angle(id, axis_rotation(1, -0.5)), 0.5, 1e-15);
  EXPECT_NEAR(geodesic_angle(id, axis_rotation(2, kPi)), kPi, 1e-15);
  // 270 deg one way is 90 deg the other way
  EXPECT_NEAR(geodesic_angle(id, axis_rotation(2, 1.5 * kPi)), 0.5 * kPi, 1e-15);
  // q and -q
  Eigen::Quaterniond q = axis_rotation(1, 0.7);
  Eigen::Quaterniond neg(-q.w(), -q.x(), -q.y(), -q.z());
  EXPECT_NEAR(geodesic_angle(q, neg), 0.0, 1e-15);
  // left-invariant: same relative rotation from another start
  Eigen::Quaterniond base = euler_to_quaternion({0.3, -0.2, 1.0}, RotationOrder::kZXY);
  EXPECT_NEAR(geodesic_angle(base, base * axis_rotation(0, 0.25)), 0.25, 1e-14);
  // 90 about x then 90 about y: composite angle is 120 deg
  EXPECT_NEAR(geodesic_angle(id, axis_rotation(0, kPi / 2) * axis_rotation(1, kPi / 2)),
              2 * kPi / 3, 1e-14);
  // tiny separation is resolved, not rounded to 0 as acos of a dot product would be
  EXPECT_NEAR(geodesic_angle(id, axis_rotation(2, 1e-10)), 1e-10, 1e-22);
}

TEST(Slerp, EndpointsMidpointAndShortPath) {
  Eigen::Quaterniond a = axis_rotation(2, 0.2);
  Eigen::Quaterniond b = axis_rotation(2, 1.0);
  EXPECT_LT(geodesic_angle(slerp(a, b, 0.0), a), 1e-15);
  EXPECT_LT(geodesic_angle(slerp(a, b, 1.0), b), 1e-14);
  EXPECT_LT(geodesic_angle(slerp(a, b, 0.25), axis_rotation(2, 0.4)), 1e-14);
  // b given as -b still interpolates along the short arc
  Eigen::Quaterniond negb(-b.w(), -b.x(), -b.y(), -b.z());
  EXPECT_LT(geodesic_angle(slerp(a, negb, 0.5), axis_rotation(2, 0.6)), 1e-14);
  // agrees with Eigen's slerp for general rotations
  Eigen::Quaterniond c = euler_to_quaternion({0.3, 1.0, -2.0}, RotationOrder::kYXZ);
  Eigen::Quaterniond d = euler_to_quaternion({-1.2, 0.4, 0.9}, RotationOrder::kXZY);
  for (double t : {0.1, 0.5, 0.9}) {
    EXPECT_LT(geodesic_angle(slerp(c, d, t), c.slerp(t, d)), 1e-12);
    EXPECT_NEAR(geodesic_angle(c, slerp(c, d, t)), t * geodesic_angle(c, d), 1e-12);
  }
}

TEST(AngularVelocity, ConstantRateAboutAnAxis) {
  const double dt = 0.01;
  Eigen::Vector3d w(0.4, -1.0, 2.0);  // rad/s
  Eigen::Quaterniond q0 = euler_to_quaternion({0.5, -0.3, 1.2}, RotationOrder::kZYX);
  // world frame: q1 = exp(w dt) q0
  Eigen::Quaterniond q1 = quaternion_exp(w * dt) * q0;
  EXPECT_LT((angular_velocity_world(q0, q1, dt) - w).norm(), 1e-10);
  // the body-frame rate is the world rate seen from q0
  EXPECT_LT((angular_velocity_body(q0, q1, dt) - q0.conjugate() * w).norm(), 1e-10);
  // sign flips of the inputs do not matter
  Eigen::Quaterniond neg(-q1.w(), -q1.x(), -q1.y(), -q1.z());
  EXPECT_LT((angular_velocity_world(q0, neg, dt) - w).norm(), 1e-10);
}

}  // namespace
}  // namespace stance
