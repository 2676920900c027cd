// Model file formats, told by the file name's extension. Below every layer: the model loaders
// and the engine backends both need it.
#pragma once

#include <string>

namespace stance {

enum class ModelFormat { kMjcf, kUrdf, kSkel, kSdf };

// by extension, case-insensitive: .xml/.mjcf -> kMjcf, .urdf -> kUrdf, .skel -> kSkel,
// .sdf -> kSdf.
// Throws InputError for anything else.
ModelFormat model_format(const std::string& path);

// the largest length (a position, a size, a scale) a model file may give, in m, in every format:
// a body at 1e217 m is finite, but FCL's broadphase overflows on the boxes' volumes and segfaults
// DART at the first collision (found by fuzz_model)
constexpr double kMaxModelLength = 1e6;

}  // namespace stance
