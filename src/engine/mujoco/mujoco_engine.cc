#include "engine/mujoco/mujoco_engine.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "engine/backend_world.h"
#include "engine/mujoco/mujoco_actuators.h"
#include "engine/mujoco/mujoco_inertia.h"
#include "engine/mujoco/mujoco_pairs.h"

namespace stance {

namespace {

// MuJoCo reports warnings through a global hook; keep the latest per thread.
thread_local std::string g_last_mujoco_warning;
void record_warning(const char* msg) {
  g_last_mujoco_warning = msg ? msg : "";
}

struct WarningHookInstaller {
  WarningHookInstaller() { mju_user_warning = record_warning; }
};
WarningHookInstaller g_install_hook;

// whether mj_passive can give anything but zeros: joint springs or dampers, tendon springs or
// dampers, a fluid, or a user callback. Without them its per-dof quaternion differences
// (ball joints' springs at zero stiffness) are wasted work on every step.
bool has_passive_forces(const mjModel* m) {
  if (mjcb_passive || m->opt.density != 0 || m->opt.viscosity != 0) return true;
  for (int j = 0; j < m->njnt; ++j)
    if (m->jnt_stiffness[j] != 0) return true;
  for (int i = 0; i < m->nv; ++i)
    if (m->dof_damping[i] != 0) return true;
  for (int t = 0; t < m->ntendon; ++t)
    if (m->tendon_stiffness[t] != 0 || m->tendon_damping[t] != 0) return true;
  return false;
}

std::string name_of(const mjModel* m, int type, int id, const std::string& fallback) {
  const char* n = mj_id2name(m, type, id);
  return (n && *n) ? std::string(n) : fallback;
}

// the first single-quoted text after `from`; empty when absent
std::string quoted_after(const std::string& msg, const std::string& from) {
  const size_t at = msg.find(from);
  if (at == std::string::npos) return "";
  const size_t begin = msg.find('\'', at + from.size());
  const size_t end = begin == std::string::npos ? begin : msg.find('\'', begin + 1);
  return end == std::string::npos ? "" : msg.substr(begin + 1, end - begin - 1);
}

// MuJoCo 2.2.2's schema refusal of an attribute or element (most often one of a newer MuJoCo,
// as current model collections use): said so; empty for other messages
std::string newer_mujoco_message(const std::string& msg) {
  const std::string element = quoted_after(msg, "Element");
  if (element.empty()) return "";
  const std::string attribute = quoted_after(msg, "unrecognized attribute:");
  const char* what =
      "is unknown to MuJoCo 2.2.2, which stance links: misspelt, or it needs a newer MuJoCo "
      "(remove it to load the model here)";
  if (!attribute.empty()) return fmt::format("<{}> attribute '{}' {}", element, attribute, what);
  if (msg.find("unrecognized element") != std::string::npos)
    return fmt::format("element <{}> {}", element, what);
  return "";
}

// MuJoCo's compiler errors contain "line = N" for XML problems; reshape them as file:line.
std::string mujoco_load_message(const std::string& file, const char* err) {
  std::string msg = err;
  while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
  for (auto& c : msg)
    if (c == '\n') c = ' ';
  int line = 0;
  auto pos = msg.find("line ");
  if (pos != std::string::npos) line = std::atoi(msg.c_str() + pos + 5);
  auto eq = msg.find("line = ");
  if (eq != std::string::npos) line = std::atoi(msg.c_str() + eq + 7);
  if (const std::string newer = newer_mujoco_message(msg); !newer.empty())
    return located(file, line, newer);
  return located(file, line, msg);
}

// MJCF text in place of files: `files` as (path, text), loaded as `name`; the VFS matches file
// names without their folders, so relative paths (meshes, includes) resolve as from `name`
mjModel* load_from_texts(const std::vector<std::pair<std::string, std::string>>& files,
                         const std::string& name, const std::string& source) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  for (const auto& [path, text] : files) {
    if (mj_makeEmptyFileVFS(vfs.get(), path.c_str(), static_cast<int>(text.size())) != 0) {
      mj_deleteVFS(vfs.get());
      throw InputError(source + ": cannot create a MuJoCo virtual file");
    }
    const int id = mj_findFileVFS(vfs.get(), path.c_str());
    std::memcpy(vfs->filedata[id], text.data(), text.size());
  }
  char err[1024] = "";
  mjModel* m = mj_loadXML(name.c_str(), vfs.get(), err, sizeof(err));
  mj_deleteVFS(vfs.get());
  if (!m) throw InputError(mujoco_load_message(source, err));
  return m;
}

mjModel* load_from_text(const std::string& text, const std::string& source) {
  const char* vname = "stance_model.xml";
  return load_from_texts({{vname, text}}, vname, source + " (translated to MJCF)");
}

// with_predefined_pairs's reload: the texts compiled as `name`
mjModel* reload_texts(const std::vector<std::pair<std::string, std::string>>& files,
                      const std::string& name) {
  return load_from_texts(files, name, name);
}

std::string file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

std::vector<std::pair<std::string, double>> mjcf_joint_force_limits(const BackendModel& model) {
  BackendWorld world;
  world.models.push_back(model);
  world.models.back().offset.setZero();
  mjModel* m = load_mujoco_model(world);
  const std::vector<double> limits = joint_force_limits(m, model);
  std::vector<std::pair<std::string, double>> out;
  for (int j = 0; j < m->njnt; ++j)
    if (std::isfinite(limits[j]))
      out.emplace_back(name_of(m, mjOBJ_JOINT, j, fmt::format("joint{}", j)), limits[j]);
  mj_deleteModel(m);
  return out;
}

MjcfLayout mjcf_layout(const BackendModel& model) {
  BackendWorld world;
  world.models.push_back(model);
  world.models.back().offset.setZero();
  mjModel* m = load_mujoco_model(world);
  MjcfLayout layout;
  for (int j = 0; j < m->njnt; ++j) {
    const int nq = j + 1 < m->njnt ? m->jnt_qposadr[j + 1] : m->nq;
    const int nv = j + 1 < m->njnt ? m->jnt_dofadr[j + 1] : m->nv;
    layout.joints.push_back({name_of(m, mjOBJ_JOINT, j, fmt::format("joint{}", j)),
                             m->jnt_qposadr[j], nq - m->jnt_qposadr[j], m->jnt_dofadr[j],
                             nv - m->jnt_dofadr[j]});
  }
  for (int i = 0; i < m->nu; ++i)
    layout.actuator_joints.push_back(m->actuator_trntype[i] == mjTRN_JOINT
                                         ? name_of(m, mjOBJ_JOINT, m->actuator_trnid[2 * i], "")
                                         : "");
  mj_deleteModel(m);
  return layout;
}

mjModel* load_mujoco_model(const BackendWorld& world, int* servos_made_motors) {
  if (world.models.size() != 1)
    throw InputError("MuJoCo loads one MJCF/URDF file per world; use <include> to compose");
  const BackendModel& model = world.models.front();
  mjModel* m = nullptr;
  if (!model.text.empty()) {
    m = load_from_text(model.text, model.name);
    m = with_predefined_pairs(m, {{"stance_model.xml", model.text}}, 0, "stance_model.xml",
                              reload_texts);
  } else if (!model.patched_files.empty()) {
    m = load_from_texts(model.patched_files, model.file, model.name);
  } else {
    char err[1024] = "";
    m = mj_loadXML(model.file.c_str(), nullptr, err, sizeof(err));
    if (!m) throw InputError(mujoco_load_message(model.name, err));
    m = with_predefined_pairs(m, {{model.file, file_text(model.file)}}, 0, model.file,
                              reload_texts);
  }
  // a translation of the whole model: shift the top-level bodies and free-joint origins
  const Eigen::Vector3d& off = model.offset;
  if (off.squaredNorm() > 0) {
    for (int b = 1; b < m->nbody; ++b) {
      if (m->body_parentid[b] != 0) continue;
      for (int k = 0; k < 3; ++k) m->body_pos[3 * b + k] += off[k];
    }
    for (int j = 0; j < m->njnt; ++j)
      if (m->jnt_type[j] == mjJNT_FREE && m->body_parentid[m->jnt_bodyid[j]] == 0)
        for (int k = 0; k < 3; ++k) m->qpos0[m->jnt_qposadr[j] + k] += off[k];
  }
  if (world.timestep) m->opt.timestep = *world.timestep;
  if (world.gravity)
    for (int k = 0; k < 3; ++k) m->opt.gravity[k] = (*world.gravity)[k];
  const int servos = servos_as_torque_motors(m);
  if (servos_made_motors) *servos_made_motors = servos;
  return m;
}

std::unique_ptr<Engine> open_mujoco_engine(const BackendWorld& world) {
  int servos = 0;
  mjModel* m = load_mujoco_model(world, &servos);
  auto engine = std::make_unique<MujocoEngine>(m, world.models.front().name);
  const std::vector<double> joint_limits = joint_force_limits(m, world.models.front());
  engine->tighten_force_limits(joint_limits);
  bound_lone_motors(m, joint_limits);
  engine->set_load_note(servo_note(world.models.front().name, servos));
  // the start keyframe, when the model has it
  if (!world.start_keyframe.empty() &&
      mj_name2id(m, mjOBJ_KEY, world.start_keyframe.c_str()) >= 0) {
    engine->apply_keyframe(world.start_keyframe);
    mj_forward(m, engine->data());  // as the runs measured so far started (the warm start too)
  }
  return engine;
}

MujocoEngine::MujocoEngine(mjModel* model, std::string source)
    : m_(model), source_(std::move(source)) {
  d_ = mj_makeData(m_);
  if (!d_) throw InputError(source_ + ": MuJoCo could not allocate data");
  build_tables();
  pending_tau_ = Eigen::VectorXd::Zero(m_->nv);
  qpos_before_forward_ = Eigen::VectorXd::Zero(m_->nq);
  velocity_command_ = Eigen::VectorXd::Constant(m_->nv, std::nan(""));
  jac_scratch_.resize(3, m_->nv);
  jac_scratch2_.resize(3, m_->nv);
  vec_scratch_.resize(std::max(1, m_->nv));
  shifted_mass_ldl_ = TreeLdl(m_->dof_parentid, m_->dof_Madr, m_->nv, m_->nM);
  // the passive forces are zero either way; disabled, MuJoCo only zeroes them (same steps)
  if (!has_passive_forces(m_)) m_->opt.disableflags |= mjDSBL_PASSIVE;
  mj_forward(m_, d_);
  warnings_seen_ = d_->warning[mjWARN_BADQACC].number + d_->warning[mjWARN_BADQPOS].number +
                   d_->warning[mjWARN_BADQVEL].number;
}

MujocoEngine::~MujocoEngine() {
  if (inverse_data_) mj_deleteData(inverse_data_);
  if (d_) mj_deleteData(d_);
  if (m_) mj_deleteModel(m_);
}

void MujocoEngine::build_tables() {
  // bodies welded to the world (static) are not part of the mobile system
  mj_to_body_.assign(m_->nbody, -1);
  for (int b = 1; b < m_->nbody; ++b) {
    if (m_->body_weldid[b] == 0) continue;
    mj_to_body_[b] = static_cast<int>(mobile_bodies_.size());
    mobile_bodies_.push_back(b);
    body_names_.push_back(name_of(m_, mjOBJ_BODY, b, fmt::format("body{}", b)));
    total_mass_ += m_->body_mass[b];
  }
  // joints and the DART-style names of their dofs
  dof_names_.assign(m_->nv, "");
  for (int j = 0; j < m_->njnt; ++j) {
    JointInfo info;
    info.name = name_of(m_, mjOBJ_JOINT, j, fmt::format("joint{}", j));
    info.body = mj_to_body_[m_->jnt_bodyid[j]];
    info.qpos_adr = m_->jnt_qposadr[j];
    info.dof_adr = m_->jnt_dofadr[j];
    info.has_limits = m_->jnt_limited[j];
    info.lower = m_->jnt_range[2 * j];
    info.upper = m_->jnt_range[2 * j + 1];
    int a = info.dof_adr;
    switch (m_->jnt_type[j]) {
      case mjJNT_FREE:
        info.type = JointType::kFree;
        info.nq = 7;
        info.nv = 6;
        // MuJoCo's free velocity is (linear in world, angular in body frame)
        dof_names_[a + 0] = info.name + "_pos_x";
        dof_names_[a + 1] = info.name + "_pos_y";
        dof_names_[a + 2] = info.name + "_pos_z";
        dof_names_[a + 3] = info.name + "_rot_x";
        dof_names_[a + 4] = info.name + "_rot_y";
        dof_names_[a + 5] = info.name + "_rot_z";
        break;
      case mjJNT_BALL:
        info.type = JointType::kBall;
        info.nq = 4;
        info.nv = 3;
        dof_names_[a + 0] = info.name + "_x";
        dof_names_[a + 1] = info.name + "_y";
        dof_names_[a + 2] = info.name + "_z";
        break;
      case mjJNT_SLIDE:
        info.type = JointType::kSlide;
        info.nq = info.nv = 1;
        dof_names_[a] = info.name;
        break;
      default:
        info.type = JointType::kHinge;
        info.nq = info.nv = 1;
        dof_names_[a] = info.name;
        break;
    }
    joints_.push_back(std::move(info));
  }
  for (int i = 0; i < m_->nu; ++i)
    actuator_names_.push_back(name_of(m_, mjOBJ_ACTUATOR, i, fmt::format("actuator{}", i)));
  // force limits of joints driven by bounded actuators (forcerange; a motor's ctrlrange x gain)
  const std::vector<double> limits = joint_force_limits(m_);
  for (int j = 0; j < m_->njnt; ++j) joints_[j].force_limit = limits[j];
}

void MujocoEngine::tighten_force_limits(const std::vector<double>& limits) {
  for (size_t j = 0; j < joints_.size(); ++j)
    joints_[j].force_limit = std::min(joints_[j].force_limit, limits[j]);
}

int MujocoEngine::body_index(std::string_view name) const {
  for (size_t i = 0; i < body_names_.size(); ++i)
    if (body_names_[i] == name) return static_cast<int>(i);
  return -1;
}
int MujocoEngine::joint_index(std::string_view name) const {
  for (size_t i = 0; i < joints_.size(); ++i)
    if (joints_[i].name == name) return static_cast<int>(i);
  return -1;
}
int MujocoEngine::dof_index(std::string_view name) const {
  for (size_t i = 0; i < dof_names_.size(); ++i)
    if (dof_names_[i] == name) return static_cast<int>(i);
  return -1;
}
int MujocoEngine::actuator_index(std::string_view name) const {
  for (size_t i = 0; i < actuator_names_.size(); ++i)
    if (actuator_names_[i] == name) return static_cast<int>(i);
  return -1;
}

Eigen::Vector3d MujocoEngine::gravity() const {
  return Eigen::Vector3d(m_->opt.gravity[0], m_->opt.gravity[1], m_->opt.gravity[2]);
}
void MujocoEngine::set_gravity(const Eigen::Vector3d& g) {
  for (int k = 0; k < 3; ++k) m_->opt.gravity[k] = g[k];
  forwarded_ = false;
}

namespace {
constexpr const char* kSolverNames[] = {"pgs", "cg", "newton"};  // mjtSolver's order
constexpr const char* kConeNames[] = {"pyramidal", "elliptic"};  // mjtCone's order

template <size_t N>
int name_index(const char* const (&names)[N], const std::string& name, const char* what) {
  for (size_t i = 0; i < N; ++i)
    if (name == names[i]) return static_cast<int>(i);
  throw InputError(fmt::format("{}: expected {}, found '{}'", what,
                               N == 3 ? "pgs, cg or newton" : "pyramidal or elliptic", name));
}
}  // namespace

SolverSettings MujocoEngine::solver_settings() const {
  SolverSettings s;
  s.iterations = m_->opt.iterations;
  s.tolerance = m_->opt.tolerance;
  s.noslip_iterations = m_->opt.noslip_iterations;
  s.solver = kSolverNames[std::clamp(m_->opt.solver, 0, 2)];
  s.cone = kConeNames[std::clamp(m_->opt.cone, 0, 1)];
  return s;
}

bool MujocoEngine::set_solver_settings(const SolverSettings& s) {
  // names first, so that a bad one changes nothing
  const int solver = s.solver.empty() ? m_->opt.solver : name_index(kSolverNames, s.solver, "type");
  const int cone = s.cone.empty() ? m_->opt.cone : name_index(kConeNames, s.cone, "cone");
  m_->opt.solver = solver;
  m_->opt.cone = cone;
  if (s.iterations > 0) m_->opt.iterations = s.iterations;
  if (s.tolerance >= 0) m_->opt.tolerance = s.tolerance;
  if (s.noslip_iterations >= 0) m_->opt.noslip_iterations = s.noslip_iterations;
  forwarded_ = false;
  return true;
}

void MujocoEngine::get_positions(Eigen::Ref<Eigen::VectorXd> q) const {
  q = Eigen::Map<const Eigen::VectorXd>(d_->qpos, m_->nq);
}
void MujocoEngine::get_velocities(Eigen::Ref<Eigen::VectorXd> v) const {
  v = Eigen::Map<const Eigen::VectorXd>(d_->qvel, m_->nv);
}
void MujocoEngine::set_positions(const Eigen::Ref<const Eigen::VectorXd>& q) {
  Eigen::Map<Eigen::VectorXd>(d_->qpos, m_->nq) = q;
  forwarded_ = false;
}
void MujocoEngine::set_velocities(const Eigen::Ref<const Eigen::VectorXd>& v) {
  Eigen::Map<Eigen::VectorXd>(d_->qvel, m_->nv) = v;
  forwarded_ = false;
}

double MujocoEngine::dof_position(int dof) const {
  const JointInfo& j = joints_[m_->dof_jntid[dof]];
  if (j.type == JointType::kHinge || j.type == JointType::kSlide) return d_->qpos[j.qpos_adr];
  if (j.type == JointType::kFree && dof - j.dof_adr < 3)
    return d_->qpos[j.qpos_adr + (dof - j.dof_adr)];
  // rotation dofs: the rotation vector component, as DART reports it
  const double* qq = d_->qpos + j.qpos_adr + (j.type == JointType::kFree ? 3 : 0);
  Eigen::Quaterniond quat(qq[0], qq[1], qq[2], qq[3]);
  Eigen::AngleAxisd aa(quat.normalized());
  Eigen::Vector3d rv = aa.angle() * aa.axis();
  int k = dof - j.dof_adr - (j.type == JointType::kFree ? 3 : 0);
  return rv[k];
}

void MujocoEngine::set_dof_position(int dof, double value) {
  const JointInfo& j = joints_[m_->dof_jntid[dof]];
  forwarded_ = false;
  if (j.type == JointType::kHinge || j.type == JointType::kSlide) {
    d_->qpos[j.qpos_adr] = value;
    return;
  }
  if (j.type == JointType::kFree && dof - j.dof_adr < 3) {
    d_->qpos[j.qpos_adr + (dof - j.dof_adr)] = value;
    return;
  }
  // rotation dofs hold a rotation vector: replace one component, convert back to a quaternion
  double* qq = d_->qpos + j.qpos_adr + (j.type == JointType::kFree ? 3 : 0);
  Eigen::Quaterniond quat(qq[0], qq[1], qq[2], qq[3]);
  Eigen::AngleAxisd aa(quat.normalized());
  Eigen::Vector3d rv = aa.angle() * aa.axis();
  rv[dof - j.dof_adr - (j.type == JointType::kFree ? 3 : 0)] = value;
  double angle = rv.norm();
  Eigen::Quaterniond out = angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, rv / angle))
                                     : Eigen::Quaterniond::Identity();
  qq[0] = out.w();
  qq[1] = out.x();
  qq[2] = out.y();
  qq[3] = out.z();
}

