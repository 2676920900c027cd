// The controller registry: adding a controller means one folder/file pair and one line here.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <atomic>
#include <iostream>

#include "control/ankle_strategy.h"
#include "control/control_noise.h"
#include "control/controller.h"
#include "control/hold_pose_pd.h"
#include "control/lqr.h"
#include "control/mocap_retarget_tracker.h"
#include "control/simbicon.h"
#include "control/skateboard_drive.h"
#include "control/slope_walker.h"
#include "control/stable_pd.h"
#include "core/error.h"

namespace stance {

namespace {
// every controller type is built the same way: C(params, context, engine)
template <class C, class P>
ControllerFactory factory_of() {
  return [](const YAML::Node& node, const ControllerContext& ctx, const Engine& engine) {
    return std::shared_ptr<const Controller>(
        std::make_shared<const C>(read_params<P>(node, ctx), ctx, engine));
  };
}
// the typed check of a block against P's visit (what factory_of<C, P> reads first)
template <class P>
ControllerParamsCheck check_of() {
  return [](const YAML::Node& node, const ControllerContext& ctx) {
    return list_params(read_params<P>(node, ctx));
  };
}
// a registry entry: built from P by C(params, context, engine), documented and checked by P's
// visit
template <class C, class P>
ControllerType type_of(std::string name, std::string summary) {
  return {std::move(name), std::move(summary), factory_of<C, P>(), document_params<P>,
          check_of<P>()};
}
// `mocap_tracker`, the old bvh2mjcf-only tracker, is now a name for mocap_retarget (without a
// joint_map: the identity map of the clip's own character). Its keys are mocap_retarget's but
// for the free mode's extra tuning terms, which went with it: those are accepted and ignored,
// with one warning per process, so that old scenarios still load.
const std::vector<std::string>& removed_tracker_keys() {
  static const std::vector<std::string> removed = {
      "stance_hip_world", "torso_kp",          "torso_kd",          "contact_stance",
      "com_feedback",     "root_force_kp_z",   "heading_gain",      "swing_heading_gain",
      "path_gain",        "ankle_cd_sagittal", "ankle_cv_sagittal", "ankle_cd_coronal",
      "ankle_cv_coronal"};
  return removed;
}
// the keys the alias reads past: "type" and the removed ones
std::vector<std::string> tracker_alias_skip() {
  std::vector<std::string> skip = {"type"};
  for (const auto& key : removed_tracker_keys()) skip.push_back(key);
  return skip;
}
ControllerFactory mocap_tracker_alias() {
  return [](const YAML::Node& node, const ControllerContext& ctx, const Engine& engine) {
    std::vector<std::string> ignored;
    for (const auto& key : removed_tracker_keys())
      if (node.IsMap() && node[key]) ignored.push_back(key);
    static std::atomic<bool> warned{false};
    if (!ignored.empty() && !warned.exchange(true))
      std::cerr << fmt::format(
          "warning: {}: {}: mocap_tracker is now mocap_retarget; ignored its removed free-mode "
          "keys: {}\n",
          ctx.source.file, ctx.path, fmt::join(ignored, ", "));
    return std::shared_ptr<const Controller>(std::make_shared<const MocapRetargetTracker>(
        read_params<MocapRetargetParams>(node, ctx, tracker_alias_skip()), ctx, engine,
        "mocap_tracker"));
  };
}
ControllerParamsCheck mocap_tracker_alias_check() {
  return [](const YAML::Node& node, const ControllerContext& ctx) {
    return list_params(read_params<MocapRetargetParams>(node, ctx, tracker_alias_skip()));
  };
}
}  // namespace

const std::vector<ControllerType>& controller_registry() {
  static const std::vector<ControllerType> registry = {
      type_of<HoldPosePd, HoldPosePdParams>("hold_pose_pd",
                                            "joint-space PD holding the initial (or a given) pose"),
      type_of<StablePd, JointPdParams>(
          "stable_pd", "stable PD (Tan et al. 2011) tracking a pose, root dofs free"),
      type_of<PlainPd, JointPdParams>(
          "pd", "plain joint PD with the stable_pd parameters, for comparison"),
      type_of<AnkleStrategy, AnkleStrategyParams>(
          "ankle_strategy", "heel/toe torques keeping the COM over the feet (DART biped tutorial)"),
      type_of<SkateboardDrive, SkateboardDriveParams>(
          "skateboard_drive",
          "velocity commands on skateboard wheels, with a speed ramp (seed 000)"),
      type_of<Simbicon, SimbiconParams>(
          "simbicon", "SIMBICON walking: FSM targets with swing-hip balance feedback"),
      type_of<SlopeWalker, SlopeWalkerParams>(
          "slope_walker", "2D biped down a slope: hip and knee state machines (seed 003)"),
      type_of<Lqr, LqrParams>(
          "lqr", "LQR balance about a static pose: inverse-dynamics set-point, FD model, DARE"),
      type_of<MocapRetargetTracker, MocapRetargetParams>(
          "mocap_retarget",
          "BVH tracking with SPD: kinematic, assisted or free root; a joint map, or the identity "
          "on a bvh2mjcf character"),
      {"mocap_tracker", "alias of mocap_retarget, for old scenarios", mocap_tracker_alias(),
       document_params<MocapRetargetParams>, mocap_tracker_alias_check()},
      type_of<ControlNoise, ControlNoiseParams>(
          "control_noise", "smoothed Gaussian noise added to the actuator controls (seeded)"),
  };
  return registry;
}

const ControllerType& find_controller_type(const std::string& name) {
  std::vector<std::string> names;
  for (const auto& t : controller_registry()) {
    if (t.name == name) return t;
    names.push_back(t.name);
  }
  throw InputError(fmt::format("unknown controller type '{}'{}", name, did_you_mean(name, names)));
}

}  // namespace stance
