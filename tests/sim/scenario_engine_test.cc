// The scenario's engine: a keyframe by name starts the run there on MuJoCo; an unknown name and
// a keyframe on DART are bad input naming the scenario key.
#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

constexpr const char* kHingeWithKeys = R"(
<mujoco model="hinge_keys">
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="swing" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03" mass="1"/>
    </body>
  </worldbody>
  <keyframe>
    <key name="raised" qpos="0.8"/>
  </keyframe>
</mujoco>
)";

Scenario with_keyframe(const std::string& model, const std::string& key) {
  Scenario s;
  s.model = {ModelEntry{model}};
  s.keyframe = key;
  return s;
}

std::string error_of(const Scenario& s, const std::string& engine) {
  try {
    make_scenario_engine(s, engine);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ScenarioEngine, KeyframeByNameOnMujoco) {
  const std::string model = test::write_temp_file("hinge_keys.xml", kHingeWithKeys);
  auto engine = make_scenario_engine(with_keyframe(model, "raised"), "mujoco");
  EXPECT_DOUBLE_EQ(engine->dof_position(engine->require_dof("swing")), 0.8);
  const std::string unknown = error_of(with_keyframe(model, "raise"), "mujoco");
  EXPECT_EQ(unknown.rfind("keyframe: unknown keyframe 'raise'", 0), 0u) << unknown;
  EXPECT_NE(unknown.find("raised"), std::string::npos) << unknown;
}

TEST(ScenarioEngine, KeyframeOnDartIsBadInputNamingTheKey) {
  if (!std::filesystem::exists("/usr/share/doc/dart/data/skel/fullbody1.skel"))
    GTEST_SKIP() << "dart-doc not installed";
  const std::string msg =
      error_of(with_keyframe("dart://sample/skel/fullbody1.skel", "init"), "dart");
  EXPECT_EQ(msg, "keyframe: the dart engine has no keyframes (asked for 'init')");
}

}  // namespace
}  // namespace stance

namespace stance {
namespace {
// a model name the file system refuses is looked up without throwing (fuzz_scenario found
// std::filesystem::exists throwing there): the model's loading then names it, exit 2
TEST(ScenarioEngine, AModelNameTooLongIsBadInput) {
  const std::string yaml = test::write_temp_file(
      "long_model.yaml", "name: x\nmodel: " + std::string(5000, 'm') + ".xml\nduration: 1\n");
  try {
    LoadedScenario loaded = load_scenario(yaml, {});
    Simulation sim(loaded, {});
    FAIL() << "loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("mmmm.xml"), std::string::npos) << e.what();
  }
}
}  // namespace
}  // namespace stance