void MujocoEngine::difference_positions(const Eigen::Ref<const Eigen::VectorXd>& q0,
                                        const Eigen::Ref<const Eigen::VectorXd>& q1,
                                        Eigen::Ref<Eigen::VectorXd> v) const {
  mj_differentiatePos(m_, v.data(), 1.0, q0.data(), q1.data());
}

void MujocoEngine::integrate_positions(const Eigen::Ref<const Eigen::VectorXd>& q,
                                       const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                                       Eigen::Ref<Eigen::VectorXd> q_out) const {
  if (q_out.data() != q.data()) q_out = q;
  mj_integratePos(m_, q_out.data(), v.data(), dt);
}

void MujocoEngine::forward() {
  if (forwarded_) return;
  // step1 computes everything that depends on positions and velocities; step2 finishes the step
  std::copy(d_->qpos, d_->qpos + m_->nq, qpos_before_forward_.data());
  step_positions_and_velocities(m_, d_);  // mj_step1, its inertia stages inlined
  if (constraint_restored_) {
    std::copy(restored_constraint_.data(), restored_constraint_.data() + m_->nv,
              d_->qfrc_constraint);
    constraint_restored_ = false;
  }
  forwarded_ = true;
}

void MujocoEngine::mass_matrix(Eigen::Ref<Eigen::MatrixXd> mm) const {
  // symmetric, so MuJoCo's row-major dense matrix reads the same column-major
  mj_fullM(m_, mm.data(), d_->qM);
}

