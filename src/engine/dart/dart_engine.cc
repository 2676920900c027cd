// DART 6.12 backend of stance::Engine: building the world from the model files and indexing
// its mobile skeletons (conventions in dart_engine.h).
#include "engine/dart/dart_engine.h"

#include <fmt/format.h>
#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>

#include "core/error.h"
#include "core/model_format.h"

namespace stance::dart_backend {

DartEngine::DartEngine(const BackendWorld& spec) : make_drawing_world_(spec.make_drawing_world) {
  load(spec);
  index_model();
  check_moving_masses(spec);
}

RenderModel DartEngine::render_model() {
  if (!drawing_ && make_drawing_world_)
    drawing_ = std::make_unique<DrawingCopy>(make_drawing_world_(), *this);
  return drawing_ ? drawing_->pose(*this) : RenderModel{};
}

void DartEngine::load(const BackendWorld& spec) {
  if (spec.models.empty()) throw InputError("world spec: no model files given");
  for (const BackendModel& model : spec.models) {
    if (model.file.empty())
      throw InputError(model.name + ": the DART backend reads model files, not text");
    dart::simulation::WorldPtr parsed = read_model_world(model, load_warnings_);
    std::vector<SkeletonPtr> skeletons;
    for (size_t i = 0; i < parsed->getNumSkeletons(); ++i)
      skeletons.push_back(parsed->getSkeleton(i));
    // offset: translate each root joint's parent frame, so q keeps its meaning
    if (!model.offset.isZero()) {
      for (const SkeletonPtr& skel : skeletons) {
        for (size_t t = 0; t < skel->getNumTrees(); ++t) {
          Joint* root = skel->getRootJoint(t);
          Eigen::Isometry3d shifted =
              Eigen::Translation3d(model.offset) * root->getTransformFromParentBodyNode();
          root->setTransformFromParentBodyNode(shifted);
        }
      }
    }
    if (!world_ && model.format != ModelFormat::kUrdf && model.format != ModelFormat::kSdf) {
      // the first world file supplies gravity, timestep and collision detector
      world_ = parsed;
      continue;
    }
    if (!world_) world_ = dart::simulation::World::create();
    for (const SkeletonPtr& skel : skeletons) {
      parsed->removeSkeleton(skel);
      // rename clashes ourselves, as DART would, but without its console message
      const std::string base = skel->getName();
      for (int k = 1; world_->getSkeleton(skel->getName()); ++k)
        skel->setName(base + "(" + std::to_string(k) + ")");
      world_->addSkeleton(skel);
    }
  }
  if (spec.timestep) set_timestep(*spec.timestep);
  if (spec.gravity) world_->setGravity(*spec.gravity);
  if (only_primitive_collision_shapes()) {
    world_->getConstraintSolver()->setCollisionDetector(
        dart::collision::DARTCollisionDetector::create());
  }
}

void DartEngine::check_moving_masses(const BackendWorld& spec) const {
  for (const SkeletonBlock& b : blocks_) {
    if (b.ndof == 0) continue;
    const Eigen::MatrixXd m = b.skeleton->getMassMatrix();
    const int dof = first_massless_dof(m);
    if (b.skeleton->getMass() > 0 && dof < 0) continue;
    const Joint* joint = b.skeleton->getDof(std::max(dof, 0))->getJoint();
    const std::string body = joint->getChildBodyNode()->getName();
    const auto [file, line] = body_line(spec, body);
    throw InputError(located(
        file, line,
        fmt::format("body '{}': joint '{}' moves no mass on DART{}: give the body an "
                    "<inertial> (or a first geom with mass)",
                    body, joint->getName(),
                    spec.models.size() == 1 && spec.models[0].format == ModelFormat::kMjcf
                        ? " (DART 6.12's MJCF reader takes a body's mass from its first geom)"
                        : "")));
  }
}

int DartEngine::first_massless_dof(Eigen::MatrixXd m) {
  const Eigen::Index n = m.rows();
  for (Eigen::Index j = 0; j < n; ++j) {
    const double diagonal = m(j, j);
    const double pivot = diagonal - m.row(j).head(j).squaredNorm();
    if (!(pivot > 1e-15 && pivot > 1e-10 * diagonal)) return static_cast<int>(j);
    m(j, j) = std::sqrt(pivot);
    for (Eigen::Index i = j + 1; i < n; ++i)
      m(i, j) = (m(i, j) - m.row(i).head(j).dot(m.row(j).head(j))) / m(j, j);
    for (Eigen::Index i = j + 1; i < n; ++i) m(j, i) = 0;
  }
  return -1;
}

std::pair<std::string, int> DartEngine::body_line(const BackendWorld& spec,
                                                  const std::string& body) {
  for (const BackendModel& model : spec.models) {
    if (model.format != ModelFormat::kMjcf) continue;
    tinyxml2::XMLDocument doc;
    if (doc.LoadFile(model.file.c_str()) != tinyxml2::XML_SUCCESS) continue;
    std::function<int(const tinyxml2::XMLElement*)> find = [&](const tinyxml2::XMLElement* e) {
      for (const tinyxml2::XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
        const char* name = c->Attribute("name");
        if (std::strcmp(c->Name(), "body") == 0 && name != nullptr && body == name)
          return c->GetLineNum();
        if (const int line = find(c)) return line;
      }
      return 0;
    };
    if (doc.RootElement() != nullptr)
      if (const int line = find(doc.RootElement())) return {model.name, line};
  }
  return {spec.models.front().name, 0};
}

bool DartEngine::only_primitive_collision_shapes() const {
  using dart::dynamics::CollisionAspect;
  for (size_t s = 0; s < world_->getNumSkeletons(); ++s) {
    const SkeletonPtr& skel = world_->getSkeleton(s);
    for (size_t b = 0; b < skel->getNumBodyNodes(); ++b) {
      for (const dart::dynamics::ShapeNode* node :
           skel->getBodyNode(b)->getShapeNodesWith<CollisionAspect>()) {
        const std::string& type = node->getShape()->getType();
        if (type == dart::dynamics::BoxShape::getStaticType()) continue;
        if (type == dart::dynamics::SphereShape::getStaticType()) continue;
        const auto* ellipsoid =
            dynamic_cast<const dart::dynamics::EllipsoidShape*>(node->getShape().get());
        if (ellipsoid && ellipsoid->isSphere()) continue;
        return false;
      }
    }
  }
  return true;
}

void DartEngine::index_model() {
  Lookup skeleton_of_dof_name, skeleton_of_body_name, skeleton_of_joint_name;
  for (size_t s = 0; s < world_->getNumSkeletons(); ++s) {
    SkeletonPtr skel = world_->getSkeleton(s);
    if (!skel->isMobile()) continue;
    SkeletonBlock block{skel, ndof_, static_cast<int>(skel->getNumDofs())};
    const int block_index = static_cast<int>(blocks_.size());
    blocks_.push_back(block);
    total_mass_ += skel->getMass();
    const std::string prefix = skel->getName() + "/";
    auto unique = [&](Lookup& seen, const std::string& name) {
      std::string out = seen.count(name) ? prefix + name : name;
      seen.emplace(name, block_index);
      return out;
    };

    // bodies
    for (size_t i = 0; i < skel->getNumBodyNodes(); ++i) {
      BodyNode* bn = skel->getBodyNode(i);
      const int index = static_cast<int>(bodies_.size());
      bodies_.push_back(bn);
      body_block_.push_back(block_index);
      body_names_.push_back(unique(skeleton_of_body_name, bn->getName()));
      body_lookup_.emplace(body_names_.back(), index);
      body_of_node_.emplace(bn, index);
    }
    // dofs
    for (size_t i = 0; i < skel->getNumDofs(); ++i) {
      dof_names_.push_back(unique(skeleton_of_dof_name, skel->getDof(i)->getName()));
      dof_lookup_.emplace(dof_names_.back(), static_cast<int>(dof_names_.size()) - 1);
      dof_block_.push_back(block_index);
      dof_joint_.push_back(-1);
    }
    // joints
    for (size_t i = 0; i < skel->getNumJoints(); ++i) {
      Joint* j = skel->getJoint(i);
      const int n = static_cast<int>(j->getNumDofs());
      if (n == 0) continue;  // weld
      const int first = block.dof_start + static_cast<int>(j->getIndexInSkeleton(0));
      const int child = body_of_node_.at(j->getChildBodyNode());
      PositionGroup group{PositionGroupKind::kVector, first, n};
      if (dynamic_cast<FreeJoint*>(j)) {
        group.kind = PositionGroupKind::kFree;
        add_joint(unique(skeleton_of_joint_name, j->getName()), JointType::kFree, child, first, n,
                  nullptr);
      } else if (dynamic_cast<BallJoint*>(j)) {
        group.kind = PositionGroupKind::kBall;
        add_joint(unique(skeleton_of_joint_name, j->getName()), JointType::kBall, child, first, n,
                  nullptr);
        // its torque limit (a joint's actuatorfrcrange, set on every dof), as MuJoCo reads it
        for (int k = 0; k < n; ++k)
          joints_.back().force_limit = std::min(
              joints_.back().force_limit,
              std::max(std::abs(j->getForceLowerLimit(k)), std::abs(j->getForceUpperLimit(k))));
      } else if (n == 1) {
        add_joint(unique(skeleton_of_joint_name, j->getName()), dof_type(j, 0), child, first, 1,
                  j->getDof(0));
      } else {
        // multi-dof joints other than free/ball: one hinge/slide entry per dof
        for (int k = 0; k < n; ++k) {
          add_joint(unique(skeleton_of_joint_name, j->getDof(k)->getName()), dof_type(j, k), child,
                    first + k, 1, j->getDof(k));
        }
      }
      position_groups_.push_back(group);
    }
    ndof_ += block.ndof;
  }
  velocity_command_.assign(ndof_, std::nan(""));
  solve_scratch_.setZero(ndof_);
  shift_forces_.setZero(ndof_);
  shift_damping_.setZero(ndof_);
  shift_springs_.setZero(ndof_);
}

JointType DartEngine::dof_type(const Joint* j, int k) {
  const std::string& type = j->getType();
  if (type == dart::dynamics::PrismaticJoint::getStaticType()) return JointType::kSlide;
  if (type == dart::dynamics::TranslationalJoint::getStaticType()) return JointType::kSlide;
  if (type == dart::dynamics::TranslationalJoint2D::getStaticType()) return JointType::kSlide;
  if (type == dart::dynamics::PlanarJoint::getStaticType() && k < 2) return JointType::kSlide;
  return JointType::kHinge;
}

void DartEngine::add_joint(const std::string& name, JointType type, int body, int first, int n,
                           const dart::dynamics::DegreeOfFreedom* limits_from) {
  JointInfo info;
  info.name = name;
  info.type = type;
  info.body = body;
  info.qpos_adr = first;
  info.dof_adr = first;
  info.nq = n;
  info.nv = n;
  if (limits_from) {
    info.lower = limits_from->getPositionLowerLimit();
    info.upper = limits_from->getPositionUpperLimit();
    info.has_limits = std::isfinite(info.lower) || std::isfinite(info.upper);
    if (!info.has_limits) info.lower = info.upper = 0;
    info.force_limit = std::max(std::abs(limits_from->getForceLowerLimit()),
                                std::abs(limits_from->getForceUpperLimit()));
  }
  const int index = static_cast<int>(joints_.size());
  joints_.push_back(info);
  joint_lookup_.emplace(name, index);
  for (int d = first; d < first + n; ++d) dof_joint_[d] = index;
}

}  // namespace stance::dart_backend

namespace stance {

std::unique_ptr<Engine> open_dart_engine(const BackendWorld& spec) {
  return std::make_unique<dart_backend::DartEngine>(spec);
}

}  // namespace stance
