// Generic tests over the controller registry: every type, present or future, gets them. A type is
// exercised in the shipped scenarios that use it (every type must be used by one): it builds
// from its defaults there, rejects a bad value naming the parameter, one model shared by two
// threads gives the runs it gives in sequence, and saving its State mid-run (in memory, on a
// clone, through a state file) reproduces the rest of the run exactly. Allocation per step is
// checked for every type in alloc_test.cc.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <thread>

#include "control/controller.h"
#include "core/error.h"
#include "params/param_list.h"
#include "params/yaml_params.h"
#include "run_support.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

constexpr int kSteps = 150;  // steps before and after the branch point

struct Host {
  std::string file;
  LoadedScenario loaded;
  size_t index = 0;  // of the type's entry in loaded.controllers
};

// the first shipped scenario that uses each registered type
std::map<std::string, Host> hosts() {
  std::map<std::string, Host> out;
  std::vector<std::filesystem::path> files;
  for (const auto& f : std::filesystem::directory_iterator(test::source_dir() + "/scenarios"))
    if (f.path().extension() == ".yaml") files.push_back(f.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    LoadedScenario l = load_scenario(f.string());
    for (size_t i = 0; i < l.controllers.size(); ++i) {
      std::string type = l.controllers[i]["type"].Scalar();
      if (!out.count(type)) out[type] = {f.string(), l, i};
    }
  }
  return out;
}

// what a run has done: positions, velocities and the controllers' signals, bit for bit
struct Trace {
  std::vector<double> values;
  bool operator==(const Trace&) const = default;
};

void step_and_trace(Simulation& sim, int steps, Trace& trace) {
  Eigen::VectorXd q(sim.engine().nq()), v(sim.engine().nv());
  std::vector<double> signals;
  for (int k = 0; k < steps; ++k) {
    if (!sim.step()) break;
    sim.engine().get_positions(q);
    sim.engine().get_velocities(v);
    trace.values.insert(trace.values.end(), q.data(), q.data() + q.size());
    trace.values.insert(trace.values.end(), v.data(), v.data() + v.size());
    signals.clear();
    sim.signals(signals);
    trace.values.insert(trace.values.end(), signals.begin(), signals.end());
  }
}

size_t first_difference(const Trace& a, const Trace& b) {
  size_t i = 0;
  while (i < a.values.size() && i < b.values.size() && a.values[i] == b.values[i]) ++i;
  return i;
}

class Registry : public ::testing::TestWithParam<std::string> {};

TEST(RegistryCoverage, EveryTypeIsUsedByAShippedScenario) {
  auto h = hosts();
  for (const auto& t : controller_registry())
    EXPECT_TRUE(h.count(t.name)) << t.name << ": no scenario in scenarios/ uses it";
}

TEST_P(Registry, BuildsFromItsDefaults) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  Host host = h[GetParam()];
  // drop every key that has a default: what is left is what the type cannot do without
  YAML::Node node = YAML::Clone(host.loaded.controllers[host.index]);
  std::vector<std::string> keys;
  for (auto it = node.begin(); it != node.end(); ++it)
    if (it->first.Scalar() != "type") keys.push_back(it->first.Scalar());
  for (const auto& key : keys) {
    YAML::Node trial = YAML::Clone(node);
    trial.remove(key);
    LoadedScenario l = host.loaded;
    l.controllers[host.index] = trial;
    try {
      Simulation sim(l, test::quiet());
      node = trial;
    } catch (const InputError&) {
      // a required key (a body name, a clip)
    }
  }
  LoadedScenario l = host.loaded;
  l.controllers[host.index] = node;
  Simulation sim(l, test::quiet());
  EXPECT_EQ(sim.controllers()[host.index]->type(), GetParam());
  // one step's outputs are finite (defaults need not suit every model for long: hold_pose_pd's
  // kd = 10 is too stiff for the light arm at 1 ms)
  sim.step();
  EXPECT_TRUE(sim.last_output().tau.allFinite());
  EXPECT_TRUE(sim.last_output().ctrl.allFinite());
}

