// The robust tuner: scores, neighbours, argument errors, and a real search on biped_stand that
// starts from gains too soft to stand and finds a point that stands on its neighbour too.
#include "batch/tune.h"

#include <gtest/gtest.h>

#include <yaml-cpp/yaml.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "test_support.h"

namespace stance {
namespace {

// the message of the InputError thrown by f, or "" when none is thrown
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

RunResult result(bool fell, double fall_time, double metric) {
  RunResult r;
  r.fell = fell;
  if (fell) r.fall_time = fall_time;
  r.sim_time = 2;
  r.metrics["mocap"]["mean_joint_error_deg"] = metric;
  return r;
}

TEST(Tune, RobustScoreIsTheWorstRun) {
  const std::string metric = "mocap.mean_joint_error_deg";
  TuneCandidate c;
  c.runs.push_back(score_run(result(false, 0, 3.0), 2.0, metric, 100));   // nominal: stays up
  c.runs.push_back(score_run(result(true, 1.5, 2.0), 2.0, metric, 100));  // falls at 1.5 s
  c.runs.push_back(score_run(result(false, 0, 5.0), 2.0, metric, 100));   // up, larger error
  EXPECT_DOUBLE_EQ(c.runs[0].score, 3.0);
  EXPECT_DOUBLE_EQ(c.runs[1].score, 100 * 0.5 + 2.0);
  EXPECT_DOUBLE_EQ(c.runs[2].score, 5.0);
  aggregate_runs(c);
  EXPECT_DOUBLE_EQ(c.robust_score, 52.0);
  EXPECT_DOUBLE_EQ(c.worst_time_up, 1.5);
  EXPECT_DOUBLE_EQ(c.mean_metric, (3.0 + 2.0 + 5.0) / 3);
  EXPECT_EQ(c.failed_runs, 0);

  // a diverged run counts as down at t = 0 and is reported
  RunResult diverged = result(false, 0, 1.0);
  diverged.diverged = true;
  diverged.divergence = "NaN at t=0.3";
  c.runs.push_back(score_run(diverged, 2.0, metric, 100));
  EXPECT_DOUBLE_EQ(c.runs.back().time_up, 0);
  EXPECT_NE(c.runs.back().error.find("NaN at t=0.3"), std::string::npos);
  c.runs.push_back(failed_run("boom", 2.0, 100));
  aggregate_runs(c);
  EXPECT_DOUBLE_EQ(c.robust_score, 200.0);
  EXPECT_DOUBLE_EQ(c.worst_time_up, 0);
  EXPECT_EQ(c.failed_runs, 2);

  // without a metric, only the time up counts
  EXPECT_DOUBLE_EQ(score_run(result(true, 0.5, 9.0), 2.0, "", 10).score, 15.0);
  EXPECT_EQ(metric_at(result(false, 0, 4.0).metrics, metric), 4.0);
  EXPECT_FALSE(metric_at(result(false, 0, 4.0).metrics, "mocap.nope"));
  // weighted sums of metrics
  nlohmann::json m = {{"a", {{"x", 1.5}}}, {"b", 4.0}};
  EXPECT_DOUBLE_EQ(*metric_at(m, "a.x+2*b"), 9.5);
  EXPECT_DOUBLE_EQ(*metric_at(m, "0.5*a.x+b+b"), 8.75);
  EXPECT_FALSE(metric_at(m, "a.x+c"));
  EXPECT_FALSE(metric_at(m, "two*b"));
  // one-sided penalties: a floor on a speed, a ceiling on an error
  EXPECT_DOUBLE_EQ(*metric_at(m, "below(b,5.5)"), 1.5);
  EXPECT_DOUBLE_EQ(*metric_at(m, "below(b,3)"), 0.0);
  EXPECT_DOUBLE_EQ(*metric_at(m, "above(a.x,1)"), 0.5);
  EXPECT_DOUBLE_EQ(*metric_at(m, "above(a.x,2)"), 0.0);
  EXPECT_DOUBLE_EQ(*metric_at(m, "-20*b+1000*below(b,4.25)"), -80 + 250.0);
  EXPECT_FALSE(metric_at(m, "below(b)"));
  EXPECT_FALSE(metric_at(m, "below(b,x)"));
  EXPECT_FALSE(metric_at(m, "below(c,1)"));
}

TEST(Tune, MultiplicativeNeighbourScalesTheCurrentValue) {
  YAML::Node doc =
      YAML::Load("timestep: 0.002\ncontrollers:\n  - {type: stable_pd, kp: 400, kd: 40}\n");
  Neighbour n = parse_neighbour("controllers.0.kp*=0.85, controllers.0.kd*=1.5,timestep=0.001");
  ASSERT_EQ(n.overrides.size(), 3u);
  EXPECT_TRUE(n.overrides[0].multiply);
  EXPECT_FALSE(n.overrides[2].multiply);
  YAML::Node copy = YAML::Clone(doc);
  apply_neighbour(copy, n);
  EXPECT_DOUBLE_EQ(*yaml_number_at(copy, "controllers.0.kp"), 340);
  EXPECT_DOUBLE_EQ(*yaml_number_at(copy, "controllers.0.kd"), 60);
  EXPECT_DOUBLE_EQ(*yaml_number_at(copy, "timestep"), 0.001);
  // the original is untouched, and a changed value is what gets multiplied
  EXPECT_DOUBLE_EQ(*yaml_number_at(doc, "controllers.0.kp"), 400);
  YAML::Node tuned = YAML::Clone(doc);
  tuned["controllers"][0]["kp"] = 100;
  apply_neighbour(tuned, parse_neighbour("controllers.0.kp*=0.85"));
  EXPECT_DOUBLE_EQ(*yaml_number_at(tuned, "controllers.0.kp"), 85);
  // lists stay whole
  EXPECT_EQ(parse_neighbour("gravity=[0, 0, -9],timestep=0.001").overrides.size(), 2u);
  // nothing to multiply: the neighbour is named
  std::string e = error_of([&] {
    YAML::Node d = YAML::Clone(doc);
    apply_neighbour(d, parse_neighbour("controllers.0.ki*=2"));
  });
  EXPECT_NE(e.find("--neighbour 'controllers.0.ki*=2'"), std::string::npos) << e;
  EXPECT_FALSE(yaml_number_at(doc, "controllers.0.ki"));
  EXPECT_FALSE(yaml_number_at(doc, "controllers.3.kp"));
}

TEST(Tune, ParsingErrorsNameTheArgument) {
  TuneParam p = parse_tune_param("controllers.0.kp=20:1000:log");
  EXPECT_EQ(p.key, "controllers.0.kp");
  EXPECT_EQ(p.lo, 20);
  EXPECT_EQ(p.hi, 1000);
  EXPECT_TRUE(p.log);
  EXPECT_FALSE(parse_tune_param("a.b=-1:2.5").log);
  for (const char* bad : {"controllers.0.kp", "kp=1", "kp=1:2:3:4", "kp=a:2", "kp=1:b", "kp=2:1",
                          "kp=1:1", "kp=0:1:log", "kp=-1:1:log", "kp=1:2:lin", "=1:2"}) {
    std::string e = error_of([&] { parse_tune_param(bad); });
    EXPECT_NE(e.find(std::string("--param '") + bad + "'"), std::string::npos) << bad << ": " << e;
  }
  for (const char* bad : {"", "kp", "kp*=x", "kp*=", "kp=", "*=2", "a*=2,,b=1"}) {
    std::string e = error_of([&] { parse_neighbour(bad); });
    EXPECT_NE(e.find(std::string("--neighbour '") + bad + "'"), std::string::npos)
        << bad << ": " << e;
  }
}

TuneOptions stand_options() {
  TuneOptions o;
  o.scenario = test::scenario_path("biped_stand.yaml");
  // far too soft to stand: falls within a second
  o.sets = {"controllers.0.kp=40", "controllers.0.kd=4"};
  o.params = {parse_tune_param("controllers.0.kp=20:1000:log"),
              parse_tune_param("controllers.0.kd=2:100:log")};
  o.neighbours = {parse_neighbour("controllers.0.kp*=0.8,controllers.0.kd*=0.8")};
  o.duration = 1.5;
  o.budget = 12;
  o.population = 4;
  o.seed = 7;
  o.metric = "com_displacement_m";
  return o;
}

TEST(Tune, BadKeysAndMetricFailBeforeTheSearch) {
  TuneOptions o = stand_options();
  o.params[1] = parse_tune_param("controllers.0.kdd=1:2");
  std::string e = error_of([&] { run_tune(o); });
  EXPECT_NE(e.find("--param 'controllers.0.kdd=1:2'"), std::string::npos) << e;
  o = stand_options();
  o.neighbours.push_back(parse_neighbour("controllers.0.kq*=2"));
  e = error_of([&] { run_tune(o); });
  EXPECT_NE(e.find("--neighbour 'controllers.0.kq*=2'"), std::string::npos) << e;
  o = stand_options();
  o.metric = "com_displacment_m";
  o.duration = 0.2;
  e = error_of([&] { run_tune(o); });
  EXPECT_NE(e.find("--metric 'com_displacment_m'"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'com_displacement_m'"), std::string::npos) << e;
}

TEST(Tune, FindsGainsThatStandFromOnesThatFall) {
  TuneOptions o = stand_options();
  std::string csv[2], best[2];
  for (int threads : {1, 2}) {
    o.threads = threads;
    int calls = 0;
    TuneResult r = run_tune(o, [&](const TuneResult&, int) { ++calls; });
    EXPECT_EQ(calls, 3);
    ASSERT_EQ(r.candidates.size(), 12u);
    const TuneCandidate& start = r.candidates.front();
    const TuneCandidate& b = r.candidates[r.best];
    // the start is the scenario's value after --set
    EXPECT_EQ(start.values, (std::vector<double>{40, 4}));
    ASSERT_EQ(start.runs.size(), 2u);
    EXPECT_LT(start.worst_time_up, 1.0);
    // the best stays up for the whole run, nominal and neighbour, and scores better
    EXPECT_DOUBLE_EQ(b.worst_time_up, 1.5);
    EXPECT_LT(b.robust_score, start.robust_score);
    EXPECT_LT(b.robust_score, 1.0);  // no fall penalty: only the COM displacement
    EXPECT_EQ(b.failed_runs, 0);
    for (const auto& c : r.candidates)
      for (size_t k = 0; k < c.values.size(); ++k) {
        EXPECT_GE(c.values[k], o.params[k].lo);
        EXPECT_LE(c.values[k], o.params[k].hi);
      }
    auto dir = std::filesystem::temp_directory_path() / "stance_tests" /
               ("tune_threads_" + std::to_string(threads));
    write_tune_outputs(dir.string(), o, r);
    csv[threads - 1] = test::read_file(dir / "tune.csv");
    best[threads - 1] = test::read_file(dir / "best.yaml");
    // best.yaml is a map of key path -> value that reads back to the best point
    YAML::Node y = YAML::LoadFile((dir / "best.yaml").string());
    EXPECT_DOUBLE_EQ(y["controllers.0.kp"].as<double>(), b.values[0]);
    EXPECT_NE(best[threads - 1].find("--set controllers.0.kp="), std::string::npos);
    // best_scenario.yaml is the scenario with the best point in it
    YAML::Node scn = YAML::LoadFile((dir / "best_scenario.yaml").string());
    EXPECT_DOUBLE_EQ(scn["controllers"][0]["kd"].as<double>(), b.values[1]);
  }
  EXPECT_EQ(csv[0].substr(0, csv[0].find('\n')),
            "generation,index,controllers.0.kp,controllers.0.kd,robust_score,worst_time_up_s,"
            "mean_metric,failed_runs");
  EXPECT_EQ(csv[0], csv[1]);
  EXPECT_EQ(best[0], best[1]);
}

// CMA-ES from the same soft start: it finds gains that stand on the nominal run and the
// neighbour, and its tune.csv does not depend on the thread count
TEST(Tune, FindsGainsThatStandWithCmaes) {
  TuneOptions o = stand_options();
  o.method = "cmaes";
  std::string csv[2];
  for (int threads : {1, 2}) {
    o.threads = threads;
    TuneResult r = run_tune(o);
    ASSERT_EQ(r.candidates.size(), 12u);
    const TuneCandidate& start = r.candidates.front();
    const TuneCandidate& b = r.candidates[r.best];
    EXPECT_EQ(start.values, (std::vector<double>{40, 4}));
    EXPECT_LT(start.worst_time_up, 1.0);
    EXPECT_DOUBLE_EQ(b.worst_time_up, 1.5);
    EXPECT_LT(b.robust_score, 1.0);
    for (const auto& c : r.candidates)
      for (size_t k = 0; k < c.values.size(); ++k) {
        EXPECT_GE(c.values[k], o.params[k].lo);
        EXPECT_LE(c.values[k], o.params[k].hi);
      }
    auto dir = std::filesystem::temp_directory_path() / "stance_tests" /
               ("tune_cmaes_threads_" + std::to_string(threads));
    write_tune_outputs(dir.string(), o, r);
    csv[threads - 1] = test::read_file(dir / "tune.csv");
  }
  EXPECT_EQ(csv[0], csv[1]);
}

// the arm of pd_hold, scored on its tracking error: cheap runs for the resume tests
TuneOptions arm_options(const std::string& method) {
  TuneOptions o;
  o.scenario = test::scenario_path("pd_hold.yaml");
  o.params = {parse_tune_param("controllers.0.kp=5:200:log"),
              parse_tune_param("controllers.0.kd=0.1:20:log")};
  o.neighbours = {parse_neighbour("controllers.0.kp*=0.8")};
  o.duration = 0.3;
  o.budget = 14;  // the last generation is cut short by the budget
  o.population = 4;
  o.seed = 3;
  o.threads = 2;
  o.metric = "com_displacement_m+0.01*torque_rms";
  o.method = method;
  return o;
}

// --engine sets the scenario's engine; a neighbour "engine=dart" still runs on DART (it was
// overridden by --engine and ran on MuJoCo, so a search "robust on both engines" was not)
TEST(Tune, AnEngineNeighbourRunsOnItsEngineWhateverTheEngineOption) {
  auto scores = [](const std::string& engine, const std::string& neighbour) {
    TuneOptions o = arm_options("cmaes");
    o.budget = 4;
    o.engine = engine;
    o.neighbours = {parse_neighbour(neighbour)};
    std::vector<double> out;
    for (const TuneCandidate& c : run_tune(o).candidates) out.push_back(c.mean_metric);
    return out;
  };
  const std::vector<double> dart_neighbour = scores("mujoco", "engine=dart");
  EXPECT_EQ(dart_neighbour, scores("", "engine=dart"));
  EXPECT_NE(dart_neighbour, scores("mujoco", "engine=mujoco"));
}

std::string outputs_of(const TuneOptions& o, const TuneResult& r, const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / "stance_tests" / name;
  write_tune_outputs(dir.string(), o, r);
  return test::read_file(dir / "tune.csv") + test::read_file(dir / "best.yaml") +
         test::read_file(dir / "best_scenario.yaml");
}

// stopped after each generation in turn and resumed from its checkpoint (as read back from
// text), a search writes exactly the files of an uninterrupted one, for both methods
TEST(Tune, ResumedSearchEqualsUninterrupted) {
  for (const std::string method : {"cem", "cmaes"}) {
    TuneOptions o = arm_options(method);
    TuneResult whole = run_tune(o);
    ASSERT_EQ(whole.generations, 4);
    ASSERT_EQ(whole.finished_generations, 4);
    EXPECT_FALSE(whole.interrupted);
    const std::string expected = outputs_of(o, whole, "tune_whole_" + method);
    for (int stop_after : {1, 3}) {
      std::atomic<bool> stop{false};
      o.interrupt = &stop;
      TuneResult part = run_tune(o, [&](const TuneResult&, int g) {
        if (g + 1 == stop_after) stop = true;
      });
      EXPECT_TRUE(part.interrupted);
      ASSERT_EQ(part.finished_generations, stop_after);
      EXPECT_EQ(part.candidates.size(), static_cast<size_t>(4 * stop_after));
      nlohmann::json checkpoint = nlohmann::json::parse(part.checkpoint.dump());
      o.interrupt = nullptr;
      o.threads = 1;  // threads are not part of the search: a resume may change them
      int calls = 0;
      TuneResult resumed = run_tune(
          o, [&](const TuneResult&, int) { ++calls; }, &checkpoint);
      o.threads = 2;
      EXPECT_EQ(calls, 4 - stop_after);
      EXPECT_FALSE(resumed.interrupted);
      EXPECT_EQ(outputs_of(o, resumed, "tune_resumed_" + method), expected)
          << method << " stopped after generation " << stop_after;
      EXPECT_EQ(resumed.checkpoint, whole.checkpoint) << method;
    }
  }
}

TEST(Tune, ResumeRefusesOtherOptions) {
  TuneOptions o = arm_options("cmaes");
  o.budget = 4;
  TuneResult r = run_tune(o);
  TuneOptions other = o;
  other.seed = 4;
  std::string e = error_of([&] { check_tune_resume(other, r.checkpoint, "--resume out/t"); });
  EXPECT_EQ(e, "--resume out/t: option 'seed' was 3 in the interrupted run, now 4");
  other = o;
  other.method = "cem";
  e = error_of([&] { run_tune(other, {}, &r.checkpoint); });
  EXPECT_EQ(e, "--resume: option 'method' was \"cmaes\" in the interrupted run, now \"cem\"");
  other = o;
  other.threads = 1;  // not an option of the search
  EXPECT_EQ(error_of([&] { check_tune_resume(other, r.checkpoint, "x"); }), "");
  e = error_of([&] { check_tune_resume(o, nlohmann::json{{"cells", 1}}, "--resume d"); });
  EXPECT_EQ(e, "--resume d: not a stance tune resume file");
  // a format that is not a string was an internal error (nlohmann's type_error.302)
  const nlohmann::json numbered = {{"format", 1}, {"options", nlohmann::json::object()}};
  e = error_of([&] { check_tune_resume(o, numbered, "--resume d"); });
  EXPECT_EQ(e, "--resume d: not a stance tune resume file");
  // a damaged checkpoint is named, not a crash
  nlohmann::json broken = r.checkpoint;
  broken["search"].erase("rng");
  e = error_of([&] { run_tune(o, {}, &broken); });
  EXPECT_EQ(e.rfind("--resume: not a stance tune resume file (", 0), 0u) << e;
  broken = r.checkpoint;
  broken["finished_generations"] = 0;
  e = error_of([&] { run_tune(o, {}, &broken); });
  EXPECT_EQ(e, "--resume: not a stance tune resume file (no finished generation)");
  // bad methods and populations are named
  other = o;
  other.method = "pso";
  EXPECT_EQ(error_of([&] { run_tune(other); }), "--method 'pso': expected cem or cmaes");
  other = o;
  other.population = 1;
  EXPECT_EQ(error_of([&] { run_tune(other); }),
            "--population 1: CMA-ES needs at least 2 candidates per generation");
}

}  // namespace
}  // namespace stance
