#include "engine/engine.h"

#include <fmt/format.h>

#include "core/error.h"

namespace stance {

bool Engine::body_in_contact(int body) const {
  for (int i = 0, n = num_contacts(); i < n; ++i) {
    Contact c = contact(i);
    if (c.body1 == body || c.body2 == body) return true;
  }
  return false;
}

bool Engine::body_touches_ground(int body) const {
  for (int i = 0, n = num_contacts(); i < n; ++i) {
    Contact c = contact(i);
    if ((c.body1 == body && c.body2 < 0) || (c.body2 == body && c.body1 < 0)) return true;
  }
  return false;
}

std::vector<std::string> Engine::body_names() const {
  std::vector<std::string> out;
  for (int i = 0; i < nbody(); ++i) out.push_back(body_name(i));
  return out;
}

std::vector<std::string> Engine::dof_names() const {
  std::vector<std::string> out;
  for (int i = 0; i < nv(); ++i) out.push_back(dof_name(i));
  return out;
}

std::vector<std::string> Engine::actuator_names() const {
  std::vector<std::string> out;
  for (int i = 0; i < nu(); ++i) out.push_back(actuator_name(i));
  return out;
}

int Engine::require_body(std::string_view name) const {
  int i = body_index(name);
  if (i < 0)
    throw InputError(fmt::format("unknown body '{}'{}", name, did_you_mean(name, body_names())));
  return i;
}

int Engine::require_dof(std::string_view name) const {
  int i = dof_index(name);
  if (i < 0)
    throw InputError(fmt::format("unknown dof '{}'{}", name, did_you_mean(name, dof_names())));
  return i;
}

int Engine::require_joint(std::string_view name) const {
  int i = joint_index(name);
  if (i < 0) {
    std::vector<std::string> names;
    for (int j = 0; j < njoint(); ++j) names.push_back(joint(j).name);
    throw InputError(fmt::format("unknown joint '{}'{}", name, did_you_mean(name, names)));
  }
  return i;
}

int Engine::require_actuator(std::string_view name) const {
  int i = actuator_index(name);
  if (i < 0)
    throw InputError(
        fmt::format("unknown actuator '{}'{}", name, did_you_mean(name, actuator_names())));
  return i;
}

void Engine::solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                                Eigen::Ref<Eigen::VectorXd> x) const {
  const int n = nv();
  if (shifted_mass_.rows() != n) {
    shifted_mass_.resize(n, n);
    shifted_llt_ = Eigen::LLT<Eigen::MatrixXd>(n);
  }
  mass_matrix(shifted_mass_);
  shifted_mass_.diagonal() += d;
  shifted_llt_.compute(shifted_mass_);
  shifted_llt_.solveInPlace(x);
}

void Engine::apply_keyframe(std::string_view name) {
  throw InputError(
      fmt::format("the {} engine has no keyframes (asked for '{}')", engine_name(), name));
}

bool Engine::dof_is_root(int dof) const {
  return joint(dof_joint(dof)).type == JointType::kFree;
}

}  // namespace stance
