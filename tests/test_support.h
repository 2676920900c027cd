// Shared by the tests: small inline models written to temp files, and paths.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

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
