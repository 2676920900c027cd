#include "sim/scenario.h"

#include <filesystem>
#include <tuple>

#include "control/controller.h"
#include "core/error.h"
#include "core/timestep.h"
#include "params/yaml_params.h"

namespace stance {

namespace {
// 0 takes the model file's (the planner: the scenario's) time step; any other value must be one
// that every engine and run can take (core/timestep.h)
void check_timesteps(const Scenario& s, const YAML::Node& doc, const std::string& source) {
  const YAML::Node planner = doc["planner"];
  const std::tuple<const char*, double, YAML::Node, const char*> steps[] = {
      {"timestep", s.timestep, doc["timestep"], "the model file's own"},
      {"planner.timestep", s.planner.timestep,
       planner && planner.IsMap() ? planner["timestep"] : YAML::Node(), "the scenario's"},
      {"planner.calm_timestep", s.planner.calm_timestep,
       planner && planner.IsMap() ? planner["calm_timestep"] : YAML::Node(), "the rollouts'"}};
  for (const auto& [name, dt, node, zero] : steps) {
    if (dt == 0) continue;
    const std::string problem = timestep_problem(dt);
    if (problem.empty()) continue;
    // a value from --set has no line
    const int line = node ? node.Mark().line + 1 : 0;
    throw InputError(located(source, line,
                             fmt::format("{}parameter '{}': {}; 0 takes {}",
                                         line > 0 ? "" : "(from --set) ", name, problem, zero)));
  }
}

// a controller block against its type's parameter struct: an unknown type, an unknown key or a
// bad value fails here, with the file and line, before any engine is built. Returns the entries.
std::vector<ParamEntry> check_controller(const YAML::Node& entry, const std::string& source,
                                         size_t index) {
  const ControllerType* type = nullptr;
  try {
    type = &find_controller_type(entry["type"].Scalar());
  } catch (const InputError& e) {
    throw InputError(located(source, entry["type"].Mark().line + 1, e.what()));
  }
  ControllerContext ctx;
  ctx.source = {source};
  ctx.path = fmt::format("controllers[{}]", index);
  return type->check_params(entry, ctx);
}
}  // namespace

std::vector<ParamEntry> controller_params(const LoadedScenario& loaded, size_t index) {
  const YAML::Node& entry = loaded.controllers.at(index);
  if (entry["type"].Scalar() == kExternalControllerType) return {};
  return check_controller(entry, loaded.source, index);
}

LoadedScenario parse_scenario(const YAML::Node& doc_in, const std::string& source,
                              const std::string& base_dir) {
  YAML::Node doc = doc_in;
  if (!doc || !doc.IsMap()) throw InputError(source + ": a scenario must be a YAML mapping");
  // shorthand: "model: file.xml"
  if (doc["model"] && doc["model"].IsScalar()) {
    YAML::Node list(YAML::NodeType::Sequence);
    YAML::Node entry(YAML::NodeType::Map);
    entry["file"] = doc["model"];
    list.push_back(entry);
    doc["model"] = list;
  }
  LoadedScenario out;
  out.source = source;
  out.document = doc;
  YamlParamReader reader(doc, {source});
  reader.claim("controllers");
  reader.read(out.scenario);
  Scenario& s = out.scenario;
  if (s.model.empty()) throw InputError(located(source, 0, "no model given (key 'model')"));
  for (auto& m : s.model) {
    if (m.file.empty()) throw InputError(located(source, 0, "a model entry has no 'file'"));
    if (m.file.rfind("dart://", 0) != 0 && m.file.rfind("mujoco://", 0) != 0 &&
        !std::filesystem::path(m.file).is_absolute() && !base_dir.empty()) {
      auto candidate = std::filesystem::path(base_dir) / m.file;
      // paths relative to the YAML's folder, falling back to the working directory
      // (a name the file system refuses, e.g. too long, counts as absent: the model's own
      // loading then reports it with the file and line)
      std::error_code ignored;
      if (std::filesystem::exists(candidate, ignored) || !std::filesystem::exists(m.file, ignored))
        m.file = candidate.lexically_normal().string();
    }
    for (std::string& dir : m.package_path)
      if (!std::filesystem::path(dir).is_absolute() && !base_dir.empty())
        dir = (std::filesystem::path(base_dir) / dir).lexically_normal().string();
  }
  for (size_t i = 0; i < s.model.size(); ++i) {
    if (s.model[i].mesh_collision == "box" || s.model[i].mesh_collision == "mesh") continue;
    const YAML::Node entry = doc["model"][i]["mesh_collision"];
    throw InputError(located(source, entry ? entry.Mark().line + 1 : 0,
                             fmt::format("parameter 'model[{}].mesh_collision': expected box or "
                                         "mesh, found '{}'",
                                         i, s.model[i].mesh_collision)));
  }
  check_timesteps(s, doc, source);
  if (s.torque_limits != "auto" && s.torque_limits != "on" && s.torque_limits != "off")
    throw InputError(located(
        source, doc["torque_limits"] ? doc["torque_limits"].Mark().line + 1 : 0,
        "parameter 'torque_limits': expected auto, on or off, found '" + s.torque_limits + "'"));
  if (!s.gravity.empty() && s.gravity.size() != 3)
    throw InputError(
        located(source, doc["gravity"].Mark().line + 1, "parameter 'gravity': expected 3 numbers"));
  if (s.engine != "mujoco" && s.engine != "dart")
    throw InputError(
        located(source, doc["engine"] ? doc["engine"].Mark().line + 1 : 0,
                "parameter 'engine': expected mujoco or dart, found '" + s.engine + "'"));
  if (s.camera.mode != "follow" && s.camera.mode != "fixed") {
    YAML::Node mode = doc["camera"] ? doc["camera"]["mode"] : YAML::Node();
    throw InputError(located(
        source, mode ? mode.Mark().line + 1 : 0,
        "parameter 'camera.mode': expected follow or fixed, found '" + s.camera.mode + "'"));
  }
  s.expect.given = static_cast<bool>(doc["expect"]);
  check_expectation(s.expect, source, doc["expect"]);
  if (YAML::Node c = doc["controllers"]) {
    if (!c.IsSequence())
      throw InputError(located(source, c.Mark().line + 1, "'controllers' must be a list"));
    for (size_t i = 0; i < c.size(); ++i) {
      YAML::Node entry = c[i];
      if (!entry.IsMap() || !entry["type"] || !entry["type"].IsScalar())
        throw InputError(located(source, entry.Mark().line + 1,
                                 fmt::format("controllers[{}]: needs a 'type'", i)));
      // python entries are resolved when the simulation is built (RunOptions)
      if (entry["type"].Scalar() != kExternalControllerType) check_controller(entry, source, i);
      out.controllers.push_back(entry);
    }
  }
  return out;
}

LoadedScenario load_scenario(const std::string& path, const std::vector<std::string>& overrides) {
  YAML::Node doc = load_yaml_file(path);
  for (const auto& o : overrides) apply_yaml_override(doc, o);
  std::string base = std::filesystem::path(path).parent_path().string();
  return parse_scenario(doc, path, base);
}

}  // namespace stance
