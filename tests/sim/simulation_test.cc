// The one step loop: branching from a saved state on many threads, the state file, the stop
// after a fall, the progress bar.
#include "sim/simulation.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/atomic_file.h"
#include "core/error.h"
#include "run_support.h"
#include "sim/observers.h"
#include "sim/scenario.h"
#include "test_support.h"

namespace stance {
namespace {

// positions and velocities after each step, bit for bit
std::vector<double> trace(Simulation& sim, int steps) {
  std::vector<double> out;
  Eigen::VectorXd q(sim.engine().nq()), v(sim.engine().nv());
  for (int k = 0; k < steps && sim.step(); ++k) {
    sim.engine().get_positions(q);
    sim.engine().get_velocities(v);
    out.insert(out.end(), q.data(), q.data() + q.size());
    out.insert(out.end(), v.data(), v.data() + v.size());
  }
  return out;
}

// N clones of one saved state, each pushed differently, give the same results on N threads as
// one after another
void expect_branches_deterministic(const std::string& file, const std::string& body,
                                   const std::string& engine = "") {
  SCOPED_TRACE(file + " " + engine);
  Simulation root(load_scenario(test::scenario_path(file)), test::quiet(engine));
  for (int k = 0; k < 300; ++k) ASSERT_TRUE(root.step());
  constexpr int kBranches = 4, kSteps = 300;
  const int b = root.engine().require_body(body);
  auto branch_run = [&](Simulation& sim, int i) {
    std::vector<double> out;
    Eigen::VectorXd q(sim.engine().nq());
    for (int k = 0; k < kSteps && !sim.done(); ++k) {
      // each branch its own push, so that the branches differ
      sim.engine().apply_external_force(b, Eigen::Vector3d(20.0 * (i - 1.5), 0, 0),
                                        sim.engine().body_com(b));
      if (!sim.step()) break;
      sim.engine().get_positions(q);
      out.insert(out.end(), q.data(), q.data() + q.size());
    }
    return out;
  };
  std::vector<std::unique_ptr<Simulation>> clones;
  for (int i = 0; i < 2 * kBranches; ++i) clones.push_back(root.clone());
  std::vector<std::vector<double>> sequential(kBranches), threaded(kBranches);
  for (int i = 0; i < kBranches; ++i) sequential[i] = branch_run(*clones[i], i);
  std::vector<std::thread> threads;
  for (int i = 0; i < kBranches; ++i)
    threads.emplace_back([&, i] { threaded[i] = branch_run(*clones[kBranches + i], i); });
  for (auto& t : threads) t.join();
  for (int i = 0; i < kBranches; ++i) {
    ASSERT_EQ(sequential[i].size(), static_cast<size_t>(kSteps) * root.engine().nq());
    EXPECT_TRUE(sequential[i] == threaded[i]) << "branch " << i;
  }
  EXPECT_FALSE(sequential[0] == sequential[kBranches - 1]) << "the pushes made no difference";
}

TEST(SimulationBranching, ClonesOnThreadsEqualClonesInSequenceBipedStand) {
  expect_branches_deterministic("biped_stand.yaml", "h_spine");
}

TEST(SimulationBranching, ClonesOnThreadsEqualClonesInSequenceSimbiconWalk) {
  expect_branches_deterministic("simbicon_walk.yaml", "torso");
}

TEST(SimulationBranching, ClonesOnThreadsEqualClonesInSequenceMocapTracking) {
  expect_branches_deterministic("mocap_track.yaml", "Hips");
}

TEST(SimulationBranching, ClonesOnThreadsEqualClonesInSequenceBipedStandDart) {
  expect_branches_deterministic("biped_stand.yaml", "h_spine", "dart");
}

class RestoreContinues : public ::testing::TestWithParam<std::string> {};

// restoring a saved state continues exactly as the run that was never interrupted
void expect_restore_continues(const std::string& file, const std::string& engine) {
  Simulation sim(load_scenario(test::scenario_path(file)), test::quiet(engine));
  trace(sim, 150);  // early: the feet still settle, contacts change
  SimulationState s;
  sim.save(s);
  std::vector<double> a = trace(sim, 500);
  RunResult ra = sim.result();
  sim.restore(s);
  std::vector<double> b = trace(sim, 500);
  RunResult rb = sim.result();
  EXPECT_TRUE(a == b);
  EXPECT_EQ(ra.steps, rb.steps);
  EXPECT_EQ(without_wall_clock(ra.metrics).dump(), without_wall_clock(rb.metrics).dump());
}

TEST_P(RestoreContinues, AsTheUnbrokenRun) {
  expect_restore_continues(GetParam(), "");
}

class RestoreContinuesDart : public RestoreContinues {};

TEST_P(RestoreContinuesDart, AsTheUnbrokenRun) {
  expect_restore_continues(GetParam(), "dart");
}

INSTANTIATE_TEST_SUITE_P(Scenarios, RestoreContinuesDart, ::testing::Values("simbicon_walk.yaml"),
                         [](const auto& info) {
                           std::string n = info.param;
                           return n.substr(0, n.find('.'));
                         });

// biped_stand on DART: the restored run continues close to, not bit for bit as, the unbroken
// one (stable PD reads the last step's constraint forces, which restore_state does not keep)
TEST(RestoreContinuesDartBipedStand, CloseToTheUnbrokenRun) {
  Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml")), test::quiet("dart"));
  trace(sim, 150);
  SimulationState s;
  sim.save(s);
  trace(sim, 500);
  RunResult ra = sim.result();
  sim.restore(s);
  trace(sim, 500);
  RunResult rb = sim.result();
  EXPECT_EQ(ra.steps, rb.steps);
  EXPECT_EQ(ra.fell, rb.fell);
  for (const char* key : {"com_displacement_m", "min_com_height_m", "stable_pd_rms_error_rad"})
    EXPECT_NEAR(ra.metrics[key].get<double>(), rb.metrics[key].get<double>(), 1e-3) << key;
}

INSTANTIATE_TEST_SUITE_P(Scenarios, RestoreContinues,
                         ::testing::Values("simbicon_walk.yaml", "biped_stand.yaml",
                                           "biped_push.yaml", "mocap_track.yaml"),
                         [](const auto& info) {
                           std::string n = info.param;
                           return n.substr(0, n.find('.'));
                         });

TEST(SimulationStateFile, RoundTripAndBadFiles) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  Simulation sim(loaded, test::quiet());
  trace(sim, 200);
  const std::string file = test::write_temp_file("sim_state.bin", "");
  sim.write_state(file);
  std::vector<double> a = trace(sim, 200);
  Simulation other(sim.shared_model());
  other.read_state(file);
  EXPECT_NEAR(other.time(), sim.time() - 200 * sim.engine().timestep(), 1e-9);
  EXPECT_TRUE(trace(other, 200) == a);
  // the file is written atomically: no temporary is left beside it
  EXPECT_FALSE(std::filesystem::exists(temporary_path_for(file)));

