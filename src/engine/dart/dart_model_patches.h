// Private to src/engine/dart: the checks and patches that model text gets before DART 6.12's
// parsers read it (dart_model_patches.cc), used by dart_model_reader.cc.
#pragma once

#include <tinyxml2.h>
#include <dart/simulation/World.hpp>

#include <map>
#include <string>

#include <Eigen/Core>

namespace stance::dart_backend {

// an MJCF <inertial>, in its body's frame
struct MjcfInertial {
  double mass = 0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();  // about the COM
};

// what DART's MJCF parser needs done before and after it runs
struct MjcfPreflight {
  double timestep = 0.002;  // MuJoCo's defaults, which DART 6.12 does not read
  Eigen::Vector3d gravity{0, 0, -9.81};
  std::string patched_text;  // non-empty: parse this instead of the file
  // DART 6.12 keeps <inertial> mass and pos but drops diaginertia/fullinertia (unit moment)
  std::map<std::string, MjcfInertial> inertials;  // by body name
};

// all model formats are XML: check well-formedness here, where the line number is known
void load_xml(const std::string& shown_name, const std::string& file, tinyxml2::XMLDocument& doc);

// the file's text with normalize_whitespace_for_dart applied; empty when nothing changed
std::string text_normalized_for_dart(tinyxml2::XMLDocument& doc);

// checks the XML (with line numbers in errors), reads <option>, and supplies <default/>
MjcfPreflight preflight_mjcf(const std::string& shown_name, const std::string& file);

// puts the file's <inertial> values on the parsed bodies
void apply_inertials(dart::simulation::World& world,
                     const std::map<std::string, MjcfInertial>& inertials);

}  // namespace stance::dart_backend
