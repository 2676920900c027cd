// Shared by the tests: small inline models written to temp files, paths and files.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <cstdio>

#include <unistd.h>

namespace stance::test {

// write text to a fresh file under the system temp folder and return its path. ctest runs
// tests as parallel processes that may write the same file: each writes a private copy and
// renames it into place (atomic), so no reader ever sees a half-written file.
inline std::string write_temp_file(const std::string& name, const std::string& text) {
  auto dir = std::filesystem::temp_directory_path() / "stance_tests";
  std::filesystem::create_directories(dir);
  auto path = dir / name;
  static int counter = 0;
  auto tmp = dir / (name + ".tmp" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::ofstream(tmp) << text;
  std::filesystem::rename(tmp, path);
  return path.string();
}

inline std::string source_dir() {
  return STANCE_SOURCE_DIR;
}
inline std::string shared_dir() {
  return std::string(STANCE_SOURCE_DIR) + "/../shared";
}
// a shipped scenario by file name
inline std::string scenario_path(const std::string& name) {
  return source_dir() + "/scenarios/" + name;
}
// one of the real BVH clips in ../shared (tests skip when it is absent)
inline std::string shared_bvh(const std::string& file) {
  return shared_dir() + "/data/bvh/" + file;
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// a program on the PATH, and a command's standard output
inline std::string run_capture(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[256];
  while (fgets(buf, sizeof(buf), p)) out += buf;
  pclose(p);
  return out;
}
inline bool have_tool(const std::string& name) {
  return !run_capture("command -v " + name + " 2>/dev/null").empty();
}

inline constexpr const char* kFullbodySkel = "dart://sample/skel/fullbody1.skel";
inline constexpr const char* kHumanoidXml = "/usr/share/mujoco/model/humanoid/humanoid.xml";

// dart-doc's models (fullbody1, Atlas), which some tests need
inline bool have_dart_data() {
  return std::filesystem::exists("/usr/share/doc/dart/data/skel/fullbody1.skel");
}
inline bool have_atlas() {
  return std::filesystem::exists("/usr/share/doc/dart/data/sdf/atlas/atlas_v3_no_head.sdf") &&
         std::filesystem::exists("/usr/share/doc/dart/data/sdf/atlas/atlas_v3_no_head.urdf");
}

// a floating body with a ball-jointed and a hinged child: covers nq != nv
inline const char* kFloatingChainMjcf = R"(
<mujoco model="floating_chain">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="base" pos="0 0 1">
      <freejoint name="root"/>
      <geom type="box" size="0.2 0.1 0.05" mass="4"/>
      <body name="link1" pos="0.2 0 0">
        <joint name="ball1" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
        <body name="link2" pos="0.3 0 0">
          <joint name="hinge2" type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.25 0.05 0" size="0.03" mass="0.7"/>
          <body name="link3" pos="0.25 0.05 0">
            <joint name="slide3" type="slide" axis="1 0 0"/>
            <geom type="sphere" size="0.05" mass="0.3"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="m_hinge2" joint="hinge2" gear="2"/>
    <motor name="m_slide3" joint="slide3"/>
  </actuator>
</mujoco>
)";

}  // namespace stance::test
