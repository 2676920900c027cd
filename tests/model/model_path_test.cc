#include "model/model_path.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "core/error.h"

namespace stance {
namespace {

namespace fs = std::filesystem;

TEST(ModelPath, DartSampleResolvesToDartDoc) {
  unsetenv("STANCE_DART_DATA");
  if (!fs::exists("/usr/share/doc/dart/data/skel/fullbody1.skel")) GTEST_SKIP() << "no dart-doc";
  EXPECT_EQ(resolve_model_path("dart://sample/skel/fullbody1.skel"),
            "/usr/share/doc/dart/data/skel/fullbody1.skel");
}

TEST(ModelPath, EnvironmentOverridesDartData) {
  fs::path dir = fs::temp_directory_path() / "stance_model_path_test";
  fs::create_directories(dir / "skel");
  std::ofstream(dir / "skel" / "a.skel") << "<skel/>";
  setenv("STANCE_DART_DATA", dir.c_str(), 1);
  EXPECT_EQ(resolve_model_path("dart://sample/skel/a.skel"), (dir / "skel" / "a.skel").string());
  unsetenv("STANCE_DART_DATA");
  fs::remove_all(dir);
}

TEST(ModelPath, MujocoModelResolvesToTheSamples) {
  unsetenv("STANCE_MUJOCO_MODELS");
  if (!fs::exists("/usr/share/mujoco/model/humanoid/humanoid.xml"))
    GTEST_SKIP() << "no libmujoco-samples";
  EXPECT_EQ(resolve_model_path("mujoco://model/humanoid/humanoid.xml"),
            "/usr/share/mujoco/model/humanoid/humanoid.xml");
  // a missing sample names what was looked for
  try {
    resolve_model_path("mujoco://model/nope.xml");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "mujoco://model/nope.xml: no such file (looked for /usr/share/mujoco/model/nope.xml)");
  }
}

TEST(ModelPath, EnvironmentOverridesMujocoModels) {
  fs::path dir = fs::temp_directory_path() / "stance_model_path_mujoco";
  fs::create_directories(dir);
  std::ofstream(dir / "a.xml") << "<mujoco/>";
  setenv("STANCE_MUJOCO_MODELS", dir.c_str(), 1);
  EXPECT_EQ(resolve_model_path("mujoco://model/a.xml"), (dir / "a.xml").string());
  unsetenv("STANCE_MUJOCO_MODELS");
  fs::remove_all(dir);
}

TEST(ModelPath, PlainPathsStayAsGiven) {
  fs::path dir = fs::temp_directory_path() / "stance_model_path_plain";
  fs::create_directories(dir);
  std::string file = (dir / "m.xml").string();
  std::ofstream(file) << "<mujoco/>";
  EXPECT_EQ(resolve_model_path(file), file);
  fs::remove_all(dir);
}

TEST(ModelPath, MissingFileNamesThePath) {
  try {
    resolve_model_path("no/such/model.skel");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "no/such/model.skel: no such file");
  }
  EXPECT_THROW(resolve_model_path("dart://sample/skel/does_not_exist.skel"), InputError);
}

TEST(ModelPath, FormatByExtension) {
  EXPECT_EQ(model_format("a/b.xml"), ModelFormat::kMjcf);
  EXPECT_EQ(model_format("b.MJCF"), ModelFormat::kMjcf);
  EXPECT_EQ(model_format("robot.urdf"), ModelFormat::kUrdf);
  EXPECT_EQ(model_format("dart://sample/skel/fullbody1.skel"), ModelFormat::kSkel);
  EXPECT_THROW(model_format("model.obj"), InputError);
  EXPECT_THROW(model_format("noextension"), InputError);
}

}  // namespace
}  // namespace stance
