// Mesh files of URDF/SDF robots: the package path, the bounds of STL and OBJ meshes and the
// boxes fitted to them.
#include "model/robot_model.h"

#include <tinyxml2.h>

#include <fmt/format.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/model_format.h"
#include "model/mjcf_writing.h"
#include "model/robot_model_detail.h"
#include "model/xml_reader.h"

namespace stance {

namespace {

using Eigen::Vector3d;

// a box side below this (a flat mesh) is raised to it: engines assert on empty boxes
constexpr double kMinBoxSide = 1e-3;  // m

}  // namespace

namespace robot_detail {

std::vector<std::string> package_folders(const RobotOptions& options) {
  std::vector<std::string> folders = options.package_path;
  const char* env = std::getenv("STANCE_PACKAGE_PATH");
  if (env != nullptr) {
    std::stringstream in(env);
    for (std::string dir; std::getline(in, dir, ':');)
      if (!dir.empty()) folders.push_back(dir);
  }
  return folders;
}

FittedBox fit_box(const std::string& shown_name, int line, const std::string& mesh,
                  const Vector3d& scale) {
  const Eigen::AlignedBox3d b = mesh_bounds(shown_name, line, mesh, scale);
  return {b.sizes().cwiseMax(kMinBoxSide), b.center()};
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace robot_detail

using robot_detail::lower_extension;

Eigen::AlignedBox3d mesh_bounds(const std::string& shown_name, int line, const std::string& path,
                                const Vector3d& scale) {
  auto fail = [&](const std::string& why) {
    throw InputError(located(shown_name, line, fmt::format("mesh '{}': {}", path, why)));
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("cannot read the file");
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Eigen::AlignedBox3d box;
  box.setEmpty();
  auto add = [&](const Vector3d& v) {
    if (!v.allFinite()) fail("a vertex is not finite");
    box.extend(v.cwiseProduct(scale));
  };
  const std::string ext = lower_extension(path);
  if (ext == ".stl") {
    uint32_t count = 0;
    const bool binary_size = data.size() >= 84 && (std::memcpy(&count, data.data() + 80, 4),
                                                   data.size() == 84 + 50 * size_t{count});
    if (binary_size) {
      for (size_t t = 0; t < count; ++t) {
        const char* tri = data.data() + 84 + 50 * t + 12;  // after the normal
        for (int k = 0; k < 3; ++k) {
          float xyz[3];
          std::memcpy(xyz, tri + 12 * k, 12);
          add(Vector3d(xyz[0], xyz[1], xyz[2]));
        }
      }
    } else if (data.compare(0, 5, "solid") == 0) {
      std::istringstream text(data);
      for (std::string word; text >> word;) {
        if (word != "vertex") continue;
        Vector3d v;
        if (!(text >> v.x() >> v.y() >> v.z())) fail("an ASCII STL vertex without 3 numbers");
        add(v);
      }
    } else {
      fail("neither a binary STL (84 + 50 bytes per triangle) nor an ASCII one ('solid')");
    }
  } else if (ext == ".obj") {
    std::istringstream text(data);
    for (std::string row; std::getline(text, row);) {
      if (row.size() < 2 || row[0] != 'v' || (row[1] != ' ' && row[1] != '\t')) continue;
      std::istringstream v_in(row.substr(1));
      Vector3d v;
      if (!(v_in >> v.x() >> v.y() >> v.z())) fail("an OBJ vertex without 3 numbers");
      add(v);
    }
  } else {
    fail(fmt::format("only STL and OBJ meshes can be fitted with boxes, found '{}'", ext));
  }
  if (box.isEmpty()) fail("no vertices");
  return box;
}

}  // namespace stance
