// Mocap tracking on a bvh2mjcf character: kinematic follows the reference to the resampling
// error, assisted tracks with a measured helper impulse, the export reads back, and (with
// ../shared) the issue's numbers on mass_walk.bvh.
#include "control/mocap_tracker.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "engine/mujoco/mujoco_engine.h"
#include "engine/world_spec.h"
#include "math/rotations.h"
#include "model/bvh_to_mjcf.h"
#include "scenario/scenario.h"
#include "scenario/simulation.h"
#include "test_support.h"

namespace stance {
namespace {

std::string shared_bvh(const std::string& file) {
  return std::string(STANCE_SOURCE_DIR) + "/../shared/data/bvh/" + file;
}

struct ClipFiles {
  std::string bvh, xml;
};

// the clip and its character as files; first_frame sets the start keyframe
ClipFiles make_files(const BvhClip& clip, const std::string& tag, bool whole_clip_ground = false) {
  ClipFiles s;
  s.bvh = test::write_temp_file(tag + ".bvh", format_bvh(clip));
  BvhCharacterOptions o;
  o.reference.align_whole_clip = whole_clip_ground;
  s.xml = test::write_temp_file(tag + ".xml", make_bvh_character(clip, o).mjcf);
  return s;
}

std::unique_ptr<Engine> start_engine(const std::string& xml) {
  WorldSpec spec;
  spec.models.push_back({xml});
  auto engine = make_mujoco_engine(spec);
  auto* mj = dynamic_cast<MujocoEngine*>(engine.get());
  mj_resetDataKeyframe(mj->model(), mj->data(), mj_name2id(mj->model(), mjOBJ_KEY, "start"));
  mj->invalidate();
  engine->forward();
  return engine;
}

struct Outcome {
  double mean_deg = 0, max_deg = 0, helper = 0, fall_time = -1, root_err = 0;
  nlohmann::json metrics;
  std::unique_ptr<ControllerState> state;  // the run's, at its end
};

Outcome track(const MocapTracker& tracker, Engine& engine, double seconds) {
  Outcome o;
  o.state = tracker.make_state(engine);
  ControlOutput out;
  out.resize(engine.nv(), engine.nu());
  const long steps = std::lround(seconds / engine.timestep());
  for (long k = 0; k < steps; ++k) {
    engine.forward();
    out.clear();
    tracker.compute(*o.state, engine, out);
    engine.set_generalized_forces(out.tau);
    engine.step();
    if (!engine.state_is_finite()) break;
  }
  tracker.add_metrics(*o.state, o.metrics);
  const MocapTracker::State& s = MocapTracker::cast(*o.state);
  o.mean_deg = s.mean_joint_error_deg();
  o.max_deg = s.max_joint_error_deg();
  o.helper = s.helper_impulse_ns();
  const auto& m = o.metrics["mocap"];
  if (!m["root_fall_time_s"].is_null()) o.fall_time = m["root_fall_time_s"];
  o.root_err = m["mean_root_error_m"];
  return o;
}

TEST(MocapTracker, KinematicFollowsTheReference) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_kin");
  auto engine = start_engine(s.xml);
  MocapTrackerParams p;
  p.bvh = s.bvh;
  p.mode = "kinematic";
  MocapTracker tracker(p, {}, *engine);
  Outcome o = track(tracker, *engine, 2.5);  // more than two loops
  EXPECT_LT(o.mean_deg, 0.5);
  EXPECT_LT(o.root_err, 0.01);
  EXPECT_LT(o.fall_time, 0);
}

TEST(MocapTracker, AssistedTracksWithAMeasuredHelper) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_assist");
  auto engine = start_engine(s.xml);
  MocapTrackerParams p;
  p.bvh = s.bvh;
  p.mode = "assisted";
  MocapTracker tracker(p, {}, *engine);
  Outcome o = track(tracker, *engine, 2.5);
  EXPECT_LT(o.mean_deg, 5.0);
  EXPECT_GT(o.helper, 0.0);
  EXPECT_LT(o.fall_time, 0);
  // without any root help (and without balance) the same gains do not keep the root on track
  p.mode = "free";
  p.balance = false;
  auto engine2 = start_engine(s.xml);
  MocapTracker loose(p, {}, *engine2);
  Outcome f = track(loose, *engine2, 2.5);
  EXPECT_EQ(f.helper, 0.0);
  EXPECT_GT(f.root_err, o.root_err);
}

