// What a person sees first: stance's floor, sky and lights on models that bring none, and a
// follow camera that frames the whole character. Offscreen (EGL); skips without OpenGL.
#include "viz/scene_view.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>

#include "test_support.h"
#include "viz/gl_context.h"
#include "viz/recorder.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

LoadedScenario named_scenario(const std::string& name) {
  LoadedScenario loaded = load_scenario(test::source_dir() + "/scenarios/" + name + ".yaml");
  loaded.scenario.name = name;
  return loaded;
}

struct Frame {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
  const unsigned char* at(int x, int y) const { return &rgb[3 * (size_t(y) * w + x)]; }
};

// distinct colours and the spread of brightness over rows [y0, y1) of the frame
struct RegionStats {
  size_t colours = 0;
  double mean = 0, stddev = 0;
};
RegionStats region_stats(const Frame& f, int y0, int y1) {
  std::map<uint32_t, long> counts;
  double sum = 0, sum2 = 0;
  long n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < f.w; ++x) {
      const unsigned char* p = f.at(x, y);
      ++counts[(p[0] << 16) | (p[1] << 8) | p[2]];
      double lum = (p[0] + p[1] + p[2]) / 3.0;
      sum += lum;
      sum2 += lum * lum;
      ++n;
    }
  RegionStats s;
  s.colours = counts.size();
  s.mean = sum / n;
  s.stddev = std::sqrt(std::max(0.0, sum2 / n - s.mean * s.mean));
  return s;
}

class SceneViewTest : public ::testing::Test {
 protected:
  void SetUp() override {
    try {
      gl_ = std::make_unique<OffscreenGlContext>();
    } catch (const std::exception&) {
      GTEST_SKIP() << "no OpenGL context (EGL or display)";
    }
  }
  std::unique_ptr<OffscreenGlContext> gl_;
};

constexpr int kWidth = 480, kHeight = 300;

Frame draw(SceneView& view, Simulation& run) {
  Frame f;
  f.w = kWidth;
  f.h = kHeight;
  view.update(run);
  view.render_offscreen(f.w, f.h, f.rgb);
  return f;
}

// the project's own MJCF, a SKEL translation, and bvh2mjcf's character all get a floor that
// is not one flat colour (checker, metre lines, shadow) under a sky that is not black
TEST_F(SceneViewTest, FloorIsNotOneFlatColourAndTheSkyIsNotBlack) {
  for (const char* name : {"simbicon_walk", "biped_stand", "mocap_track", "slope_walk"}) {
    SCOPED_TRACE(name);
    RunOptions ro;
    ro.quiet = true;
    Simulation run(named_scenario(name), ro);
    SceneView view(run, kWidth, kHeight);
    view.options.contacts = view.options.com = view.options.markers = false;
    view.options.ghost = false;
    Frame f = draw(view, run);
    write_png((fs::temp_directory_path() / "stance_viz_tests" / (std::string(name) + "_look.png"))
                  .string(),
              f.w, f.h, f.rgb.data());
    // the bottom tenth is floor: squares and lines of several shades
    RegionStats floor = region_stats(f, kHeight * 9 / 10, kHeight);
    EXPECT_GT(floor.colours, 20u);
    EXPECT_GT(floor.stddev, 3.0);
    // the top rows are sky: bright, and a gradient (more than one colour)
    RegionStats sky = region_stats(f, 0, kHeight / 20);
    EXPECT_GT(sky.mean, 100.0);
    EXPECT_GT(sky.colours, 1u);
  }
}

// the floor's light lines are one metre apart: brighter on x = k m than anywhere inside a square
TEST_F(SceneViewTest, FloorLinesAreOneMetreApart) {
  RunOptions ro;
  ro.quiet = true;
  Simulation run(named_scenario("simbicon_walk"), ro);
  SceneView view(run, kWidth, kHeight);
  view.options.contacts = view.options.com = view.options.markers = false;
  Frame f = draw(view, run);
  auto brightness = [&](double x) {
    // on the floor, between the camera and the character
    Eigen::Vector2d p = view.project(Eigen::Vector3d(x, -0.6, 0), double(kWidth) / kHeight);
    int px = std::clamp(int(p.x() * kWidth), 0, kWidth - 1);
    int py = std::clamp(int((1 - p.y()) * kHeight), 0, kHeight - 1);
    const unsigned char* c = f.at(px, py);
    return (c[0] + c[1] + c[2]) / 3.0;
  };
  double x0 = std::round(view.focus().x());
  for (int k = -1; k <= 1; ++k) {
    SCOPED_TRACE(k);
    double on_line = 0, in_square = 0;
    for (double dx = -0.03; dx <= 0.03; dx += 0.005)
      on_line = std::max(on_line, brightness(x0 + k + dx));
    for (double dx = 0.1; dx <= 0.9; dx += 0.01)
      in_square = std::max(in_square, brightness(x0 + k + dx));
    EXPECT_GT(on_line, in_square + 4);
  }
}

