#include "model/mjcf_writing.h"

#include <fmt/format.h>

namespace stance::mjcf {

std::string num(double v) {
  return fmt::format("{:.17g}", v);
}

std::string vec(const Eigen::Vector3d& v) {
  return fmt::format("{} {} {}", num(v.x()), num(v.y()), num(v.z()));
}

std::string quat_text(const Eigen::Quaterniond& q) {
  return fmt::format("{} {} {} {}", num(q.w()), num(q.x()), num(q.y()), num(q.z()));
}

std::string quat_text(const Eigen::Matrix3d& r) {
  return quat_text(Eigen::Quaterniond(r).normalized());
}

void set_pose(tinyxml2::XMLElement* el, const Eigen::Isometry3d& t) {
  el->SetAttribute("pos", vec(t.translation()).c_str());
  if (!t.linear().isIdentity(0.0)) el->SetAttribute("quat", quat_text(t.linear()).c_str());
}

}  // namespace stance::mjcf