void MujocoEngine::solve_mass(Eigen::Ref<Eigen::VectorXd> x) const {
  std::memcpy(vec_scratch_.data(), x.data(), sizeof(double) * m_->nv);
  mj_solveM(m_, d_, x.data(), vec_scratch_.data(), 1);
}

void MujocoEngine::solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                                      Eigen::Ref<Eigen::VectorXd> x) const {
  // qM (filled by mj_step1) shifted and factored in our own buffers; mjData's factor stays
  // untouched for mj_step2's constraint solver
  shifted_mass_ldl_.factor(d_->qM, d.data());
  shifted_mass_ldl_.solve(x.data());
}

void MujocoEngine::bias_forces(Eigen::Ref<Eigen::VectorXd> c) const {
  c = Eigen::Map<const Eigen::VectorXd>(d_->qfrc_bias, m_->nv);
}
void MujocoEngine::constraint_forces(Eigen::Ref<Eigen::VectorXd> f) const {
  f = Eigen::Map<const Eigen::VectorXd>(d_->qfrc_constraint, m_->nv);
}

void MujocoEngine::inverse_dynamics(const Eigen::Ref<const Eigen::VectorXd>& vdot,
                                    Eigen::Ref<Eigen::VectorXd> tau) const {
  if (vdot.size() != m_->nv || tau.size() != m_->nv)
    throw std::invalid_argument(fmt::format("inverse_dynamics: expected dim nv = {}, got {} and {}",
                                            m_->nv, vdot.size(), tau.size()));
  if (!inverse_data_) {
    inverse_data_ = mj_makeData(m_);
    if (!inverse_data_) throw InputError(source_ + ": MuJoCo could not allocate data");
  }
  // the state mj_inverse reads: positions, velocities, activations and the acceleration
  mjData* d = inverse_data_;
  d->time = d_->time;
  mju_copy(d->qpos, d_->qpos, m_->nq);
  mju_copy(d->qvel, d_->qvel, m_->nv);
  mju_copy(d->act, d_->act, m_->na);
  Eigen::Map<Eigen::VectorXd>(d->qacc, m_->nv) = vdot;
  mj_inverse(m_, d);
  tau = Eigen::Map<const Eigen::VectorXd>(d->qfrc_inverse, m_->nv);
}