  // truncated, foreign, missing: located errors, the simulation unchanged
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const double t = other.time();
  const std::string cut = test::write_temp_file("sim_state_cut.bin", bytes.substr(0, 100));
  try {
    other.read_state(cut);
    ADD_FAILURE() << "a truncated state file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos) << e.what();
  }
  EXPECT_EQ(other.time(), t);
  EXPECT_THROW(other.read_state(test::write_temp_file("sim_state_junk.bin", "hello")), InputError);
  EXPECT_THROW(other.read_state("/no/such/state.bin"), InputError);
  Simulation walker(load_scenario(test::scenario_path("simbicon_walk.yaml")), test::quiet());
  try {
    walker.read_state(file);
    ADD_FAILURE() << "a state of another model was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("another model"), std::string::npos) << e.what();
  }
}

TEST(SimulationLoop, StopsOneSecondAfterAFallUnlessAskedOtherwise) {
  // the biped without its ankle strategy falls well before 10 s
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  loaded.controllers.resize(1);
  RunResult r = Simulation(loaded, test::quiet()).run();
  ASSERT_TRUE(r.fell);
  EXPECT_NEAR(r.sim_time, *r.fall_time + 1.0, 2e-3);
  RunOptions o = test::quiet();
  o.stop_after_fall_s = -1;
  RunResult full = Simulation(loaded, o).run();
  EXPECT_TRUE(full.fell);
  EXPECT_EQ(*full.fall_time, *r.fall_time);
  EXPECT_NEAR(full.sim_time, loaded.scenario.duration, 2e-3);
}

TEST(SimulationLoop, ObserversSeeEveryStep) {
  struct Counter : StepObserver {
    int starts = 0, steps = 0, finishes = 0;
    void on_start(const Simulation&) override { ++starts; }
    void on_step(const Simulation&) override { ++steps; }
    void on_finish(const Simulation&, const RunResult&) override { ++finishes; }
  } counter;
  RunOptions o = test::quiet();
  o.duration = 0.25;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  sim.add_observer(&counter);
  RunResult r = sim.run();
  EXPECT_EQ(counter.starts, 1);
  EXPECT_EQ(counter.steps, r.steps);
  EXPECT_EQ(counter.finishes, 1);
  EXPECT_GT(r.steps, 0);
}

TEST(SimulationLoop, RunWritesItsFilesWithoutTemporaries) {
  const std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" /
                           ("simloop_" + std::to_string(::getpid())))
                              .string();
  RunOptions o = test::quiet();
  o.duration = 0.3;
  o.out_dir = dir;
  Simulation(load_scenario(test::scenario_path("pd_hold.yaml")), o).run();
  EXPECT_TRUE(std::filesystem::exists(dir + "/summary.json"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/log.csv"));
  for (const auto& f : std::filesystem::directory_iterator(dir))
    EXPECT_NE(f.path().filename().string()[0], '.') << f.path();
  std::filesystem::remove_all(dir);
}

// a controller whose torque on one dof turns NaN at a given time (a bug or a blown-up solve)
struct NanAfterState {
  template <class A>
  void serialize(A&) {}
};
class NanAfter final : public TypedController<NanAfterState> {
 public:
  explicit NanAfter(double t) : t_(t) {}
  std::string_view type() const override { return "nan_after"; }
  YAML::Node params_yaml() const override { return {}; }

 protected:
  void reset_state(State&, const Engine&) const override {}
  void compute_step(State&, const Engine& e, ControlOutput& out) const override {
    if (e.time() >= t_) out.tau[out.tau.size() - 1] = std::numeric_limits<double>::quiet_NaN();
  }

 private:
  double t_;
};

class NanController : public ::testing::TestWithParam<std::string> {};

// on either engine, a non-finite controller output ends the run as diverged, with the time, the
// controller and the dof, and the run's files are written and whole
TEST_P(NanController, StopsTheRunWithTimeCauseAndOutputs) {
  const std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" /
                           ("nan_" + GetParam() + std::to_string(::getpid())))
                              .string();
  std::filesystem::remove_all(dir);
  RunOptions o = test::quiet(GetParam());
  o.out_dir = dir;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  sim.replace_controller(0, std::make_shared<NanAfter>(0.25));
  RunResult r = sim.run();
  ASSERT_TRUE(r.diverged);
  EXPECT_NEAR(r.sim_time, 0.25, sim.engine().timestep() + 1e-9);
  const std::string dof = sim.engine().dof_name(sim.engine().nv() - 1);
  EXPECT_NE(r.divergence.find("controller 0 ('nan_after') output a non-finite torque nan on dof '" +
                              dof + "' at t=0.25"),
            std::string::npos)
      << r.divergence;
  // the engine never saw the NaN: its state is the last good one
  EXPECT_TRUE(sim.engine().state_is_finite());
  std::ifstream in(dir + "/summary.json");
  nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["diverged"].get<bool>());
  EXPECT_FALSE(j["interrupted"].get<bool>());
  EXPECT_EQ(j["divergence"].get<std::string>(), r.divergence);
  std::ifstream log(dir + "/log.csv");
  std::string line, last;
  int rows = 0;
  while (std::getline(log, line)) last = line, ++rows;
  EXPECT_GT(rows, 20);
  EXPECT_EQ(last.find("nan"), std::string::npos) << last;
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Engines, NanController, ::testing::Values("mujoco", "dart"));

