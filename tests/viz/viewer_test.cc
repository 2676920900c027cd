// The viewer on every shipped scenario, driven by key events through its programmatic API.
// Needs an X display: ctest runs this file again under xvfb-run (test viz.xvfb); without a
// display the tests skip.
#include "viz/viewer.h"

#include <GLFW/glfw3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <thread>

#include "control/lqr.h"
#include "core/error.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

bool have_display() {
  return std::getenv("DISPLAY") != nullptr;
}

fs::path shot_dir() {
  fs::path d = fs::temp_directory_path() / "stance_viewer_tests";
  fs::create_directories(d);
  return d;
}

std::vector<unsigned char> frame_of(const Viewer& v) {
  int w = 0, h = 0;
  return v.last_frame(w, h);
}

// share of pixels differing from the most common colour
double non_background_fraction(const std::vector<unsigned char>& rgb) {
  std::map<uint32_t, long> counts;
  for (size_t i = 0; i + 2 < rgb.size(); i += 3)
    ++counts[(rgb[i] << 16) | (rgb[i + 1] << 8) | rgb[i + 2]];
  long most = 0;
  for (const auto& [c, n] : counts) most = std::max(most, n);
  return rgb.empty() ? 0.0 : 1.0 - static_cast<double>(most) / (rgb.size() / 3);
}

double mean_abs_difference(const std::vector<unsigned char>& a,
                           const std::vector<unsigned char>& b) {
  if (a.size() != b.size() || a.empty()) return -1;
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += std::abs(int(a[i]) - int(b[i]));
  return sum / a.size();
}

ViewerOptions test_options() {
  ViewerOptions o;
  o.width = 640;
  o.height = 400;
  o.threaded = false;  // reproducible: each frame() advances 1/60 s
  // the model as it is: the sky, floor and shadows cost a lot in software rendering, and
  // tests/viz/scene_view_test.cc checks them
  o.scene_look = false;
  o.save_path = (shot_dir() / "saved.yaml").string();
  return o;
}

class ViewerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_display()) GTEST_SKIP() << "no display (ctest runs these under xvfb-run)";
  }
};

TEST_F(ViewerTest, EveryScenarioDrawsPausesStepsPushesAndReplays) {
  std::vector<fs::path> files;
  for (const auto& f : fs::directory_iterator(test::source_dir() + "/scenarios"))
    if (f.path().extension() == ".yaml") files.push_back(f.path());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 5u);
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    LoadedScenario loaded = load_scenario(f.string());
    Viewer v(loaded, test_options());
    for (int i = 0; i < 3; ++i) v.frame();
    std::vector<unsigned char> first = frame_of(v);
    EXPECT_GT(non_background_fraction(first), 0.2);
    v.screenshot((shot_dir() / (f.stem().string() + "_a.png")).string());

    // pause: the clock stands still over frames; n steps exactly one timestep
    v.key(GLFW_KEY_SPACE);
    ASSERT_TRUE(v.paused());
    double t_paused = v.sim_time();
    v.frame();
    v.frame();
    EXPECT_EQ(v.sim_time(), t_paused);
    v.key(GLFW_KEY_N);
    EXPECT_GT(v.sim_time(), t_paused);
    EXPECT_LT(v.sim_time(), t_paused + 0.011);
    v.key(GLFW_KEY_SPACE);
    EXPECT_FALSE(v.paused());

    // push forth, then run on: the picture changes (motion, arrow, clock)
    v.key(GLFW_KEY_PERIOD);
    EXPECT_NE(v.status().find("push"), std::string::npos);
    for (int i = 0; i < 4; ++i) v.frame();
    v.screenshot((shot_dir() / (f.stem().string() + "_b.png")).string());
    std::vector<unsigned char> pushed = frame_of(v);
    EXPECT_GT(non_background_fraction(pushed), 0.2);
    EXPECT_GT(mean_abs_difference(first, pushed), 0.05);

    // replay: back to the start, and the follow camera survives it
    ASSERT_TRUE(v.follow_camera());
    v.key(GLFW_KEY_P);
    EXPECT_EQ(v.sim_time(), 0.0);
    EXPECT_TRUE(v.follow_camera());
    v.frame();
    EXPECT_LT(v.sim_time(), 0.02);
  }
}

