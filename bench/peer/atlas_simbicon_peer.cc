// DART's own atlas_simbicon example, headless: the example's Controller (with its State,
// StateMachine and TerminalCondition, compiled from dart-doc's sources, not copied here) walks the
// SDF Atlas on ground.urdf as the example's main.cpp and AtlasSimbiconWorldNode set them up, under
// the bench's schedule of pushes on the pelvis. Prints one JSON line: how long it stays up, how
// far the pelvis walks, and the wall time per simulated second (docs/simbicon.md, "The peer").
//   stance_atlas_simbicon_peer [--duration S] [--gait walking] [--push-force N]
//       [--push-duration S] [--first-push S] [--push-every S] [--fall-fraction F]
//       [--stop-after-fall S] [--ground-size M]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include <dart/dart.hpp>
#include <dart/utils/sdf/SdfParser.hpp>
#include <dart/utils/urdf/DartLoader.hpp>

#include "Controller.hpp"
#include "StateMachine.hpp"
#include "model/model_path.h"

namespace {

struct PeerOptions {
  double duration_s = 60;
  std::string gait = "walking";  // the example's "Normal-Stride Walking" radio button
  // the bench's push schedule (docs/simbicon.md): forward, back, left, right in turn
  double push_force_n = 100;
  double push_duration_s = 0.2;
  double first_push_s = 5;
  double push_every_s = 5;
  // a fall: the COM below this fraction of its start height above the ground, or a body other
  // than the feet touching the ground (stance's fall criterion)
  double fall_fraction = 0.8;
  double stop_after_fall_s = 1;  // as stance run: a while past a fall, then stop
  // ground.urdf's box is 25 m x 25 m: the walk reaches its edge in about 17 s, so the bench
  // widens it (same top face, same material); 25 keeps the example's floor
  double ground_size_m = 200;
};

[[noreturn]] void usage_error(const std::string& message) {
  std::cerr << "stance_atlas_simbicon_peer: " << message << "\n";
  std::exit(2);
}

double number_after(int& i, int argc, char** argv) {
  if (i + 1 >= argc) usage_error(std::string(argv[i]) + " needs a value");
  char* end = nullptr;
  const double v = std::strtod(argv[++i], &end);
  if (*end != '\0' || !std::isfinite(v))
    usage_error(std::string(argv[i - 1]) + ": '" + argv[i] + "' is not a finite number");
  return v;
}

PeerOptions parse_options(int argc, char** argv) {
  PeerOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--duration")
      o.duration_s = number_after(i, argc, argv);
    else if (a == "--push-force")
      o.push_force_n = number_after(i, argc, argv);
    else if (a == "--push-duration")
      o.push_duration_s = number_after(i, argc, argv);
    else if (a == "--first-push")
      o.first_push_s = number_after(i, argc, argv);
    else if (a == "--push-every")
      o.push_every_s = number_after(i, argc, argv);
    else if (a == "--fall-fraction")
      o.fall_fraction = number_after(i, argc, argv);
    else if (a == "--stop-after-fall")
      o.stop_after_fall_s = number_after(i, argc, argv);
    else if (a == "--ground-size")
      o.ground_size_m = number_after(i, argc, argv);
    else if (a == "--gait") {
      if (i + 1 >= argc) usage_error("--gait needs a value");
      o.gait = argv[++i];
    } else
      usage_error("unknown argument '" + a + "'");
  }
  if (o.duration_s <= 0) usage_error("--duration must be > 0");
  if (o.push_every_s <= 0) usage_error("--push-every must be > 0");
  if (o.ground_size_m <= 0) usage_error("--ground-size must be > 0");
  // the example's state machines (Controller::_buildStateMachines); it asserts on any other name
  if (o.gait != "standing" && o.gait != "walking in place" && o.gait != "walking" &&
      o.gait != "running")
    usage_error("--gait: no state machine '" + o.gait +
                "' (standing, walking in place, walking, running)");
  return o;
}