// absurd gains blow the engine's state up: the run stops as diverged, and every metric in the
// summary is still a number (those of the state stop at its last finite step)
TEST_P(NanController, AnEngineBlowUpLeavesFiniteMetrics) {
  const std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" /
                           ("blowup_" + GetParam() + std::to_string(::getpid())))
                              .string();
  std::filesystem::remove_all(dir);
  RunOptions o = test::quiet(GetParam());
  o.out_dir = dir;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml"), {"controllers.0.kp=1e12"}), o);
  RunResult r = sim.run();
  ASSERT_TRUE(r.diverged);
  std::ifstream in(dir + "/summary.json");
  nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["diverged"].get<bool>());
  for (const auto& [key, value] : j["metrics"].items())
    if (!value.is_object()) EXPECT_TRUE(value.is_number()) << key << ": " << value;
  std::filesystem::remove_all(dir);
}

// a body lying on the floor may blow up after its fall: the run fell (it is no error of the
// run), the fall's reason tells of the divergence after it, and the summary's numbers are finite
TEST_P(NanController, ADivergenceAfterAFallIsReportedAsTheFall) {
  RunOptions o = test::quiet(GetParam());
  o.duration = 4;
  // unpowered, the biped collapses; a NaN 0.3 s later (within the second run on past a fall).
  // It states its own expectation: the shipped one names the ankle strategy's metrics
  const std::vector<std::string> unpowered = {"controllers=[{type: stable_pd, kp: 0, kd: 0}]",
                                              "expect={fell: true}"};
  Simulation collapse(load_scenario(test::scenario_path("biped_stand.yaml"), unpowered), o);
  collapse.replace_controller(0, std::make_shared<NanAfter>(1e9));
  const RunResult fall = collapse.run();
  ASSERT_TRUE(fall.fell);
  ASSERT_FALSE(fall.diverged);
  Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml"), unpowered), o);
  sim.replace_controller(0, std::make_shared<NanAfter>(*fall.fall_time + 0.3));
  const RunResult r = sim.run();
  EXPECT_TRUE(r.fell);
  EXPECT_FALSE(r.diverged) << r.divergence;
  EXPECT_DOUBLE_EQ(*r.fall_time, *fall.fall_time);
  EXPECT_NE(r.fall_reason.find("(then diverged 0.3"), std::string::npos) << r.fall_reason;
  EXPECT_NE(r.fall_reason.find("output a non-finite torque"), std::string::npos) << r.fall_reason;
  for (const auto& [key, value] : r.metrics.items())
    if (!value.is_object()) EXPECT_TRUE(value.is_number()) << key << ": " << value;
}