TEST_F(ViewerTest, SkateboardSpeedKeys) {
  fs::path file = test::scenario_path("biped_skateboard.yaml");
  if (!fs::exists(file)) GTEST_SKIP() << "no skateboard scenario";
  Viewer v(load_scenario(file.string()), test_options());
  int drive = -1;
  for (size_t i = 0; i < v.param_panel().size() && drive < 0; ++i)
    if (!std::isnan(v.param_value(static_cast<int>(i), "speed"))) drive = static_cast<int>(i);
  ASSERT_GE(drive, 0);
  double speed0 = v.param_value(drive, "speed");
  double step = v.param_value(drive, "speed_step");
  // no ramp, so that the command is the speed from the first step
  v.set_param(drive, "start_s", 0);
  v.set_param(drive, "ramp_s", 0);
  v.key(GLFW_KEY_S);
  v.key(GLFW_KEY_S);
  v.key(GLFW_KEY_A);
  EXPECT_NEAR(v.param_value(drive, "speed"), speed0 + step, 1e-12);
  // the edit keeps the run's State, and the command it sends follows the new speed
  v.frame();
  EXPECT_NEAR(v.plot_value("wheel_speed_command"), speed0 + step, 1e-6);
}

TEST_F(ViewerTest, PushKeyChangesTheMotion) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  Viewer pushed(loaded, test_options()), calm(loaded, test_options());
  pushed.key(GLFW_KEY_PERIOD);  // forth: +x
  for (int i = 0; i < 6; ++i) {
    pushed.frame();
    calm.frame();
  }
  EXPECT_GT(pushed.com_velocity().x() - calm.com_velocity().x(), 0.05);
}

// the key's push and the mouse spring go through the run's state: a saved state holds them, so
// the planner's rollouts (which branch from it) feel them, and restoring it replays them
TEST_F(ViewerTest, KeyPushAndMouseSpringAreInTheRunsSavedState) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  RunOptions run_options;
  run_options.quiet = true;
  auto owned = std::make_unique<Simulation>(loaded, run_options);
  Simulation& run = *owned;
  Viewer v(loaded, test_options(), std::move(owned));
  v.key(GLFW_KEY_PERIOD);  // forth: +x
  SimulationState pushed;
  run.save(pushed);
  ASSERT_EQ(pushed.progress.external.pushes.size(), 1u);
  const ExternalForces::Push& push = pushed.progress.external.pushes[0];
  EXPECT_GT(push.force[0], 0);
  EXPECT_GT(push.until_s, run.time());

  ASSERT_TRUE(v.select_body("h_head"));
  v.drag_to(v.body_position("h_head") + Eigen::Vector3d(0.3, 0, 0));
  v.frame();
  SimulationState pulled;
  run.save(pulled);
  EXPECT_EQ(pulled.progress.external.spring.body, v.selected_body());
  EXPECT_GT(pulled.progress.external.spring.stiffness, 0);

  // the run's own step applies them, and restored, it goes on as it did from there
  for (int i = 0; i < 30; ++i) ASSERT_TRUE(run.step());
  const Eigen::Vector3d com = run.engine().com();
  run.restore(pulled);
  for (int i = 0; i < 30; ++i) ASSERT_TRUE(run.step());
  EXPECT_EQ(run.engine().com(), com);
  v.release();
  v.frame();
  SimulationState released;
  run.save(released);
  EXPECT_EQ(released.progress.external.spring.body, -1);
}

