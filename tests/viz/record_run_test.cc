// `stance run --record`: the video is rendered in the run that writes summary.json and log.csv,
// so those files are the unrecorded run's, byte for byte (but for its wall-clock timings).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "app/commands.h"
#include "test_support.h"
#include "viz/gl_context.h"
#include "viz/viz_commands.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// summary.json without what the wall and CPU clocks decide
nlohmann::json summary_without_timings(const fs::path& dir) {
  nlohmann::json j = nlohmann::json::parse(file_bytes(dir / "summary.json"));
  j.erase("wall_time_s");
  j["metrics"].erase("realtime_factor");
  for (const char* key : {"compute_s_per_sim_s", "cpu_s_per_sim_s"}) {
    j["metrics"].erase(key);
    if (j["metrics"].contains("mocap")) j["metrics"]["mocap"].erase(key);
  }
  return j;
}

bool can_render_offscreen() {
  try {
    OffscreenGlContext gl;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

TEST(RecordedRun, WritesTheUnrecordedRunsFilesAndAFrameEveryStepOfTheVideo) {
  if (!can_render_offscreen()) GTEST_SKIP() << "no OpenGL context (EGL or display)";
  if (!test::have_tool("ffmpeg") || !test::have_tool("ffprobe"))
    GTEST_SKIP() << "no ffmpeg/ffprobe";
  const fs::path root = fs::temp_directory_path() / "stance_record_run_test";
  fs::remove_all(root);
  RunCommand cmd;
  cmd.scenario = test::source_dir() + "/scenarios/mocap_track.yaml";
  cmd.duration = 1.0;
  cmd.quiet = true;
  cmd.out_dir = (root / "plain").string();
  ASSERT_EQ(run_command(cmd), kExitOk);

  cmd.out_dir = (root / "recorded").string();
  cmd.record = (root / "recorded" / "run.mp4").string();
  cmd.fps = 25;
  cmd.size = "160x120";
  ASSERT_EQ(record_command(cmd), kExitOk);

  ASSERT_TRUE(fs::exists(root / "recorded" / "summary.json"));
  EXPECT_EQ(file_bytes(root / "plain" / "log.csv"), file_bytes(root / "recorded" / "log.csv"));
  EXPECT_EQ(summary_without_timings(root / "plain"), summary_without_timings(root / "recorded"));
  const std::string frames = test::run_capture(
      "ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames "
      "-of csv=p=0 '" +
      cmd.record + "'");
  EXPECT_EQ(std::stoi(frames), 25) << frames;
}

}  // namespace
}  // namespace stance