// a blow-up within a few steps of the fall it caused (a clip played far too fast flings the
// character off, and that reads as a fall first) is the run's divergence: exit 3, not a fall
TEST_P(NanController, ABlowUpRightAfterAFallIsADivergence) {
  RunOptions o = test::quiet(GetParam());
  o.duration = 4;
  // unpowered, with its own expectation (the shipped one names the ankle strategy's metrics)
  const std::vector<std::string> unpowered = {"controllers=[{type: stable_pd, kp: 0, kd: 0}]",
                                              "expect={fell: true}"};
  Simulation collapse(load_scenario(test::scenario_path("biped_stand.yaml"), unpowered), o);
  collapse.replace_controller(0, std::make_shared<NanAfter>(1e9));
  const RunResult fall = collapse.run();
  ASSERT_TRUE(fall.fell);
  Simulation sim(load_scenario(test::scenario_path("biped_stand.yaml"), unpowered), o);
  sim.replace_controller(0, std::make_shared<NanAfter>(*fall.fall_time + 0.02));
  const RunResult r = sim.run();
  EXPECT_TRUE(r.fell);
  EXPECT_TRUE(r.diverged);
  EXPECT_NE(r.divergence.find("output a non-finite torque"), std::string::npos) << r.divergence;
  EXPECT_EQ(r.fall_reason.find("then diverged"), std::string::npos) << r.fall_reason;
  EXPECT_TRUE(r.to_json()["diverged"].get<bool>());
}