TEST(MocapTracker, ExportedMotionReadsBack) {
  BvhClip clip = make_synthetic_walk_clip();
  ClipFiles s = make_files(clip, "track_export");
  auto engine = start_engine(s.xml);
  MocapTrackerParams p;
  p.bvh = s.bvh;
  p.mode = "kinematic";
  p.export_bvh = "tracked.bvh";
  MocapTracker tracker(p, {}, *engine);
  Outcome o = track(tracker, *engine, 1.0);
  std::string dir = (std::filesystem::temp_directory_path() / "stance_tests" / "export").string();
  std::filesystem::create_directories(dir);
  tracker.write_outputs(*o.state, dir);
  BvhClip back = read_bvh(dir + "/tracked.bvh");
  EXPECT_EQ(back.joint_count(), clip.joint_count());
  EXPECT_NEAR(back.frame_time_s, clip.frame_time_s, 1e-9);
  EXPECT_NEAR(back.frame_count, 1.0 / clip.frame_time_s, 1.5);
  // kinematic tracking: the exported frames are the clip's own, up to the tracking error
  for (int f : {1, 20, 45}) {
    for (int j = 1; j < clip.joint_count(); ++j)
      EXPECT_LT(geodesic_angle(back.rotation(f, j), clip.rotation(f, j)), 2.0 * M_PI / 180)
          << "frame " << f << " joint " << clip.joints[j].name;
    // the root moves like the clip's, up to the constant ground-alignment shift (cm)
    Eigen::Vector3d shift = back.translation(1, 0) - clip.translation(1, 0);
    EXPECT_LT((back.translation(f, 0) - clip.translation(f, 0) - shift).norm(), 0.5);
  }
}

TEST(MocapTracker, RejectsBadInput) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_bad");
  auto engine = start_engine(s.xml);
  MocapTrackerParams p;
  EXPECT_THROW(MocapTracker(p, {}, *engine), InputError);  // no clip
  p.bvh = s.bvh;
  p.mode = "hover";
  EXPECT_THROW(MocapTracker(p, {}, *engine), InputError);
  p.mode = "assisted";
  p.kp_joints["NoSuchJoint"] = 10;
  EXPECT_THROW(MocapTracker(p, {}, *engine), InputError);
  // a model that is not the clip's character
  WorldSpec spec;
  spec.models.push_back({test::write_temp_file("chain.xml", test::kFloatingChainMjcf)});
  auto other = make_mujoco_engine(spec);
  MocapTrackerParams q;
  q.bvh = s.bvh;
  EXPECT_THROW(MocapTracker(q, {}, *other), InputError);
}

// the Coros virtual force: a force at the COM reacted at a foot is internal (no root share) and
// does the same virtual work as the two forces it stands for
TEST(MocapTracker, ComSupportTorqueIsInternal) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_support");
  auto engine = start_engine(s.xml);
  const int nv = engine->nv();
  const int foot = engine->body_index("LeftFoot");
  ASSERT_GE(foot, 0);
  Eigen::MatrixXd jac_com(3, nv), scratch(3, nv), jac_foot(3, nv), none(3, 0);
  engine->com_jacobian(jac_com);
  const Eigen::Vector3d force(30, -20, 650);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(nv);
  add_com_support_torque(*engine, foot, force, jac_com, scratch, tau);
  const int root = engine->joint(engine->joint_index("root")).dof_adr;
  EXPECT_LT(tau.segment<6>(root).norm(), 1e-9 * force.norm());
  EXPECT_GT(tau.norm(), 10.0);
  // virtual work: tau . v == F . (v_com - v_foot point at the COM) for any v
  engine->point_jacobian(foot, engine->com(), jac_foot, none);
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(nv, -1, 1);
  EXPECT_NEAR(tau.dot(v), force.dot((jac_com - jac_foot) * v), 1e-9 * force.norm());
}

// free mode: carrying the weight through the stance leg keeps the character closer to the clip
TEST(MocapTracker, GravityCompensationReducesSag) {
  ClipFiles s = make_files(make_synthetic_walk_clip(), "track_gravity");
  Outcome o[2];
  for (int with = 0; with < 2; ++with) {
    auto engine = start_engine(s.xml);
    MocapTrackerParams p;
    p.bvh = s.bvh;
    p.mode = "free";
    p.gravity_compensation = with;
    MocapTracker tracker(p, {}, *engine);
    o[with] = track(tracker, *engine, 0.5);
    EXPECT_LT(o[with].fall_time, 0);
  }
  EXPECT_LT(o[1].mean_deg, o[0].mean_deg);
  EXPECT_LT(o[1].root_err, o[0].root_err);
}

// the issue's acceptance numbers on the MASS walk, looped for 10 s
TEST(MocapTracker, MassWalkTenSeconds) {
  const std::string path = shared_bvh("mass_walk.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  for (const char* mode : {"kinematic", "assisted"}) {
    SCOPED_TRACE(mode);
    // kinematic: the clip's feet dip below their start height, and the floor would push them
    // back; align the lowest point of the whole clip instead
    bool kinematic = std::string(mode) == "kinematic";
    ClipFiles s = make_files(read_bvh(path), std::string("mass_walk_") + mode, kinematic);
    auto engine = start_engine(s.xml);
    MocapTrackerParams p;
    p.bvh = path;
    p.mode = mode;
    if (kinematic) p.ground = "clip";
    MocapTracker tracker(p, {}, *engine);
    Outcome o = track(tracker, *engine, 10.0);
    std::cout << mode << ": " << o.metrics.dump() << "\n";
    EXPECT_LT(o.mean_deg, std::string(mode) == "kinematic" ? 0.5 : 5.0);
    EXPECT_LT(o.fall_time, 0);
    if (std::string(mode) == "assisted") EXPECT_GT(o.helper, 0);
  }
}

