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

}  // namespace stance
