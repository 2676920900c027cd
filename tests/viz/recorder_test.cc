// Offscreen recording: a playable MP4 of the expected length, the same frames for the same run,
// and screenshots that are not blank and change over time. Needs no display (EGL).
#include "viz/recorder.h"

#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "test_support.h"
#include "viz/gl_context.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

bool have_gl() {
  try {
    OffscreenGlContext gl;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

fs::path out_dir() {
  fs::path d = fs::temp_directory_path() / "stance_viz_tests";
  fs::create_directories(d);
  return d;
}

LoadedScenario shipped_scenario(const std::string& name) {
  return load_scenario(test::source_dir() + "/scenarios/" + name + ".yaml");
}

struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
};

Image read_png(const std::string& path) {
  Image im;
  int n = 0;
  unsigned char* data = stbi_load(path.c_str(), &im.w, &im.h, &n, 3);
  if (!data) return im;
  im.rgb.assign(data, data + static_cast<size_t>(im.w) * im.h * 3);
  stbi_image_free(data);
  return im;
}

// share of pixels that differ from the most common colour: 0 for a blank frame
double non_background_fraction(const Image& im) {
  std::map<uint32_t, long> counts;
  for (size_t i = 0; i + 2 < im.rgb.size(); i += 3)
    ++counts[(im.rgb[i] << 16) | (im.rgb[i + 1] << 8) | im.rgb[i + 2]];
  long most = 0;
  for (const auto& [c, n] : counts) most = std::max(most, n);
  long total = static_cast<long>(im.rgb.size() / 3);
  return total ? 1.0 - static_cast<double>(most) / total : 0.0;
}

double mean_abs_difference(const Image& a, const Image& b) {
  if (a.rgb.size() != b.rgb.size() || a.rgb.empty()) return -1;
  double sum = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) sum += std::abs(int(a.rgb[i]) - int(b.rgb[i]));
  return sum / a.rgb.size();
}

class RecorderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_gl()) GTEST_SKIP() << "no OpenGL context (EGL or display)";
  }
};

TEST_F(RecorderTest, Mp4HasTheExpectedLength) {
  if (!test::have_tool("ffmpeg") || !test::have_tool("ffprobe"))
    GTEST_SKIP() << "no ffmpeg/ffprobe";
  RunOptions ro;
  ro.quiet = true;
  ro.duration = 1.0;
  RecordOptions o;
  o.video = (out_dir() / "walk.mp4").string();
  o.fps = 30;
  o.width = 320;
  o.height = 240;
  RecordResult r = record_scenario(shipped_scenario("simbicon_walk"), ro, o);
  EXPECT_EQ(r.frames, 30);
  EXPECT_FALSE(r.diverged);
  std::string probe = test::run_capture(
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
      "stream=nb_read_frames,width,height,codec_name -show_entries format=duration -of "
      "default=noprint_wrappers=1 '" +
      o.video + "'");
  EXPECT_NE(probe.find("codec_name=h264"), std::string::npos) << probe;
  EXPECT_NE(probe.find("width=320"), std::string::npos) << probe;
  EXPECT_NE(probe.find("height=240"), std::string::npos) << probe;
  EXPECT_NE(probe.find("nb_read_frames=30"), std::string::npos) << probe;
  auto at = probe.find("duration=");
  ASSERT_NE(at, std::string::npos) << probe;
  EXPECT_NEAR(std::stod(probe.substr(at + 9)), 1.0, 0.05) << probe;
  // ffmpeg wrote a hidden temporary that was renamed into place: none is left beside it
  for (const auto& entry : std::filesystem::directory_iterator(out_dir()))
    EXPECT_NE(entry.path().filename().string().rfind(".walk.mp4", 0), 0u) << entry.path();
}

// the README's moving pictures: a GIF from a later start, played back at its own rate
TEST_F(RecorderTest, GifFromAStartTimeHasTheFramesOfItsWindow) {
  if (!test::have_tool("ffmpeg") || !test::have_tool("ffprobe"))
    GTEST_SKIP() << "no ffmpeg/ffprobe";
  RunOptions ro;
  ro.quiet = true;
  ro.duration = 1.0;
  RecordOptions o;
  o.video = (out_dir() / "walk.gif").string();
  o.video_start = 0.6;
  o.fps = 20;           // frames at 0.6, 0.65, ..., 0.95 s: 8 frames
  o.playback_fps = 10;  // half speed
  o.width = 160;
  o.height = 100;
  RecordResult r = record_scenario(shipped_scenario("simbicon_walk"), ro, o);
  EXPECT_EQ(r.frames, 8);
  std::string probe = test::run_capture(
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries "
      "stream=nb_read_frames,width,codec_name -show_entries format=duration -of "
      "default=noprint_wrappers=1 '" +
      o.video + "'");
  EXPECT_NE(probe.find("codec_name=gif"), std::string::npos) << probe;
  EXPECT_NE(probe.find("width=160"), std::string::npos) << probe;
  EXPECT_NE(probe.find("nb_read_frames=8"), std::string::npos) << probe;
  auto at = probe.find("duration=");
  ASSERT_NE(at, std::string::npos) << probe;
  EXPECT_NEAR(std::stod(probe.substr(at + 9)), 0.8, 0.05) << probe;
}