TEST_F(ViewerTest, PanelGainChangesBehaviourAndSaves) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  Viewer stiff(loaded, test_options()), soft(loaded, test_options());
  // the panel lists stable_pd's kp with the visit's range; set it the way a slider does
  const auto& panel = soft.param_panel();
  ASSERT_FALSE(panel.empty());
  bool listed = std::any_of(panel[0].begin(), panel[0].end(),
                            [](const ParamEntry& e) { return e.path == "kp" && e.value == 400; });
  EXPECT_TRUE(listed);
  soft.set_param(0, "kp", 20);
  bool updated = std::any_of(soft.param_panel()[0].begin(), soft.param_panel()[0].end(),
                             [](const ParamEntry& e) { return e.path == "kp" && e.value == 20; });
  EXPECT_TRUE(updated);
  double stiff_low = 1e9, soft_low = 1e9;
  for (int i = 0; i < 30; ++i) {
    stiff.frame();
    soft.frame();
    stiff_low = std::min(stiff_low, stiff.com_height());
    soft_low = std::min(soft_low, soft.com_height());
  }
  // a twentieth of the gain: the character sags clearly lower within half a second (2.3 cm)
  EXPECT_LT(soft_low, stiff_low - 0.01) << "stiff " << stiff_low << " soft " << soft_low;
  std::string saved = soft.save_scenario();
  LoadedScenario again = load_scenario(saved);
  EXPECT_EQ(again.controllers[0]["kp"].as<double>(), 20);
  EXPECT_GT(mean_abs_difference(frame_of(stiff), frame_of(soft)), 0.05);
}

// the planner block has its own sliders: listed from its visit, an edit reaches the running
// planner (what the next plan uses) and the saved scenario
TEST_F(ViewerTest, PlannerSlidersReachThePlannerAndTheSavedScenario) {
  LoadedScenario loaded =
      load_scenario(test::scenario_path("biped_stand.yaml"),
                    {"planner.enabled=true", "planner.samples=3", "planner.horizon_s=0.05",
                     "planner.interval_s=0.05", "planner.threads=1"});
  Viewer viewer(loaded, test_options());
  auto value = [&](const std::string& path) {
    for (const ParamEntry& e : viewer.planner_panel())
      if (e.path == path) return e.value;
    return -1.0;
  };
  EXPECT_EQ(value("samples"), 3);
  viewer.set_planner_param("samples", 5);
  EXPECT_EQ(value("samples"), 5);
  EXPECT_THROW(viewer.set_planner_param("samples", -2), InputError);
  for (int i = 0; i < 3; ++i) viewer.frame();
  LoadedScenario again = load_scenario(viewer.save_scenario());
  EXPECT_EQ(again.scenario.planner.samples, 5);
  Viewer plain(load_scenario(test::scenario_path("biped_stand.yaml")), test_options());
  EXPECT_TRUE(plain.planner_panel().empty());
}

TEST_F(ViewerTest, DartRunsAreDrawn) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  ViewerOptions o = test_options();
  o.engine = "dart";
  Viewer dart(loaded, o);
  o.engine = "mujoco";
  Viewer mujoco(loaded, o);
  for (int i = 0; i < 3; ++i) {
    dart.frame();
    mujoco.frame();
  }
  dart.screenshot((shot_dir() / "biped_stand_dart.png").string());
  EXPECT_GT(non_background_fraction(frame_of(dart)), 0.2);
  // the same model in the same pose: the pictures nearly agree (the panels' engine name and
  // small state differences aside)
  EXPECT_LT(mean_abs_difference(frame_of(dart), frame_of(mujoco)), 3.0);
}

TEST_F(ViewerTest, PhysicsThreadAdvancesAndPauses) {
  LoadedScenario loaded = load_scenario(test::scenario_path("pd_hold.yaml"));
  ViewerOptions o = test_options();
  o.threaded = true;
  Viewer v(loaded, o);
  // the physics thread runs on its own while frames are drawn
  for (int i = 0; i < 200 && v.sim_time() < 0.05; ++i) v.frame();
  EXPECT_GE(v.sim_time(), 0.05);
  v.key(GLFW_KEY_SPACE);
  double t = v.sim_time();
  for (int i = 0; i < 5; ++i) v.frame();
  EXPECT_EQ(v.sim_time(), t);
  v.key(GLFW_KEY_N);  // single steps go through the physics thread
  for (int i = 0; i < 50 && v.sim_time() == t; ++i) v.frame();
  EXPECT_GT(v.sim_time(), t);
}