TEST_P(Registry, RejectsABadValueNamingTheParameter) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  Host host = h[GetParam()];
  std::vector<ParamEntry> entries;
  {
    Simulation sim(host.loaded, test::quiet());
    entries = tunable_params(*sim.controllers()[host.index]);
  }
  ASSERT_FALSE(entries.empty()) << "no tunable parameters";
  // a value outside the visit's range where one is given, else a NaN
  const ParamEntry* pick = &entries[0];
  double bad = std::nan("");
  for (const auto& e : entries)
    if (e.kind == ParamEntry::Kind::kDouble && std::isfinite(e.meta.min)) {
      pick = &e;
      bad = e.meta.min - 1;
      break;
    }
  YAML::Node node = YAML::Clone(host.loaded.controllers[host.index]);
  apply_yaml_override(node, pick->path + "=" + (std::isnan(bad) ? ".nan" : std::to_string(bad)));
  LoadedScenario l = host.loaded;
  l.controllers[host.index] = node;
  try {
    Simulation sim(l, test::quiet());
    ADD_FAILURE() << pick->path << " = " << bad << " was accepted";
  } catch (const InputError& e) {
    const std::string last = pick->path.substr(pick->path.rfind('.') + 1);
    EXPECT_NE(std::string(e.what()).find(last), std::string::npos) << e.what();
  }
}

// parameters are typed at load: a misspelt key or a value out of range fails when the scenario
// is loaded (no engine, no controller built), naming the file and the parameter
TEST_P(Registry, BadKeyOrValueFailsWhenTheScenarioIsLoaded) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  const Host& host = h[GetParam()];
  const std::string block = fmt::format("controllers.{}.", host.index);
  const std::string file = std::filesystem::path(host.file).filename().string();
  try {
    load_scenario(host.file, {block + "gain_typo=1"});
    ADD_FAILURE() << "an unknown key was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    const std::string key =
        fmt::format("unknown parameter 'controllers[{}].gain_typo'", host.index);
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
  for (const ParamEntry& e : controller_params(host.loaded, host.index)) {
    if (e.kind != ParamEntry::Kind::kDouble || !std::isfinite(e.meta.min)) continue;
    const std::string set = fmt::format("{}{}={}", block, e.path, e.meta.min - 1);
    EXPECT_THROW(load_scenario(host.file, {set}), InputError) << set;
    break;
  }
}

// what the loader reads (tune's defaults) is what the built model offers the viewer's panel
TEST_P(Registry, ParamsTypedAtLoadAreTheBuiltModelsTunableParams) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  const Host& host = h[GetParam()];
  Simulation sim(host.loaded, test::quiet());
  std::vector<ParamEntry> built = tunable_params(*sim.controllers()[host.index]);
  std::vector<ParamEntry> loaded = controller_params(host.loaded, host.index);
  ASSERT_EQ(built.size(), loaded.size());
  for (size_t i = 0; i < built.size(); ++i) {
    EXPECT_EQ(built[i].path, loaded[i].path);
    EXPECT_EQ(built[i].value, loaded[i].value) << built[i].path;
  }
}

TEST_P(Registry, OneModelSharedByTwoThreadsRunsAsInSequence) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  const Host& host = h[GetParam()];
  auto model = make_simulation_model(host.loaded, test::quiet());
  Trace seq[2], par[2];
  for (auto& t : seq) {
    Simulation sim(model);
    step_and_trace(sim, 2 * kSteps, t);
  }
  std::vector<std::thread> threads;
  for (auto& t : par)
    threads.emplace_back([&model, &t] {
      Simulation sim(model);
      step_and_trace(sim, 2 * kSteps, t);
    });
  for (auto& th : threads) th.join();
  EXPECT_FALSE(seq[0].values.empty());
  EXPECT_TRUE(seq[0] == seq[1]);
  EXPECT_TRUE(par[0] == seq[0]);
  EXPECT_TRUE(par[1] == seq[0]);
}