// a walker whose state blows up on the floor after its fall: its distance and speed are those
// it had when it fell, not those of the blown-up state
TEST(SimulationLoop, AWalkerThatBlowsUpAfterItsFallKeepsTheMetricsOfItsFall) {
  const std::vector<std::string> shove = {
      "perturbations=[{body: torso, force: [900, 0, 0], start: 2.0, duration: 0.2}]"};
  RunOptions o = test::quiet();
  o.duration = 6;
  Simulation until_fall(load_scenario(test::scenario_path("simbicon_walk.yaml"), shove), o);
  while (!until_fall.progress().fell && until_fall.step()) {
  }
  ASSERT_TRUE(until_fall.progress().fell);
  const RunResult at_fall = until_fall.result();
  Simulation whole(load_scenario(test::scenario_path("simbicon_walk.yaml"), shove), o);
  whole.add_controller(std::make_shared<NanAfter>(*at_fall.fall_time + 0.5));
  const RunResult r = whole.run();
  ASSERT_TRUE(r.fell);
  EXPECT_FALSE(r.diverged);
  EXPECT_NEAR(r.sim_time, *r.fall_time + 0.5, 1e-2);
  for (const char* key : {"distance_m", "mean_speed_mps", "step_count", "flight_fraction"})
    EXPECT_EQ(r.metrics[key], at_fall.metrics[key]) << key;
  // the walk went on moving in that half second: the metrics would differ without the rule
  Simulation on_the_floor(load_scenario(test::scenario_path("simbicon_walk.yaml"), shove), o);
  const RunResult no_blow_up = on_the_floor.run();
  EXPECT_NE(no_blow_up.metrics["distance_m"], at_fall.metrics["distance_m"]);
}

// an interrupt (SIGINT's flag) stops the run before its next step; the outputs say so
TEST(SimulationLoop, InterruptStopsTheRunAndWritesItsFiles) {
  const std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" /
                           ("interrupt_" + std::to_string(::getpid())))
                              .string();
  std::atomic<bool> stop{false};
  struct StopAt : StepObserver {
    std::atomic<bool>* stop;
    double at;
    void on_step(const Simulation& sim) override {
      if (sim.time() >= at) stop->store(true);
    }
  } stopper;
  stopper.stop = &stop;
  stopper.at = 0.5;
  RunOptions o = test::quiet();
  o.out_dir = dir;
  o.interrupt = &stop;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  sim.add_observer(&stopper);
  RunResult r = sim.run();
  EXPECT_TRUE(r.interrupted);
  EXPECT_FALSE(r.diverged);
  EXPECT_NEAR(r.sim_time, 0.5, sim.engine().timestep() + 1e-9);
  std::ifstream in(dir + "/summary.json");
  nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["interrupted"].get<bool>());
  EXPECT_NEAR(j["sim_time"].get<double>(), 0.5, 0.01);
  std::filesystem::remove_all(dir);
}

