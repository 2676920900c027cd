#include "control/mocap_gains.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"
#include "engine/engine.h"

namespace stance {

void set_gain_by_name(const Engine& engine, Eigen::VectorXd& gains, const std::string& name,
                      double value, const char* what) {
  if (engine.dof_index(name) >= 0) {
    gains[engine.dof_index(name)] = value;
  } else if (const int j = engine.joint_index(name); j >= 0) {
    gains.segment(engine.joint(j).dof_adr, engine.joint(j).nv).setConstant(value);
  } else {
    std::vector<std::string> names = engine.dof_names();
    for (int k = 0; k < engine.njoint(); ++k) names.push_back(engine.joint(k).name);
    throw InputError(fmt::format("{}: the model has no dof or joint '{}'{}", what, name,
                                 did_you_mean(name, names)));
  }
}

void cap_gains_at_limits(const Engine& engine, double limit_gain_error, Eigen::VectorXd& kp,
                         Eigen::VectorXd& kd) {
  for (int d = 0; d < engine.nv(); ++d) {
    const double limit = engine.joint(engine.dof_joint(d)).force_limit;
    if (!std::isfinite(limit) || kp[d] <= 0) continue;
    const double scale = std::min(1.0, limit / limit_gain_error / kp[d]);
    kp[d] *= scale;
    kd[d] *= scale;
  }
}

void raise_gains_to_floor(const Engine& engine, const std::vector<int>& leg_bodies, double floor,
                          double limit_gain_error, Eigen::VectorXd& kp, Eigen::VectorXd& kd) {
  for (int b : leg_bodies)
    for (int j = 0; j < engine.njoint(); ++j) {
      const JointInfo& joint = engine.joint(j);
      if (joint.body != b || joint.type == JointType::kFree) continue;
      for (int d = joint.dof_adr; d < joint.dof_adr + joint.nv; ++d) {
        if (kp[d] <= 0 || kp[d] >= floor) continue;
        const double cap = limit_gain_error > 0 ? joint.force_limit / limit_gain_error
                                                : std::numeric_limits<double>::infinity();
        const double raised = std::min(floor, cap);
        if (raised <= kp[d]) continue;
        kd[d] *= raised / kp[d];
        kp[d] = raised;
      }
    }
}

}  // namespace stance
