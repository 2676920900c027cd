// DART 6.12 backend of stance::Engine.
//
// Conventions of this backend (see engine.h for the shared ones):
//  - only mobile skeletons are simulated state: immobile ones (e.g. a ground skeleton) add no
//    dofs, bodies or mass, and count as "the world" (body -1) in contacts.
//  - nq == nv: free and ball joints store exponential coordinates, as DART does. A free
//    joint's q is (rotation vector, translation of the child frame in the parent frame) and its
//    v is the child body's twist in the child body frame (angular, linear); positions are
//    integrated as T(q) * T(v dt), exactly as DART's FreeJoint::integratePositions does.
//  - Euler and universal joints appear as one hinge JointInfo per dof, named like the dof.
//  - contacts: DART reports normal from its 2nd to its 1st object and force on its 1st; we
//    swap the pair, so Contact::normal points from body1 to body2 and Contact::force (normal
//    plus friction, world frame, N) acts on body2.
//  - contacts come from the last step (with forces) or, when positions were set since,
//    from forward() (geometry only, zero forces).
//  - collision detection uses DART's own detector whenever every collision shape is a box or
//    sphere: it tests pairs in a fixed order. Models with other shapes keep the detector the
//    file asks for; FCL and Bullet order contacts by their broad-phase trees, which depend on
//    history, so the tree is rebuilt from the state at save, restore and forward's contact
//    query (rebuild_broad_phase): restore_state + step replays bit-exactly on every detector.
//  - MJCF through DART 6.12's MjcfParser: <option> timestep/gravity are read here (the parser
//    ignores them), a missing <default> is supplied (the parser asserts on it), <freejoint/>
//    becomes <joint type="free"/> (the parser skips the shorthand and welds the body), and
//    <inertial> diaginertia/fullinertia/quat are applied (the parser leaves a unit moment).
//
// Private to src/engine/dart: the engine class, split over dart_engine.cc (building the model),
// dart_engine_dynamics.cc (kinematics and dynamics queries), dart_engine_stepping.cc (contacts,
// stepping, state save/restore) and dart_model_reader.cc (parsing the model files, patched first
// by dart_model_patches.cc).
#pragma once

#include <dart/dart.hpp>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/error.h"
#include "engine/backend_world.h"
#include "engine/drawing_copy.h"
#include "engine/engine.h"

namespace stance::dart_backend {

using dart::dynamics::BallJoint;
using dart::dynamics::BodyNode;
using dart::dynamics::FreeJoint;
using dart::dynamics::Joint;
using dart::dynamics::SkeletonPtr;

// how a run of coordinates moves on its configuration space
enum class PositionGroupKind { kVector, kFree, kBall };

struct PositionGroup {
  PositionGroupKind kind = PositionGroupKind::kVector;
  int start = 0;  // in q (== in v)
  int size = 0;
};

// one mobile skeleton's slice of the global vectors
struct SkeletonBlock {
  SkeletonPtr skeleton;
  int dof_start = 0;
  int ndof = 0;
};

// parses one model file into a temporary world of its own
dart::simulation::WorldPtr read_model_world(const BackendModel& model, std::string& warnings);

class DartEngine final : public Engine {
 public:
  explicit DartEngine(const BackendWorld& spec);

  std::string_view engine_name() const override { return "dart"; }

  int nq() const override { return ndof_; }
  int nv() const override { return ndof_; }
  int nu() const override { return 0; }
  int nbody() const override { return static_cast<int>(bodies_.size()); }
  int njoint() const override { return static_cast<int>(joints_.size()); }
  double total_mass() const override { return total_mass_; }

