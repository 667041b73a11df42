// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "scenario.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <sstream>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc::app {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void Fail(const std::string& file, int line, const std::string& what) {
  std::ostringstream msg;
  msg << "scenario " << (file.empty() ? "<flags>" : file);
  if (line > 0) msg << ":" << line;
  msg << ": " << what;
  throw ScenarioError(msg.str());
}

// Reads an optional double attribute; a present but non-numeric value is an error.
std::optional<double> OptionalDouble(const std::string& file, const tinyxml2::XMLElement* e,
                                     const char* attr) {
  const char* text = e->Attribute(attr);
  if (text == nullptr) return std::nullopt;
  double value = 0.0;
  if (e->QueryDoubleAttribute(attr, &value) != tinyxml2::XML_SUCCESS || !std::isfinite(value)) {
    Fail(file, e->GetLineNum(),
         "<" + std::string(e->Name()) + "> attribute " + attr + "=\"" + text +
             "\" is not a finite number");
  }
  return value;
}

// attr="first" or attr="second"; anything else fails naming both.
std::optional<std::string> OptionalChoice(const std::string& file, const tinyxml2::XMLElement* e,
                                          const char* attr, const char* first,
                                          const char* second) {
  const char* text = e->Attribute(attr);
  if (text == nullptr) return std::nullopt;
  const std::string v = text;
  if (v != first && v != second) {
    Fail(file, e->GetLineNum(),
         "<" + std::string(e->Name()) + "> " + attr + "=\"" + v + "\" (expected " + first +
             " or " + second + ")");
  }
  return v;
}

// An integer count >= 1.
std::optional<int> OptionalCount(const std::string& file, const tinyxml2::XMLElement* e,
                                 const char* attr) {
  const std::optional<double> value = OptionalDouble(file, e, attr);
  if (!value) return std::nullopt;
  if (*value != std::floor(*value) || *value < 1) {
    Fail(file, e->GetLineNum(),
         "<" + std::string(e->Name()) + "> " + attr + " must be an integer >= 1");
  }
  return static_cast<int>(*value);
}

double RequiredDouble(const std::string& file, const tinyxml2::XMLElement* e, const char* attr) {
  auto value = OptionalDouble(file, e, attr);
  if (!value) {
    Fail(file, e->GetLineNum(),
         "<" + std::string(e->Name()) + "> is missing attribute " + attr);
  }
  return *value;
}

// Every attribute of e must be one of `known`. A removed one is named with where it went.
void CheckAttributes(const std::string& file, const tinyxml2::XMLElement* e,
                     std::initializer_list<const char*> known) {
  for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a != nullptr; a = a->Next()) {
    const std::string name = a->Name();
    bool ok = false;
    std::string list;
    for (const char* k : known) {
      ok = ok || name == k;
      list += (list.empty() ? "" : ", ") + std::string(k);
    }
    if (ok) continue;
    std::string hint;
    if (name == "flight_pitch_feedback" || name == "flight_pitch_feedback_from_hop") {
      hint = "; the pitch feedback experiment moved to <experiment flight_pitch_feedback=... "
             "from_hop=...>";
    } else if (name == "regularization_scaling" || name == "alpha_scales") {
      hint = "; " + name + " was removed with the engine rework (docs/experiments.md)";
    }
    Fail(file, e->GetLineNum(),
         "<" + std::string(e->Name()) + "> has an unknown attribute " + name + " (expected " +
             list + ")" + hint);
  }
}

std::string ResolvePath(const std::string& scenario_file, const char* path) {
  fs::path p(path);
  if (p.is_absolute() || scenario_file.empty()) return p.lexically_normal().string();
  return (fs::path(scenario_file).parent_path() / p).lexically_normal().string();
}

}  // namespace

Method ParseMethod(const std::string& name) {
  if (name == "alg1") return Method::kAlg1;
  if (name == "ocfb") return Method::kOcfb;
  if (name == "mrl") return Method::kMrl;
  throw ScenarioError("unknown method \"" + name + "\" (expected alg1, ocfb or mrl)");
}

const char* MethodName(Method method) {
  switch (method) {
    case Method::kAlg1: return "alg1";
    case Method::kOcfb: return "ocfb";
    case Method::kMrl: return "mrl";
  }
  return "?";
}

