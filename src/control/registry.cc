// The controller registry: adding a controller means one folder/file pair and one line here.
#include <fmt/format.h>

#include "control/controller.h"
#include "control/hold_pose_pd.h"
#include "core/error.h"

namespace stance {

namespace {
template <class C, class P>
ControllerFactory factory_of() {
  return [](const YAML::Node& node, const ControllerContext& ctx, const Engine& engine) {
    return std::unique_ptr<Controller>(new C(read_params<P>(node, ctx), engine));
  };
}
}  // namespace

const std::vector<ControllerType>& controller_registry() {
  static const std::vector<ControllerType> registry = {
      {"hold_pose_pd", "joint-space PD holding the initial (or a given) pose",
       factory_of<HoldPosePd, HoldPosePdParams>()},
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
