// Reading model files (SKEL, MJCF, URDF, SDF) with DART 6.12's parsers, on text patched first
// (dart_model_patches.cc), with their console output turned into one error line.
#include <fmt/format.h>
#include <tinyxml2.h>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/utils/mjcf/MjcfParser.hpp>
#include <dart/utils/sdf/SdfParser.hpp>
#include <dart/utils/urdf/urdf.hpp>
#include <dart/utils/utils.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/model_format.h"
#include "engine/dart/dart_engine.h"
#include "engine/dart/dart_model_patches.h"

namespace stance::dart_backend {

namespace {

// collects what DART prints to std::cerr while parsing, so errors can quote it
class CerrCapture {
 public:
  CerrCapture() : old_(std::cerr.rdbuf(buffer_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old_); }
  CerrCapture(const CerrCapture&) = delete;
  CerrCapture& operator=(const CerrCapture&) = delete;
  std::string text() const { return buffer_.str(); }

 private:
  std::ostringstream buffer_;
  std::streambuf* old_;
};

// DART's messages are multi-line and colour-coded; keep the first few lines, joined
std::string leading_message_lines(const std::string& text, int max_lines = 3) {
  std::istringstream in(text);
  std::string line, out;
  int taken = 0;
  while (taken < max_lines && std::getline(in, line)) {
    std::string clean;
    for (size_t i = 0; i < line.size(); ++i) {
      if (line[i] == '\033') {  // skip an ANSI colour escape
        while (i < line.size() && line[i] != 'm') ++i;
        continue;
      }
      clean += line[i];
    }
    const size_t b = clean.find_first_not_of(" \t-");
    if (b == std::string::npos) continue;
    if (!out.empty()) out += ' ';
    out.append(clean, b, std::string::npos);
    ++taken;
  }
  return out;
}

// a read-only in-memory file for DART's resource interface
class MemoryResource final : public dart::common::Resource {
 public:
  explicit MemoryResource(std::string text) : text_(std::move(text)) {}
  std::size_t getSize() override { return text_.size(); }
  std::size_t tell() override { return pos_; }
  bool seek(ptrdiff_t offset, SeekType origin) override {
    ptrdiff_t base = origin == SEEKTYPE_CUR   ? static_cast<ptrdiff_t>(pos_)
                     : origin == SEEKTYPE_END ? static_cast<ptrdiff_t>(text_.size())
                                              : 0;
    ptrdiff_t target = base + offset;
    if (target < 0 || target > static_cast<ptrdiff_t>(text_.size())) return false;
    pos_ = static_cast<std::size_t>(target);
    return true;
  }
  std::size_t read(void* buffer, std::size_t size, std::size_t count) override {
    if (size == 0) return 0;
    const std::size_t items = std::min(count, (text_.size() - pos_) / size);
    std::memcpy(buffer, text_.data() + pos_, items * size);
    pos_ += items * size;
    return items;
  }
  std::string readAll() override { return text_; }

 private:
  std::string text_;
  std::size_t pos_ = 0;
};

// serves one URI from memory (a patched model file) and everything else from disk
class PatchedFileRetriever final : public dart::common::ResourceRetriever {
 public:
  PatchedFileRetriever(std::string uri, std::string text)
      : uri_(std::move(uri)),
        text_(std::move(text)),
        disk_(std::make_shared<dart::common::LocalResourceRetriever>()) {}
  bool exists(const dart::common::Uri& uri) override {
    return uri.toString() == uri_ || disk_->exists(uri);
  }
  dart::common::ResourcePtr retrieve(const dart::common::Uri& uri) override {
    if (uri.toString() == uri_) return std::make_shared<MemoryResource>(text_);
    return disk_->retrieve(uri);
  }
  std::string readAll(const dart::common::Uri& uri) override {
    if (uri.toString() == uri_) return text_;
    return disk_->readAll(uri);
  }
  std::string getFilePath(const dart::common::Uri& uri) override { return disk_->getFilePath(uri); }

