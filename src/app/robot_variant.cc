// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "robot_variant.h"

#include <tinyxml2.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace ddoc::app {
namespace {

namespace fs = std::filesystem;

// The shortest text that reads back as v (0.6, not 0.59999999999999998).
std::string Number(double v) {
  std::string text;
  for (int digits = 1; digits <= 17; ++digits) {
    std::ostringstream out;
    out.precision(digits);
    out << v;
    text = out.str();
    if (std::strtod(text.c_str(), nullptr) == v) break;
  }
  return text;
}

std::string Where(const std::string& file, const tinyxml2::XMLElement* e) {
  return "robot MJCF '" + file + "' line " + std::to_string(e->GetLineNum());
}

void Load(const std::string& file, tinyxml2::XMLDocument* doc) {
  const tinyxml2::XMLError rc = doc->LoadFile(file.c_str());
  if (rc == tinyxml2::XML_ERROR_FILE_NOT_FOUND ||
      rc == tinyxml2::XML_ERROR_FILE_COULD_NOT_BE_OPENED) {
    throw std::runtime_error("robot MJCF '" + file + "' does not exist");
  }
  if (rc != tinyxml2::XML_SUCCESS) {
    throw std::runtime_error("robot MJCF '" + file + "': malformed XML at line " +
                             std::to_string(doc->ErrorLineNum()));
  }
  if (doc->RootElement() == nullptr || std::string(doc->RootElement()->Name()) != "mujoco") {
    throw std::runtime_error("robot MJCF '" + file + "': the top element must be <mujoco>");
  }
}

// The file an <include file=f> of the model in `dir` names: f when absolute, else dir/f.
std::string IncludePath(const std::string& dir, const char* f) {
  return fs::path(f).is_absolute() ? std::string(f) : (fs::path(dir) / f).string();
}

// Replaces every <include> below `parent` (of the document `out`, read from `file`) by the
// children of the included file's <mujoco>, recursively; `dir` is the main model's directory.
void Inline(tinyxml2::XMLDocument* out, tinyxml2::XMLElement* parent, const std::string& file,
            const std::string& dir, int depth) {
  if (depth > 16) throw std::runtime_error("robot MJCF '" + file + "': <include> nested too deeply");
  for (tinyxml2::XMLElement* e = parent->FirstChildElement(); e != nullptr;) {
    tinyxml2::XMLElement* next = e->NextSiblingElement();
    const std::string name = e->Name();
    if (name != "include") {
      if (e->Attribute("file") != nullptr) {
        throw std::runtime_error(Where(file, e) + ": <" + name + " file=...>: files other than "
                                 "<include> are not supported in a robot variant");
      }
      Inline(out, e, file, dir, depth);
      e = next;
      continue;
    }
    const char* f = e->Attribute("file");
    if (f == nullptr) throw std::runtime_error(Where(file, e) + ": <include> without file");
    const std::string included = IncludePath(dir, f);
    if (!fs::is_regular_file(included)) {
      throw std::runtime_error(
          Where(file, e) + ": <include file=\"" + f + "\">: '" + included +
          "' does not exist. A variant copied out of models/ needs absolute include paths "
          "(file=\"/path/to/models/" + fs::path(f).filename().string() +
          "\"), or use ddoc-hopper --robot-variant mass=...,c_d=... on a shipped robot");
    }
    tinyxml2::XMLDocument doc;
    Load(included, &doc);
    Inline(&doc, doc.RootElement(), included, dir, depth + 1);  // its own includes first
    // The included file's children go where the <include> was, in order.
    tinyxml2::XMLNode* at = e;
    for (const tinyxml2::XMLNode* c = doc.RootElement()->FirstChild(); c; c = c->NextSibling()) {
      if (c->ToComment() != nullptr) continue;
      tinyxml2::XMLNode* copy = c->DeepClone(out);
      parent->InsertAfterChild(at, copy);
      at = copy;
    }
    parent->DeleteChild(e);
    e = next;
  }
}

// The first element <tag name="name"> below e, depth first.
tinyxml2::XMLElement* FindNamed(tinyxml2::XMLElement* e, const char* tag, const char* name) {
  for (tinyxml2::XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    const char* n = c->Attribute("name");
    if (std::string(c->Name()) == tag && n != nullptr && std::string(n) == name) return c;
    if (tinyxml2::XMLElement* found = FindNamed(c, tag, name)) return found;
  }
  return nullptr;
}

// Makes the actuator `name` (a <motor> or <general>) deliver `gain` times what it is commanded:
// a <motor> becomes the <general> it stands for (gainprm 1, no bias) with gainprm[0] scaled. The
// gear stays (the controller checks it as a sign convention and does not read the gain).
void ScaleGain(tinyxml2::XMLElement* root, const std::string& path, const char* name,
               double gain) {
  tinyxml2::XMLElement* actuator = FindNamed(root, "motor", name);
  if (actuator != nullptr) {
    actuator->SetName("general");
  } else {
    actuator = FindNamed(root, "general", name);
  }
  if (actuator == nullptr) {
    throw std::runtime_error("robot MJCF '" + path + "' has no <motor name=\"" + name +
                             "\"> to set the strength of");
  }
  std::istringstream in(actuator->Attribute("gainprm") ? actuator->Attribute("gainprm") : "1");
  std::string gainprm;
  for (double g; in >> g;) gainprm += gainprm.empty() ? Number(g * gain) : " " + Number(g);
  actuator->SetAttribute("gainprm", gainprm.c_str());
}

void SetNumeric(tinyxml2::XMLElement* root, const std::string& path, const char* name,
                double value) {
  for (tinyxml2::XMLElement* custom = root->FirstChildElement("custom"); custom;
       custom = custom->NextSiblingElement("custom")) {
    for (tinyxml2::XMLElement* n = custom->FirstChildElement("numeric"); n;
         n = n->NextSiblingElement("numeric")) {
      const char* nn = n->Attribute("name");
      if (nn != nullptr && std::string(nn) == name) {
        n->SetAttribute("data", Number(value).c_str());
        return;
      }
    }
  }
  throw std::runtime_error("robot MJCF '" + path + "' has no <custom><numeric name=\"" + name +
                           "\"> to set");
}

}  // namespace