namespace {

using Element = tinyxml2::XMLElement;

void ParseModel(const std::string& path, const Element* e, Scenario* s) {
  CheckAttributes(path, e, {"mjcf", "M", "J_body", "J_leg", "r0", "c_d", "beta", "g"});
  if (const char* mjcf = e->Attribute("mjcf")) s->model_mjcf = ResolvePath(path, mjcf);
  ModelNumbers& n = s->model_numbers;
  n.mass = OptionalDouble(path, e, "M");
  n.j_body = OptionalDouble(path, e, "J_body");
  n.j_leg = OptionalDouble(path, e, "J_leg");
  n.r0 = OptionalDouble(path, e, "r0");
  n.drag = OptionalDouble(path, e, "c_d");
  n.beta = OptionalDouble(path, e, "beta");
  n.gravity = OptionalDouble(path, e, "g");
}

void ParseDuration(const std::string& path, const Element* e, Scenario* s) {
  CheckAttributes(path, e, {"hops", "seconds"});
  s->hops = 0;
  if (auto hops = OptionalDouble(path, e, "hops")) {
    if (*hops != std::floor(*hops)) {
      Fail(path, e->GetLineNum(), "<duration> hops must be an integer");
    }
    s->hops = static_cast<int>(*hops);
  }
  s->seconds = OptionalDouble(path, e, "seconds").value_or(0.0);
}

void ParseLearning(const std::string& path, const Element* e, LearningOverrides* l) {
  CheckAttributes(path, e,
                  {"c", "gamma", "epsilon", "alpha_min", "max_duration_step", "regularization",
                   "alpha_initial", "cyclic_value", "terminal", "reference",
                   "alpha_after_accept", "delta_i", "initial_hops", "preset"});
  if (auto v = OptionalChoice(path, e, "preset", "default", "paper")) l->paper = *v == "paper";
  l->c = OptionalDouble(path, e, "c");
  l->gamma = OptionalDouble(path, e, "gamma");
  l->epsilon = OptionalDouble(path, e, "epsilon");
  l->alpha_min = OptionalDouble(path, e, "alpha_min");
  l->max_duration_step = OptionalDouble(path, e, "max_duration_step");
  l->regularization = OptionalDouble(path, e, "regularization");
  l->alpha_initial = OptionalDouble(path, e, "alpha_initial");
  l->cyclic_value = OptionalDouble(path, e, "cyclic_value");
  if (auto v = OptionalChoice(path, e, "terminal", "time", "event")) {
    l->terminal_event = *v == "event";
  }
  if (auto v = OptionalChoice(path, e, "reference", "own", "gait")) {
    l->anchor_reference = *v == "gait";
  }
  if (auto v = OptionalChoice(path, e, "alpha_after_accept", "reset", "grow")) {
    l->reset_alpha_on_accept = *v == "reset";
  }
  l->delta_i = OptionalCount(path, e, "delta_i");
  l->initial_hops = OptionalCount(path, e, "initial_hops");
}

// <push time=.../> or <push hop=... phase=.../>, with force and duration.
void ParsePushElement(const std::string& path, const Element* e, Scenario* s) {
  CheckAttributes(path, e, {"time", "hop", "phase", "force", "duration"});
  const bool by_time = e->Attribute("time") != nullptr;
  if (by_time == (e->Attribute("hop") != nullptr || e->Attribute("phase") != nullptr)) {
    Fail(path, e->GetLineNum(), "<push> needs either time or hop and phase");
  }
  const double force = RequiredDouble(path, e, "force");
  const double duration = RequiredDouble(path, e, "duration");
  if (by_time) {
    s->pushes.push_back({RequiredDouble(path, e, "time"), force, duration});
    return;
  }
  const double hop = RequiredDouble(path, e, "hop");
  if (hop != std::floor(hop) || hop < 1 || hop > 1e9) {
    Fail(path, e->GetLineNum(), "<push> hop must be an integer >= 1");
  }
  s->hop_pushes.push_back({static_cast<int>(hop), RequiredDouble(path, e, "phase"), force,
                           duration});
}

// One child element of <ddoc_scenario>.
void ParseElement(const std::string& path, const Element* e, Scenario* s) {
  const std::string tag = e->Name();
  const int line = e->GetLineNum();
  if (tag == "robot") {
    CheckAttributes(path, e, {"mjcf"});
    const char* mjcf = e->Attribute("mjcf");
    if (mjcf == nullptr) Fail(path, line, "<robot> is missing attribute mjcf");
    s->robot_mjcf = ResolvePath(path, mjcf);
  } else if (tag == "model") {
    ParseModel(path, e, s);
  } else if (tag == "method") {
    CheckAttributes(path, e, {"name"});
    const char* name = e->Attribute("name");
    if (name == nullptr) Fail(path, line, "<method> is missing attribute name");
    try {
      s->method = ParseMethod(name);
    } catch (const ScenarioError& err) {
      Fail(path, line, err.what());
    }
  } else if (tag == "duration") {
    ParseDuration(path, e, s);
  } else if (tag == "push") {
    ParsePushElement(path, e, s);
  } else if (tag == "learning") {
    ParseLearning(path, e, &s->learning);
  } else if (tag == "experiment") {
    CheckAttributes(path, e, {"flight_pitch_feedback", "from_hop"});
    s->experiment.flight_pitch_feedback = OptionalDouble(path, e, "flight_pitch_feedback");
    s->experiment.from_hop = OptionalCount(path, e, "from_hop");
  } else if (tag == "gait") {
    CheckAttributes(path, e, {"speed", "k0_hip", "k0_leg"});
    s->forward_speed = OptionalDouble(path, e, "speed").value_or(0.0);
    s->gait_k0_hip = OptionalDouble(path, e, "k0_hip");
    s->gait_k0_leg = OptionalDouble(path, e, "k0_leg");
  } else {
    Fail(path, line, "unknown element <" + tag + "> (expected robot, model, method, "
                     "duration, push, learning, experiment or gait)");
  }
}

}  // namespace