TEST_P(Registry, SavedStateReproducesTheRestOfTheRun) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  const Host& host = h[GetParam()];
  Simulation sim(host.loaded, test::quiet());
  Trace before;
  step_and_trace(sim, kSteps, before);
  SimulationState saved;
  sim.save(saved);
  Trace reference;
  step_and_trace(sim, kSteps, reference);
  ASSERT_FALSE(reference.values.empty());
  const std::string metrics = without_wall_clock(sim.result().metrics).dump();

  // in memory, on the same simulation
  sim.restore(saved);
  Trace again;
  step_and_trace(sim, kSteps, again);
  EXPECT_TRUE(again == reference) << "restore on the same simulation; first difference at "
                                  << first_difference(again, reference) << " of "
                                  << reference.values.size();
  EXPECT_EQ(without_wall_clock(sim.result().metrics).dump(), metrics);
  // a clone on a new engine, branched from the saved state
  sim.restore(saved);
  std::unique_ptr<Simulation> branch = sim.clone();
  Trace cloned;
  step_and_trace(*branch, kSteps, cloned);
  EXPECT_TRUE(cloned == reference) << "clone";
  EXPECT_EQ(without_wall_clock(branch->result().metrics).dump(), metrics);
}

TEST_P(Registry, StateFileReproducesTheRestOfTheRun) {
  auto h = hosts();
  ASSERT_TRUE(h.count(GetParam()));
  const Host& host = h[GetParam()];
  Simulation sim(host.loaded, test::quiet());
  Trace before;
  step_and_trace(sim, kSteps, before);
  const std::string file = test::write_temp_file("registry_" + GetParam() + ".state", "");
  sim.write_state(file);
  Trace reference;
  step_and_trace(sim, kSteps, reference);
  ASSERT_FALSE(reference.values.empty());
  // on a fresh simulation of the same model
  Simulation fresh(sim.shared_model());
  fresh.read_state(file);
  Trace from_file;
  step_and_trace(fresh, kSteps, from_file);
  EXPECT_TRUE(from_file == reference);
  EXPECT_EQ(without_wall_clock(fresh.result().metrics).dump(),
            without_wall_clock(sim.result().metrics).dump());
}

// a client finds an optional interface exactly where a controller offers it
TEST(ControllerInterfaces, FoundWhereOfferedOnly) {
  Simulation walk(load_scenario(test::scenario_path("simbicon_walk.yaml")), test::quiet());
  const Controller& simbicon = *walk.controllers().at(0);
  ASSERT_EQ(simbicon.type(), "simbicon");
  EXPECT_EQ(simbicon.as<Drawable>(), dynamic_cast<const Drawable*>(&simbicon));
  EXPECT_NE(simbicon.as<Correctable>(), nullptr);
  EXPECT_NE(simbicon.as<Reporting>(), nullptr);
  EXPECT_EQ(simbicon.as<Tracking>(), nullptr);
  EXPECT_EQ(simbicon.as<FallJudge>(), nullptr);
  EXPECT_EQ(simbicon.as<HorizonSampling>(), nullptr);
  EXPECT_EQ(simbicon.as<InitialState>(), nullptr);
  // slow to rebuild is declared, not inferred from a type name
  ASSERT_NE(simbicon.as<Retunable>(), nullptr);
  EXPECT_FALSE(simbicon.as<Retunable>()->slow_to_rebuild());
  Simulation lqr(load_scenario(test::scenario_path("lqr_one_leg.yaml")), test::quiet());
  ASSERT_NE(lqr.controllers().at(0)->as<Retunable>(), nullptr);
  EXPECT_TRUE(lqr.controllers().at(0)->as<Retunable>()->slow_to_rebuild());
}

std::vector<std::string> registered_types() {
  std::vector<std::string> names;
  for (const auto& t : controller_registry()) names.push_back(t.name);
  return names;
}

INSTANTIATE_TEST_SUITE_P(EveryType, Registry, ::testing::ValuesIn(registered_types()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace stance