// issue 7's free-mode bar, robustly: the MASS walk looped for 10 s with no root help stays up
// for at least 5 s (the runner's COM test and the root above half its reference height) with a
// mean joint error under 10 degrees, at the settings in docs/mocap.md ("Free mode on mass_walk")
// and with kp and kd 15% off or a 1 ms timestep. The search scored these neighbours (among 12);
// the docs give the worst case over neighbours it did not score.
constexpr const char* kMassWalkFreeYaml = R"(
name: mocap_mass_walk_free
engine: mujoco
model:
  - file: set-by-the-test
keyframe: start
duration: 10
fall:
  com_height_fraction: 0.6
controllers:
  - type: mocap_tracker
    bvh: set-by-the-test
    mode: free
    loop: true
    kp: 3000
    kd: 219
    contact_stance: true
    stance_hip_world_weight: 0.6
    swing_foot_world: true
    cd_sagittal: 1.124
    cv_sagittal: 0.04
    cd_coronal: 0.88
    cv_coronal: 0.16
    ankle_cd_sagittal: 0.23
    ankle_cv_sagittal: 0.05
    ankle_cd_coronal: 0.986
    ankle_cv_coronal: 0.16
    swing_heading_gain: 0.2
    path_gain: 0.012
    gravity_compensation: 0.5
    root_force_kp: 715
    root_force_kd: 70
)";

struct FreeVariant {
  const char* name;
  double gain_scale, timestep;  // timestep 0: the scenario's
  double placement_scale = 1;   // the swing-thigh feedback gains cd and cv, both planes
};
constexpr FreeVariant kFreeVariants[] = {{"as tuned", 1.0, 0},
                                         {"kp kd x0.85", 0.85, 0},
                                         {"kp kd x1.15", 1.15, 0},
                                         {"dt 1 ms", 1.0, 1e-3}};

// the run stays up for min_up_s (5 s: the issue's bar) with a mean joint error under 10 degrees
// and no root help
void expect_walks_free(YAML::Node doc, const FreeVariant& variant, const std::string& source,
                       double min_up_s = 5.0) {
  SCOPED_TRACE(variant.name);
  YAML::Node c = doc["controllers"][0];
  c["kp"] = c["kp"].as<double>() * variant.gain_scale;
  c["kd"] = c["kd"].as<double>() * variant.gain_scale;
  for (const char* key : {"cd_sagittal", "cv_sagittal", "cd_coronal", "cv_coronal"})
    c[key] = c[key].as<double>() * variant.placement_scale;
  if (variant.timestep > 0) doc["timestep"] = variant.timestep;
  RunOptions opt;
  opt.quiet = true;
  RunResult r =
      Simulation(parse_scenario(doc, source, test::source_dir() + "/scenarios"), opt).run();
  const nlohmann::json& m = r.metrics["mocap"];
  std::cout << variant.name << ": fell " << r.fell << " at " << r.fall_time.value_or(-1)
            << ", mean error " << m["mean_joint_error_deg"] << " deg, root error "
            << m["mean_root_error_m"] << " m\n";
  EXPECT_FALSE(r.diverged);
  if (r.fell) EXPECT_GE(*r.fall_time, min_up_s);
  if (!m["root_fall_time_s"].is_null()) EXPECT_GE(m["root_fall_time_s"].get<double>(), min_up_s);
  EXPECT_LT(m["mean_joint_error_deg"].get<double>(), 10.0);
  EXPECT_EQ(m["helper_impulse_Ns"].get<double>(), 0.0);
}

TEST(MocapTracker, FreeModeMassWalkStaysUpOverANeighbourhood) {
  const std::string path = shared_bvh("mass_walk.bvh");
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no ../shared data";
  ClipFiles s = make_files(read_bvh(path), "mass_walk_free");
  for (const FreeVariant& variant : kFreeVariants) {
    YAML::Node doc = YAML::Load(kMassWalkFreeYaml);
    doc["model"][0]["file"] = s.xml;
    doc["controllers"][0]["bvh"] = path;
    expect_walks_free(doc, variant, "mass_walk_free");
  }
}

// the shipped free-mode scenario (synthetic clip) walks its whole 10 s at its settings and at
// the six neighbours `stance tune` scored it on (scenarios/mocap_track_free.yaml)
TEST(MocapTracker, FreeScenarioStaysUpOverANeighbourhood) {
  const std::string file = test::source_dir() + "/scenarios/mocap_track_free.yaml";
  constexpr FreeVariant kScored[] = {
      {"as tuned", 1.0, 0},           {"kp kd x0.8", 0.8, 0},     {"kp kd x1.2", 1.2, 0},
      {"dt 1 ms", 1.0, 1e-3},         {"dt 1.5 ms", 1.0, 1.5e-3}, {"placement x0.8", 1.0, 0, 0.8},
      {"placement x1.2", 1.0, 0, 1.2}};
  for (const FreeVariant& variant : kScored) {
    YAML::Node doc = YAML::LoadFile(file);
    ASSERT_EQ(doc["duration"].as<double>(), 10.0);
    expect_walks_free(doc, variant, file, 10.0);
  }
}

}  // namespace
}  // namespace stance
