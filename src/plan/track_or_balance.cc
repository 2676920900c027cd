#include "plan/track_or_balance.h"

#include <algorithm>
#include <cmath>

#include "engine/engine.h"
#include "sim/simulation.h"

namespace stance {

Eigen::Vector3d support_center(const RunStart& start, const Engine& e) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int b : start.support_bodies) sum += e.body_pose(b).pos;
  return sum / static_cast<double>(start.support_bodies.size());
}

Eigen::Vector3d capture_offset(const RunStart& start, const Simulation& sim) {
  const Engine& e = sim.engine();
  const Eigen::Vector3d up = sim.model().up;
  const Eigen::Vector3d com = e.com();
  const Eigen::Vector3d vel = horizontal(e.com_velocity(), up);
  const double h = std::max(1e-3, up.dot(com) - sim.model().scenario.fall.ground_height);
  const double g = std::max(1e-6, e.gravity().norm());
  const Eigen::Vector3d anchor = start.support_bodies.empty()
                                     ? sim.progress().com0
                                     : support_center(start, e) + start.com_over_support0;
  return horizontal(com - anchor, up) + std::sqrt(h / g) * vel;
}

namespace {

class TrackOrBalance : public PlannerObjective {
 public:
  TrackOrBalance(const PlannerCostWeights& w, const RunStart& start) : w_(w), start_(start) {}

  double stage_cost(const Simulation& sim) const override {
    TrackingError total;
    if (tracking_error(sim, total))
      return w_.joint * total.joint_rad * total.joint_rad + w_.root * total.root_m * total.root_m +
             w_.body * total.body_m * total.body_m +
             w_.root_tilt * total.root_tilt_rad * total.root_tilt_rad;
    return balance_cost(sim);
  }

  double balance_error(const Simulation& sim) const override {
    TrackingError e;
    return tracking_error(sim, e) ? e.body_m : capture_offset(start_, sim).norm();
  }

 private:
  double balance_cost(const Simulation& sim) const {
    const Engine& e = sim.engine();
    const Eigen::Vector3d up = sim.model().up;
    const Eigen::Vector3d com = e.com();
    const Eigen::Vector3d vel = horizontal(e.com_velocity(), up);
    const Eigen::Vector3d offset = capture_offset(start_, sim);
    double tilt = 0;
    if (start_.root_body >= 0) {
      const Eigen::Vector3d root_up = e.body_pose(start_.root_body).quat * start_.root_up_local;
      tilt = std::acos(std::clamp(root_up.dot(up), -1.0, 1.0));
    }
    const double drop = std::max(0.0, up.dot(sim.progress().com0 - com));
    return w_.capture * offset.squaredNorm() + w_.com_velocity * vel.squaredNorm() +
           w_.upright * tilt * tilt + w_.height * drop * drop;
  }

  PlannerCostWeights w_;
  RunStart start_;
};

}  // namespace

std::unique_ptr<const PlannerObjective> make_track_or_balance(const PlannerParams& params,
                                                              const RunStart& start) {
  return std::make_unique<TrackOrBalance>(params.cost, start);
}

}  // namespace stance