 private:
  std::string uri_, text_;
  dart::common::LocalResourceRetrieverPtr disk_;
};

// joints' effort limits, by name, as their dofs' force limits
void apply_effort_limits(dart::dynamics::Skeleton& skeleton,
                         const std::vector<std::pair<std::string, double>>& limits) {
  for (const auto& [name, effort] : limits) {
    Joint* j = skeleton.getJoint(name);
    if (j == nullptr) continue;
    for (size_t k = 0; k < j->getNumDofs(); ++k) {
      j->setForceLowerLimit(k, -effort);
      j->setForceUpperLimit(k, effort);
    }
  }
}
void apply_effort_limits(dart::simulation::World& world,
                         const std::vector<std::pair<std::string, double>>& limits) {
  for (size_t s = 0; s < world.getNumSkeletons(); ++s)
    apply_effort_limits(*world.getSkeleton(s), limits);
}

}  // namespace

// lock_joints on MJCF (the names checked by the factory): each joint becomes a weld at its zero
// position, as MuJoCo gets the file without it. The skeletons leave the world while joints
// change (its collision group keeps the shape frames it had: a crash in the next collide) and
// come back in their order, so that the dofs keep theirs
void weld_joints(dart::simulation::World& world, const BackendModel& model) {
  if (model.lock_joints.empty()) return;
  std::vector<SkeletonPtr> skeletons;
  for (size_t s = 0; s < world.getNumSkeletons(); ++s) skeletons.push_back(world.getSkeleton(s));
  for (const SkeletonPtr& skeleton : skeletons) world.removeSkeleton(skeleton);
  for (const std::string& name : model.lock_joints) {
    Joint* joint = nullptr;
    for (size_t s = 0; s < skeletons.size() && !joint; ++s) joint = skeletons[s]->getJoint(name);
    if (joint == nullptr || joint->getChildBodyNode() == nullptr)
      throw InputError(fmt::format("{}: lock_joints: DART has no joint '{}'", model.name, name));
    dart::dynamics::WeldJoint::Properties weld;
    weld.mName = joint->getName();
    weld.mT_ParentBodyToJoint = joint->getTransformFromParentBodyNode();
    weld.mT_ChildBodyToJoint = joint->getTransformFromChildBodyNode();
    joint->getChildBodyNode()->changeParentJointType<dart::dynamics::WeldJoint>(weld);
  }
  for (const SkeletonPtr& skeleton : skeletons) world.addSkeleton(skeleton);
}

// parses one model file into a temporary world of its own
dart::simulation::WorldPtr read_model_world(const BackendModel& model, std::string& warnings) {
  const std::string& shown_name = model.name;
  const std::string& file = model.file;
  const ModelFormat format = model.format;
  const std::string absolute = std::filesystem::absolute(file).string();
  const dart::common::Uri uri = dart::common::Uri::createFromPath(absolute);
  dart::simulation::WorldPtr world;
  std::string printed;
  {
    CerrCapture capture;
    try {
      if (format == ModelFormat::kSkel) {
        tinyxml2::XMLDocument doc;
        load_xml(shown_name, file, doc);
        const std::string patched = text_normalized_for_dart(doc);
        world = patched.empty()
                    ? dart::utils::SkelParser::readWorld(uri)
                    : dart::utils::SkelParser::readWorld(
                          uri, std::make_shared<PatchedFileRetriever>(uri.toString(), patched));
      } else if (format == ModelFormat::kMjcf) {
        const MjcfPreflight mjcf = preflight_mjcf(shown_name, file);
        dart::utils::MjcfParser::Options options;
        if (!mjcf.patched_text.empty())
          options.mRetriever =
              std::make_shared<PatchedFileRetriever>(uri.toString(), mjcf.patched_text);
        world = dart::utils::MjcfParser::readWorld(uri, options);
        if (world) {
          world->setTimeStep(mjcf.timestep);
          world->setGravity(mjcf.gravity);
          apply_inertials(*world, mjcf.inertials);
          apply_effort_limits(*world, model.effort_limits);
          weld_joints(*world, model);
        }
      } else {
        // URDF and SDF: checked and patched by the factory (model/robot_model.h)
        dart::common::ResourceRetrieverPtr retriever;
        if (!model.text.empty()) {
          tinyxml2::XMLDocument doc;
          std::string text = model.text;
          if (doc.Parse(text.c_str(), text.size()) == tinyxml2::XML_SUCCESS) {
            const std::string patched = text_normalized_for_dart(doc);
            if (!patched.empty()) text = patched;
          }
          retriever = std::make_shared<PatchedFileRetriever>(uri.toString(), text);
        }
        SkeletonPtr skeleton;
        if (format == ModelFormat::kSdf) {
          dart::utils::SdfParser::Options options(
              retriever, model.fixed_base ? dart::utils::SdfParser::RootJointType::FIXED
                                          : dart::utils::SdfParser::RootJointType::FLOATING);
          skeleton = dart::utils::SdfParser::readSkeleton(uri, options);
        } else {
          dart::utils::DartLoader::Options options(
              retriever, model.fixed_base ? dart::utils::DartLoader::RootJointType::FIXED
                                          : dart::utils::DartLoader::RootJointType::FLOATING);
          dart::utils::DartLoader loader(options);
          skeleton = loader.parseSkeleton(uri);
        }
        if (skeleton) {
          // effort limits as joint force limits (DART's SdfParser does not read them)
          apply_effort_limits(*skeleton, model.effort_limits);
          // a robot welded whole to the world (a ground) cannot move: it is part of the world,
          // as MuJoCo's static bodies are
          if (skeleton->getNumDofs() == 0) skeleton->setMobile(false);
          world = dart::simulation::World::create();
          world->addSkeleton(skeleton);
        }
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      printed = e.what();
      world = nullptr;
    }
    printed = capture.text() + printed;
  }
  if (!world) {
    // DART prints warnings before the error that stopped it: the error lines say why
    std::string errors;
    std::istringstream lines(printed);
    for (std::string line; std::getline(lines, line);)
      if (line.find("rror") != std::string::npos) errors += line + "\n";
    std::string why = leading_message_lines(errors.empty() ? printed : errors);
    if (why.empty()) why = "DART could not parse the file";
    throw InputError(located(shown_name, 0, "cannot load model: " + why));
  }
  if (!printed.empty()) warnings += printed;
  return world;
}

}  // namespace stance::dart_backend
