#include "model/mjcf_lock.h"

#include <tinyxml2.h>

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <memory>
#include <set>
#include <sstream>

#include "core/error.h"

namespace stance {

namespace {

using tinyxml2::XMLElement;

bool named(const XMLElement* e, const char* attribute, const std::set<std::string>& names) {
  const char* v = e->Attribute(attribute);
  return v != nullptr && names.count(v) > 0;
}

// every <joint> under `parent`'s bodies, in document order: from a file's root, those of its
// <worldbody> and, in an included file, of the elements its <include> stands for
void collect_joints(XMLElement* parent, std::vector<XMLElement*>& out) {
  for (XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
    if (std::strcmp(e->Name(), "joint") == 0 || std::strcmp(e->Name(), "freejoint") == 0)
      out.push_back(e);
    if (std::strcmp(e->Name(), "body") == 0 || std::strcmp(e->Name(), "worldbody") == 0)
      collect_joints(e, out);
  }
}

// removes the children of `parent` for which `drop` holds; returns the names of those removed
template <class Drop>
std::vector<std::string> remove_children(XMLElement* parent, Drop drop) {
  std::vector<std::string> removed;
  for (XMLElement* e = parent->FirstChildElement(); e;) {
    XMLElement* next = e->NextSiblingElement();
    if (drop(e)) {
      const char* n = e->Attribute("name");
      removed.push_back(n != nullptr ? n : "");
      parent->DeleteChild(e);
    }
    e = next;
  }
  return removed;
}

// the numbers of a keyframe attribute without the entries at `drop` (indices)
std::string without_entries(const char* value, const std::set<int>& drop) {
  std::istringstream in(value);
  std::string out, item;
  for (int i = 0; in >> item; ++i)
    if (!drop.count(i)) out += (out.empty() ? "" : " ") + item;
  return out;
}

void patch_keyframes(XMLElement* root, const KeyframeEntries& dropped) {
  for (XMLElement* keyframe = root->FirstChildElement("keyframe"); keyframe;
       keyframe = keyframe->NextSiblingElement("keyframe"))
    for (XMLElement* key = keyframe->FirstChildElement("key"); key;
         key = key->NextSiblingElement("key"))
      for (const auto& [attribute, drop] :
           {std::pair{"qpos", &dropped.qpos}, std::pair{"qvel", &dropped.qvel},
            std::pair{"ctrl", &dropped.ctrl}})
        if (const char* v = key->Attribute(attribute))
          key->SetAttribute(attribute, without_entries(v, *drop).c_str());
}

// what names a locked joint, outside the body tree: actuators, sensors, fixed-tendon entries,
// joint equalities; sensors of a removed actuator go too
void remove_references(XMLElement* root, const std::set<std::string>& names) {
  std::set<std::string> actuators;
  for (XMLElement* s = root->FirstChildElement("actuator"); s;
       s = s->NextSiblingElement("actuator"))
    for (const std::string& a : remove_children(s, [&](const XMLElement* e) {
           return named(e, "joint", names) || named(e, "jointinparent", names);
         }))
      if (!a.empty()) actuators.insert(a);
  for (XMLElement* s = root->FirstChildElement("sensor"); s; s = s->NextSiblingElement("sensor"))
    remove_children(s, [&](const XMLElement* e) {
      return named(e, "joint", names) || named(e, "actuator", actuators);
    });
  for (XMLElement* s = root->FirstChildElement("equality"); s;
       s = s->NextSiblingElement("equality"))
    remove_children(s, [&](const XMLElement* e) {
      return std::strcmp(e->Name(), "joint") == 0 &&
             (named(e, "joint1", names) || named(e, "joint2", names));
    });
  for (XMLElement* s = root->FirstChildElement("tendon"); s; s = s->NextSiblingElement("tendon"))
    for (XMLElement* fixed = s->FirstChildElement("fixed"); fixed;
         fixed = fixed->NextSiblingElement("fixed"))
      remove_children(fixed, [&](const XMLElement* e) { return named(e, "joint", names); });
}

}  // namespace

std::vector<std::string> mjcf_include_paths(
    const std::string& main_path, const std::function<std::string(const std::string&)>& text_of) {
  const std::filesystem::path dir = std::filesystem::path(main_path).parent_path();
  std::vector<std::string> paths = {main_path};
  for (size_t i = 0; i < paths.size() && paths.size() <= 100; ++i) {  // 100: an include cycle
    const std::string text = text_of(paths[i]);
    tinyxml2::XMLDocument doc;
    if (doc.Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS) continue;
    std::vector<const XMLElement*> open = {doc.RootElement()};
    while (!open.empty()) {
      const XMLElement* parent = open.back();
      open.pop_back();
      if (parent == nullptr) continue;
      for (const XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
        const char* file = e->Attribute("file");
        if (std::strcmp(e->Name(), "include") == 0 && file != nullptr)
          paths.push_back((dir / file).string());
        if (std::strcmp(e->Name(), "body") == 0 || std::strcmp(e->Name(), "worldbody") == 0)
          open.push_back(e);
      }
    }
  }
  return paths;
}

std::vector<std::string> mjcf_with_joints_locked(const std::string& shown_name,
                                                 const std::vector<MjcfFileText>& files,
                                                 const std::vector<std::string>& names,
                                                 const KeyframeEntries& dropped) {
  std::vector<std::unique_ptr<tinyxml2::XMLDocument>> docs;
  std::vector<XMLElement*> joints;
  std::vector<std::string> joint_file;  // the file each joint is in, as messages name it
  for (const MjcfFileText& f : files) {
    auto& doc = docs.emplace_back(std::make_unique<tinyxml2::XMLDocument>());
    const std::string shown = docs.size() == 1 ? shown_name : f.path;
    if (doc->Parse(f.text.c_str(), f.text.size()) != tinyxml2::XML_SUCCESS || !doc->RootElement())
      throw InputError(shown + ": lock_joints: the file is not well-formed XML");
    collect_joints(doc->RootElement(), joints);
    joint_file.resize(joints.size(), shown);
  }
  const std::set<std::string> locked(names.begin(), names.end());
  for (const std::string& name : names) {
    auto it = std::find_if(joints.begin(), joints.end(), [&](const XMLElement* j) {
      const char* n = j->Attribute("name");
      return n != nullptr && name == n;
    });
    if (it == joints.end()) {
      std::vector<std::string> have;
      for (const XMLElement* j : joints)
        if (const char* n = j->Attribute("name")) have.push_back(n);
      throw InputError(fmt::format("{}: lock_joints: no joint '{}' in the file{} (it has: {})",
                                   shown_name, name, files.size() > 1 ? " or its includes" : "",
                                   fmt::join(have, ", ")));
    }
    const char* type = (*it)->Attribute("type");
    if (std::strcmp((*it)->Name(), "freejoint") == 0 || (type && std::strcmp(type, "free") == 0))
      throw InputError(
          fmt::format("{}:{}: lock_joints: '{}' is a free joint (the root), which "
                      "cannot be locked",
                      joint_file[it - joints.begin()], (*it)->GetLineNum(), name));
  }
  for (XMLElement* j : joints)
    if (named(j, "name", locked)) j->Parent()->DeleteChild(j);
  std::vector<std::string> texts;
  for (auto& doc : docs) {
    patch_keyframes(doc->RootElement(), dropped);
    remove_references(doc->RootElement(), locked);
    tinyxml2::XMLPrinter printer;
    doc->Print(&printer);
    texts.emplace_back(printer.CStr());
  }
  return texts;
}

}  // namespace stance