// a running window reads no frame back unless asked (a read-back of every frame costs a software
// renderer a few ms): the i key keeps and saves the next one
TEST_F(ViewerTest, RunningWindowKeepsAFrameOnlyWhenAsked) {
  LoadedScenario loaded = load_scenario(test::scenario_path("pd_hold.yaml"));
  ViewerOptions o = test_options();
  o.threaded = true;
  o.capture_dir = (shot_dir() / "asked").string();
  fs::remove_all(o.capture_dir);
  fs::create_directories(o.capture_dir);
  Viewer v(loaded, o);
  for (int i = 0; i < 3; ++i) v.frame();
  EXPECT_TRUE(frame_of(v).empty());
  v.key(GLFW_KEY_I);
  EXPECT_TRUE(v.last_capture().empty());
  v.frame();
  const std::string png = (fs::path(o.capture_dir) / "pd_hold_001.png").string();
  EXPECT_EQ(v.last_capture(), png);
  EXPECT_TRUE(fs::exists(png));
  int w = 0, h = 0;
  const size_t kept = v.last_frame(w, h).size();
  EXPECT_GT(w, 0);
  EXPECT_EQ(kept, static_cast<size_t>(w) * h * 3);
}

// software rendering (Xvfb's llvmpipe) draws the quick look unless told otherwise
TEST_F(ViewerTest, QuickLookFollowsTheOption) {
  LoadedScenario loaded = load_scenario(test::scenario_path("pd_hold.yaml"));
  ViewerOptions o = test_options();
  o.quick_look = false;
  EXPECT_FALSE(Viewer(loaded, o).quick_look());
  o.quick_look = true;
  Viewer quick(loaded, o);
  EXPECT_TRUE(quick.quick_look());
  quick.frame();
  EXPECT_GT(non_background_fraction(frame_of(quick)), 0.01);
}

// the mouse spring pulls the selected body towards the target, on either engine
TEST_F(ViewerTest, DraggingABodyMovesItTowardsTheTarget) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  for (const char* engine : {"mujoco", "dart"}) {
    SCOPED_TRACE(engine);
    ViewerOptions o = test_options();
    o.engine = engine;
    Viewer pulled(loaded, o), calm(loaded, o);
    ASSERT_FALSE(pulled.select_body("no_such_body"));
    ASSERT_TRUE(pulled.select_body("h_head"));
    ASSERT_GE(pulled.selected_body(), 0);
    Eigen::Vector3d head0 = pulled.body_position("h_head");
    Eigen::Vector3d target = head0 + Eigen::Vector3d(0.3, 0, 0);
    pulled.drag_to(target);
    for (int i = 0; i < 20; ++i) {
      pulled.frame();
      calm.frame();
      // early on, the pull arrow is long
      if (i == 2 && std::string(engine) == "mujoco")
        pulled.screenshot((shot_dir() / "biped_stand_drag.png").string());
    }
    Eigen::Vector3d head = pulled.body_position("h_head");
    // towards the target: forward along x, well beyond what standing still does
    EXPECT_GT(head.x() - calm.body_position("h_head").x(), 0.05);
    EXPECT_LT((head - target).norm(), (head0 - target).norm() - 0.05);
    // letting go keeps the selection (a double-click on empty space clears it)
    pulled.release();
    EXPECT_GE(pulled.selected_body(), 0);
  }
}

