// Reading XML model files (URDF, SDF, SKEL) with tinyxml2: every error names file:line of the
// element. The formats' readers (robot_model.cc, skel_to_mjcf.cc) build on this one.
#pragma once

#include <tinyxml2.h>

#include <set>
#include <string>
#include <vector>

namespace stance {

class XmlReader {
 public:
  // `length_elements`: the names of the elements whose numbers are lengths (the format's own list)
  XmlReader(std::string file, std::set<std::string> length_elements)
      : file_(std::move(file)), length_elements_(std::move(length_elements)) {}

  // throws InputError "<file>:<line of el>: message"
  [[noreturn]] void fail(const tinyxml2::XMLElement* el, const std::string& message) const;
  // the first child <name> of parent; fails when it has none
  const tinyxml2::XMLElement* need(const tinyxml2::XMLElement* parent, const char* name) const;
  // an attribute that must be there
  std::string attribute(const tinyxml2::XMLElement* el, const char* name) const;

  // the whitespace-separated numbers of `text` (of element el), finite, and of magnitude at most
  // kMaxModelLength when they are lengths; `count` < 0 accepts any count. `what` names them in
  // messages, `not_a_number` says what a word that is no number is ("is not a number")
  std::vector<double> parse_numbers(const tinyxml2::XMLElement* el, const std::string& text,
                                    const std::string& what, int count, bool lengths,
                                    const char* not_a_number) const;

  // the element's text as written, "" when it has none
  static std::string text(const tinyxml2::XMLElement* el);
  // the element's text without leading and trailing white space
  static std::string trimmed_text(const tinyxml2::XMLElement* el);
  // whether the element's numbers are lengths (its name is one of the length elements)
  bool is_length(const tinyxml2::XMLElement* el) const {
    return length_elements_.count(el->Name()) > 0;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
  std::set<std::string> length_elements_;
};

}  // namespace stance
