// The LQR design's engine side: inverse dynamics for the set-point, the COM Jacobians and one
// step's A and B by finite differences, all through the engine interface. The design moves
// the engine it is given and puts it back; the controller gives it a scratch engine of the
// scenario's world, so the run's engine keeps its state.
#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <memory>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <cctype>

#include "analysis/finite_difference.h"
#include "control/lqr.h"
#include "control/mocap_clip.h"
#include "core/error.h"

namespace stance {

namespace {

// the free joint of the root body: its qpos and dof addresses
struct RootJoint {
  int qpos_adr = -1;
  int dof_adr = -1;
};

RootJoint find_root_joint(const LqrParams& params, const Engine& engine) {
  int body = engine.body_index(params.root_body);
  if (body < 0)
    throw InputError(fmt::format("lqr: root_body: unknown body '{}'{}", params.root_body,
                                 did_you_mean(params.root_body, engine.body_names())));
  for (int j = 0; j < engine.njoint(); ++j) {
    const JointInfo& info = engine.joint(j);
    if (info.body == body && info.type == JointType::kFree) return {info.qpos_adr, info.dof_adr};
  }
  throw InputError(fmt::format("lqr: root_body '{}' has no free joint", params.root_body));
}

int require_body(const Engine& engine, const std::string& name, const char* what) {
  int body = engine.body_index(name);
  if (body < 0)
    throw InputError(fmt::format("lqr: {}: unknown body '{}'{}", what, name,
                                 did_you_mean(name, engine.body_names())));
  return body;
}

Eigen::Vector3d up_axis(const Engine& engine) {
  Eigen::Vector3d g = engine.gravity();
  if (g.norm() == 0) throw InputError("lqr: the set-point search needs gravity");
  return -g.normalized();
}

// puts the engine back into the state it had when the design started
struct StateGuard {
  Engine& engine;
  EngineState saved;
  explicit StateGuard(Engine& e) : engine(e) { engine.save_state(saved); }
  ~StateGuard() {
    engine.restore_state(saved);
    engine.forward();
  }
};

std::string lower_case(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trimmed(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

bool named_like_foot(const std::string& name) {
  return lower_case(name).find("foot") != std::string::npos;
}

std::string feet_names(const Engine& engine, const std::vector<int>& feet) {
  std::vector<std::string> names;
  for (int b : feet) names.push_back(engine.body_name(b));
  return names.empty() ? std::string("none") : fmt::format("{}", fmt::join(names, ", "));
}

// the body whose origin is lowest along up among those named on one side (-1 left, +1 right),
// or -1: on a robot that names no body a foot, its foot (the standing pose's rule, a sole's
// link being its leg's lowest body)
int lowest_body_of_side(const Engine& engine, int side) {
  if (engine.gravity().norm() == 0) return -1;
  const Eigen::Vector3d up = -engine.gravity().normalized();
  int lowest = -1;
  for (int b = 0; b < engine.nbody(); ++b) {
    if (side_of_joint_name(engine.body_name(b)) != side) continue;
    if (lowest < 0 || engine.body_pose(b).pos.dot(up) < engine.body_pose(lowest).pos.dot(up))
      lowest = b;
  }
  return lowest;
}

// the body named like a foot on one side (-1 left, +1 right): among bodies whose name holds
// "foot", the topmost of that side (a toe body "l_foot_toe" below "l_foot" is not another foot)
int foot_of_side(const Engine& engine, int side) {
  std::vector<int> found, feet_seen;
  auto foot_of_this_side = [&](int b) {
    return b >= 0 && named_like_foot(engine.body_name(b)) &&
           side_of_joint_name(engine.body_name(b)) == side;
  };
  for (int b = 0; b < engine.nbody(); ++b) {
    if (named_like_foot(engine.body_name(b))) feet_seen.push_back(b);
    if (foot_of_this_side(b) && !foot_of_this_side(engine.body_parent(b))) found.push_back(b);
  }
  const char* word = side < 0 ? "left" : "right";
  if (found.size() == 1) return found[0];
  if (found.empty() && feet_seen.empty()) {
    // no body is named a foot (a robot's "left_ankle_link"): its lowest body on that side
    if (const int lowest = lowest_body_of_side(engine, side); lowest >= 0) return lowest;
  }
  if (found.empty())
    throw InputError(fmt::format(
        "lqr: stance_foot: no body is named like a {} foot (bodies with 'foot' in the name: "
        "{}): name the foot bodies, e.g. stance_foot: l_foot,r_foot",
        word, feet_names(engine, feet_seen)));
  throw InputError(fmt::format("lqr: stance_foot: '{}' is ambiguous ({}): name the foot bodies",
                               word, feet_names(engine, found)));
}

// true when `body` is one of `feet` or below one of them in the tree
bool under_feet(const Engine& engine, int body, const std::vector<int>& feet) {
  for (int steps = 0; body >= 0 && steps <= engine.nbody(); ++steps) {
    if (std::find(feet.begin(), feet.end(), body) != feet.end()) return true;
    const int parent = engine.body_parent(body);
    if (parent == body) break;
    body = parent;
  }
  return false;
}

}  // namespace

std::vector<int> find_stance_feet(const std::string& stance_foot, const Engine& engine) {
  std::vector<int> feet;
  auto add = [&](int body) {
    if (std::find(feet.begin(), feet.end(), body) == feet.end()) feet.push_back(body);
  };
  size_t start = 0;
  while (start <= stance_foot.size()) {
    size_t comma = stance_foot.find(',', start);
    if (comma == std::string::npos) comma = stance_foot.size();
    const std::string name = trimmed(stance_foot.substr(start, comma - start));
    start = comma + 1;
    if (name.empty())
      throw InputError(
          fmt::format("lqr: stance_foot: an empty name in '{}' (expected a body, several "
                      "separated by commas, or left, right, both)",
                      stance_foot));
    const int body = engine.body_index(name);
    if (body >= 0) {
      add(body);
    } else if (name == "left" || name == "right") {
      add(foot_of_side(engine, name == "left" ? -1 : 1));
    } else if (name == "both") {
      add(foot_of_side(engine, -1));
      add(foot_of_side(engine, 1));
    } else {
      throw InputError(fmt::format(
          "lqr: stance_foot: unknown body '{}' (expected a body, several separated by commas, "
          "or left, right, both){}",
          name, did_you_mean(name, engine.body_names())));
    }
  }
  return feet;
}

Eigen::Vector3d feet_centre(const Engine& engine, const std::vector<int>& feet) {
  Eigen::Vector3d c = engine.body_com(feet[0]);
  for (size_t i = 1; i < feet.size(); ++i) c += engine.body_com(feet[i]);
  return c / static_cast<double>(feet.size());
}

namespace {

// the free root's qpos placed by a height h along up and a tilt about two horizontal axes
// through a pivot (MuJoCo's layout: position, then the quaternion w x y z)
struct RootPlacement {
  Eigen::VectorXd pose;  // nq: the target pose
  int qpos_adr = -1;
  Eigen::Vector3d up, axis1, axis2, pivot;

  void apply(double h, const Eigen::Vector2d& tilt, Eigen::VectorXd& q) const {
    q = pose;
    if (tilt.isZero()) {
      for (int k = 0; k < 3; ++k) q[qpos_adr + k] += h * up[k];
      return;
    }
    const Eigen::Quaterniond turn =
        Eigen::AngleAxisd(tilt[0], axis1) * Eigen::AngleAxisd(tilt[1], axis2);
    const Eigen::Vector3d p = q.segment<3>(qpos_adr);
    q.segment<3>(qpos_adr) = pivot + turn * (p - pivot) + h * up;
    const Eigen::Quaterniond r(q[qpos_adr + 3], q[qpos_adr + 4], q[qpos_adr + 5], q[qpos_adr + 6]);
    const Eigen::Quaterniond turned = (turn * r).normalized();
    q.segment<4>(qpos_adr + 3) << turned.w(), turned.x(), turned.y(), turned.z();
  }
};

double max_abs_root(const Eigen::VectorXd& tau, int dof_adr) {
  return tau.segment<6>(dof_adr).cwiseAbs().maxCoeff();
}

// Gauss-Newton on (height, tilt 1, tilt 2) against the six root forces, from the height search's
// solution: central differences, a backtracking step, at most 30 iterations. Leaves the result
// in sp (height_offset_m, tilt_rad, tilt_iterations, residual_vertical_force_N).
template <class Place>
void tilt_onto_feet(const RootPlacement& placement, int root_dof, double tolerance_N,
                    Place& place_tilted, const Eigen::VectorXd& tau, LqrSetPoint& sp) {
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  auto root_forces = [&](const Eigen::Vector3d& x) -> Vec6 {
    place_tilted(x[0], Eigen::Vector2d(x[1], x[2]));
    return tau.segment<6>(root_dof);
  };
  Eigen::Vector3d x(sp.height_offset_m, 0, 0);
  Vec6 r = root_forces(x);
  const Eigen::Vector3d fd_step(1e-7, 1e-6, 1e-6);   // m, rad, rad
  const Eigen::Vector3d max_step(1e-3, 0.02, 0.02);  // per iteration
  for (int it = 0; it < 30 && r.cwiseAbs().maxCoeff() > tolerance_N; ++it) {
    Eigen::Matrix<double, 6, 3> jac;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d dx = Eigen::Vector3d::Zero();
      dx[k] = fd_step[k];
      jac.col(k) = (root_forces(x + dx) - root_forces(x - dx)) / (2 * fd_step[k]);
    }
    Eigen::Vector3d dx = -jac.colPivHouseholderQr().solve(r);
    const double scale = (dx.cwiseAbs().array() / max_step.array()).maxCoeff();
    if (scale > 1) dx /= scale;
    bool improved = false;
    for (double alpha = 1; alpha > 1e-3 && !improved; alpha *= 0.5) {
      const Vec6 trial = root_forces(x + alpha * dx);
      if (trial.cwiseAbs().maxCoeff() < r.cwiseAbs().maxCoeff()) {
        x += alpha * dx;
        r = trial;
        improved = true;
      }
    }
    ++sp.tilt_iterations;
    if (!improved) break;
  }
  sp.height_offset_m = x[0];
  sp.tilt_rad = x.tail<2>();

  sp.residual_vertical_force_N = placement.up.dot(r.head<3>());
}

// the body other than the feet that the set-point rests on most (engine at the set-point, at
// rest): the contact forces of one step with ctrl0, which holds the pose
void find_other_support(Engine& engine, const std::vector<int>& feet, LqrSetPoint& sp) {
  engine.set_controls(sp.ctrl0);
  engine.step();
  const Eigen::Vector3d up = -engine.gravity().normalized();
  std::vector<double> load(engine.nbody(), 0.0);
  for (int i = 0; i < engine.num_contacts(); ++i) {
    const Contact c = engine.contact(i);
    if (c.body1 >= 0 && c.body2 < 0) load[c.body1] -= up.dot(c.force);
    if (c.body2 >= 0 && c.body1 < 0) load[c.body2] += up.dot(c.force);
  }
  for (int b = 0; b < engine.nbody(); ++b)
    if (load[b] > sp.other_support_force_N && !under_feet(engine, b, feet)) {
      sp.other_support_force_N = load[b];
      sp.other_support_body = engine.body_name(b);
    }
}

}  // namespace

LqrSetPoint find_lqr_setpoint(const LqrParams& params, Engine& engine) {
  const int nq = engine.nq(), nv = engine.nv(), nu = engine.nu();
  if (nu == 0)
    throw InputError(
        fmt::format("lqr: the model has no actuators (on the {} engine)", engine.engine_name()));
  StateGuard guard(engine);
  if (guard.saved.act.size() != 0)
    throw InputError("lqr: actuators with activation states are not supported");
  const RootJoint root = find_root_joint(params, engine);
  const std::vector<int> feet = find_stance_feet(params.stance_foot, engine);
  RootPlacement placement;
  placement.up = up_axis(engine);
  placement.qpos_adr = root.qpos_adr;
  const Eigen::Vector3d& up = placement.up;

  LqrSetPoint sp;
  Eigen::VectorXd q(nq), tau(nv);
  const Eigen::VectorXd zero_v = Eigen::VectorXd::Zero(nv);
  placement.pose.resize(nq);
  engine.get_positions(placement.pose);
  sp.weight_N = engine.total_mass() * engine.gravity().norm();
  engine.set_velocities(zero_v);
  engine.set_controls(Eigen::VectorXd::Zero(nu));
  // the tilt axes: horizontal, through the feet's centre
  engine.forward();
  placement.pivot = feet_centre(engine, feet);
  placement.axis1 = up.unitOrthogonal();
  placement.axis2 = up.cross(placement.axis1);

  // inverse dynamics at rest with the root placed: the force lands in tau
  auto place_tilted = [&](double h, const Eigen::Vector2d& tilt) {
    placement.apply(h, tilt, q);
    engine.set_positions(q);
    engine.forward();
    engine.inverse_dynamics(zero_v, tau);
  };
  auto place = [&](double h) { place_tilted(h, sp.tilt_rad); };
  // the fictitious force along up on the root: positive when the body is held up by it
  auto vertical_force = [&](double h) {
    place(h);
    ++sp.offset_evaluations;
    return up.dot(tau.segment<3>(root.dof_adr));
  };

  // bracket: walk away from 0, doubling the step, in the direction that reduces the force
  double a = 0, fa = vertical_force(0);
  double step = fa > 0 ? -params.offset_first_step_m : params.offset_first_step_m;
  double b = a, fb = fa;
  const double max_offset = 0.5;  // m: beyond this the pose is not near the ground at all
  while (fb != 0 && (fb > 0) == (fa > 0)) {
    a = b;
    fa = fb;
    b = a + step;
    if (std::abs(b) > max_offset)
      throw InputError(fmt::format(
          "lqr: the vertical root force does not change sign within {} m of the pose (force "
          "{:.3g} N at {:+.4f} m): is the stance foot near the ground?",
          max_offset, fb, a));
    fb = vertical_force(b);
    step *= 2;
  }
  RootResult root_result = find_root_brent(vertical_force, a, b, fa, fb, params.offset_tolerance_m);
  sp.height_offset_m = root_result.x;
  sp.residual_vertical_force_N = root_result.fx;

  // the root wrench left: on several feet (or one foot's heel and toe) the flat contact's
  // pressure need not pass under the COM; tilting the body about the feet moves it there
  place(sp.height_offset_m);
  if (max_abs_root(tau, root.dof_adr) > params.root_tolerance_N)
    tilt_onto_feet(placement, root.dof_adr, params.root_tolerance_N, place_tilted, tau, sp);

  // the set-point itself
  place(sp.height_offset_m);
  sp.q0 = q;
  sp.qfrc0 = tau;
  sp.root_residual_N = max_abs_root(tau, root.dof_adr);
  Eigen::MatrixXd moment(nu, nv);
  engine.actuator_moment(moment);
  // least-squares, minimum-norm: the generalised force of ctrl is moment^T ctrl
  Eigen::MatrixXd moment_t = moment.transpose();
  sp.ctrl0 = moment_t.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(sp.qfrc0);

  // the actuator forces ctrl0 produces, against qfrc0
  const Eigen::VectorXd qfrc_actuator = moment_t * sp.ctrl0;
  for (int i = 0; i < nv; ++i) {
    double err = std::abs(qfrc_actuator[i] - sp.qfrc0[i]);
    bool is_root = i >= root.dof_adr && i < root.dof_adr + 6;
    bool actuated = moment.col(i).cwiseAbs().maxCoeff() > 0;
    if (is_root)
      sp.mismatch_root_N = std::max(sp.mismatch_root_N, err);
    else if (actuated)
      sp.mismatch_actuated_N = std::max(sp.mismatch_actuated_N, err);
  }

  // the curve for the plot: the seed's +-1 mm, widened to show the solution with margin
  const double half = std::max(1e-3, 2 * std::abs(sp.height_offset_m));
  const int samples = 401;
  for (int i = 0; i < samples; ++i) {
    double h = sp.height_offset_m - half + 2 * half * i / (samples - 1);
    place(h);
    sp.curve_offset_m.push_back(h);
    sp.curve_force_N.push_back(up.dot(tau.segment<3>(root.dof_adr)));
  }
  place(sp.height_offset_m);
  find_other_support(engine, feet, sp);
  return sp;
}

void check_lqr_setpoint(const LqrParams& params, const Engine& engine, const LqrSetPoint& sp) {
  const std::vector<int> feet = find_stance_feet(params.stance_foot, engine);
  const std::string bodies = feet_names(engine, feet);
  const std::string named = bodies == params.stance_foot
                                ? fmt::format("stance_foot '{}'", bodies)
                                : fmt::format("stance_foot '{}' ({})", params.stance_foot, bodies);
  if (sp.root_residual_N > params.max_root_residual_N) {
    const std::string hint =
        sp.other_support_body.empty()
            ? std::string("move the COM over the feet")
            : fmt::format("'{}' touches the ground too: name it in stance_foot (e.g. both)",
                          sp.other_support_body);
    throw InputError(
        fmt::format("lqr: the set-point leaves {:.3g} N on the root (ctrl0_mismatch_root_N; "
                    "max_root_residual_N {:g}): {} cannot hold this pose; {}",
                    sp.root_residual_N, params.max_root_residual_N, named, hint));
  }
  if (sp.other_support_force_N > params.max_root_residual_N)
    throw InputError(fmt::format(
        "lqr: the set-point rests {:.3g} N of the {:.3g} N weight on '{}', which {} does not "
        "name (max_root_residual_N {:g}): name it in stance_foot (e.g. both) or lift it",
        sp.other_support_force_N, sp.weight_N, sp.other_support_body, named,
        params.max_root_residual_N));
}

void linearize_lqr_plant(const LqrParams& params, Engine& engine, const LqrSetPoint& sp,
                         LqrPlant& plant) {
  const int nv = engine.nv();
  const int root = require_body(engine, params.root_body, "root_body");
  const std::vector<int> feet = find_stance_feet(params.stance_foot, engine);
  StateGuard guard(engine);
  engine.set_positions(sp.q0);
  engine.set_velocities(Eigen::VectorXd::Zero(nv));
  engine.set_controls(sp.ctrl0);
  engine.forward();

  // COM Jacobians at the set-point
  plant.jac_com.resize(3, nv);
  plant.jac_foot.resize(3, nv);
  engine.subtree_com_jacobian(root, plant.jac_com);
  // the feet's mean COM Jacobian
  Eigen::MatrixXd none(3, 0), jac(3, nv);
  engine.point_jacobian(feet[0], engine.body_com(feet[0]), plant.jac_foot, none);
  for (size_t i = 1; i < feet.size(); ++i) {
    engine.point_jacobian(feet[i], engine.body_com(feet[i]), jac, none);
    plant.jac_foot += jac;
  }
  plant.jac_foot /= static_cast<double>(feet.size());

  // the solver's warm start from the set-point alone, not from the engine's history: one step
  // from a cold start leaves its solution there
  EngineState x0, stepped;
  engine.save_state(x0);
  x0.extra.clear();
  engine.restore_state(x0);
  engine.step();
  engine.save_state(stepped);
  x0.extra = stepped.extra;

  // A and B of one step, centred differences
  linearize_fd(engine, x0, sp.ctrl0, params.fd_eps, true, plant.A, plant.B);
}

LqrDesign design_lqr(const LqrParams& params, const ControllerContext& ctx, const Engine& engine) {
  if (!ctx.scratch_engine)
    throw InputError("lqr: the design needs a scratch engine of the scenario's world");
  std::unique_ptr<Engine> scratch = ctx.scratch_engine();
  if (scratch->nq() != engine.nq() || scratch->nv() != engine.nv() || scratch->nu() != engine.nu())
    throw InputError("lqr: the scratch engine is not the run's model");
  // the run's pose on the scratch engine
  Eigen::VectorXd q(engine.nq());
  engine.get_positions(q);
  scratch->set_positions(q);
  scratch->forward();
  return design_lqr(params, *scratch);
}

}  // namespace stance