Eigen::Vector3d MujocoEngine::com() const {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int b : mobile_bodies_)
    c += m_->body_mass[b] * Eigen::Map<const Eigen::Vector3d>(d_->xipos + 3 * b);
  return total_mass_ > 0 ? Eigen::Vector3d(c / total_mass_) : c;
}

Eigen::Vector3d MujocoEngine::com_velocity() const {
  // cvel holds each body's (angular, linear) velocity at its tree's subtree COM, world-aligned;
  // shift the linear part to the body's own COM (what mj_objectVelocity does, without the call)
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int b : mobile_bodies_) {
    Eigen::Map<const Eigen::Vector3d> w(d_->cvel + 6 * b), v(d_->cvel + 6 * b + 3);
    Eigen::Map<const Eigen::Vector3d> p(d_->xipos + 3 * b),
        origin(d_->subtree_com + 3 * m_->body_rootid[b]);
    c += m_->body_mass[b] * (v + w.cross(p - origin));
  }
  return total_mass_ > 0 ? Eigen::Vector3d(c / total_mass_) : c;
}

BodyPose MujocoEngine::body_pose(int body) const {
  int b = mobile_bodies_[body];
  BodyPose p;
  p.pos = Eigen::Map<const Eigen::Vector3d>(d_->xpos + 3 * b);
  p.quat = Eigen::Quaterniond(d_->xquat[4 * b], d_->xquat[4 * b + 1], d_->xquat[4 * b + 2],
                              d_->xquat[4 * b + 3]);
  return p;
}