Scenario LoadScenario(const std::string& path) {
  if (!fs::exists(path)) Fail(path, 0, "file does not exist");
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS) {
    Fail(path, doc.ErrorLineNum(), std::string("malformed XML: ") + doc.ErrorStr());
  }
  const Element* root = doc.RootElement();
  if (root == nullptr || std::string(root->Name()) != "ddoc_scenario") {
    Fail(path, root ? root->GetLineNum() : 0, "the root element must be <ddoc_scenario>");
  }
  CheckAttributes(path, root, {"name"});
  Scenario s;
  s.file = path;
  s.name = root->Attribute("name") ? root->Attribute("name") : fs::path(path).stem().string();
  for (const Element* e = root->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
    ParseElement(path, e, &s);
  }
  std::sort(s.pushes.begin(), s.pushes.end(),
            [](const Push& a, const Push& b) { return a.time < b.time; });
  std::stable_sort(s.hop_pushes.begin(), s.hop_pushes.end(), [](const HopPush& a, const HopPush& b) {
    return a.hop < b.hop || (a.hop == b.hop && a.phase < b.phase);
  });
  ValidateScenario(s);
  return s;
}

void ValidateScenario(const Scenario& s) {
  const std::string& f = s.file;
  if (s.robot_mjcf.empty()) Fail(f, 0, "no robot MJCF given (<robot mjcf=...>)");
  if (!fs::is_regular_file(s.robot_mjcf)) {
    Fail(f, 0, "robot MJCF \"" + s.robot_mjcf + "\" does not exist");
  }
  if (!s.model_mjcf.empty() && !fs::is_regular_file(s.model_mjcf)) {
    Fail(f, 0, "model MJCF \"" + s.model_mjcf + "\" does not exist");
  }
  if (s.hops < 0) Fail(f, 0, "hops must be >= 0, got " + std::to_string(s.hops));
  if (!(s.seconds >= 0.0) || !std::isfinite(s.seconds)) Fail(f, 0, "seconds must be >= 0");
  if (s.hops == 0 && s.seconds == 0.0) Fail(f, 0, "give a number of hops or of seconds");
  auto positive = [&](const std::optional<double>& v, const char* name) {
    if (v && !(*v > 0.0)) Fail(f, 0, std::string(name) + " must be > 0");
  };
  positive(s.model_numbers.mass, "model M");
  positive(s.model_numbers.j_body, "model J_body");
  positive(s.model_numbers.j_leg, "model J_leg");
  positive(s.model_numbers.r0, "model r0");
  positive(s.model_numbers.beta, "model beta");
  positive(s.model_numbers.gravity, "model g");
  if (s.model_numbers.drag && *s.model_numbers.drag < 0.0) Fail(f, 0, "model c_d must be >= 0");
  const LearningOverrides& l = s.learning;
  positive(l.c, "learning c");
  positive(l.epsilon, "learning epsilon");
  positive(l.alpha_min, "learning alpha_min");
  positive(l.max_duration_step, "learning max_duration_step");
  if (l.regularization && *l.regularization < 0.0) {
    Fail(f, 0, "learning regularization must be >= 0");
  }
  if (l.gamma && !(*l.gamma > 0.0 && *l.gamma < 1.0)) {
    Fail(f, 0, "learning gamma must be in (0, 1)");
  }
  const std::optional<double>& pitch = s.experiment.flight_pitch_feedback;
  if (pitch && !(*pitch >= 0.0 && *pitch <= 1.0)) {
    Fail(f, 0, "experiment flight_pitch_feedback must be in [0, 1]");
  }
  if (l.alpha_initial && !(*l.alpha_initial > 0.0 && *l.alpha_initial <= 1.0)) {
    Fail(f, 0, "learning alpha_initial must be in (0, 1]");
  }
  if (l.cyclic_value && !(*l.cyclic_value >= 0.0 && *l.cyclic_value <= 1.0)) {
    Fail(f, 0, "learning cyclic_value must be in [0, 1]");
  }
  auto in_bounds = [&](const std::optional<double>& v, const char* name, double lo, double hi) {
    if (v && !(*v >= lo && *v <= hi)) {
      std::ostringstream msg;
      msg << "gait " << name << " = " << *v << " is outside the input bounds [" << lo << ", " << hi
          << "]";
      Fail(f, 0, msg.str());
    }
  };
  const Eigen::Vector4d lo = hopper::InputLowerBound(), hi = hopper::InputUpperBound();
  in_bounds(s.gait_k0_hip, "k0_hip", lo(hopper::kK0hip), hi(hopper::kK0hip));
  in_bounds(s.gait_k0_leg, "k0_leg", lo(hopper::kK0leg), hi(hopper::kK0leg));
  for (const Push& p : s.pushes) {
    if (!(p.time >= 0.0)) Fail(f, 0, "push time must be >= 0");
    if (!(p.duration > 0.0)) Fail(f, 0, "push duration must be > 0");
  }
  for (const HopPush& p : s.hop_pushes) {
    if (p.hop < 1) Fail(f, 0, "push hop must be >= 1 (hop 0 has no previous hop)");
    if (!(p.phase >= 0.0 && p.phase < 1.0)) Fail(f, 0, "push phase must be in [0, 1)");
    if (!(p.duration > 0.0)) Fail(f, 0, "push duration must be > 0");
  }
}

