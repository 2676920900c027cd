// BVH parse speed from memory (bytes/s), on the shared real files, or on a synthetic clip of
// similar shape when ../shared is absent. Target: >= 50 MB/s.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "motion/bvh.h"

namespace {

std::string shared_bvh_text(const std::string& file) {
  const std::string path = std::string(STANCE_SOURCE_DIR) + "/../shared/data/bvh/" + file;
  if (!std::filesystem::exists(path)) return {};
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// a 31-joint chain, 96 channels, 2000 frames of smooth motion: about the size and number
// density of a long CMU clip
std::string synthetic_bvh_text() {
  constexpr int kJoints = 31;
  constexpr int kFrames = 2000;
  std::string text = "HIERARCHY\n";
  for (int j = 0; j < kJoints; ++j) {
    std::string indent(j, '\t');
    text += indent + (j == 0 ? "ROOT" : "JOINT") + fmt::format(" j{}\n", j) + indent + "{\n";
    text += indent + fmt::format("\tOFFSET 0 {:.5f} 0.5\n", -3.0 - 0.1 * j);
    text += indent + (j == 0 ? "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation "
                               "Xrotation\n"
                             : "\tCHANNELS 3 Zrotation Xrotation Yrotation\n");
  }
  text += std::string(kJoints, '\t') + "End Site\n" + std::string(kJoints, '\t') + "{\n" +
          std::string(kJoints + 1, '\t') + "OFFSET 0 -1 0\n" + std::string(kJoints, '\t') + "}\n";
  for (int j = kJoints - 1; j >= 0; --j) text += std::string(j, '\t') + "}\n";
  text += fmt::format("MOTION\nFrames: {}\nFrame Time: .0083333\n", kFrames);
  for (int f = 0; f < kFrames; ++f) {
    double t = f * 0.0083333;
    text += fmt::format("{:.4f} {:.4f} {:.4f}", 2.0 * t, 17.0 + std::sin(t), -30.0 + t);
    for (int c = 0; c < 3 * kJoints; ++c) text += fmt::format(" {:.4f}", 40.0 * std::sin(t + c));
    text += "\r\n";
  }
  return text;
}

void parse_from_memory(benchmark::State& state, const std::string& text, const char* name) {
  if (text.empty()) {
    state.SkipWithError("shared BVH file not found");
    return;
  }
  for (auto _ : state) {
    stance::BvhClip clip = stance::parse_bvh(text, name);
    benchmark::DoNotOptimize(clip.rotations.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(text.size()));
}

void BM_BvhParseMassWalk(benchmark::State& state) {
  static const std::string text = shared_bvh_text("mass_walk.bvh");
  parse_from_memory(state, text, "mass_walk.bvh");
}
BENCHMARK(BM_BvhParseMassWalk)->Unit(benchmark::kMillisecond);

void BM_BvhParseCmu131(benchmark::State& state) {
  static const std::string text = shared_bvh_text("cmu_131_01.bvh");
  parse_from_memory(state, text, "cmu_131_01.bvh");
}
BENCHMARK(BM_BvhParseCmu131)->Unit(benchmark::kMillisecond);

// runs whether or not ../shared is present
void BM_BvhParseSynthetic(benchmark::State& state) {
  static const std::string text = synthetic_bvh_text();
  parse_from_memory(state, text, "synthetic.bvh");
}
BENCHMARK(BM_BvhParseSynthetic)->Unit(benchmark::kMillisecond);

void BM_BvhFormatCmu131(benchmark::State& state) {
  static const std::string text = shared_bvh_text("cmu_131_01.bvh");
  if (text.empty()) {
    state.SkipWithError("shared BVH file not found");
    return;
  }
  const stance::BvhClip clip = stance::parse_bvh(text, "cmu_131_01.bvh");
  size_t bytes = 0;
  for (auto _ : state) {
    std::string out = stance::format_bvh(clip);
    bytes += out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(bytes));
}
BENCHMARK(BM_BvhFormatCmu131)->Unit(benchmark::kMillisecond);

}  // namespace
