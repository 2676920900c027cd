// Files that are never torn: written to a hidden temporary name beside the target and renamed
// into place, so a reader (or a crash) sees the old complete file or the new one.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace stance {

// the hidden temporary beside `path`: "dir/.name.tmp"
std::filesystem::path temporary_path_for(const std::filesystem::path& path);

// write `content` to `path` atomically; throws InputError naming the path on failure
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

}  // namespace stance