TEST_F(RecorderTest, SameRunGivesTheSameFrames) {
  if (!test::have_tool("ffmpeg")) GTEST_SKIP() << "no ffmpeg";
  RunOptions ro;
  ro.quiet = true;
  ro.duration = 0.5;
  RecordOptions o;
  o.fps = 20;
  o.width = 160;
  o.height = 120;
  std::string md5[2];
  for (int i = 0; i < 2; ++i) {
    o.video = (out_dir() / fmt::format("same_{}.mp4", i)).string();
    record_scenario(shipped_scenario("biped_stand"), ro, o);
    // decoded frames, not container bytes
    md5[i] = test::run_capture("ffmpeg -v error -i '" + o.video + "' -f md5 -");
  }
  EXPECT_FALSE(md5[0].empty());
  EXPECT_EQ(md5[0], md5[1]);
}

TEST_F(RecorderTest, ScreenshotsAreNotBlankAndChangeOverTime) {
  RunOptions ro;
  ro.quiet = true;
  ro.duration = 1.2;
  for (std::string engine : {"mujoco", "dart"}) {
    ro.engine = engine;
    Image shots[2];
    for (int i = 0; i < 2; ++i) {
      RecordOptions o;
      o.width = 320;
      o.height = 200;
      o.screenshot = (out_dir() / fmt::format("walk_{}_{}.png", engine, i)).string();
      o.screenshot_time = i * 1.0;
      record_scenario(shipped_scenario("simbicon_walk"), ro, o);
      shots[i] = read_png(o.screenshot);
      ASSERT_EQ(shots[i].w, 320);
      // floor, character and markers: far from one flat colour
      EXPECT_GT(non_background_fraction(shots[i]), 0.2) << engine;
    }
    // the walker moved and the clock overlay changed
    EXPECT_GT(mean_abs_difference(shots[0], shots[1]), 0.3) << engine;
  }
}

// as `stance run` does, a recording ends a second after a fall (--past-fall records on)
TEST_F(RecorderTest, EndsOneSecondAfterAFall) {
  if (!test::have_tool("ffmpeg")) GTEST_SKIP() << "no ffmpeg";
  LoadedScenario falls = shipped_scenario("biped_stand");
  falls.controllers.resize(1);  // without the ankle strategy it falls
  RunOptions ro;
  ro.quiet = true;
  RecordOptions o;
  o.video = (out_dir() / "fall.mp4").string();
  o.fps = 20;
  o.width = 160;
  o.height = 120;
  RecordResult r = record_scenario(falls, ro, o);
  ASSERT_TRUE(r.fall_time.has_value());
  EXPECT_TRUE(r.stopped_after_fall);
  EXPECT_NEAR(r.sim_time, *r.fall_time + 1.0, 0.01);
  EXPECT_LT(r.frames, std::lround(falls.scenario.duration * o.fps));
  EXPECT_NEAR(r.frames, std::floor(r.sim_time * o.fps) + 1, 1);
  ro.stop_after_fall_s = -1;
  ro.duration = *r.fall_time + 2.0;
  RecordResult full = record_scenario(falls, ro, o);
  EXPECT_FALSE(full.stopped_after_fall);
  EXPECT_NEAR(full.sim_time, *ro.duration, 2.0 / o.fps);  // to the last frame
}

TEST(RecorderOptions, BadSizesAreInputErrors) {
  int w = 0, h = 0;
  parse_frame_size("640x360", w, h);
  EXPECT_EQ(w, 640);
  EXPECT_EQ(h, 360);
  EXPECT_THROW(parse_frame_size("640", w, h), InputError);
  EXPECT_THROW(parse_frame_size("640x360x2", w, h), InputError);
  EXPECT_THROW(parse_frame_size("8x8", w, h), InputError);
}

}  // namespace
}  // namespace stance
