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

// The <tag name="name"> below root, or an error naming it and what the variant needs it for
// ("robot MJCF '...' has no <joint name="leg"> to set the damping of").
tinyxml2::XMLElement* Required(tinyxml2::XMLElement* root, const std::string& path,
                               const char* tag, const char* name, const char* why) {
  tinyxml2::XMLElement* e = FindNamed(root, tag, name);
  if (e == nullptr) {
    throw std::runtime_error("robot MJCF '" + path + "' has no <" + tag + " name=\"" + name +
                             "\"> to set " + why);
  }
  return e;
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

// Sets the damping of the <joint name="name">.
void SetJointDamping(tinyxml2::XMLElement* root, const std::string& path, const char* name,
                     double damping) {
  Required(root, path, "joint", name, "the damping of")
      ->SetAttribute("damping", Number(damping).c_str());
}

// The floor turned about -y by alpha = -slope (a positive angle counter-clockwise seen with x
// right and z up, as the hinges), moved out by the foot radius along its normal so that the foot
// centre touches on the line z = x tan(alpha) through the origin (HopperParams::slope's
// switching surface): pos = radius (sin alpha, 0, -cos alpha). The flat floor is this at 0.
void SetSlope(tinyxml2::XMLElement* root, const std::string& path, double slope) {
  tinyxml2::XMLElement* floor = Required(root, path, "geom", "floor", "the slope of");
  tinyxml2::XMLElement* foot = FindNamed(root, "geom", "foot");
  const char* size = foot != nullptr ? foot->Attribute("size") : nullptr;
  const double radius = size != nullptr ? std::strtod(size, nullptr) : 0.0;
  if (!(radius > 0.0)) {
    throw std::runtime_error("robot MJCF '" + path + "' has no <geom name=\"foot\" size=...> "
                             "(the foot radius places the sloped floor)");
  }
  const double alpha = -slope;
  const std::string pos = Number(radius * std::sin(alpha)) + " 0 " +
                          Number(-radius * std::cos(alpha));
  floor->SetAttribute("pos", pos.c_str());
  for (const char* other : {"quat", "euler", "xyaxes", "zaxis", "axisangle"}) {
    floor->DeleteAttribute(other);
  }
  if (alpha != 0.0) {
    floor->SetAttribute("axisangle", ("0 -1 0 " + Number(alpha)).c_str());
  }
}

// Replaces solref[0] (the time constant) of `e`, keeping the damping ratio (MuJoCo's default
// "0.02 1" when `e` has none).
void SetTimeConstant(tinyxml2::XMLElement* e, double timeconst) {
  std::istringstream in(e->Attribute("solref") ? e->Attribute("solref") : "0.02 1");
  double old = 0.0, ratio = 1.0;
  in >> old >> ratio;
  e->SetAttribute("solref", (Number(timeconst) + " " + Number(ratio)).c_str());
}

// The foot-floor contact's time constant: solref of the floor, of the foot's default class and
// of the foot geom when it has its own (MuJoCo mixes the two geoms' solref; both get it).
void SetContactTimeConstant(tinyxml2::XMLElement* root, const std::string& path,
                            double timeconst) {
  double timestep = 0.002;  // MuJoCo's default
  if (tinyxml2::XMLElement* option = root->FirstChildElement("option")) {
    option->QueryDoubleAttribute("timestep", &timestep);
  }
  if (!(timeconst >= 2.0 * timestep)) {
    throw std::runtime_error("--robot-variant: contact_timeconst=" + Number(timeconst) +
                             ", expected >= 2 x timestep = " + Number(2.0 * timestep) +
                             " s (MuJoCo's smallest contact time constant; robot MJCF '" + path +
                             "' has timestep " + Number(timestep) + " s)");
  }
  SetTimeConstant(Required(root, path, "geom", "floor", "the contact time constant of"),
                  timeconst);
  tinyxml2::XMLElement* foot =
      Required(root, path, "geom", "foot", "the contact time constant of");
  if (foot->Attribute("solref") != nullptr) SetTimeConstant(foot, timeconst);
  const char* cls = foot->Attribute("class");
  if (cls != nullptr) {
    // <default class="CLS"><geom solref=.../></default>
    auto find_class = [&](auto&& self, tinyxml2::XMLElement* e) -> tinyxml2::XMLElement* {
      for (tinyxml2::XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
        const char* n = c->Attribute("class");
        if (std::string(c->Name()) == "default" && n != nullptr && std::string(n) == cls) return c;
        if (tinyxml2::XMLElement* found = self(self, c)) return found;
      }
      return nullptr;
    };
    tinyxml2::XMLElement* def = find_class(find_class, root);
    tinyxml2::XMLElement* geom = def ? def->FirstChildElement("geom") : nullptr;
    if (geom != nullptr) SetTimeConstant(geom, timeconst);
  }
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
  add("b_leg", b_leg);
  add("b_hip", b_hip);
  add("slope", slope);
  add("contact_timeconst", contact_timeconst);
  add("r0", r0);
  return out;
}

RobotVariant ParseRobotVariant(const std::string& text, const std::string& flag) {
  RobotVariant v;
  auto fail = [&](const std::string& what) { throw std::invalid_argument(flag + ": " + what); };
  const std::string keys =
      "mass, j_body, c_d, beta, hip_gain, leg_gain, b_leg, b_hip, slope, contact_timeconst or r0";
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
                                   : key == "b_leg"    ? &v.b_leg
                                   : key == "b_hip"    ? &v.b_hip
                                   : key == "slope"    ? &v.slope
                                   : key == "contact_timeconst" ? &v.contact_timeconst
                                   : key == "r0"                ? &v.r0
                                                                : nullptr;
    if (field == nullptr) fail("unknown key \"" + key + "\"; expected " + keys);
    if (*field) fail(key + " given twice");
    const bool non_negative = key == "c_d" || key == "b_leg" || key == "b_hip";
    if (key == "slope") {
      if (!(std::abs(x) < RobotVariant::kMaxSlope)) {
        fail(key + "=" + value + ", expected |slope| < " + Number(RobotVariant::kMaxSlope) +
             " rad");
      }
    } else if (!(non_negative ? x >= 0 : x > 0)) {
      fail(key + "=" + value + ", expected " + (non_negative ? ">= 0" : "> 0") +
           (key == "contact_timeconst" ? " s (and >= 2 x the robot's timestep)" : ""));
    }
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
  if (variant.b_leg) SetJointDamping(root, path, "leg", *variant.b_leg);
  if (variant.b_hip) SetJointDamping(root, path, "hip", *variant.b_hip);
  if (variant.slope) SetSlope(root, path, *variant.slope);
  if (variant.contact_timeconst) SetContactTimeConstant(root, path, *variant.contact_timeconst);
  if (variant.r0) {
    Required(root, path, "body", "foot", "the leg's rest length r0 of")
        ->SetAttribute("pos", ("0 0 " + Number(-*variant.r0)).c_str());
  }
  tinyxml2::XMLPrinter printer;
  doc.Print(&printer);
  return printer.CStr();
}

}  // namespace ddoc::app