// the push acting at time t, in stance's Z-up frame (x forward, y left): forward, back, left,
// right in turn, one every push_every_s from first_push_s
Eigen::Vector3d push_at(const PeerOptions& o, double t) {
  if (o.push_force_n == 0 || t < o.first_push_s) return Eigen::Vector3d::Zero();
  const double since = t - o.first_push_s;
  const long k = static_cast<long>(std::floor(since / o.push_every_s));
  if (since - k * o.push_every_s >= o.push_duration_s) return Eigen::Vector3d::Zero();
  static const Eigen::Vector3d kDirections[4] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  return o.push_force_n * kDirections[k % 4];
}

}  // namespace

int main(int argc, char** argv) {
  const PeerOptions o = parse_options(argc, argv);

  // the world of the example's main.cpp: ground.urdf, the SDF Atlas turned to Y-up
  // dart://sample resolved as stance resolves it (STANCE_DART_DATA, else dart-doc's folder), so
  // DART's retriever does not first try its build machine's data path for every mesh
  std::string ground_path, atlas_path;
  try {
    ground_path = stance::resolve_model_path("dart://sample/sdf/atlas/ground.urdf");
    atlas_path = stance::resolve_model_path("dart://sample/sdf/atlas/atlas_v3_no_head.sdf");
  } catch (const std::exception& e) {
    std::cerr << "stance_atlas_simbicon_peer: " << e.what() << "\n";
    return 71;
  }
  auto world = std::make_shared<dart::simulation::World>();
  dart::utils::DartLoader urdf_loader;
  auto ground = urdf_loader.parseSkeleton(ground_path);
  auto atlas = dart::utils::SdfParser::readSkeleton(atlas_path);
  if (!ground || !atlas) {
    std::cerr << "stance_atlas_simbicon_peer: cannot load " << atlas_path << "\n";
    return 71;
  }
  // the floor: ground.urdf's one box (0.05 m thick, centred at y = -0.95), widened in x and z;
  // heights are measured from its top face
  double ground_top = 0;
  for (auto* shape_node : ground->getBodyNode(0)->getShapeNodes()) {
    auto box = std::dynamic_pointer_cast<dart::dynamics::BoxShape>(shape_node->getShape());
    if (!box) continue;
    box->setSize(Eigen::Vector3d(o.ground_size_m, box->getSize().y(), o.ground_size_m));
    ground_top = shape_node->getWorldTransform().translation().y() + 0.5 * box->getSize().y();
  }
  world->addSkeleton(ground);
  world->addSkeleton(atlas);
  atlas->setPosition(0, -0.5 * dart::math::constantsd::pi());
  world->setGravity(Eigen::Vector3d(0.0, -9.81, 0.0));

  // the example's world node: its Controller on the world's constraint solver, then the gait
  Controller controller(atlas, world->getConstraintSolver());
  controller.changeStateMachine(o.gait, 0.0);

  // stance's Z-up frame (x forward, y left, z up) in the example's Y-up world: the inverse of
  // the -90 degree turn about x that main.cpp gives the robot
  Eigen::Matrix3d world_from_stance;
  world_from_stance << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  const Eigen::Vector3d up = world_from_stance * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d forward = world_from_stance * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d left = world_from_stance * Eigen::Vector3d::UnitY();

  auto* pelvis = atlas->getBodyNode("pelvis");
  const Eigen::Vector3d pelvis0 = pelvis->getWorldTransform().translation();
  const double com_height0 = up.dot(atlas->getCOM()) - ground_top;
  const double dt = world->getTimeStep();
  const long steps = std::lround(o.duration_s / dt);

  bool fell = false;
  double fall_time = 0;
  std::string fall_reason;
  Eigen::Vector3d pelvis_at_fall = pelvis0;
  long stepped = 0;
  const auto wall0 = std::chrono::steady_clock::now();
  for (long n = 0; n < steps; ++n) {
    // the world node's customPreStep: the push on the pelvis, the controller, then the step
    const Eigen::Vector3d push = push_at(o, world->getTime());
    if (!push.isZero()) pelvis->addExtForce(world_from_stance * push);
    controller.update();
    world->step();
    ++stepped;
    const double t = world->getTime();
    if (fell) {
      if (t > fall_time + o.stop_after_fall_s) break;
      continue;
    }
    const double h = up.dot(atlas->getCOM()) - ground_top;
    if (!std::isfinite(h)) {
      fell = true;
      fall_reason = "the state is not finite";
    } else if (h < o.fall_fraction * com_height0) {
      fell = true;
      char text[96];
      std::snprintf(text, sizeof text, "COM %.3f m below %g of its start %.3f m", h,
                    o.fall_fraction, com_height0);
      fall_reason = text;
    } else {
      for (const auto& c : world->getLastCollisionResult().getContacts()) {
        const auto* b1 = c.collisionObject1->getShapeFrame()->asShapeNode()->getBodyNodePtr().get();
        const auto* b2 = c.collisionObject2->getShapeFrame()->asShapeNode()->getBodyNodePtr().get();
        const dart::dynamics::BodyNode* robot_body = nullptr;
        if (b1->getSkeleton() == ground) robot_body = b2;
        if (b2->getSkeleton() == ground) robot_body = b1;
        if (!robot_body || robot_body->getSkeleton() != atlas) continue;
        if (robot_body->getName() == "l_foot" || robot_body->getName() == "r_foot") continue;
        fell = true;
        fall_reason = "'" + robot_body->getName() + "' touched the ground";
        break;
      }
    }
    if (fell) {
      fall_time = t;
      pelvis_at_fall = pelvis->getWorldTransform().translation();
      const Eigen::Vector3d flat = pelvis_at_fall - up.dot(pelvis_at_fall) * up;
      if (flat.cwiseAbs().maxCoeff() > 0.5 * o.ground_size_m) fall_reason += " (off the floor)";
    }
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double sim_s = stepped * dt;
  const double time_up = fell ? fall_time : sim_s;
  const Eigen::Vector3d walked =
      (fell ? pelvis_at_fall : Eigen::Vector3d(pelvis->getWorldTransform().translation())) -
      pelvis0;

  // one JSON line (the names and the strings are plain ASCII: no escaping needed)
  // clang-format off
  std::printf("{\"peer\": \"dart atlas_simbicon\", \"gait\": \"%s\", \"timestep\": %g, "
              "\"duration\": %g, \"sim_time\": %.4f, \"fell\": %s, \"fall_time\": %s, "
              "\"fall_reason\": \"%s\", \"time_up_s\": %.4f, \"distance_m\": %.4f, "
              "\"lateral_m\": %.4f, \"displacement_m\": %.4f, \"mean_speed_mps\": %.4f, "
              "\"wall_time_s\": %.4f, \"wall_s_per_sim_s\": %.4f, \"push_force_n\": %g, "
              "\"push_duration_s\": %g, \"first_push_s\": %g, \"push_every_s\": %g, "
              "\"com_height_start_m\": %.4f, \"ground_size_m\": %g, "
              "\"collision_detector\": \"%s\"}\n",
              o.gait.c_str(), dt, o.duration_s, sim_s, fell ? "true" : "false",
              fell ? std::to_string(fall_time).c_str() : "null", fall_reason.c_str(), time_up,
              forward.dot(walked), left.dot(walked), (walked - up.dot(walked) * up).norm(),
              time_up > 0 ? forward.dot(walked) / time_up : 0.0, wall_s,
              sim_s > 0 ? wall_s / sim_s : 0.0, o.push_force_n, o.push_duration_s,
              o.first_push_s, o.push_every_s, com_height0, o.ground_size_m,
              world->getConstraintSolver()->getCollisionDetector()->getType().c_str());
  // clang-format on
  return 0;
}
