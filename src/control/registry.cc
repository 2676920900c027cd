// The controller registry: adding a controller means one folder/file pair and one line here.
#include <fmt/format.h>

#include "control/ankle_strategy.h"
#include "control/control_noise.h"
#include "control/controller.h"
#include "control/hold_pose_pd.h"
#include "control/lqr.h"
#include "control/mocap_retarget_tracker.h"
#include "control/mocap_tracker.h"
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
}  // namespace

const std::vector<ControllerType>& controller_registry() {
  static const std::vector<ControllerType> registry = {
      {"hold_pose_pd", "joint-space PD holding the initial (or a given) pose",
       factory_of<HoldPosePd, HoldPosePdParams>()},
      {"stable_pd", "stable PD (Tan et al. 2011) tracking a pose, root dofs free",
       factory_of<StablePd, JointPdParams>()},
      {"pd", "plain joint PD with the stable_pd parameters, for comparison",
       factory_of<PlainPd, JointPdParams>()},
      {"ankle_strategy", "heel/toe torques keeping the COM over the feet (DART biped tutorial)",
       factory_of<AnkleStrategy, AnkleStrategyParams>()},
      {"skateboard_drive", "velocity commands on skateboard wheels, with a speed ramp (seed 000)",
       factory_of<SkateboardDrive, SkateboardDriveParams>()},
      {"simbicon", "SIMBICON walking: FSM targets with swing-hip balance feedback",
       factory_of<Simbicon, SimbiconParams>()},
      {"slope_walker", "2D biped down a slope: hip and knee state machines (seed 003)",
       factory_of<SlopeWalker, SlopeWalkerParams>()},
      {"lqr", "LQR balance about a static pose: inverse-dynamics set-point, FD model, DARE",
       factory_of<Lqr, LqrParams>()},
      {"mocap_tracker", "BVH tracking with SPD: kinematic, assisted or free root",
       factory_of<MocapTracker, MocapTrackerParams>()},
      {"mocap_retarget", "BVH tracking on any model through a YAML joint map (retargeting)",
       factory_of<MocapRetargetTracker, MocapRetargetParams>()},
      {"control_noise", "smoothed Gaussian noise added to the actuator controls (seeded)",
       factory_of<ControlNoise, ControlNoiseParams>()},
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
