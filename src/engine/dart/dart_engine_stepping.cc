// DART backend: forward(), contacts, velocity servos, stepping, state save/restore and the
// divergence report.
#include "engine/dart/dart_engine.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace stance::dart_backend {

namespace {

// a number as printf's `format` writes it, for messages
std::string number_text(double x, const char* format = "%.6f") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

}  // namespace

void DartEngine::forward() {
  // a diverged state would trip DART's transform asserts (abort) instead of being reported
  if (!positions_usable()) return;
  // DART computes lazily; refresh kinematics now so later const reads are cheap
  for (const SkeletonBlock& b : blocks_) b.skeleton->computeForwardKinematics(true, true, false);
  // contact geometry for a state set by hand; after a step the step's own contacts stand
  if (positions_set_since_step_) {
    dart::constraint::ConstraintSolver* solver = world_->getConstraintSolver();
    forward_contacts_.clear();
    // the query, and the next step, each on a broad phase built from the state alone
    rebuild_broad_phase();
    solver->getCollisionGroup()->collide(solver->getCollisionOption(), &forward_contacts_);
    broad_phase_rebuilt_ = false;
    rebuild_broad_phase();
    use_forward_contacts_ = true;
    positions_set_since_step_ = false;
  }
}

void DartEngine::rebuild_broad_phase() const {
  if (broad_phase_rebuilt_) return;
  broad_phase_rebuilt_ = true;
  dart::constraint::ConstraintSolver* solver = world_->getConstraintSolver();
  const auto detector = solver->getCollisionDetector();
  if (detector->getType() == dart::collision::DARTCollisionDetector::getStaticType()) return;
  const dart::collision::CollisionGroupPtr group = solver->getCollisionGroup();
  const auto holder = detector->createCollisionGroupAsSharedPtr();
  for (size_t i = 0; i < world_->getNumSkeletons(); ++i)
    holder->addShapeFramesOf(world_->getSkeleton(i).get());
  holder->collide(dart::collision::CollisionOption(false, 1));
  // each skeleton's frames removed through it first: removeAllShapeFrames alone keeps the
  // group's subscription to the skeleton, whose records then point at freed objects (a crash in
  // the next collide on MJCF robots with capsules, which go to FCL)
  for (size_t i = 0; i < world_->getNumSkeletons(); ++i)
    group->removeShapeFramesOf(world_->getSkeleton(i).get());
  group->removeAllShapeFrames();
  for (size_t i = 0; i < world_->getNumSkeletons(); ++i)
    group->addShapeFramesOf(world_->getSkeleton(i).get());
}

Contact DartEngine::contact(int i) const {
  const dart::collision::Contact& c = contacts().getContact(i);
  // DART: normal points from its body 2 to its body 1 and force acts on its body 1.
  // Ours: normal from body1 to body2, force on body2. So DART's body 2 is our body1.
  Contact out;
  out.body1 = body_of(c.collisionObject2);
  out.body2 = body_of(c.collisionObject1);
  out.pos = c.point;
  out.normal = c.normal;
  out.force = use_forward_contacts_ ? Eigen::Vector3d::Zero() : c.force;
  return out;
}

void DartEngine::set_dof_velocity_command(int dof, double velocity) {
  Joint* j = block_of(dof).skeleton->getDof(dof - block_of(dof).dof_start)->getJoint();
  // a multi-dof joint can never have been commanded, so releasing it (NaN) has nothing to do
  if (j->getNumDofs() != 1 && std::isnan(velocity)) return;
  if (j->getNumDofs() != 1)
    throw std::invalid_argument("velocity command on dof '" + dof_names_[dof] +
                                "': DART actuates whole joints; only 1-dof joints supported");
  velocity_command_[dof] = velocity;
  if (std::isnan(velocity)) {
    j->setActuatorType(Joint::FORCE);
    j->setCommand(0, 0.0);
  } else {
    j->setActuatorType(Joint::VELOCITY);
    j->setCommand(0, velocity);
  }
}