// a double-click in the middle of the window picks the followed character
TEST_F(ViewerTest, SelectAtPicksTheCharacterAndEmptySpaceReleases) {
  LoadedScenario loaded = load_scenario(test::scenario_path("biped_stand.yaml"));
  ViewerOptions o = test_options();
  Viewer v(loaded, o);
  v.frame();
  // the follow camera looks at the pelvis, in the middle of the window
  EXPECT_TRUE(v.select_at(o.width / 2.0, o.height / 2.0));
  EXPECT_GE(v.selected_body(), 0);
  // the top left corner shows the sky
  EXPECT_FALSE(v.select_at(2, 2));
  EXPECT_EQ(v.selected_body(), -1);
}

// run, pause, scrub back: the state is the one shown at that time
TEST_F(ViewerTest, HistoryScrubRestoresARecordedTimeAndRunsOnFromIt) {
  LoadedScenario loaded = load_scenario(test::scenario_path("simbicon_walk.yaml"));
  ViewerOptions o = test_options();
  o.width = 1280;  // room for the panels: the screenshot shows the slider and the plots
  o.height = 800;
  Viewer v(loaded, o);
  std::vector<double> times;
  std::vector<Eigen::Vector3d> coms;
  for (int i = 0; i < 40; ++i) {
    v.frame();
    times.push_back(v.sim_time());
    coms.push_back(v.com());
  }
  EXPECT_GE(v.history_size(), 40);
  v.key(GLFW_KEY_SPACE);
  ASSERT_TRUE(v.paused());
  const int k = 12;
  EXPECT_EQ(v.scrub_to(times[k]), times[k]);
  EXPECT_EQ(v.sim_time(), times[k]);
  EXPECT_LT((v.com() - coms[k]).norm(), 1e-9);
  // scrubbing while paused changes nothing else: still paused over frames
  v.frame();
  EXPECT_EQ(v.sim_time(), times[k]);
  v.screenshot((shot_dir() / "simbicon_walk_scrubbed.png").string());
  EXPECT_TRUE(v.paused());
  // further back, then run on from there: later history is dropped
  v.scrub_to(times[3]);
  EXPECT_LT((v.com() - coms[3]).norm(), 1e-9);
  v.key(GLFW_KEY_SPACE);
  v.frame();
  EXPECT_GT(v.sim_time(), times[3]);
  EXPECT_LT(v.sim_time(), times[5]);
  EXPECT_LE(v.history_time(v.history_size() - 1), v.sim_time());
  EXPECT_LT(v.history_size(), 10);
  // and p replays from the start, with a fresh history
  v.key(GLFW_KEY_P);
  EXPECT_EQ(v.sim_time(), 0.0);
  EXPECT_EQ(v.history_size(), 1);
}

// g toggles the tracking ghost and k the controller markers: they are drawn where a
// controller gives them, and nothing changes where none does
TEST_F(ViewerTest, GhostAndMarkerKeysChangeThePictureOnlyWhereThereIsSomethingToDraw) {
  // the middle third of the window, between the panels (their check boxes change too)
  auto middle = [](const std::vector<unsigned char>& rgb, int w, int h) {
    std::vector<unsigned char> out;
    for (int y = 0; y < h; ++y)
      for (int x = w / 3; x < 2 * w / 3; ++x)
        for (int c = 0; c < 3; ++c) out.push_back(rgb[(static_cast<size_t>(y) * w + x) * 3 + c]);
    return out;
  };
  auto toggled_difference = [&](const std::string& scenario, int key) {
    ViewerOptions o = test_options();
    Viewer v(load_scenario(test::source_dir() + "/scenarios/" + scenario), o);
    for (int i = 0; i < 30; ++i) v.frame();
    v.key(GLFW_KEY_SPACE);  // paused: only the toggle differs between the two frames
    v.frame();
    std::vector<unsigned char> on = middle(frame_of(v), o.width, o.height);
    v.key(key);
    v.frame();
    v.screenshot((shot_dir() / (scenario + "_toggled.png")).string());
    return mean_abs_difference(on, middle(frame_of(v), o.width, o.height));
  };
  EXPECT_GT(toggled_difference("mocap_track.yaml", GLFW_KEY_G), 0.05);
  EXPECT_EQ(toggled_difference("pd_hold.yaml", GLFW_KEY_G), 0.0);
  EXPECT_GT(toggled_difference("simbicon_walk.yaml", GLFW_KEY_K), 0.05);
  EXPECT_EQ(toggled_difference("pd_hold.yaml", GLFW_KEY_K), 0.0);
}

