// The resume file of stance tune: what a checkpoint holds and the check that it fits the options.
#include <fmt/format.h>

#include <filesystem>

#include "batch/tune.h"
#include "batch/tune_detail.h"
#include "core/error.h"

namespace stance {

namespace tune_detail {

// what a resumed tune must share with the interrupted one (not threads: results do not depend
// on them)
nlohmann::json tune_fingerprint(const TuneOptions& o) {
  std::vector<std::string> params, neighbours;
  for (const auto& p : o.params) params.push_back(param_text(p));
  for (const auto& n : o.neighbours) neighbours.push_back(n.text);
  return {{"scenario", std::filesystem::absolute(o.scenario).lexically_normal().string()},
          {"set", o.sets},
          {"param", params},
          {"neighbour", neighbours},
          {"budget", o.budget},
          {"population", o.population},
          {"seed", o.seed},
          {"engine", o.engine},
          {"duration", o.duration ? nlohmann::json(*o.duration) : nlohmann::json(nullptr)},
          {"metric", o.metric},
          {"fall-penalty", o.fall_penalty},
          {"method", o.method}};
}

// numbers are written in their shortest exact form, so every double reads back unchanged
nlohmann::json run_to_json(const TuneRun& r) {
  return {{"score", r.score},
          {"time_up", r.time_up},
          {"metric", r.metric ? nlohmann::json(*r.metric) : nlohmann::json(nullptr)},
          {"fell", r.fell},
          {"diverged", r.diverged},
          {"error", r.error}};
}

TuneRun run_from_json(const nlohmann::json& j) {
  TuneRun r;
  r.score = j.at("score").get<double>();
  r.time_up = j.at("time_up").get<double>();
  if (!j.at("metric").is_null()) r.metric = j.at("metric").get<double>();
  r.fell = j.at("fell").get<bool>();
  r.diverged = j.at("diverged").get<bool>();
  r.error = j.at("error").get<std::string>();
  return r;
}

nlohmann::json candidate_to_json(const TuneCandidate& c) {
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& r : c.runs) runs.push_back(run_to_json(r));
  return {{"generation", c.generation}, {"index", c.index}, {"values", c.values}, {"runs", runs}};
}

TuneCandidate candidate_from_json(const nlohmann::json& j) {
  TuneCandidate c;
  c.generation = j.at("generation").get<int>();
  c.index = j.at("index").get<int>();
  c.values = j.at("values").get<std::vector<double>>();
  for (const auto& r : j.at("runs")) c.runs.push_back(run_from_json(r));
  aggregate_runs(c);
  return c;
}

}  // namespace tune_detail

using namespace tune_detail;

void check_tune_resume(const TuneOptions& o, const nlohmann::json& checkpoint,
                       const std::string& where) {
  // compared as JSON: value("format", "") throws on a format that is not a string
  if (!checkpoint.is_object() || !checkpoint.contains("format") ||
      checkpoint.at("format") != kCheckpointFormat || !checkpoint.contains("options") ||
      !checkpoint["options"].is_object())
    throw InputError(fmt::format("{}: not a stance tune resume file", where));
  const nlohmann::json now = tune_fingerprint(o);
  const nlohmann::json& saved = checkpoint["options"];
  for (auto it = now.begin(); it != now.end(); ++it) {
    nlohmann::json was = saved.contains(it.key()) ? saved[it.key()] : nlohmann::json(nullptr);
    if (was != it.value())
      throw InputError(fmt::format("{}: option '{}' was {} in the interrupted run, now {}", where,
                                   it.key(), was.dump(), it.value().dump()));
  }
}

}  // namespace stance