void DartEngine::save_state(EngineState& s) const {
  s.time = world_->getTime();
  s.q.resize(ndof_);
  s.v.resize(ndof_);
  get_positions(s.q);
  get_velocities(s.v);
  s.act.resize(0);
  s.ctrl.resize(0);
  s.extra.resize(2 * static_cast<size_t>(ndof_));
  Eigen::Map<Eigen::VectorXd> constraint(s.extra.data(), ndof_);
  constraint_forces(constraint);
  std::copy(velocity_command_.begin(), velocity_command_.end(), s.extra.begin() + ndof_);
  // what follows a saved state then depends on it alone, as after its restore
  rebuild_broad_phase();
}

void DartEngine::restore_state(const EngineState& s) {
  world_->setTime(s.time);
  set_positions(s.q);
  set_velocities(s.v);
  // the per-step inputs of a run that was left before its step
  for (const SkeletonBlock& b : blocks_) {
    b.skeleton->clearInternalForces();
    b.skeleton->clearExternalForces();
  }
  external_forces_since_step_ = false;
  const bool warm = s.extra.size() == 2 * static_cast<size_t>(ndof_);
  if (warm)
    restored_constraint_ = Eigen::Map<const Eigen::VectorXd>(s.extra.data(), ndof_);
  else
    restored_constraint_.setZero(ndof_);  // a cold start (an older state file)
  constraint_restored_ = true;
  for (int dof = 0; dof < ndof_; ++dof) {
    const double command = warm ? s.extra[ndof_ + dof] : kNaN;
    const double now = velocity_command_[dof];
    if (command != now && !(std::isnan(command) && std::isnan(now)))
      set_dof_velocity_command(dof, command);
  }
  // contacts come from forward() now
  forward_contacts_.clear();
  use_forward_contacts_ = true;
  rebuild_broad_phase();
}

void DartEngine::step() {
  // World::step resets joint commands afterwards; velocity servos persist, so re-arm them
  for (int dof = 0; dof < ndof_; ++dof) {
    if (std::isnan(velocity_command_[dof])) continue;
    const SkeletonBlock& b = block_of(dof);
    b.skeleton->getDof(dof - b.dof_start)->setCommand(velocity_command_[dof]);
  }
  // stepping a diverged state aborts in DART's FreeJoint assert; the runner reports it instead
  step_start_time_ = world_->getTime();
  if (!state_is_finite()) return;
  world_->step();
  broad_phase_rebuilt_ = false;
  constraint_restored_ = false;
  use_forward_contacts_ = false;
  positions_set_since_step_ = false;
  positions_usable_ = -1;
  external_forces_since_step_ = false;
}

bool DartEngine::state_is_finite() const {
  if (!positions_usable()) return false;
  // dof by dof: getVelocities() returns a fresh vector
  for (const SkeletonBlock& b : blocks_)
    for (int i = 0; i < b.ndof; ++i)
      if (!(std::abs(b.skeleton->getVelocity(i)) <= kBlownUpSpeed)) return false;
  return true;
}

std::string DartEngine::last_warning() const {
  if (state_is_finite()) return load_warnings_;
  for (const SkeletonBlock& b : blocks_)
    for (int i = 0; i < b.ndof; ++i) {
      const double q = b.skeleton->getPosition(i), v = b.skeleton->getVelocity(i);
      if (std::isfinite(q) && std::abs(v) <= kBlownUpSpeed) continue;
      const bool bad_v = !(std::abs(v) <= kBlownUpSpeed);
      const char* what = !bad_v             ? "non-finite position "
                         : std::isfinite(v) ? "blown-up velocity "
                                            : "non-finite velocity ";
      return std::string("DART instability at t=") + number_text(step_start_time_) + " s: " + what +
             number_text(bad_v ? v : q, "%g") + " on dof '" + dof_name(b.dof_start + i) + "'";
    }
  // all finite, but the squared positions overflow: name the largest
  int worst = 0;
  double value = 0;
  for (const SkeletonBlock& b : blocks_)
    for (int i = 0; i < b.ndof; ++i)
      if (std::abs(b.skeleton->getPosition(i)) > std::abs(value)) {
        value = b.skeleton->getPosition(i);
        worst = b.dof_start + i;
      }
  return "DART instability at t=" + number_text(step_start_time_) + " s: position too large " +
         number_text(value, "%g") + " on dof '" + dof_name(worst) + "'";
}

}  // namespace stance::dart_backend