// the live plots: joint torques (MuJoCo), the FSM state and the controller's signals
TEST_F(ViewerTest, LivePlotsShowTorquesAndTheFsmState) {
  LoadedScenario loaded = load_scenario(test::scenario_path("simbicon_walk.yaml"));
  Viewer v(loaded, test_options());
  EXPECT_TRUE(std::isnan(v.plot_value("no such plot")));
  int states_seen = 0, last_state = -1;
  double largest_rms = 0;
  for (int i = 0; i < 60; ++i) {
    v.frame();
    double rms = v.plot_value("joint torque RMS (N m)");
    double peak = v.plot_value("largest joint torque (N m)");
    ASSERT_TRUE(std::isfinite(rms));
    EXPECT_GE(peak + 1e-6, rms);
    largest_rms = std::max(largest_rms, rms);
    int state = static_cast<int>(v.plot_value("simbicon_state"));
    if (state != last_state) ++states_seen;
    last_state = state;
  }
  // a walking biped's joints carry tens of N m; the FSM goes through its states in a second
  EXPECT_GT(largest_rms, 5.0);
  EXPECT_GE(states_seen, 3);
  // the tracking error is plotted for the tracker
  Viewer mocap(load_scenario(test::scenario_path("mocap_track.yaml")), test_options());
  for (int i = 0; i < 5; ++i) mocap.frame();
  EXPECT_TRUE(std::isfinite(mocap.plot_value("mocap_joint_error_deg")));
  // on DART the torque plot shows the controllers' output
  ViewerOptions on_dart = test_options();
  on_dart.engine = "dart";
  Viewer dart(load_scenario(test::scenario_path("biped_stand.yaml")), on_dart);
  double dart_rms = 0;
  for (int i = 0; i < 10; ++i) {
    dart.frame();
    dart_rms = std::max(dart_rms, dart.plot_value("joint torque RMS (N m)"));
  }
  EXPECT_GT(dart_rms, 1.0);  // the standing biped's legs hold its weight
}

// the viewer reports a fall in its status line and keeps running
TEST_F(ViewerTest, ReportsAFallAndRunsOn) {
  LoadedScenario falls = load_scenario(test::scenario_path("biped_stand.yaml"));
  falls.controllers.resize(1);  // without the ankle strategy it falls
  Viewer v(falls, test_options());
  for (int i = 0; i < 60 * 6 && v.status().find("fell") == std::string::npos; ++i) v.frame();
  EXPECT_NE(v.status().find("fell at t="), std::string::npos) << v.status();
  const double t = v.sim_time();
  for (int i = 0; i < 120; ++i) v.frame();
  EXPECT_GT(v.sim_time(), t + 1.5);
  EXPECT_FALSE(v.paused());
}

