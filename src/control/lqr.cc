#include "control/lqr.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>

#include "core/atomic_file.h"
#include "core/error.h"
#include "math/dare.h"

namespace stance {

namespace {
std::atomic<long> g_designs_made{0};

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

RootResult find_root_brent(const std::function<double(double)>& f, double a, double b, double fa,
                           double fb, double tol, int max_evaluations) {
  if (fa * fb > 0)
    throw std::invalid_argument(
        fmt::format("find_root_brent: f({})={} and f({})={} have the same sign", a, fa, b, fb));
  RootResult r;
  // Brent (1973) zeroin: b is the best estimate, a the previous one, c the other bracket end
  double c = a, fc = fa, d = b - a, e = d;
  while (true) {
    if ((fb > 0) == (fc > 0)) {
      c = a;
      fc = fa;
      d = e = b - a;
    }
    if (std::abs(fc) < std::abs(fb)) {
      a = b;
      b = c;
      c = a;
      fa = fb;
      fb = fc;
      fc = fa;
    }
    const double half_tol = 0.5 * tol;
    const double m = 0.5 * (c - b);
    if (std::abs(m) <= half_tol || fb == 0 || r.evaluations >= max_evaluations) break;
    if (std::abs(e) >= half_tol && std::abs(fa) > std::abs(fb)) {
      // inverse quadratic interpolation, or secant when two points coincide
      double p, q, s = fb / fa;
      if (a == c) {
        p = 2 * m * s;
        q = 1 - s;
      } else {
        double qa = fa / fc, rb = fb / fc;
        p = s * (2 * m * qa * (qa - rb) - (b - a) * (rb - 1));
        q = (qa - 1) * (rb - 1) * (s - 1);
      }
      if (p > 0)
        q = -q;
      else
        p = -p;
      if (2 * p < std::min(3 * m * q - std::abs(half_tol * q), std::abs(e * q))) {
        e = d;
        d = p / q;
      } else {
        d = e = m;  // bisection
      }
    } else {
      d = e = m;
    }
    a = b;
    fa = fb;
    b += std::abs(d) > half_tol ? d : (m > 0 ? half_tol : -half_tol);
    fb = f(b);
    ++r.evaluations;
  }
  r.x = b;
  r.fx = fb;
  r.bracket_width = std::abs(c - b);
  return r;
}

std::vector<int> match_dofs(const Engine& engine, const std::vector<std::string>& patterns) {
  std::vector<std::regex> res;
  for (const auto& p : patterns) {
    try {
      res.emplace_back(p);
    } catch (const std::regex_error& e) {
      throw InputError(fmt::format("lqr: balance_dofs: bad pattern '{}': {}", p, e.what()));
    }
  }
  std::vector<int> dofs;
  for (int i = 0; i < engine.nv(); ++i)
    for (const auto& re : res)
      if (std::regex_match(engine.dof_name(i), re)) {
        dofs.push_back(i);
        break;
      }
  return dofs;
}

Eigen::MatrixXd lqr_state_cost(const LqrParams& params, const Eigen::MatrixXd& jac_com,
                               const Eigen::MatrixXd& jac_foot, const std::vector<bool>& is_root,
                               const std::vector<int>& balance_dofs) {
  const int nv = static_cast<int>(jac_com.cols());
  // the COM over the foot
  const Eigen::MatrixXd jac_diff = jac_com - jac_foot;
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(2 * nv, 2 * nv);
  q.topLeftCorner(nv, nv) = params.balance_cost * jac_diff.transpose() * jac_diff;
  // joints near the pose: balance set stiffer than the rest, root free
  Eigen::VectorXd joint_cost = Eigen::VectorXd::Constant(nv, params.other_joint_cost);
  for (int i : balance_dofs) joint_cost[i] = params.balance_joint_cost;
  for (int i = 0; i < nv; ++i)
    if (is_root[i]) joint_cost[i] = 0;
  q.topLeftCorner(nv, nv).diagonal() += joint_cost;
  q.diagonal().array() += params.velocity_cost;
  return q;
}

long lqr_designs_made() {
  return g_designs_made.load();
}

LqrDesign design_lqr(const LqrParams& params, Engine& engine) {
  const auto t0 = std::chrono::steady_clock::now();
  LqrDesign design;
  const int nv = engine.nv(), nu = engine.nu();
  design.foot_bodies = find_stance_feet(params.stance_foot, engine);
  design.balance_dofs = match_dofs(engine, params.balance_dofs);
  design.actuator_names = engine.actuator_names();
  design.dof_names = engine.dof_names();
  if (design.balance_dofs.empty())
    throw InputError("lqr: balance_dofs: no dof matches the patterns");

  // 1. set-point (from here on, the design is counted)
  ++g_designs_made;
  auto t = std::chrono::steady_clock::now();
  design.setpoint = find_lqr_setpoint(params, engine);
  design.setpoint_ms = ms_since(t);
  check_lqr_setpoint(params, engine, design.setpoint);

  // 2-3. Jacobians, A and B
  t = std::chrono::steady_clock::now();
  linearize_lqr_plant(params, engine, design.setpoint, design.plant);
  design.linearize_ms = ms_since(t);

  // cost
  std::vector<bool> is_root(nv);
  for (int i = 0; i < nv; ++i) is_root[i] = engine.dof_is_root(i);
  design.Q = lqr_state_cost(params, design.plant.jac_com, design.plant.jac_foot, is_root,
                            design.balance_dofs);
  design.R = Eigen::MatrixXd::Identity(nu, nu);

  // 4. DARE and gain
  t = std::chrono::steady_clock::now();
  DareResult dare = solve_dare(design.plant.A, design.plant.B, design.Q, design.R);
  design.dare_ms = ms_since(t);
  if (!dare.success)
    throw InputError("lqr: the Riccati equation has no stabilising solution: " + dare.message);
  design.K = dare.K;
  design.dare_residual = dare.relative_residual;
  design.spectral_radius = dare.spectral_radius;
  design.design_ms = ms_since(t0);
  return design;
}

void LqrState::resize(int nq, int nv, int nu) {
  q = Eigen::VectorXd::Zero(nq);
  x = Eigen::VectorXd::Zero(2 * nv);
  u = Eigen::VectorXd::Zero(nu);
}

void compute_lqr(const LqrDesign& design, bool feedback, LqrState& s, const Engine& engine,
                 ControlOutput& out) {
  const int nv = engine.nv();
  out.ctrl += design.setpoint.ctrl0;
  out.ctrl_used = true;
  if (feedback) {
    // x = [q (-) q0; v], the tangent-space error
    engine.get_positions(s.q);
    engine.difference_positions(design.setpoint.q0, s.q, s.x.head(nv));
    engine.get_velocities(s.x.tail(nv));
    s.u.noalias() = design.K * s.x;
    out.ctrl -= s.u;
  }
  // the COM's horizontal distance from the stance feet's centre
  Eigen::Vector3d g = engine.gravity();
  Eigen::Vector3d up = g.norm() > 0 ? Eigen::Vector3d(-g.normalized()) : Eigen::Vector3d::UnitZ();
  Eigen::Vector3d diff = engine.com() - feet_centre(engine, design.foot_bodies);
  s.com_foot_distance_m = (diff - up * up.dot(diff)).norm();
  s.max_com_foot_distance_m = std::max(s.max_com_foot_distance_m, s.com_foot_distance_m);
}

Lqr::Lqr(const LqrParams& params, const ControllerContext& ctx, const Engine& engine)
    : params_(params), design_(design_lqr(params, ctx, engine)) {}

void Lqr::reset_state(LqrState& s, const Engine& engine) const {
  s.resize(engine.nq(), engine.nv(), engine.nu());
  s.com_foot_distance_m = 0;
  s.max_com_foot_distance_m = 0;
  s.compute_ns_sum = 0;
  s.computes = 0;
}

void Lqr::compute_step(LqrState& s, const Engine& engine, ControlOutput& out) const {
  const auto t0 = std::chrono::steady_clock::now();
  compute_lqr(design_, params_.feedback, s, engine, out);
  s.compute_ns_sum +=
      std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
  ++s.computes;
}

void Lqr::signal_names(std::vector<std::string>& names) const {
  names.push_back("lqr_com_foot_distance_m");
  names.push_back("lqr_state_error_norm");
}

// the YAML's numbers, without the visit's units and ranges (as before the typed panel)
std::vector<ParamEntry> Lqr::tunable_params() const {
  std::vector<ParamEntry> out;
  list_yaml_params(params_yaml(), "", out);
  return out;
}

void Lqr::signals(const ControllerState& state, std::vector<double>& values) const {
  const State& s = cast(state);
  values.push_back(s.com_foot_distance_m);
  values.push_back(s.x.norm());
}

void Lqr::add_metrics(const ControllerState& state, nlohmann::json& metrics) const {
  const State& s = cast(state);
  const LqrSetPoint& sp = design_.setpoint;
  metrics["height_offset_mm"] = sp.height_offset_m * 1e3;
  metrics["residual_vertical_force_N"] = sp.residual_vertical_force_N;
  metrics["ctrl0_mismatch_actuated_N"] = sp.mismatch_actuated_N;
  metrics["ctrl0_mismatch_root_N"] = sp.mismatch_root_N;
  metrics["design_time_ms"] = design_.design_ms;
  metrics["dare_relative_residual"] = design_.dare_residual;
  metrics["spectral_radius"] = design_.spectral_radius;
  metrics["max_com_foot_distance_m"] = s.max_com_foot_distance_m;
  metrics["controller_ns_per_step"] = s.computes ? s.compute_ns_sum / s.computes : 0.0;
}

void write_force_offset_csv(const LqrSetPoint& sp, const std::string& csv_path) {
  AtomicFile file(csv_path);
  std::ostream& csv = file.stream();
  csv << "offset_mm,vertical_force_N\n";
  for (size_t i = 0; i < sp.curve_offset_m.size(); ++i)
    csv << fmt::format("{:.9g},{:.9g}\n", sp.curve_offset_m[i] * 1e3, sp.curve_force_N[i]);
  file.commit();
}

void plot_force_offset(const LqrSetPoint& sp, const std::string& csv_path,
                       const std::string& png_path) {
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0)
    throw InputError(
        "lqr: force_plot: gnuplot not found on PATH (Debian: apt-get install gnuplot-nox)");
  namespace fs = std::filesystem;
  const fs::path png = fs::absolute(png_path);
  const fs::path script = fs::path(png).replace_extension(".gp");
  const fs::path err = fs::path(png).replace_extension(".gnuplot_err");
  const auto [lo, hi] = std::minmax_element(sp.curve_force_N.begin(), sp.curve_force_N.end());
  std::error_code ec;
  {
    AtomicFile file(script);
    std::ostream& gp = file.stream();
    // the seed's figure: force against offset, the weight, and the chosen offset; the caller
    // may name another output (the PNG's temporary, renamed into place when gnuplot is done)
    gp << "set terminal pngcairo size 900,540 enhanced font 'sans,11'\n"
       << "if (!exists('png')) png = '" << png.string() << "'\n"
       << "set output png\n"
       << "set datafile separator ','\n"
       << "set title 'Fictitious vertical root force against root height offset (mj\\_inverse, "
          "qacc = 0)'\n"
       << "set xlabel 'vertical offset (mm)'\n"
       << "set ylabel 'vertical force (N)'\n"
       << "set grid\n"
       << "set key right bottom\n"
       << fmt::format(
              "set arrow from {0:.9g},{1:.9g} to {0:.9g},{2:.9g} nohead dt 2 lw 2 "
              "lc rgb '#c0392b'\n",
              sp.height_offset_m * 1e3, std::min(*lo, 0.0), std::max(*hi, sp.weight_N))
       << fmt::format(
              "set label 'offset {:.4f} mm, residual {:.2g} N' at {:.9g},{:.9g} "
              "offset 1,0\n",
              sp.height_offset_m * 1e3, sp.residual_vertical_force_N, sp.height_offset_m * 1e3,
              0.5 * sp.weight_N)
       << "plot '" << fs::absolute(csv_path).string()
       << "' every ::1 using 1:2 with lines lw 2 lc rgb '#1f4e9c' title 'vertical force', \\\n"
       << fmt::format(
              "  {:.9g} with lines dt 2 lw 2 lc rgb '#27ae60' title 'weight ({:.1f} N)', "
              "\\\n",
              sp.weight_N, sp.weight_N)
       << "  NaN with lines dt 2 lw 2 lc rgb '#c0392b' title 'chosen offset'\n";
    file.commit();
  }
  const fs::path png_tmp = temporary_path_for(png);
  const std::string cmd = fmt::format("gnuplot -e \"png='{}'\" '{}' 2>'{}'", png_tmp.string(),
                                      script.string(), err.string());
  if (std::system(cmd.c_str()) != 0) {
    fs::remove(png_tmp, ec);
    std::ifstream in(err);
    std::string first;
    std::getline(in, first);
    throw InputError(fmt::format("lqr: gnuplot failed on {}: {}", script.string(), first));
  }
  fs::remove(err, ec);
  rename_into_place(png_tmp, png);
}

void Lqr::write_outputs(const ControllerState&, const std::string& out_dir) const {
  namespace fs = std::filesystem;
  const fs::path dir(out_dir);
  {
    AtomicFile file(dir / "K.csv");
    std::ostream& k = file.stream();
    // one row per actuator, one column per state entry: dq_<dof> then v_<dof>
    const Eigen::MatrixXd& K = design_.K;
    k << "actuator";
    for (const auto& n : design_.dof_names) k << ",dq_" << n;
    for (const auto& n : design_.dof_names) k << ",v_" << n;
    k << '\n';
    for (int i = 0; i < K.rows(); ++i) {
      k << design_.actuator_names[i];
      for (int j = 0; j < K.cols(); ++j) k << fmt::format(",{:.17g}", K(i, j));
      k << '\n';
    }
    file.commit();
  }
  const std::string csv = (dir / "force_offset.csv").string();
  write_force_offset_csv(design_.setpoint, csv);
  if (params_.force_plot)
    plot_force_offset(design_.setpoint, csv, (dir / "force_offset.png").string());
}

}  // namespace stance
