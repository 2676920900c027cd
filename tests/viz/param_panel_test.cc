// The parameter panel's layout without a window: labels from the visit, groups from the key
// paths (FSM states), the hover text and the filter.
#include "viz/param_panel.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "control/controller.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::vector<ParamEntry> simbicon_entries() {
  LoadedScenario loaded = load_scenario(test::scenario_path("simbicon_walk.yaml"));
  RunOptions ro;
  ro.quiet = true;
  Simulation run(loaded, ro);
  return tunable_params(*run.controllers().at(0));
}

const ParamEntry& find_entry(const std::vector<ParamEntry>& entries, const std::string& path) {
  auto it = std::find_if(entries.begin(), entries.end(),
                         [&](const ParamEntry& e) { return e.path == path; });
  if (it == entries.end()) throw std::runtime_error("no entry " + path);
  return *it;
}

const ParamGroup* find_group(const ParamGroup& g, const std::string& name) {
  for (const auto& sub : g.groups)
    if (sub.name == name) return &sub;
  return nullptr;
}

TEST(ParamPanel, LabelsAreTheLastKeyPartAndTheUnitFromTheVisit) {
  std::vector<ParamEntry> entries = simbicon_entries();
  const ParamEntry& cd = find_entry(entries, "gait.states.1.cd");
  EXPECT_EQ(param_label(cd), "cd (rad/m)");
  const ParamEntry& kp = find_entry(entries, "gait.gains.torso.kp");
  EXPECT_EQ(param_label(kp), "kp (N m/rad)");
  // a vector's component keeps its name; no unit, no brackets around nothing
  ParamEntry component{"heel_point.1", ParamEntry::Kind::kDouble, 0, {}};
  EXPECT_EQ(param_label(component), "heel_point[1]");
  ParamEntry plain{"initial_state", ParamEntry::Kind::kInt, 0, {}};
  EXPECT_EQ(param_label(plain), "initial_state");
  // the hover text has the full path, the help and the range
  std::string tip = param_tooltip(cd);
  EXPECT_NE(tip.find("gait.states.1.cd"), std::string::npos) << tip;
  EXPECT_NE(tip.find("feedback on distance d"), std::string::npos) << tip;
  EXPECT_NE(tip.find("range: -100 .. 100"), std::string::npos) << tip;
}

TEST(ParamPanel, GroupsFollowTheStructsAndTheFsmStates) {
  std::vector<ParamEntry> entries = simbicon_entries();
  ParamGroup tree = build_param_tree(entries);
  EXPECT_EQ(tree.size(), static_cast<int>(entries.size()));
  const ParamGroup* gait = find_group(tree, "gait");
  ASSERT_NE(gait, nullptr);
  const ParamGroup* states = find_group(*gait, "states");
  ASSERT_NE(states, nullptr);
  // one collapsible group per FSM state, in order
  ASSERT_GE(states->groups.size(), 2u);
  EXPECT_EQ(states->groups[0].name, "states 0");
  EXPECT_EQ(states->groups[1].name, "states 1");
  bool has_cd = false;
  for (int i : states->groups[1].entries) has_cd |= entries[i].path == "gait.states.1.cd";
  EXPECT_TRUE(has_cd);
}

TEST(ParamPanel, FilterFindsAParameterByNameOrHelp) {
  std::vector<ParamEntry> entries = simbicon_entries();
  // by name, whatever the case
  ParamGroup by_name = build_param_tree(entries, "Stance_Hip_Max");
  ASSERT_EQ(by_name.size(), 1);
  const ParamGroup* gains = find_group(*find_group(by_name, "gait"), "gains");
  ASSERT_NE(gains, nullptr);
  ASSERT_EQ(gains->entries.size(), 1u);
  EXPECT_EQ(entries[gains->entries[0]].path, "gait.gains.stance_hip_max_torque");
  // by help words, all of which must match: the velocity feedback of every state
  ParamGroup by_help = build_param_tree(entries, "feedback velocity");
  EXPECT_GE(by_help.size(), 2);
  for (const auto& e : entries)
    if (param_matches(e, "feedback velocity")) {
      EXPECT_NE(e.path.find("cv"), std::string::npos) << e.path;
    }
  EXPECT_EQ(build_param_tree(entries, "no_such_parameter").size(), 0);
  EXPECT_TRUE(build_param_tree(entries, "no_such_parameter").groups.empty());
}

}  // namespace
}  // namespace stance
