// Every controller in the registry steps without allocating: after its first compute(), no
// further call may reach the heap. Counts global operator new (the C++ containers) and malloc,
// calloc and realloc (Eigen's dynamic matrices allocate with malloc, not new), replaced in this
// test binary and forwarded to glibc. A controller is built on the first scenario in
// scenarios/ that can host it: with that scenario's own parameters when it uses the type, with
// the defaults otherwise.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <new>
#include <set>

#include "control/controller.h"
#include "engine/engine.h"
#include "sim/scenario.h"
#include "sim/simulation.h"
#include "test_support.h"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_news{0};
std::atomic<long> g_mallocs{0};
}  // namespace

extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t n, size_t size);
void* __libc_realloc(void* p, size_t size);
void __libc_free(void* p);

void* malloc(size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_malloc(size);
}
void* calloc(size_t n, size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_calloc(n, size);
}
void* realloc(void* p, size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_realloc(p, size);
}
void free(void* p) {
  __libc_free(p);
}
}

void* operator new(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) ++g_news;
  if (void* p = __libc_malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  return operator new(size);
}
void operator delete(void* p) noexcept {
  __libc_free(p);
}
void operator delete[](void* p) noexcept {
  __libc_free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  __libc_free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  __libc_free(p);
}

namespace stance {
namespace {

struct Counts {
  long news = 0, mallocs = 0;
};

// the heap calls made by fn
template <class Fn>
Counts count_allocations(Fn&& fn) {
  g_news = 0;
  g_mallocs = 0;
  g_counting = true;
  fn();
  g_counting = false;
  return {g_news.load(), g_mallocs.load()};
}

// keeps a computed value from being optimised away
template <class T>
void benchmark_guard(const T& value) {
  volatile double sink = value[0];
  (void)sink;
}

TEST(AllocationCounter, SeesNewAndEigenAllocations) {
  Counts c = count_allocations([] {
    auto* v = new std::vector<int>(100);
    delete v;
  });
  EXPECT_GE(c.news, 1);
  c = count_allocations([] {
    Eigen::VectorXd x = Eigen::VectorXd::Random(50);
    Eigen::VectorXd y = x * 2;  // a heap temporary for the result
    EXPECT_EQ(y.size(), 50);
  });
  EXPECT_GE(c.mallocs, 1);
  Eigen::VectorXd a = Eigen::VectorXd::Zero(50), b = Eigen::VectorXd::Ones(50);
  c = count_allocations([&] { a.noalias() += 2 * b; });
  EXPECT_EQ(c.news + c.mallocs, 0);
}

struct Host {
  std::string scenario;
  YAML::Node node;
};

// controllers whose authors made them allocation-free; the test fails if one cannot be built
const std::set<std::string> kRequired = {
    "lqr",           "stable_pd",     "pd", "ankle_strategy", "hold_pose_pd", "control_noise",
    "mocap_tracker", "mocap_retarget"};

std::vector<std::string> scenario_files() {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(test::source_dir() + "/scenarios"))
    if (e.path().extension() == ".yaml") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ControllerAllocations, NoneAfterTheFirstCompute) {
  const auto files = scenario_files();
  std::set<std::string> tested;
  for (const ControllerType& type : controller_registry()) {
    // hosts: scenarios that use the type (their parameters), then the rest (defaults)
    // (built by push_back only: assigning a YAML::Node, as vector::insert does when it shifts
    // elements, overwrites the node it refers to instead of rebinding)
    std::vector<Host> hosts, fallbacks;
    for (const auto& f : files) {
      LoadedScenario l;
      try {
        l = load_scenario(f);
      } catch (const std::exception&) {
        continue;
      }
      for (const auto& node : l.controllers)
        if (node["type"].Scalar() == type.name) {
          hosts.push_back({f, YAML::Clone(node)});
          // the trackers' free mode (the balance layer, the planner's correction) has no
          // shipped scenario of its own: checked on the same hosts
          if (node["mode"] && node["mode"].Scalar() == "assisted") {
            YAML::Node free = YAML::Clone(node);
            free["mode"] = "free";
            hosts.push_back({f, free});
          }
        }
      YAML::Node defaults(YAML::NodeType::Map);
      defaults["type"] = type.name;
      fallbacks.push_back({f, defaults});
    }
    // every scenario that uses the type (free and assisted modes alike), else the first
    // scenario that can host its defaults
    auto check = [&](const Host& host) {
      std::unique_ptr<Engine> engine;
      std::shared_ptr<const Controller> controller;
      std::unique_ptr<ControllerState> state;
      try {
        LoadedScenario l = load_scenario(host.scenario);
        // DART's own queries allocate inside DART (on fullbody1 per call: mass matrix ~4450
        // mallocs, bias forces 40, constraint forces 20), so controllers are checked on MuJoCo
        if (l.scenario.engine != "mujoco") return false;
        engine = make_scenario_engine(l.scenario, l.scenario.engine);
        YAML::Node node = YAML::Clone(host.node);
        if (type.name == "lqr") node["force_plot"] = false;
        const Scenario scenario = l.scenario;
        ControllerContext ctx{{host.scenario}, "controllers[0]", 1, 1.0, [scenario] {
                                return make_scenario_engine(scenario, scenario.engine);
                              }};
        controller = type.make(node, ctx, *engine);
      } catch (const std::exception&) {
        return false;  // not a model this controller can run on
      }
      SCOPED_TRACE(type.name + " on " + host.scenario);
      ControlOutput out;
      out.resize(engine->nv(), engine->nu());
      // a correction on every dimension the controller offers the planner
      std::vector<CorrectionDim> dims;
      if (const auto* c = controller->as<Correctable>()) c->correction_dims(dims);
      const Tracking* tracking = controller->as<Tracking>();
      const std::vector<double> correction(dims.size(), 0.05);
      TrackingError error;
      state = controller->make_state(*engine);
      auto step = [&](bool counted) {
        engine->forward();
        out.clear();
        Counts c = count_allocations([&] {
          if (dims.empty())
            controller->compute(*state, *engine, out);
          else
            controller->as<Correctable>()->compute_corrected(*state, *engine, correction.data(),
                                                             out);
          if (tracking) tracking->tracking_error(*state, *engine, error);
        });
        if (counted) {
          EXPECT_EQ(c.news, 0) << "operator new calls in compute()";
          EXPECT_EQ(c.mallocs, 0) << "malloc calls in compute()";
        }
        engine->set_generalized_forces(out.tau);
        if (out.ctrl_used) engine->set_controls(out.ctrl);
        engine->step();
      };
      step(false);
      for (int k = 0; k < 200 && !::testing::Test::HasFailure(); ++k) step(true);
      tested.insert(type.name);
      return true;
    };
    bool checked = false;
    for (const Host& host : hosts) checked = check(host) || checked;
    if (!checked)
      for (const Host& host : fallbacks)
        if (check(host)) break;
  }
  for (const auto& name : kRequired) EXPECT_TRUE(tested.count(name)) << name << " was not built";
  std::string list;
  for (const auto& n : tested) list += n + " ";
  std::cout << "allocation-free: " << list << "\n";
}

#ifdef STANCE_HAVE_DART
// DART's per-step queries that stance computes itself allocate nothing; the ones DART computes
// (bias and constraint forces, the articulated-body solve, the mass matrix, a body's Jacobian
// refreshed after a step) allocate inside DART 6.12 and are counted for the record
// (docs/biped.md)
TEST(DartQueryAllocations, StanceSideOfEveryPerStepQueryIsAllocationFree) {
  LoadedScenario l = load_scenario(test::scenario_path("biped_stand.yaml"));
  auto engine = make_scenario_engine(l.scenario, "dart");
  Engine& e = *engine;
  const int nq = e.nq(), nv = e.nv(), heel = e.require_body("h_heel_left");
  Eigen::VectorXd q(nq), v(nv), c(nv), f(nv), x(nv), tau = Eigen::VectorXd::Zero(nv);
  const Eigen::VectorXd shift = Eigen::VectorXd::Constant(nv, 0.04);
  Eigen::MatrixXd jp(3, nv), jr(3, nv), m(nv, nv);
  for (int k = 0; k < 50; ++k) e.step();  // in contact
  auto warm_and_count = [&](auto&& query) {
    e.step();
    e.forward();
    query();  // a first call may size DART's caches
    e.step();
    e.forward();
    Counts n = count_allocations(query);
    return n.news + n.mallocs;
  };
  const Eigen::Vector3d point(0.05, 0, 0);
  std::map<std::string, long> ours = {
      {"positions and velocities", warm_and_count([&] {
         e.get_positions(q);
         e.get_velocities(v);
       })},
      {"com and its velocity", warm_and_count([&] {
         benchmark_guard(e.com());
         benchmark_guard(e.com_velocity());
       })},
      {"body pose and velocity", warm_and_count([&] {
         benchmark_guard(e.body_pose(heel).pos);
         benchmark_guard(e.body_velocity(heel).head<3>());
       })},
      {"state is finite", warm_and_count([&] { EXPECT_TRUE(e.state_is_finite()); })},
      {"generalized forces", warm_and_count([&] { e.set_generalized_forces(tau); })}};
  for (const auto& [what, n] : ours) EXPECT_EQ(n, 0) << what;
  std::cout << "inside DART, heap calls per call: bias forces "
            << warm_and_count([&] { e.bias_forces(c); }) << ", constraint forces "
            << warm_and_count([&] { e.constraint_forces(f); }) << ", shifted solve "
            << warm_and_count([&] { e.solve_mass_shifted(shift, x.setOnes()); }) << ", mass matrix "
            << warm_and_count([&] { e.mass_matrix(m); })
            << ", point jacobian (the body's cached Jacobian, refreshed after a step) "
            << warm_and_count([&] { e.point_jacobian(heel, point, jp, jr); }) << "\n";
}
#endif

}  // namespace
}  // namespace stance