Eigen::Vector3d MujocoEngine::body_com(int body) const {
  return Eigen::Map<const Eigen::Vector3d>(d_->xipos + 3 * mobile_bodies_[body]);
}

Eigen::Matrix<double, 6, 1> MujocoEngine::body_velocity(int body) const {
  double res[6];
  mj_objectVelocity(m_, d_, mjOBJ_XBODY, mobile_bodies_[body], res, 0);
  Eigen::Matrix<double, 6, 1> out;
  for (int k = 0; k < 6; ++k) out[k] = res[k];
  return out;
}

void MujocoEngine::point_jacobian(int body, const Eigen::Vector3d& point_world,
                                  Eigen::Ref<Eigen::MatrixXd> jac_pos,
                                  Eigen::Ref<Eigen::MatrixXd> jac_rot) const {
  mj_jac(m_, d_, jac_scratch_.data(), jac_scratch2_.data(), point_world.data(),
         mobile_bodies_[body]);
  if (jac_pos.cols() > 0) jac_pos = jac_scratch_;
  if (jac_rot.cols() > 0) jac_rot = jac_scratch2_;
}

void MujocoEngine::com_jacobian(Eigen::Ref<Eigen::MatrixXd> jac) const {
  // the mass-weighted sum of each body's COM Jacobian, each column as mj_jac computes it, but
  // only the columns of the dofs above the body: mj_jac clears all nv and the sum adds all nv,
  // zeros included. The same bits in a quarter of the time.
  jac.setZero();
  for (int b : mobile_bodies_) {
    const double weight = m_->body_mass[b] / total_mass_;
    double offset[3];
    mju_sub3(offset, d_->xipos + 3 * b, d_->subtree_com + 3 * m_->body_rootid[b]);
    int moving = b;  // the first body up the chain with dofs of its own
    while (moving > 0 && m_->body_dofnum[moving] == 0) moving = m_->body_parentid[moving];
    if (moving <= 0) continue;
    const int last = m_->body_dofadr[moving] + m_->body_dofnum[moving] - 1;
    for (int i = last; i >= 0; i = m_->dof_parentid[i]) {
      // cdof's rotation x offset, inline as mju_cross computes it (a call per dof cost a
      // fifth of this function)
      const double* w = d_->cdof + 6 * i;
      const double cross[3] = {w[1] * offset[2] - w[2] * offset[1],
                               w[2] * offset[0] - w[0] * offset[2],
                               w[0] * offset[1] - w[1] * offset[0]};
      for (int r = 0; r < 3; ++r) jac(r, i) += weight * (w[3 + r] + cross[r]);
    }
  }
}

