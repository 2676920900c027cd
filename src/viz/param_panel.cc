#include "viz/param_panel.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace stance {

namespace {
std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> parts;
  std::stringstream in(path);
  std::string part;
  while (std::getline(in, part, '.')) parts.push_back(part);
  return parts;
}

bool is_index(const std::string& part) {
  return !part.empty() &&
         std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// the group names of a key path, outermost first: "gait.states.0.swh" -> gait, states,
// states 0 (a list's element is a group in the list's group)
std::vector<std::string> group_names(const std::vector<std::string>& parts) {
  std::vector<std::string> names;
  size_t n = parts.size();
  // a vector's component ("heel_point.1") is one entry, not a group
  size_t leaf = n >= 2 && is_index(parts[n - 1]) ? n - 2 : n - 1;
  for (size_t i = 0; i < leaf; ++i) {
    if (is_index(parts[i]) && i > 0)
      names.push_back(parts[i - 1] + " " + parts[i]);
    else
      names.push_back(parts[i]);
  }
  return names;
}
}  // namespace

std::string param_label(const ParamEntry& entry) {
  std::vector<std::string> parts = split_path(entry.path);
  if (parts.empty()) return entry.path;
  std::string name = parts.back();
  if (parts.size() >= 2 && is_index(name)) name = parts[parts.size() - 2] + "[" + name + "]";
  if (!entry.meta.unit.empty()) name += fmt::format(" ({})", entry.meta.unit);
  return name;
}

std::string param_tooltip(const ParamEntry& entry) {
  std::string text = entry.path;
  if (!entry.meta.help.empty()) text += fmt::format("\n{}", entry.meta.help);
  if (!entry.meta.unit.empty()) text += fmt::format("\nunit: {}", entry.meta.unit);
  bool lo = std::isfinite(entry.meta.min), hi = std::isfinite(entry.meta.max);
  if (lo || hi)
    text += fmt::format("\nrange: {} .. {}", lo ? fmt::format("{:g}", entry.meta.min) : "-inf",
                        hi ? fmt::format("{:g}", entry.meta.max) : "inf");
  return text;
}

bool param_matches(const ParamEntry& entry, std::string_view filter) {
  std::string haystack =
      lower(entry.path + " " + param_label(entry) + " " + std::string(entry.meta.help));
  std::stringstream words{lower(filter)};
  std::string word;
  while (words >> word)
    if (haystack.find(word) == std::string::npos) return false;
  return true;
}

int ParamGroup::size() const {
  int n = static_cast<int>(entries.size());
  for (const auto& g : groups) n += g.size();
  return n;
}

ParamGroup build_param_tree(const std::vector<ParamEntry>& entries, std::string_view filter) {
  ParamGroup root;
  for (int i = 0; i < static_cast<int>(entries.size()); ++i) {
    if (!param_matches(entries[i], filter)) continue;
    ParamGroup* at = &root;
    for (const auto& name : group_names(split_path(entries[i].path))) {
      auto it = std::find_if(at->groups.begin(), at->groups.end(),
                             [&](const ParamGroup& g) { return g.name == name; });
      if (it == at->groups.end()) {
        at->groups.push_back({name, {}, {}});
        it = at->groups.end() - 1;
      }
      at = &*it;
    }
    at->entries.push_back(i);
  }
  return root;
}

}  // namespace stance
