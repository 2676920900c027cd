#include "model/mjcf_lock.h"

#include <tinyxml2.h>

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
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

// every <joint> under <worldbody>, in document order
void collect_joints(XMLElement* parent, std::vector<XMLElement*>& out) {
  for (XMLElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
    if (std::strcmp(e->Name(), "joint") == 0 || std::strcmp(e->Name(), "freejoint") == 0)
      out.push_back(e);
    if (std::strcmp(e->Name(), "body") == 0) collect_joints(e, out);
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

std::string mjcf_with_joints_locked(const std::string& shown_name, const std::string& text,
                                    const std::vector<std::string>& names,
                                    const KeyframeEntries& dropped) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(text.c_str(), text.size()) != tinyxml2::XML_SUCCESS || !doc.RootElement())
    throw InputError(shown_name + ": lock_joints: the file is not well-formed XML");
  XMLElement* root = doc.RootElement();
  std::vector<XMLElement*> joints;
  for (XMLElement* w = root->FirstChildElement("worldbody"); w;
       w = w->NextSiblingElement("worldbody"))
    collect_joints(w, joints);
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
      throw InputError(fmt::format("{}: lock_joints: no joint '{}' in the file (it has: {})",
                                   shown_name, name, fmt::join(have, ", ")));
    }
    const char* type = (*it)->Attribute("type");
    if (std::strcmp((*it)->Name(), "freejoint") == 0 || (type && std::strcmp(type, "free") == 0))
      throw InputError(
          fmt::format("{}:{}: lock_joints: '{}' is a free joint (the root), which "
                      "cannot be locked",
                      shown_name, (*it)->GetLineNum(), name));
  }
  patch_keyframes(root, dropped);
  for (XMLElement* j : joints)
    if (named(j, "name", locked)) j->Parent()->DeleteChild(j);
  remove_references(root, locked);
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace stance