TEST(SimulationLoop, MemoryLogHoldsTheRowsOfLogCsv) {
  const std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" /
                           ("memlog_" + std::to_string(::getpid())))
                              .string();
  RunOptions o = test::quiet();
  o.duration = 2.5;  // through the push at 2 s
  o.out_dir = dir;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  MemoryLog log;
  sim.add_observer(&log);
  sim.run();
  std::ifstream csv(dir + "/log.csv");
  std::string line;
  std::getline(csv, line);
  std::string header;
  for (const auto& c : log.columns) header += (header.empty() ? "" : ",") + c;
  EXPECT_EQ(line, header);
  size_t rows = 0;
  int pushed_rows = 0;
  for (; std::getline(csv, line); ++rows) {
    std::stringstream ss(line);
    std::string cell;
    for (size_t c = 0; std::getline(ss, cell, ','); ++c) {
      const double logged = log.values.at(rows * log.columns.size() + c);
      EXPECT_NEAR(std::stod(cell), logged, 1e-8 * std::max(1.0, std::abs(logged)))
          << log.columns[c] << " row " << rows;
      if (log.columns[c] == "push_fz" && logged == -20.0) ++pushed_rows;
    }
  }
  EXPECT_EQ(rows, 251u);
  EXPECT_EQ(log.values.size(), rows * log.columns.size());
  // the push of 0.2 s at 2 s, logged at 100 Hz
  EXPECT_GE(pushed_rows, 19);
  EXPECT_LE(pushed_rows, 21);
  std::filesystem::remove_all(dir);
}

TEST(SimulationLoop, RunForAStepCountThenToTheEnd) {
  RunOptions o = test::quiet();
  o.duration = 0.5;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  EXPECT_EQ(sim.run(120).steps, 120);
  EXPECT_EQ(sim.run().steps, 500);
  EXPECT_TRUE(sim.done());
}

// an entry of type python: a located error without a factory (the CLI), built by the factory
// when there is one (the Python module)
TEST(SimulationExternalControllers, NeedAFactoryAndUseIt) {
  const std::string path = test::write_temp_file("external.yaml", fmt::format(
                                                                      R"(name: external
model: {}/models/arm3.xml
duration: 0.2
controllers:
  - type: python
    module: my_ctrl
    class: MyController
)",
                                                                      test::source_dir()));
  try {
    Simulation sim(load_scenario(path), test::quiet());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              path +
                  ":5: controllers[0]: type 'python' is resolved only when the scenario is "
                  "loaded from Python (stance.load)");
  }
  RunOptions o = test::quiet();
  std::string module;
  o.external_controllers = [&](const YAML::Node& node, const ControllerContext& ctx,
                               const Engine& engine) {
    module = node["module"].Scalar();
    YAML::Node pd;
    pd["type"] = "hold_pose_pd";
    return find_controller_type("hold_pose_pd").make(pd, ctx, engine);
  };
  Simulation sim(load_scenario(path), o);
  EXPECT_EQ(module, "my_ctrl");
  EXPECT_EQ(sim.controllers().at(0)->type(), "hold_pose_pd");
}

// a controller added to a loaded simulation composes with the scenario's, and clones take it
TEST(SimulationLoop, AddedControllersComposeAndClone) {
  RunOptions o = test::quiet();
  o.duration = 1;
  Simulation sim(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  Simulation plain(load_scenario(test::scenario_path("pd_hold.yaml")), o);
  ControllerContext ctx = controller_context(sim.model(), 1);
  YAML::Node pd;
  pd["type"] = "hold_pose_pd";
  pd["kp"] = 30;
  pd["kd"] = 1;
  sim.add_controller(find_controller_type("hold_pose_pd").make(pd, ctx, sim.engine()));
  ASSERT_EQ(sim.controllers().size(), 2u);
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(sim.step() && plain.step());
  // the second controller's torques add to the first's
  EXPECT_GT((sim.last_output().tau - plain.last_output().tau).norm(), 1e-6);
  auto clone = sim.clone();
  ASSERT_EQ(clone->controllers().size(), 2u);
  EXPECT_EQ(trace(*clone, 200), trace(sim, 200));
}

TEST(ProgressBar, LineShowsFractionTimesAndEta) {
  EXPECT_EQ(ProgressBar::line(0.5, 5, 10, 2),
            "[###############               ]  50%  5.0/10.0 s  ETA 2s");
  EXPECT_EQ(ProgressBar::line(0.25, 2.5, 10, 60),
            "[########                      ]  25%  2.5/10.0 s"
            "  ETA 3m00s");
  EXPECT_NE(ProgressBar::line(0, 0, 10, 0).find("ETA --"), std::string::npos);
}

}  // namespace
}  // namespace stance
