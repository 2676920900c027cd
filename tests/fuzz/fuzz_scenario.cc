// scenario loading with --set overrides. Input: lines "--set a.b=value" first, then the YAML.
// The YAML is written beside a link to the source tree's models/, so that the shipped
// scenarios' relative model paths resolve as they do in scenarios/.
#include <cstdint>
#include <string>
#include <vector>

#include "core/error.h"
#include "fuzz_support.h"
#include "sim/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace stance;
  static const std::string dir = [] {
    std::filesystem::create_directories(fuzz::scratch_dir() / "scenarios");
    std::filesystem::path models = fuzz::scratch_dir() / "models";
    if (!std::filesystem::exists(models))
      std::filesystem::create_directory_symlink(std::string(STANCE_SOURCE_DIR) + "/models", models);
    return std::string("scenarios/");
  }();
  std::string_view text = fuzz::as_text(data, size);
  std::vector<std::string> overrides;
  constexpr std::string_view kSet = "--set ";
  while (text.starts_with(kSet)) {
    size_t end = text.find('\n');
    std::string_view line = text.substr(
        kSet.size(), end == std::string_view::npos ? std::string_view::npos : end - kSet.size());
    overrides.emplace_back(line);
    text = end == std::string_view::npos ? std::string_view() : text.substr(end + 1);
  }
  const std::string path = fuzz::write_scratch(dir + "fuzz.yaml", text);
  try {
    load_scenario(path, overrides);
  } catch (const InputError&) {
  }
  return 0;
}