void MujocoEngine::subtree_com_jacobian(int body, Eigen::Ref<Eigen::MatrixXd> jac) const {
  mj_jacSubtreeCom(m_, d_, jac_scratch_.data(), mobile_bodies_[body]);
  jac = jac_scratch_;
}

Eigen::Vector3d MujocoEngine::subtree_com(int body) const {
  return Eigen::Map<const Eigen::Vector3d>(d_->subtree_com + 3 * mobile_bodies_[body]);
}

Contact MujocoEngine::contact(int i) const {
  const mjContact& c = d_->contact[i];
  Contact out;
  out.body1 = mj_to_body_[m_->geom_bodyid[c.geom1]];
  out.body2 = mj_to_body_[m_->geom_bodyid[c.geom2]];
  out.pos = Eigen::Map<const Eigen::Vector3d>(c.pos);
  out.normal = Eigen::Map<const Eigen::Vector3d>(c.frame);
  double f[6];
  mj_contactForce(m_, d_, i, f);
  // contact-frame force -> world; the frame's rows are its axes, normal from geom1 to geom2
  Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> frame(c.frame);
  out.force = frame.transpose() * Eigen::Vector3d(f[0], f[1], f[2]);
  return out;
}

void MujocoEngine::set_generalized_forces(const Eigen::Ref<const Eigen::VectorXd>& tau) {
  pending_tau_ = tau;
}
void MujocoEngine::set_controls(const Eigen::Ref<const Eigen::VectorXd>& ctrl) {
  Eigen::Map<Eigen::VectorXd>(d_->ctrl, m_->nu) = ctrl;
}
void MujocoEngine::get_controls(Eigen::Ref<Eigen::VectorXd> ctrl) const {
  ctrl = Eigen::Map<const Eigen::VectorXd>(d_->ctrl, m_->nu);
}

