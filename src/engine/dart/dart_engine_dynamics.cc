// DART backend: position algebra, mass-matrix solves, inverse dynamics and Jacobians.
#include "engine/dart/dart_engine.h"

#include <cstddef>
#include <vector>

namespace stance::dart_backend {

void DartEngine::difference_positions(const Eigen::Ref<const Eigen::VectorXd>& q0,
                                      const Eigen::Ref<const Eigen::VectorXd>& q1,
                                      Eigen::Ref<Eigen::VectorXd> v) const {
  check_size(q0.size(), ndof_, "difference_positions q0");
  check_size(q1.size(), ndof_, "difference_positions q1");
  check_size(v.size(), ndof_, "difference_positions v");
  for (const PositionGroup& g : position_groups_) {
    switch (g.kind) {
      case PositionGroupKind::kVector:
        v.segment(g.start, g.size) = q1.segment(g.start, g.size) - q0.segment(g.start, g.size);
        break;
      case PositionGroupKind::kFree: {
        // same as FreeJoint::getPositionDifferencesStatic: log of T0^-1 T1, piecewise
        const Eigen::Isometry3d t0 = FreeJoint::convertToTransform(q0.segment<6>(g.start));
        const Eigen::Isometry3d t1 = FreeJoint::convertToTransform(q1.segment<6>(g.start));
        v.segment<6>(g.start) = FreeJoint::convertToPositions(t0.inverse() * t1);
        break;
      }
      case PositionGroupKind::kBall: {
        const Eigen::Matrix3d r0 = BallJoint::convertToRotation(q0.segment<3>(g.start));
        const Eigen::Matrix3d r1 = BallJoint::convertToRotation(q1.segment<3>(g.start));
        v.segment<3>(g.start) = BallJoint::convertToPositions(Eigen::Matrix3d(r0.transpose() * r1));
        break;
      }
    }
  }
}

void DartEngine::integrate_positions(const Eigen::Ref<const Eigen::VectorXd>& q,
                                     const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                                     Eigen::Ref<Eigen::VectorXd> q_out) const {
  check_size(q.size(), ndof_, "integrate_positions q");
  check_size(v.size(), ndof_, "integrate_positions v");
  check_size(q_out.size(), ndof_, "integrate_positions q_out");
  for (const PositionGroup& g : position_groups_) {
    switch (g.kind) {
      case PositionGroupKind::kVector:
        q_out.segment(g.start, g.size) =
            q.segment(g.start, g.size) + dt * v.segment(g.start, g.size);
        break;
      case PositionGroupKind::kFree: {
        // FreeJoint::integratePositions: Q_next = Q * T(v dt), i.e. a body-frame step
        const Eigen::Vector6d step = v.segment<6>(g.start) * dt;
        const Eigen::Isometry3d t = FreeJoint::convertToTransform(q.segment<6>(g.start)) *
                                    FreeJoint::convertToTransform(step);
        q_out.segment<6>(g.start) = FreeJoint::convertToPositions(t);
        break;
      }
      case PositionGroupKind::kBall: {
        // BallJoint::integratePositions: R_next = R * exp(w dt)
        const Eigen::Vector3d step = v.segment<3>(g.start) * dt;
        const Eigen::Matrix3d r = BallJoint::convertToRotation(q.segment<3>(g.start)) *
                                  BallJoint::convertToRotation(step);
        q_out.segment<3>(g.start) = BallJoint::convertToPositions(r);
        break;
      }
    }
  }
}

void DartEngine::solve_mass(Eigen::Ref<Eigen::VectorXd> x) const {
  // DART's inverse comes from its articulated-body recursion, not a dense inversion
  for (const SkeletonBlock& b : blocks_) {
    auto seg = x.segment(b.dof_start, b.ndof);
    auto out = solve_scratch_.head(b.ndof);
    out.noalias() = b.skeleton->getInvMassMatrix() * seg;
    seg = out;
  }
}

void DartEngine::solve_mass_shifted(const Eigen::Ref<const Eigen::VectorXd>& d,
                                    Eigen::Ref<Eigen::VectorXd> x) const {
  // DART's articulated-body forward dynamics solves (M + h D + h^2 K) a = tau - C - D v -
  // K (q + h v - q0) + F_ext for its implicit joint damping D and springs K, in O(n) and
  // without building M (about 240 us on fullbody1). With D = d / h, K = 0 and
  // tau = x + C + D v - F_ext (C and F_ext are cached by DART) it gives (M + diag d)^-1 x in
  // one pass. The joints' own damping, springs and forces are put back afterwards and the
  // articulated inertias marked stale for the real step.
  const double h = timestep();
  for (const SkeletonBlock& b : blocks_) {
    auto& skel = *b.skeleton;
    if (!force_driven(skel) || !(h > 0) || (d.array() < 0).any()) {
      Engine::solve_mass_shifted(d, x);  // velocity servos: ABA would prescribe them
      return;
    }
  }
  for (const SkeletonBlock& b : blocks_) {
    auto& skel = *b.skeleton;
    // per dof, so that nothing here allocates
    for (int i = 0; i < b.ndof; ++i) {
      dart::dynamics::DegreeOfFreedom* dof = skel.getDof(i);
      shift_forces_[b.dof_start + i] = dof->getForce();
      shift_damping_[b.dof_start + i] = dof->getDampingCoefficient();
      shift_springs_[b.dof_start + i] = dof->getSpringStiffness();
      dof->setDampingCoefficient(d[b.dof_start + i] / h);
      dof->setSpringStiffness(0.0);
    }
    const Eigen::VectorXd& bias = skel.getCoriolisAndGravityForces();
    // DART aggregates the external forces body by body (14 k instructions on fullbody1): only
    // when a force was applied since the last step; otherwise they are zero
    const Eigen::VectorXd* external =
        external_forces_since_step_ ? &skel.getExternalForces() : nullptr;
    for (int i = 0; i < b.ndof; ++i) {
      dart::dynamics::DegreeOfFreedom* dof = skel.getDof(i);
      dof->setForce(x[b.dof_start + i] + bias[i] - (external ? (*external)[i] : 0.0) +
                    d[b.dof_start + i] / h * dof->getVelocity());
    }
    mark_articulated_inertia_stale(skel);
    skel.computeForwardDynamics();
    for (int i = 0; i < b.ndof; ++i) {
      dart::dynamics::DegreeOfFreedom* dof = skel.getDof(i);
      x[b.dof_start + i] = dof->getAcceleration();
      dof->setDampingCoefficient(shift_damping_[b.dof_start + i]);
      dof->setSpringStiffness(shift_springs_[b.dof_start + i]);
      dof->setForce(shift_forces_[b.dof_start + i]);
    }
    mark_articulated_inertia_stale(skel);
  }
}

bool DartEngine::force_driven(const dart::dynamics::Skeleton& skel) {
  for (std::size_t j = 0; j < skel.getNumJoints(); ++j) {
    const auto type = skel.getJoint(j)->getActuatorType();
    if (type != dart::dynamics::Joint::FORCE && type != dart::dynamics::Joint::PASSIVE)
      return false;
  }
  return true;
}

void DartEngine::mark_articulated_inertia_stale(dart::dynamics::Skeleton& skel) {
  for (std::size_t t = 0; t < skel.getNumTrees(); ++t) skel.dirtyArticulatedInertia(t);
}

void DartEngine::inverse_dynamics(const Eigen::Ref<const Eigen::VectorXd>& vdot,
                                  Eigen::Ref<Eigen::VectorXd> tau) const {
  check_size(vdot.size(), ndof_, "inverse_dynamics vdot");
  check_size(tau.size(), ndof_, "inverse_dynamics tau");
  // M vdot + C, plus what the joints' damping and springs take away (DART treats them
  // implicitly in a step; here they are the continuous-time forces). Per dof: no allocation.
  for (const SkeletonBlock& b : blocks_) {
    auto out = tau.segment(b.dof_start, b.ndof);
    out.noalias() = b.skeleton->getMassMatrix() * vdot.segment(b.dof_start, b.ndof);
    out += b.skeleton->getCoriolisAndGravityForces();
    for (int i = 0; i < b.ndof; ++i) {
      const dart::dynamics::DegreeOfFreedom* dof = b.skeleton->getDof(i);
      out[i] += dof->getDampingCoefficient() * dof->getVelocity() +
                dof->getSpringStiffness() * (dof->getPosition() - dof->getRestPosition());
    }
  }
}

void DartEngine::point_jacobian(int body, const Eigen::Vector3d& point_world,
                                Eigen::Ref<Eigen::MatrixXd> jac_pos,
                                Eigen::Ref<Eigen::MatrixXd> jac_rot) const {
  const BodyNode* bn = bodies_.at(body);
  const SkeletonBlock& b = blocks_[body_block_[body]];
  if (jac_pos.cols() > 0) jac_pos.setZero();
  if (jac_rot.cols() > 0) jac_rot.setZero();
  // Skeleton::getWorldJacobian(body, offset) without its two by-value copies: the body's
  // cached world Jacobian (rows angular; linear) over the dofs it depends on, the linear
  // rows moved to the point by omega x (R offset), as DART does
  const Eigen::Isometry3d& t = bn->getWorldTransform();
  const Eigen::Vector3d offset = t.inverse() * point_world;
  const Eigen::Vector3d r = t.linear() * offset;
  const dart::math::Jacobian& j = bn->getWorldJacobian();
  const std::vector<std::size_t>& deps = bn->getDependentGenCoordIndices();
  for (std::size_t k = 0; k < deps.size(); ++k) {
    const Eigen::Index col = b.dof_start + static_cast<Eigen::Index>(deps[k]);
    const Eigen::Vector3d w = j.col(k).head<3>();
    if (jac_rot.cols() > 0) jac_rot.col(col) = w;
    if (jac_pos.cols() > 0) jac_pos.col(col) = j.col(k).tail<3>() + w.cross(r);
  }
}

void DartEngine::com_jacobian(Eigen::Ref<Eigen::MatrixXd> jac) const {
  jac.setZero();
  if (total_mass_ <= 0) return;
  for (const SkeletonBlock& b : blocks_) {
    jac.middleCols(b.dof_start, b.ndof) =
        (b.skeleton->getMass() / total_mass_) * b.skeleton->getCOMLinearJacobian();
  }
}

void DartEngine::subtree_com_jacobian(int body, Eigen::Ref<Eigen::MatrixXd> jac) const {
  check_size(jac.cols(), ndof_, "subtree_com_jacobian columns");
  jac.setZero();
  const SkeletonBlock& b = blocks_[body_block_.at(body)];
  const double mass = subtree_mass(body);
  if (mass <= 0) return;
  // every body whose chain of parents reaches `body`, weighted by its mass
  for (int other = 0; other < nbody(); ++other) {
    if (!in_subtree(other, body)) continue;
    const BodyNode* bn = bodies_[other];
    jac.middleCols(b.dof_start, b.ndof) +=
        (bn->getMass() / mass) * b.skeleton->getLinearJacobian(bn, bn->getLocalCOM());
  }
}

Eigen::Vector3d DartEngine::subtree_com(int body) const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int other = 0; other < nbody(); ++other)
    if (in_subtree(other, body)) sum += bodies_[other]->getMass() * bodies_[other]->getCOM();
  const double mass = subtree_mass(body);
  return mass > 0 ? Eigen::Vector3d(sum / mass) : bodies_.at(body)->getCOM();
}

}  // namespace stance::dart_backend
