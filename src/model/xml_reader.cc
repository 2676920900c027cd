#include "model/xml_reader.h"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "core/error.h"
#include "core/model_format.h"

namespace stance {

using tinyxml2::XMLElement;

void XmlReader::fail(const XMLElement* el, const std::string& message) const {
  throw InputError(located(file_, el != nullptr ? el->GetLineNum() : 0, message));
}

const XMLElement* XmlReader::need(const XMLElement* parent, const char* name) const {
  const XMLElement* el = parent->FirstChildElement(name);
  if (el == nullptr) fail(parent, fmt::format("<{}> is missing <{}>", parent->Name(), name));
  return el;
}

std::string XmlReader::attribute(const XMLElement* el, const char* name) const {
  const char* a = el->Attribute(name);
  if (a == nullptr) fail(el, fmt::format("<{}> is missing the attribute '{}'", el->Name(), name));
  return a;
}

std::string XmlReader::text(const XMLElement* el) {
  const char* t = el->GetText();
  return t != nullptr ? std::string(t) : std::string();
}

std::string XmlReader::trimmed_text(const XMLElement* el) {
  const std::string s = text(el);
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

std::vector<double> XmlReader::parse_numbers(const XMLElement* el, const std::string& text,
                                             const std::string& what, int count, bool lengths,
                                             const char* not_a_number) const {
  std::vector<double> values;
  const char* p = text.c_str();
  while (true) {
    while (*p != '\0' && std::isspace(static_cast<unsigned char>(*p))) ++p;
    if (*p == '\0') break;
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(p, &end);
    const bool separated =
        end != p && (*end == '\0' || std::isspace(static_cast<unsigned char>(*end)));
    if (!separated || errno == ERANGE || !std::isfinite(v)) {
      const char* stop = p;
      while (*stop != '\0' && !std::isspace(static_cast<unsigned char>(*stop))) ++stop;
      fail(el, fmt::format("{}: '{}' {}", what, std::string(p, stop), not_a_number));
    }
    if (std::abs(v) > kMaxModelLength && lengths)
      fail(el, fmt::format("{}: {} is out of range (lengths are at most {} m)", what, v,
                           kMaxModelLength));
    values.push_back(v);
    p = end;
  }
  if (count >= 0 && static_cast<int>(values.size()) != count)
    fail(el, fmt::format("{}: expected {} number{}, found {} in '{}'", what, count,
                         count == 1 ? "" : "s", values.size(), text));
  return values;
}

}  // namespace stance
