// The States of the LQR and the motion-capture trackers: a run written to a state file mid-way
// and read back goes on bit for bit (recorded frames for the export included), and a live edit
// keeps the State over a gain but not over another clip.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "control/lqr.h"
#include "control/mocap_retarget_tracker.h"
#include "run_support.h"
#include "sim/live_tuning.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

// the metrics without the wall-clock ones (each run designs its own LQR)
std::string deterministic_metrics(const Simulation& run) {
  nlohmann::json m = run.result().metrics;
  m.erase("controller_ns_per_step");
  m.erase("design_time_ms");
  return m.dump();
}

// run to t1, save in memory and to a file, run on to t2; a run restored from memory and one read
// from the file reach the same state at t2 as the run that went on
template <class S>
void expect_state_file_resumes(const LoadedScenario& loaded, double t1, double t2) {
  const std::string file =
      (fs::temp_directory_path() /
       ("stance_tracker_state_" + loaded.scenario.name + "_" + std::to_string(::getpid())))
          .string();
  Simulation run(loaded, test::quiet());
  test::step_to(run, t1);
  SimulationState saved;
  run.save(saved);
  run.write_state(file);
  test::step_to(run, t2);
  Simulation restored(loaded, test::quiet()), resumed(loaded, test::quiet());
  restored.restore(saved);
  resumed.read_state(file);
  test::step_to(restored, t2);
  test::step_to(resumed, t2);
  Eigen::VectorXd qa(restored.engine().nq()), qb(resumed.engine().nq()), qc(run.engine().nq());
  restored.engine().get_positions(qa);
  resumed.engine().get_positions(qb);
  run.engine().get_positions(qc);
  EXPECT_EQ(qa, qb);
  std::vector<double> sa, sb, sc;
  restored.signals(sa);
  resumed.signals(sb);
  run.signals(sc);
  EXPECT_EQ(sa, sb);
  EXPECT_EQ(deterministic_metrics(restored), deterministic_metrics(resumed));
  if constexpr (std::is_same_v<S, MocapRetargetState>) {
    EXPECT_GT(resumed.state_as<S>(0).recorded_roots.size(), 0u);
    EXPECT_EQ(resumed.state_as<S>(0).recorded_roots, restored.state_as<S>(0).recorded_roots);
  }
  {
    EXPECT_EQ(qc, qb);
    EXPECT_EQ(sc, sb);
    EXPECT_EQ(deterministic_metrics(run), deterministic_metrics(resumed));
  }
  fs::remove(file);
}

TEST(TrackerStateFile, LqrBalancing) {
  if (!fs::exists(test::kHumanoidXml))
    GTEST_SKIP() << test::kHumanoidXml << " missing (libmujoco-samples)";
  expect_state_file_resumes<LqrState>(
      load_scenario(test::scenario_path("lqr_one_leg.yaml"), {"controllers.0.force_plot=false"}),
      0.3, 0.6);
}

// the bvh2mjcf character (the identity map) and the humanoid through its map, assisted and in
// free mode with the balance layer
TEST(TrackerStateFile, MocapTrackerAssistedAndFree) {
  for (const char* name : {"mocap_track.yaml", "mocap_retarget.yaml"})
    for (const char* mode : {"assisted", "free"}) {
      SCOPED_TRACE(std::string(name) + " " + mode);
      expect_state_file_resumes<MocapRetargetState>(
          load_scenario(test::scenario_path(name), {"controllers.0.export_bvh=out.bvh",
                                                    std::string("controllers.0.mode=") + mode}),
          0.5, 1.0);
    }
}

// the design is redone for a cost edit; the State (metrics so far) goes on
TEST(TrackerLiveEdit, LqrKeepsItsStateOverACostEdit) {
  if (!fs::exists(test::kHumanoidXml))
    GTEST_SKIP() << test::kHumanoidXml << " missing (libmujoco-samples)";
  LoadedScenario loaded =
      load_scenario(test::scenario_path("lqr_one_leg.yaml"), {"controllers.0.force_plot=false"});
  Simulation run(loaded, test::quiet());
  test::step_to(run, 0.2);
  const auto* before = &run.state_as<LqrState>(0);
  const long computes = before->computes;
  const long designs = lqr_designs_made();
  retune_controller(run, loaded, 0, "balance_cost", 2000);
  EXPECT_EQ(lqr_designs_made(), designs + 1);
  EXPECT_EQ(&run.state_as<LqrState>(0), before);
  EXPECT_EQ(before->computes, computes);
  ASSERT_TRUE(run.step());
}

// a gain edit keeps the errors and the recorded frames; another clip range starts afresh
TEST(TrackerLiveEdit, MocapTrackerKeepsItsStateUnlessTheClipChanges) {
  LoadedScenario loaded =
      load_scenario(test::scenario_path("mocap_track.yaml"), {"controllers.0.export_bvh=out.bvh"});
  Simulation run(loaded, test::quiet());
  test::step_to(run, 0.3);
  const auto* before = &run.state_as<MocapRetargetState>(0);
  const long steps = before->steps;
  const size_t frames = before->recorded_roots.size();
  ASSERT_GT(frames, 0u);
  retune_controller(run, loaded, 0, "kp", 900);
  EXPECT_EQ(&run.state_as<MocapRetargetState>(0), before);
  EXPECT_EQ(before->steps, steps);
  EXPECT_EQ(before->recorded_roots.size(), frames);
  retune_controller(run, loaded, 0, "first_frame", 10);
  EXPECT_EQ(run.state_as<MocapRetargetState>(0).steps, 0);
  EXPECT_EQ(run.state_as<MocapRetargetState>(0).recorded_roots.size(), 0u);
  ASSERT_TRUE(run.step());
}

TEST(TrackerLiveEdit, MocapRetargetKeepsItsStateOverAGainEdit) {
  LoadedScenario loaded = load_scenario(test::scenario_path("mocap_retarget.yaml"));
  Simulation run(loaded, test::quiet());
  test::step_to(run, 0.3);
  const auto* before = &run.state_as<MocapRetargetState>(0);
  const long steps = before->steps;
  retune_controller(run, loaded, 0, "kd", 40);
  EXPECT_EQ(&run.state_as<MocapRetargetState>(0), before);
  EXPECT_EQ(before->steps, steps);
  retune_controller(run, loaded, 0, "first_frame", 10);
  EXPECT_EQ(run.state_as<MocapRetargetState>(0).steps, 0);
  ASSERT_TRUE(run.step());
}

}  // namespace
}  // namespace stance