void MujocoEngine::actuator_moment(Eigen::Ref<Eigen::MatrixXd> moment) const {
  if (moment.rows() != m_->nu || moment.cols() != m_->nv)
    throw std::invalid_argument(fmt::format("actuator_moment: expected {} x {}, got {} x {}",
                                            m_->nu, m_->nv, moment.rows(), moment.cols()));
  // MuJoCo 2.2 stores actuator_moment dense, nu x nv row-major: qfrc_actuator = moment^T force,
  // and a fixed-gain actuator's force is gain * ctrl
  for (int i = 0; i < m_->nu; ++i) {
    if (m_->actuator_gaintype[i] != mjGAIN_FIXED || m_->actuator_dyntype[i] != mjDYN_NONE)
      throw InputError(fmt::format(
          "actuator '{}': actuator_moment needs a fixed gain and no activation dynamics",
          actuator_names_[i]));
    const double gain = m_->actuator_gainprm[mjNGAIN * i];
    for (int j = 0; j < m_->nv; ++j) moment(i, j) = gain * d_->actuator_moment[m_->nv * i + j];
  }
}

std::vector<std::string> MujocoEngine::keyframe_names() const {
  std::vector<std::string> names;
  for (int k = 0; k < m_->nkey; ++k) names.push_back(name_of(m_, mjOBJ_KEY, k, ""));
  return names;
}

void MujocoEngine::apply_keyframe(std::string_view name) {
  const int key = mj_name2id(m_, mjOBJ_KEY, std::string(name).c_str());
  if (key < 0) {
    std::vector<std::string> names = keyframe_names();
    throw InputError(fmt::format(
        "unknown keyframe '{}'{}", name,
        names.empty() ? std::string(" (the model has none)") : did_you_mean(name, names)));
  }
  mj_resetDataKeyframe(m_, d_, key);
  pending_tau_.setZero();
  forwarded_ = false;
  diverged_ = false;
  // the reset cleared MuJoCo's warning counters too
  warnings_seen_ = d_->warning[mjWARN_BADQACC].number + d_->warning[mjWARN_BADQPOS].number +
                   d_->warning[mjWARN_BADQVEL].number;
}

void MujocoEngine::apply_external_force(int body, const Eigen::Vector3d& force_world,
                                        const Eigen::Vector3d& point_world) {
  // xfrc_applied is a (force, torque) pair acting at the body's COM
  int b = mobile_bodies_[body];
  Eigen::Map<Eigen::Vector3d> f(d_->xfrc_applied + 6 * b);
  Eigen::Map<Eigen::Vector3d> t(d_->xfrc_applied + 6 * b + 3);
  Eigen::Vector3d arm = point_world - Eigen::Map<const Eigen::Vector3d>(d_->xipos + 3 * b);
  f += force_world;
  t += arm.cross(force_world);
}

void MujocoEngine::set_dof_velocity_command(int dof, double velocity) {
  velocity_command_[dof] = velocity;
  has_velocity_commands_ = !velocity_command_.array().isNaN().all();
}