  int body_index(std::string_view name) const override { return find(body_lookup_, name); }
  int joint_index(std::string_view name) const override { return find(joint_lookup_, name); }
  int dof_index(std::string_view name) const override { return find(dof_lookup_, name); }
  int actuator_index(std::string_view) const override { return -1; }
  const std::string& body_name(int body) const override { return body_names_.at(body); }
  const std::string& dof_name(int dof) const override { return dof_names_.at(dof); }
  const std::string& actuator_name(int actuator) const override {
    throw std::out_of_range("DART backend has no actuators (index " + std::to_string(actuator) +
                            ")");
  }
  const JointInfo& joint(int joint) const override { return joints_.at(joint); }
  int dof_joint(int dof) const override { return dof_joint_.at(dof); }
  double body_mass(int body) const override { return bodies_.at(body)->getMass(); }
  int body_parent(int body) const override {
    const BodyNode* parent = bodies_.at(body)->getParentBodyNode();
    if (!parent) return -1;
    auto it = body_of_node_.find(parent);
    return it == body_of_node_.end() ? -1 : it->second;
  }

  double time() const override { return world_->getTime(); }
  double timestep() const override { return world_->getTimeStep(); }
  void set_timestep(double dt) override {
    if (!(dt > 0) || !std::isfinite(dt))
      throw std::invalid_argument("timestep must be positive, got " + std::to_string(dt));
    world_->setTimeStep(dt);
  }
  Eigen::Vector3d gravity() const override { return world_->getGravity(); }
  void set_gravity(const Eigen::Vector3d& g) override { world_->setGravity(g); }