// every point of a geom's bounding sphere along up and down, projected through the camera
void expect_in_frame(const SceneView& view, int geom, double margin) {
  const mjModel* m = view.draw_model();
  const mjData* d = view.draw_data();
  Eigen::Vector3d c(d->geom_xpos[3 * geom], d->geom_xpos[3 * geom + 1], d->geom_xpos[3 * geom + 2]);
  double r = m->geom_rbound[geom];
  for (const Eigen::Vector3d& offset : {Eigen::Vector3d(0, 0, -r), Eigen::Vector3d(0, 0, r),
                                        Eigen::Vector3d(r, 0, 0), Eigen::Vector3d(-r, 0, 0)}) {
    Eigen::Vector2d p = view.project(c + offset, double(kWidth) / kHeight);
    const char* name = mj_id2name(m, mjOBJ_BODY, m->geom_bodyid[geom]);
    EXPECT_GT(p.x(), margin) << name;
    EXPECT_LT(p.x(), 1 - margin) << name;
    EXPECT_GT(p.y(), margin) << name;
    EXPECT_LT(p.y(), 1 - margin) << name;
  }
}

TEST_F(SceneViewTest, FollowCameraKeepsTheFeetOfTheWalkIn3dInFrame) {
  RunOptions ro;
  ro.quiet = true;
  Simulation run(named_scenario("simbicon_walk_3d"), ro);
  SceneView view(run, kWidth, kHeight);
  ASSERT_EQ(view.options.camera, CameraMode::kFollow);
  const mjModel* m = view.draw_model();
  std::vector<int> feet;
  for (int g = 0; g < m->ngeom; ++g) {
    const char* body = mj_id2name(m, mjOBJ_BODY, m->geom_bodyid[g]);
    if (body && std::string(body).find("foot") != std::string::npos) feet.push_back(g);
  }
  ASSERT_GE(feet.size(), 2u);
  Frame f = draw(view, run);
  for (int g : feet) expect_in_frame(view, g, 0.05);
  // the whole character at the start, head included
  for (int g = 0; g < m->ngeom; ++g)
    if (m->body_weldid[m->geom_bodyid[g]] != 0) expect_in_frame(view, g, 0.02);
  // walking on: the recorder's 30 frames a second, to t = 2 s
  Engine& e = run.engine();
  double next = 0;
  while (e.time() < 2.0 - 0.5 * e.timestep()) {
    ASSERT_TRUE(run.step());
    if (e.time() >= next) {
      view.update(run);
      next += 1.0 / 30;
    }
  }
  ASSERT_GT(e.body_pose(0).pos.x(), 0.5);  // it walked
  f = draw(view, run);
  write_png((fs::temp_directory_path() / "stance_viz_tests" / "walk_3d_follow_2s.png").string(),
            f.w, f.h, f.rgb.data());
  for (int g : feet) expect_in_frame(view, g, 0.05);
}

TEST_F(SceneViewTest, ScenarioCameraSetsDistanceAnglesAndAFixedMode) {
  LoadedScenario loaded = named_scenario("simbicon_walk");
  loaded.scenario.camera.distance = 7;
  loaded.scenario.camera.azimuth = 60;
  loaded.scenario.camera.elevation = -30;
  loaded.scenario.camera.mode = "fixed";
  RunOptions ro;
  ro.quiet = true;
  Simulation run(loaded, ro);
  SceneView view(run, kWidth, kHeight);
  EXPECT_EQ(view.options.camera, CameraMode::kFree);
  EXPECT_EQ(view.camera().distance, 7);
  EXPECT_EQ(view.camera().azimuth, 60);
  EXPECT_EQ(view.camera().elevation, -30);
  double lookat_x = view.camera().lookat[0];
  for (int i = 0; i < 1000; ++i) ASSERT_TRUE(run.step());
  view.update(run);
  EXPECT_EQ(view.camera().lookat[0], lookat_x);  // fixed: stays where it started
  // follow from here keeps the distance
  view.options.camera = CameraMode::kFollow;
  view.update(run);
  EXPECT_EQ(view.camera().distance, 7);
  EXPECT_NE(view.camera().lookat[0], lookat_x);
}

TEST(CameraFraming, DistanceGrowsWithTheCharacter) {
  double d1 = SceneView::framing_distance(1.0, 45);
  double d2 = SceneView::framing_distance(2.0, 45);
  EXPECT_NEAR(d2, 2 * d1, 1e-12);
  // a 1.8 m character in a 45 degree view: its whole height takes 60..75% of it
  double d = SceneView::framing_distance(1.8, 45);
  double share = 1.8 / (2 * d * std::tan(M_PI / 8));
  EXPECT_GT(share, 0.6);
  EXPECT_LT(share, 0.75);
}

}  // namespace
}  // namespace stance