void MujocoEngine::save_state(EngineState& s) const {
  s.time = d_->time;
  if (forwarded_)
    s.q = qpos_before_forward_;
  else
    s.q = Eigen::Map<const Eigen::VectorXd>(d_->qpos, m_->nq);
  s.v = Eigen::Map<const Eigen::VectorXd>(d_->qvel, m_->nv);
  s.act = Eigen::Map<const Eigen::VectorXd>(d_->act, m_->na);
  s.ctrl = Eigen::Map<const Eigen::VectorXd>(d_->ctrl, m_->nu);
  // the solver's warm start, and the last step's constraint forces (read by controllers before
  // the next step, e.g. stable PD): both are state a continued run depends on
  s.extra.assign(d_->qacc_warmstart, d_->qacc_warmstart + m_->nv);
  s.extra.insert(s.extra.end(), d_->qfrc_constraint, d_->qfrc_constraint + m_->nv);
}

void MujocoEngine::restore_state(const EngineState& s) {
  d_->time = s.time;
  Eigen::Map<Eigen::VectorXd>(d_->qpos, m_->nq) = s.q;
  Eigen::Map<Eigen::VectorXd>(d_->qvel, m_->nv) = s.v;
  if (m_->na) Eigen::Map<Eigen::VectorXd>(d_->act, m_->na) = s.act;
  if (m_->nu) Eigen::Map<Eigen::VectorXd>(d_->ctrl, m_->nu) = s.ctrl;
  const int nv = m_->nv;
  if (static_cast<int>(s.extra.size()) == 2 * nv) {
    std::copy(s.extra.begin(), s.extra.begin() + nv, d_->qacc_warmstart);
    restored_constraint_ = Eigen::Map<const Eigen::VectorXd>(s.extra.data() + nv, nv);
    constraint_restored_ = true;
  } else if (s.extra.empty()) {
    mju_zero(d_->qacc_warmstart, nv);  // a cold start
    restored_constraint_.setZero(nv);
    constraint_restored_ = true;
  }
  mju_zero(d_->xfrc_applied, 6 * m_->nbody);
  pending_tau_.setZero();
  forwarded_ = false;
  diverged_ = false;
}

void MujocoEngine::step() {
  forward();
  double t_before = d_->time;
  Eigen::Map<Eigen::VectorXd> applied(d_->qfrc_applied, m_->nv);
  applied = pending_tau_;
  if (has_velocity_commands_) {
    // one-step velocity servo: the force that reaches the commanded speed this step,
    // ignoring coupling through the mass matrix (DART's VELOCITY actuators behave alike)
    for (int i = 0; i < m_->nv; ++i) {
      double vd = velocity_command_[i];
      if (std::isnan(vd)) continue;
      double mii = d_->qM[m_->dof_Madr[i]];
      applied[i] += mii * (vd - d_->qvel[i]) / m_->opt.timestep + d_->qfrc_bias[i];
    }
  }
  mj_step2(m_, d_);
  applied.setZero();
  pending_tau_.setZero();
  mju_zero(d_->xfrc_applied, 6 * m_->nbody);
  forwarded_ = false;
  // MuJoCo resets the data on a bad acceleration and counts a warning: that is a divergence.
  // The reset also clears the counters, so a second reset after a restore can leave the count
  // where it was; the clock, set back to 0, shows it either way (a planner's rollout otherwise
  // ran its horizon again from t = 0)
  int seen = d_->warning[mjWARN_BADQACC].number + d_->warning[mjWARN_BADQPOS].number +
             d_->warning[mjWARN_BADQVEL].number;
  if (seen != warnings_seen_ || d_->time < t_before) {
    warnings_seen_ = seen;
    diverged_ = true;
    last_warning_ =
        fmt::format("MuJoCo instability at t={:.6f} s: {}", t_before,
                    g_last_mujoco_warning.empty() ? "bad state" : g_last_mujoco_warning);
  }
}

bool MujocoEngine::applied_joint_forces(Eigen::Ref<Eigen::VectorXd> tau) const {
  // the smooth force less bias and passive forces: qfrc_applied, qfrc_actuator and J^T xfrc
  for (int i = 0; i < m_->nv; ++i)
    tau[i] = d_->qfrc_smooth[i] + d_->qfrc_bias[i] - d_->qfrc_passive[i];
  return true;
}

bool MujocoEngine::state_is_finite() const {
  if (diverged_) return false;
  for (int i = 0; i < m_->nq; ++i)
    if (!std::isfinite(d_->qpos[i])) return false;
  for (int i = 0; i < m_->nv; ++i)
    if (!std::isfinite(d_->qvel[i])) return false;
  return true;
}

}  // namespace stance