  void get_positions(Eigen::Ref<Eigen::VectorXd> q) const override {
    // per dof: getPositions() returns a fresh vector
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) q[b.dof_start + i] = b.skeleton->getPosition(i);
  }
  void get_velocities(Eigen::Ref<Eigen::VectorXd> v) const override {
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) v[b.dof_start + i] = b.skeleton->getVelocity(i);
  }
  void set_positions(const Eigen::Ref<const Eigen::VectorXd>& q) override {
    check_size(q.size(), ndof_, "set_positions");
    for (const SkeletonBlock& b : blocks_) b.skeleton->setPositions(q.segment(b.dof_start, b.ndof));
    positions_set_since_step_ = true;
    positions_usable_ = -1;
    broad_phase_rebuilt_ = false;
  }
  void set_velocities(const Eigen::Ref<const Eigen::VectorXd>& v) override {
    check_size(v.size(), ndof_, "set_velocities");
    for (const SkeletonBlock& b : blocks_)
      b.skeleton->setVelocities(v.segment(b.dof_start, b.ndof));
  }
  double dof_position(int dof) const override {
    const SkeletonBlock& b = block_of(dof);
    return b.skeleton->getPosition(dof - b.dof_start);
  }
  double dof_velocity(int dof) const override {
    const SkeletonBlock& b = block_of(dof);
    return b.skeleton->getVelocity(dof - b.dof_start);
  }
  void set_dof_position(int dof, double value) override {
    // rotation dofs of free/ball joints are exponential coordinates already: set directly
    const SkeletonBlock& b = block_of(dof);
    b.skeleton->setPosition(dof - b.dof_start, value);
    positions_set_since_step_ = true;
    positions_usable_ = -1;
    broad_phase_rebuilt_ = false;
  }

  void difference_positions(const Eigen::Ref<const Eigen::VectorXd>& q0,
                            const Eigen::Ref<const Eigen::VectorXd>& q1,
                            Eigen::Ref<Eigen::VectorXd> v) const override;

  void integrate_positions(const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                           Eigen::Ref<Eigen::VectorXd> q_out) const override;

  void forward() override;

  void mass_matrix(Eigen::Ref<Eigen::MatrixXd> m) const override {
    m.setZero();
    for (const SkeletonBlock& b : blocks_)
      m.block(b.dof_start, b.dof_start, b.ndof, b.ndof) = b.skeleton->getMassMatrix();
  }
  void solve_mass(Eigen::Ref<Eigen::VectorXd> x) const override;
  void solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                          Eigen::Ref<Eigen::VectorXd> x) const override;
  // every joint takes forces (no velocity or acceleration servo, which ABA would prescribe)
  static bool force_driven(const dart::dynamics::Skeleton& skel);
  // DART caches articulated inertias (which hold h D) until positions change
  static void mark_articulated_inertia_stale(dart::dynamics::Skeleton& skel);

  void bias_forces(Eigen::Ref<Eigen::VectorXd> c) const override {
    for (const SkeletonBlock& b : blocks_)
      c.segment(b.dof_start, b.ndof) = b.skeleton->getCoriolisAndGravityForces();
  }
  void constraint_forces(Eigen::Ref<Eigen::VectorXd> f) const override {
    if (constraint_restored_) {
      f = restored_constraint_;
      return;
    }
    for (const SkeletonBlock& b : blocks_)
      f.segment(b.dof_start, b.ndof) = b.skeleton->getConstraintForces();
  }

  void inverse_dynamics(const Eigen::Ref<const Eigen::VectorXd>& vdot,
                        Eigen::Ref<Eigen::VectorXd> tau) const override;

  Eigen::Vector3d com() const override {
    if (!positions_usable()) return Eigen::Vector3d::Constant(kNaN);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const SkeletonBlock& b : blocks_) sum += b.skeleton->getMass() * b.skeleton->getCOM();
    return total_mass_ > 0 ? Eigen::Vector3d(sum / total_mass_) : sum;
  }
  Eigen::Vector3d com_velocity() const override {
    if (!positions_usable()) return Eigen::Vector3d::Constant(kNaN);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const SkeletonBlock& b : blocks_)
      sum += b.skeleton->getMass() * b.skeleton->getCOMLinearVelocity();
    return total_mass_ > 0 ? Eigen::Vector3d(sum / total_mass_) : sum;
  }
  BodyPose body_pose(int body) const override {
    if (!positions_usable()) {
      BodyPose nan;
      nan.pos.setConstant(kNaN);
      nan.quat.coeffs().setConstant(kNaN);
      return nan;
    }
    const Eigen::Isometry3d& t = bodies_.at(body)->getWorldTransform();
    BodyPose pose;
    pose.pos = t.translation();
    pose.quat = Eigen::Quaterniond(t.linear());
    return pose;
  }
  Eigen::Vector3d body_com(int body) const override {
    if (!positions_usable()) return Eigen::Vector3d::Constant(kNaN);
    return bodies_.at(body)->getCOM();
  }
  Eigen::Matrix<double, 6, 1> body_velocity(int body) const override {
    const BodyNode* bn = bodies_.at(body);
    Eigen::Matrix<double, 6, 1> out;
    if (!positions_usable()) return out.setConstant(kNaN);
    out.head<3>() = bn->getAngularVelocity();
    out.tail<3>() = bn->getLinearVelocity();  // of the frame origin
    return out;
  }
  void point_jacobian(int body, const Eigen::Vector3d& point_world,
                      Eigen::Ref<Eigen::MatrixXd> jac_pos,
                      Eigen::Ref<Eigen::MatrixXd> jac_rot) const override;
  void com_jacobian(Eigen::Ref<Eigen::MatrixXd> jac) const override;

  void subtree_com_jacobian(int body, Eigen::Ref<Eigen::MatrixXd> jac) const override;
  Eigen::Vector3d subtree_com(int body) const override;

  int num_contacts() const override { return static_cast<int>(contacts().getNumContacts()); }
  Contact contact(int i) const override;

  void set_generalized_forces(const Eigen::Ref<const Eigen::VectorXd>& tau) override {
    check_size(tau.size(), ndof_, "set_generalized_forces");
    // per dof: setForces takes a VectorXd, so a segment would be copied into a fresh one
    for (const SkeletonBlock& b : blocks_)
      for (int i = 0; i < b.ndof; ++i) b.skeleton->setForce(i, tau[b.dof_start + i]);
  }
  void set_controls(const Eigen::Ref<const Eigen::VectorXd>& ctrl) override {
    check_size(ctrl.size(), 0, "set_controls (DART models have no actuators)");
  }
  void get_controls(Eigen::Ref<Eigen::VectorXd> ctrl) const override {
    check_size(ctrl.size(), 0, "get_controls (DART models have no actuators)");
  }
  void actuator_moment(Eigen::Ref<Eigen::MatrixXd>) const override {
    throw InputError("actuator moments: the dart engine has no actuators (nu = 0)");
  }
  void apply_external_force(int body, const Eigen::Vector3d& force_world,
                            const Eigen::Vector3d& point_world) override {
    // force and point both in world coordinates; DART clears it after the step
    bodies_.at(body)->addExtForce(force_world, point_world, false, false);
    external_forces_since_step_ = true;
  }
  void set_dof_velocity_command(int dof, double velocity) override;

  // extra: the last step's constraint forces (dim nv; read by controllers before the next
  // step) and the velocity servos' commands (dim nv; NaN: none)
  void save_state(EngineState& s) const override;
  // bit-exact: a run from a restored state repeats the run that followed its save, whatever
  // this engine (or another one built from the same files) ran in between
  void restore_state(const EngineState& s) override;

  void step() override;

  // a speed no simulation reaches: beyond it the state is blowing up (an Euler joint near its
  // singularity), and DART's next step would overflow to NaN inside its forward dynamics and
  // abort in GenericJoint's assert instead of returning a NaN state (as MuJoCo's QACC check does)
  static constexpr double kBlownUpSpeed = 1e6;  // rad/s or m/s

  bool state_is_finite() const override;
  // after a divergence its cause (the load's warnings are not one), else the load's warnings
  std::string last_warning() const override;
  // a MuJoCo copy of the world, posed as DART's (engine/drawing_copy.h)
  RenderModel render_model() override;

 private:
  using Lookup = std::map<std::string, int, std::less<>>;

  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  // true when DART can build transforms from the positions: finite, and a rotation vector's
  // norm that does not overflow (exp of an infinite angle gives NaN, which DART asserts on)
  bool positions_usable() const {
    // once per change of the positions: every pose and COM query asks, and reading each dof
    // from its joint object misses the cache after a step (about 4 us a pass on fullbody1)
    if (positions_usable_ >= 0) return positions_usable_ == 1;
    // dof by dof: getPositions() would allocate in the controllers' hot loop
    double sum = 0;
    for (const SkeletonBlock& b : blocks_) {
      for (int i = 0; i < b.ndof; ++i) {
        const double q = b.skeleton->getPosition(i);
        sum += q * q;
      }
    }
    positions_usable_ = std::isfinite(sum) ? 1 : 0;
    return positions_usable_ == 1;
  }

  // true when `body` is `root` or hangs below it
  bool in_subtree(int body, int root) const {
    for (int b = body; b >= 0; b = body_parent(b))
      if (b == root) return true;
    return false;
  }
  double subtree_mass(int root) const {
    double mass = 0;
    for (int b = 0; b < nbody(); ++b)
      if (in_subtree(b, root)) mass += bodies_[b]->getMass();
    return mass;
  }

  static int find(const Lookup& lookup, std::string_view name) {
    auto it = lookup.find(name);
    return it == lookup.end() ? -1 : it->second;
  }
  static void check_size(Eigen::Index got, int want, const char* what) {
    if (got != want)
      throw std::invalid_argument(std::string(what) + ": expected size " + std::to_string(want) +
                                  ", got " + std::to_string(got));
  }
  const SkeletonBlock& block_of(int dof) const { return blocks_[dof_block_.at(dof)]; }
  const dart::collision::CollisionResult& contacts() const {
    return use_forward_contacts_ ? forward_contacts_ : world_->getLastCollisionResult();
  }

  int body_of(const dart::collision::CollisionObject* object) const {
    const dart::dynamics::ShapeFrame* frame = object->getShapeFrame();
    const dart::dynamics::ShapeNode* node = frame ? frame->asShapeNode() : nullptr;
    if (!node) return -1;
    auto it = body_of_node_.find(node->getBodyNodePtr().get());
    return it == body_of_node_.end() ? -1 : it->second;
  }

  // builds world_ from the spec's files
  void load(const BackendWorld& spec);

  // FCL's and Bullet's broad phases keep a tree that each collision check refits from the last
  // one, and they report contact pairs in its order: two runs from one state differed in the
  // last bits when their histories did (a planner's result then depended on its thread count).
  // Each check also rebalances the tree a little, so it is rebuilt from the current poses after
  // a save, a restore and forward()'s check: a step's contacts are then a function of the
  // state alone. The collision objects (and the shapes' geometry) are kept: a second group holds
  // them meanwhile, and its check moves their bounding boxes to the current poses first.
  void rebuild_broad_phase() const;

  // every mobile skeleton must move mass along each dof, or DART aborts in its first step
  // (mTotalMass != 0, !isNan(PI)). The readers check URDF, SDF and SKEL files and MuJoCo's
  // compiler an MJCF file, but DART 6.12's MJCF reader takes a body's mass from its first geom
  // only: a massless visual geom first left the body with none. A Cholesky factorisation of
  // the mass matrix at the initial state finds the first dof (parents come first) without.
  void check_moving_masses(const BackendWorld& spec) const;

  // the first dof whose pivot in M = L L^T vanishes, or -1 when M is positive definite
  static int first_massless_dof(Eigen::MatrixXd m);

  // the file and line of an MJCF <body> of that name (line 0 when not found)
  static std::pair<std::string, int> body_line(const BackendWorld& spec, const std::string& body);

  // true when DART's own (deterministic) detector handles every collision shape
  bool only_primitive_collision_shapes() const;

  // names, index maps and position groups over the mobile skeletons, in world order
  void index_model();

  // translational dofs of prismatic/translational/planar joints are slides
  static JointType dof_type(const Joint* j, int k);

  void add_joint(const std::string& name, JointType type, int body, int first, int n,
                 const dart::dynamics::DegreeOfFreedom* limits_from);

  dart::simulation::WorldPtr world_;
  std::vector<SkeletonBlock> blocks_;
  std::vector<PositionGroup> position_groups_;
  int ndof_ = 0;
  double total_mass_ = 0;

  std::vector<BodyNode*> bodies_;
  std::vector<int> body_block_;
  std::vector<std::string> body_names_;
  std::unordered_map<const BodyNode*, int> body_of_node_;
  Lookup body_lookup_;

  std::vector<std::string> dof_names_;
  std::vector<int> dof_block_;
  std::vector<int> dof_joint_;
  Lookup dof_lookup_;

  std::vector<JointInfo> joints_;
  Lookup joint_lookup_;

  std::vector<double> velocity_command_;   // NaN: no servo
  mutable Eigen::VectorXd solve_scratch_;  // dim nv; keeps solve_mass allocation-free
  // solve_mass_shifted's saved joint forces, damping and spring stiffnesses; dim nv
  mutable Eigen::VectorXd shift_forces_, shift_damping_, shift_springs_;
  std::string load_warnings_;
  std::function<std::unique_ptr<Engine>()> make_drawing_world_;  // BackendWorld's
  std::unique_ptr<DrawingCopy> drawing_;                         // made on first drawing
  double step_start_time_ = 0;  // s, of the last step (for the divergence message)

  // contacts: the last step's, or those forward() found for positions set since
  dart::collision::CollisionResult forward_contacts_;
  bool use_forward_contacts_ = false;
  bool positions_set_since_step_ = true;
  // positions_usable() of the current positions: -1 not known yet, else 0 or 1
  mutable int positions_usable_ = -1;
  // an external force was added since the last step (DART clears them in the step)
  bool external_forces_since_step_ = false;
  // the broad phase was rebuilt from the current poses and has not been used since
  mutable bool broad_phase_rebuilt_ = false;
  // restore_state's constraint forces (dim nv), reported until the next step
  Eigen::VectorXd restored_constraint_;
  bool constraint_restored_ = false;
};

}  // namespace stance::dart_backend
