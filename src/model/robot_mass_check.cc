// The check that a robot's joints move something with inertia (read_robot runs it).
#include "model/robot_model.h"

#include <tinyxml2.h>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/model_format.h"
#include "model/mjcf_writing.h"
#include "model/robot_model_detail.h"
#include "model/xml_reader.h"

namespace stance {

namespace {

using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;

// ---------------------------------------------------------------------------------------------
// masses an engine can move: every joint's dofs must carry inertia. Massless links are fine
// where something with mass is welded to them or hangs below them (URDF "dummy" links); a
// floating base whose links all weigh 0 (DART asserts mTotalMass != 0) or a hinge that turns
// nothing with inertia about its axis (DART's articulated-body recursion divides by 0 and
// asserts !isNan) is refused, with the joint's line.

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

Matrix3d skew(const Vector3d& v) {
  Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// a link's spatial inertia about its frame's origin, in its axes, (angular; linear)
Matrix6d spatial_inertia(const RobotLink& l) {
  const Matrix3d c = skew(l.com);
  Matrix6d s;
  s << l.inertia + l.mass * c * c.transpose(), l.mass * c, l.mass * c.transpose(),
      l.mass * Matrix3d::Identity();
  return s;
}

// a child link's spatial inertia in its parent's frame; `t` is the child's pose in the parent
Matrix6d inertia_in_parent(const Isometry3d& t, const Matrix6d& child) {
  // the motion transform parent -> child coordinates; I_parent = X^T I_child X
  const Matrix3d rt = t.linear().transpose();
  Matrix6d x = Matrix6d::Zero();
  x.topLeftCorner<3, 3>() = rt;
  x.bottomLeftCorner<3, 3>() = -rt * skew(t.translation());
  x.bottomRightCorner<3, 3>() = rt;
  return x.transpose() * child * x;
}

// the joint's motion subspace in its child link's frame (angular; linear), one column per dof
Matrix6Xd motion_subspace(RobotJointType type, const Isometry3d& child_to_joint,
                          const Vector3d& axis_in_joint) {
  const Vector3d p = child_to_joint.translation();
  const Vector3d a = child_to_joint.linear() * axis_in_joint;
  Matrix6Xd s;
  switch (type) {
    case RobotJointType::kFixed:
      return Matrix6Xd(6, 0);
    case RobotJointType::kRevolute:
    case RobotJointType::kContinuous:
      s.resize(6, 1);
      s << a, p.cross(a);
      return s;
    case RobotJointType::kPrismatic:
      s.resize(6, 1);
      s << Vector3d::Zero(), a;
      return s;
    case RobotJointType::kBall:
      s.resize(6, 3);
      s << Matrix3d::Identity(), skew(p);
      return s;
    case RobotJointType::kFloating:
      return Matrix6d::Identity();
  }
  return Matrix6Xd(6, 0);
}

// what a joint moves, as the link below it sees it
struct MovedInertia {
  Matrix6d articulated = Matrix6d::Zero();  // with the joints below free
  Matrix6d composite = Matrix6d::Zero();    // with the joints below locked
  double mass = 0;                          // kg, of the links below
};

class MassCheck {
 public:
  explicit MassCheck(const RobotModel& m) : m_(m) {
    for (const RobotLink& l : m.links) links_[l.name] = &l;
    for (const RobotJoint& j : m.joints) children_[j.parent].push_back(&j);
  }

  void run() {
    // a floating base that weighs nothing at all: said so, before any joint below it
    double mass = 0;
    for (const RobotLink& l : m_.links) mass += l.mass;
    if (!m_.root_joint.empty() && !(mass > 0))
      fail(RobotJointType::kFloating, m_.root, m_.root_joint, links_.at(m_.root)->line, mass);
    collect_below();
    if (m_.root == "world") {
      for (const RobotJoint* j : children_["world"])
        seen_through(j->type, j->child, j->child_to_joint, j->axis, j->name, j->line);
      return;
    }
    const RobotJointType root_type =
        m_.root_joint.empty() ? RobotJointType::kFixed : RobotJointType::kFloating;
    seen_through(root_type, m_.root, Isometry3d::Identity(), Vector3d::UnitX(), m_.root_joint,
                 links_.at(m_.root)->line);
  }

 private:
  // below_[link]: the inertia of the link and everything below it, leaves first (no
  // recursion: a chain may be kMaxRobotLinks deep); every joint below a link is checked
  void collect_below() {
    std::vector<std::string> order;
    std::vector<std::string> stack;
    if (m_.root != "world") stack.push_back(m_.root);
    for (const RobotJoint* j : children_["world"]) stack.push_back(j->child);
    while (!stack.empty()) {
      order.push_back(stack.back());
      stack.pop_back();
      for (const RobotJoint* j : children_[order.back()]) stack.push_back(j->child);
    }
    for (auto it = order.rbegin(); it != order.rend(); ++it) {
      const RobotLink& l = *links_.at(*it);
      MovedInertia out;
      out.articulated = out.composite = spatial_inertia(l);
      out.mass = l.mass;
      for (const RobotJoint* j : children_[l.name]) {
        const MovedInertia& child = below_.at(j->child);
        const Matrix6d seen =
            seen_through(j->type, j->child, j->child_to_joint, j->axis, j->name, j->line);
        out.articulated += inertia_in_parent(j->parent_to_child, seen);
        out.composite += inertia_in_parent(j->parent_to_child, child.composite);
        out.mass += child.mass;
      }
      below_[l.name] = out;
    }
  }

  // checks the joint above `child` (its dofs must carry inertia) and returns the articulated
  // inertia the joint's parent sees through it
  Matrix6d seen_through(RobotJointType type, const std::string& child,
                        const Isometry3d& child_to_joint, const Vector3d& axis,
                        const std::string& joint, int line) const {
    const MovedInertia& moved = below_.at(child);
    const Matrix6Xd s = motion_subspace(type, child_to_joint, axis);
    if (s.cols() == 0) return moved.articulated;
    const Eigen::MatrixXd d = s.transpose() * moved.articulated * s;
    const Eigen::MatrixXd rigid = s.transpose() * moved.composite * s;
    // relative to the same dofs with the joints below locked: rounding leaves ~1e-16 of that
    const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(d).eigenvalues()(0);
    const double scale =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(rigid).eigenvalues()(rigid.rows() - 1);
    if (!(smallest > kMinMovedInertia && smallest > 1e-10 * scale))
      fail(type, child, joint, line, moved.mass);
    return moved.articulated -
           moved.articulated * s * d.inverse() * s.transpose() * moved.articulated;
  }

  [[noreturn]] void fail(RobotJointType type, const std::string& child, const std::string& joint,
                         int line, double mass) const {
    const int child_line = links_.at(child)->line;
    if (type == RobotJointType::kFloating && mass <= 0)
      throw InputError(located(
          m_.file, line,
          fmt::format("link '{}': a floating base whose links all weigh 0 kg cannot move: give "
                      "the links <inertial> masses, or weld the base to the world",
                      child)));
    const std::string what =
        mass <= 0 ? fmt::format("link '{}' (line {}) and the links below it weigh 0 kg", child,
                                child_line)
                  : fmt::format(
                        "link '{}' (line {}) and the links below it have no inertia "
                        "about the joint's axis",
                        child, child_line);
    throw InputError(located(
        m_.file, line,
        fmt::format("joint '{}' moves nothing with inertia: {}; give them <inertial> mass and "
                    "inertia, or make the joint fixed",
                    joint, what)));
  }

  // kg m^2 or kg: MuJoCo's mjMINVAL, below which it refuses a moving body's mass and inertia
  static constexpr double kMinMovedInertia = 1e-15;

  const RobotModel& m_;
  std::map<std::string, const RobotLink*> links_;
  std::map<std::string, std::vector<const RobotJoint*>> children_;
  std::map<std::string, MovedInertia> below_;
};

}  // namespace

namespace robot_detail {

void check_robot_masses(const RobotModel& m) {
  MassCheck(m).run();
}

}  // namespace robot_detail

}  // namespace stance
