#include "sim/correction.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "control/controller.h"
#include "core/error.h"
#include "engine/engine.h"
#include "sim/simulation.h"

namespace stance {

void CorrectionPlan::evaluate(double t, Eigen::Ref<Eigen::VectorXd> out) const {
  const int n = static_cast<int>(knots.cols());
  if (n == 0 || knots.rows() != out.size()) {
    out.setZero();
    return;
  }
  if (n == 1 || knot_dt <= 0) {
    out = knots.col(0);
    return;
  }
  const double s = std::max(0.0, (t - t0) / knot_dt);
  const int j = static_cast<int>(std::floor(s));
  if (j >= n - 1) {
    out = knots.col(n - 1);
    return;
  }
  const double a = s - j;
  out = (1 - a) * knots.col(j) + a * knots.col(j + 1);
}

namespace {
// set once, before main, by the plan layer's static initialiser; read-only afterwards
CorrectionSourceMakerFactory g_correction_source_factory = nullptr;
}  // namespace

void install_correction_source(CorrectionSourceMakerFactory factory) {
  g_correction_source_factory = factory;
}

CorrectionSourceMakerFactory correction_source_factory() {
  return g_correction_source_factory;
}

void check_planner_params(const PlannerParams& params, const std::string& where) {
  auto fail = [&](const std::string& msg) {
    throw InputError(where.empty() ? msg : fmt::format("{}: {}", where, msg));
  };
  if (params.method != "sampling" && params.method != "cem")
    fail(fmt::format("planner.method: expected sampling or cem, found '{}'", params.method));
  if (params.method == "cem" && params.elites > params.samples)
    fail(fmt::format("planner.elites: {} is more than planner.samples ({})", params.elites,
                     params.samples));
  if (params.interval_s > params.horizon_s)
    fail(fmt::format("planner.interval_s: {} s is longer than planner.horizon_s ({} s)",
                     params.interval_s, params.horizon_s));
  if (params.calm_horizon_s > params.horizon_s)
    fail(fmt::format("planner.calm_horizon_s: {} s is longer than planner.horizon_s ({} s)",
                     params.calm_horizon_s, params.horizon_s));
}

void resolve_correction_dims(const SimulationModel& model, const Engine& e,
                             CorrectionModel& correction) {
  const std::string& where = model.source;
  auto fail = [&](const std::string& msg) {
    throw InputError(where.empty() ? msg : fmt::format("{}: {}", where, msg));
  };
  const PlannerParams& params = correction.params;
  std::vector<PlanDimension>& out = correction.dimensions;
  // the controllers' own corrections
  correction.controller_first.assign(model.controllers.size(), -1);
  std::vector<CorrectionDim> dims;
  for (size_t i = 0; i < model.controllers.size(); ++i) {
    dims.clear();
    if (const Correctable* c = model.controllers[i]->as<Correctable>()) c->correction_dims(dims);
    if (dims.empty()) continue;
    correction.controller_first[i] = static_cast<int>(out.size());
    for (const CorrectionDim& d : dims)
      out.push_back(
          {fmt::format("controllers[{}].{}", i, d.name), static_cast<int>(i), -1, d.scale});
  }
  // else residual torques
  if (out.empty()) {
    std::vector<int> dofs;
    for (const std::string& name : params.residual_dofs) {
      int dof = e.dof_index(name);
      if (dof < 0)
        fail(fmt::format("planner.residual_dofs: unknown dof '{}'{}", name,
                         did_you_mean(name, e.dof_names())));
      dofs.push_back(dof);
    }
    if (dofs.empty())
      for (int dof = 0; dof < e.nv(); ++dof)
        if (e.joint(e.dof_joint(dof)).type != JointType::kFree) dofs.push_back(dof);
    for (int dof : dofs)
      out.push_back({"residual." + e.dof_name(dof), -1, dof, params.residual_torque});
  }
  if (out.empty()) fail("planner: the model has no joint to correct");
}

}  // namespace stance