std::string RobotVariant::ToString() const {
  std::string out;
  auto add = [&](const char* key, const std::optional<double>& v) {
    if (!v) return;
    if (!out.empty()) out += ',';
    out += std::string(key) + "=" + Number(*v);
  };
  add("mass", mass);
  add("j_body", j_body);
  add("c_d", c_d);
  add("beta", beta);
  add("hip_gain", hip_gain);
  add("leg_gain", leg_gain);
  return out;
}

RobotVariant ParseRobotVariant(const std::string& text, const std::string& flag) {
  RobotVariant v;
  auto fail = [&](const std::string& what) { throw std::invalid_argument(flag + ": " + what); };
  const std::string keys = "mass, j_body, c_d, beta, hip_gain or leg_gain";
  if (text.empty()) fail("empty; expected KEY=VALUE,... with keys " + keys);
  std::istringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos) fail("\"" + item + "\": expected KEY=VALUE");
    const std::string key = item.substr(0, eq), value = item.substr(eq + 1);
    char* end = nullptr;
    const double x = std::strtod(value.c_str(), &end);
    if (value.empty() || end == nullptr || *end != '\0' || !std::isfinite(x)) {
      fail(key + "=" + value + ": not a finite number");
    }
    std::optional<double>* field = key == "mass"     ? &v.mass
                                   : key == "j_body" ? &v.j_body
                                   : key == "c_d"    ? &v.c_d
                                   : key == "beta"   ? &v.beta
                                   : key == "hip_gain" ? &v.hip_gain
                                   : key == "leg_gain" ? &v.leg_gain
                                                     : nullptr;
    if (field == nullptr) fail("unknown key \"" + key + "\"; expected " + keys);
    if (*field) fail(key + " given twice");
    const bool ok = key == "c_d" ? x >= 0 : x > 0;
    if (!ok) fail(key + "=" + value + ", expected " + (key == "c_d" ? ">= 0" : "> 0"));
    *field = x;
  }
  return v;
}

bool IncludesNeedResolving(const std::string& path) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS || doc.RootElement() == nullptr) {
    return false;  // LoadMjcf reports it
  }
  const std::string dir = fs::path(path).parent_path().string();
  bool found = false;
  auto walk = [&](auto&& self, const tinyxml2::XMLElement* e, int depth) -> void {
    for (const tinyxml2::XMLElement* c = e->FirstChildElement(); c && !found && depth < 16;
         c = c->NextSiblingElement()) {
      if (std::string(c->Name()) == "include" && c->Attribute("file") != nullptr) {
        const char* f = c->Attribute("file");
        if (fs::path(f).is_absolute() || !fs::is_regular_file(IncludePath(dir, f))) {
          found = true;
          return;
        }
        tinyxml2::XMLDocument sub;
        if (sub.LoadFile(IncludePath(dir, f).c_str()) == tinyxml2::XML_SUCCESS &&
            sub.RootElement() != nullptr) {
          self(self, sub.RootElement(), depth + 1);
        }
      } else {
        self(self, c, depth);
      }
    }
  };
  walk(walk, doc.RootElement(), 0);
  return found;
}

std::string ExpandRobotMjcf(const std::string& path, const RobotVariant& variant) {
  tinyxml2::XMLDocument doc;
  Load(path, &doc);
  const std::string dir = fs::path(path).parent_path().string();
  Inline(&doc, doc.RootElement(), path, dir, 0);
  tinyxml2::XMLElement* root = doc.RootElement();
  if (variant.mass || variant.j_body) {
    tinyxml2::XMLElement* torso = FindNamed(root, "body", "torso");
    tinyxml2::XMLElement* inertial = torso ? torso->FirstChildElement("inertial") : nullptr;
    if (inertial == nullptr) {
      throw std::runtime_error("robot MJCF '" + path +
                               "' has no <body name=\"torso\"> with an <inertial> to set");
    }
    if (variant.mass) inertial->SetAttribute("mass", Number(*variant.mass).c_str());
    if (variant.j_body) {
      const std::string j = Number(*variant.j_body);
      inertial->SetAttribute("diaginertia", (j + " " + j + " " + j).c_str());
      inertial->DeleteAttribute("fullinertia");
    }
  }
  if (variant.c_d) SetNumeric(root, path, "drag_cd", *variant.c_d);
  if (variant.beta) SetNumeric(root, path, "vsa_beta", *variant.beta);
  if (variant.hip_gain) ScaleGain(root, path, "hip_motor", *variant.hip_gain);
  if (variant.leg_gain) ScaleGain(root, path, "leg_motor", *variant.leg_gain);
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace ddoc::app