// an LQR cost re-solves the DARE on a worker; the running controller is swapped later
TEST_F(ViewerTest, LqrCostChangeSwapsTheGainInLater) {
  LoadedScenario loaded = load_scenario(test::scenario_path("lqr_one_leg.yaml"));
  Viewer v(loaded, test_options());
  v.frame();
  const auto* lqr = dynamic_cast<const Lqr*>(&v.controller(0));
  ASSERT_NE(lqr, nullptr);
  Eigen::MatrixXd k0 = lqr->design().K;
  double cost0 = v.param_value(0, "balance_cost");
  v.set_param(0, "balance_cost", 4 * cost0);
  // pending: the old controller and its value are still in place
  EXPECT_TRUE(v.param_pending());
  EXPECT_EQ(v.param_value(0, "balance_cost"), cost0);
  EXPECT_EQ(&v.controller(0), static_cast<const Controller*>(lqr));
  // the frames go on while the worker solves; the swap happens in one of them
  for (int i = 0; i < 3000 && v.param_pending(); ++i) {
    v.frame();
    if (v.param_pending()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_FALSE(v.param_pending());
  EXPECT_EQ(v.param_value(0, "balance_cost"), 4 * cost0);
  const auto* swapped = dynamic_cast<const Lqr*>(&v.controller(0));
  ASSERT_NE(swapped, nullptr);
  ASSERT_EQ(swapped->design().K.rows(), k0.rows());
  EXPECT_GT((swapped->design().K - k0).norm(), 1e-3 * k0.norm());
  // and it still balances
  for (int i = 0; i < 30; ++i) v.frame();
  EXPECT_GT(v.com_height(), 0.8);
  // a rejected value is reported at once and changes nothing
  EXPECT_THROW(v.set_param(0, "no_such_cost", 1), InputError);
  EXPECT_FALSE(v.param_pending());
}

TEST_F(ViewerTest, RecordKeyWritesAnMp4AsLongAsTheSimulatedTimeRecorded) {
  if (!test::have_tool("ffmpeg") || !test::have_tool("ffprobe"))
    GTEST_SKIP() << "no ffmpeg/ffprobe";
  ViewerOptions o = test_options();
  o.capture_dir = (shot_dir() / "captures").string();
  fs::remove_all(o.capture_dir);
  o.record_fps = 30;
  LoadedScenario loaded = load_scenario(test::scenario_path("simbicon_walk.yaml"));
  loaded.scenario.name = "simbicon_walk";
  Viewer v(loaded, o);
  v.frame();
  v.frame();
  double t0 = v.sim_time();
  v.key(GLFW_KEY_R);
  ASSERT_TRUE(v.recording()) << v.status();
  const std::string mp4 = (fs::path(o.capture_dir) / "simbicon_walk_001.mp4").string();
  EXPECT_EQ(v.last_capture(), mp4);
  // a slow-motion factor does not change the recorded time: frames are 1/30 s apart
  v.key(GLFW_KEY_MINUS);
  for (int i = 0; i < 45; ++i) v.frame();
  double recorded = v.sim_time() - t0;
  v.key(GLFW_KEY_R);
  EXPECT_FALSE(v.recording());
  EXPECT_NE(v.status().find("wrote " + mp4 + ": 45 frames, 1.500 s"), std::string::npos)
      << v.status();
  EXPECT_NEAR(recorded, 1.5, 1e-3);
  std::string probe = test::run_capture(
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
      "stream=nb_read_frames,width,height,codec_name -show_entries format=duration -of "
      "default=noprint_wrappers=1 '" +
      mp4 + "'");
  EXPECT_NE(probe.find("codec_name=h264"), std::string::npos) << probe;
  EXPECT_NE(probe.find("nb_read_frames=45"), std::string::npos) << probe;
  EXPECT_NE(probe.find("width=640"), std::string::npos) << probe;
  auto at = probe.find("duration=");
  ASSERT_NE(at, std::string::npos) << probe;
  EXPECT_NEAR(std::stod(probe.substr(at + 9)), recorded, 0.04) << probe;

  // the PNG key: the frame shown, next to the video
  v.key(GLFW_KEY_I);
  const std::string png = (fs::path(o.capture_dir) / "simbicon_walk_001.png").string();
  EXPECT_EQ(v.last_capture(), png);
  EXPECT_TRUE(fs::exists(png));
  EXPECT_NE(v.status().find("wrote " + png), std::string::npos) << v.status();
  // a second recording does not overwrite the first
  v.key(GLFW_KEY_R);
  EXPECT_EQ(v.last_capture(), (fs::path(o.capture_dir) / "simbicon_walk_002.mp4").string());
  v.frame();
  v.key(GLFW_KEY_R);
  EXPECT_TRUE(fs::exists(mp4));
}

}  // namespace
}  // namespace stance
