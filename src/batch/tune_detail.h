// Private to src/scenario/tune*.cc: the text helpers and the resume-file pieces the tune files
// share (tune.cc the search, tune_inputs.cc the arguments and scores, tune_checkpoint.cc the
// resume file, tune_outputs.cc the files written).
#pragma once

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "batch/tune.h"

namespace stance::tune_detail {

// s without leading and trailing white space
std::string trim(const std::string& s);
// a whole finite number, or nothing
std::optional<double> to_number(const std::string& text);
// "a.b.c" -> {"a", "b", "c"}
std::vector<std::string> split_path(const std::string& key);
// "key=lo:hi" or "key=lo:hi:log"
std::string param_text(const TuneParam& p);

// --- the resume file (tune_checkpoint.cc) ---
inline constexpr const char* kCheckpointFormat = "stance tune checkpoint 1";
// what a resumed tune must share with the interrupted one
nlohmann::json tune_fingerprint(const TuneOptions& o);
nlohmann::json run_to_json(const TuneRun& r);
TuneRun run_from_json(const nlohmann::json& j);
nlohmann::json candidate_to_json(const TuneCandidate& c);
TuneCandidate candidate_from_json(const nlohmann::json& j);

}  // namespace stance::tune_detail