Push ParsePush(const std::string& text) {
  Push p;
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  if (!(in >> p.time >> c1 >> p.force >> c2 >> p.duration) || c1 != ',' || c2 != ',' ||
      !in.eof() && (in >> std::ws, !in.eof())) {
    throw ScenarioError("--push \"" + text + "\": expected TIME,FORCE,DURATION");
  }
  if (!(p.time >= 0.0) || !(p.duration > 0.0) || !std::isfinite(p.force)) {
    throw ScenarioError("--push \"" + text + "\": time must be >= 0 and duration > 0");
  }
  return p;
}

HopPush ParseHopPush(const std::string& text) {
  HopPush p;
  double hop = 0.0;
  char at = 0, c1 = 0, c2 = 0;
  std::istringstream in(text);
  if (!(in >> hop >> at >> p.phase >> c1 >> p.force >> c2 >> p.duration) || at != '@' ||
      c1 != ',' || c2 != ',' || !in.eof() && (in >> std::ws, !in.eof())) {
    throw ScenarioError("--push \"" + text + "\": expected HOP@PHASE,FORCE,DURATION");
  }
  if (hop != std::floor(hop) || !(hop >= 1 && hop <= 1e9) || !(p.phase >= 0.0 && p.phase < 1.0) ||
      !(p.duration > 0.0) || !std::isfinite(p.force)) {
    throw ScenarioError("--push \"" + text +
                        "\": hop must be an integer >= 1, phase in [0, 1) and duration > 0");
  }
  p.hop = static_cast<int>(hop);
  return p;
}

}  // namespace ddoc::app
