// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "scenario.h"

#include <tinyxml2.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <utility>
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

using Element = tinyxml2::XMLElement;

constexpr double kInf = std::numeric_limits<double>::infinity();
// Counts and hop numbers: integers up to this (an int, and more hops than any run).
constexpr double kMaxCount = 1e9;

// The range of a number attribute; an open end excludes the value.
struct Range {
  double lo = -kInf, hi = kInf;
  bool lo_open = true, hi_open = true;
  bool Contains(double v) const {
    return (lo_open ? v > lo : v >= lo) && (hi_open ? v < hi : v <= hi);
  }
  std::string Text() const {
    std::ostringstream os;
    if (hi == kInf) {
      os << (lo_open ? "> " : ">= ") << lo;
    } else {
      os << "in " << (lo_open ? "(" : "[") << lo << ", " << hi << (hi_open ? ")" : "]");
    }
    return os.str();
  }
};
const Range kAnyNumber{};
const Range kPositive{0.0, kInf, true, true};
const Range kNonNegative{0.0, kInf, false, true};
Range Closed(double lo, double hi) { return {lo, hi, false, false}; }

// What an attribute holds: a number in `range`, an integer in `range`, or text (a path, a
// name, a choice: its parser checks it).
enum class Kind { kNumber, kInteger, kText };
struct AttributeSpec {
  const char* name;
  Kind kind = Kind::kText;
  Range range = kAnyNumber;
};
struct ElementSpec {
  const char* name;
  bool repeatable;  // may appear more than once (<push>); the others at most once
  std::vector<AttributeSpec> attributes;
};
AttributeSpec Number(const char* name, Range range = kAnyNumber) {
  return {name, Kind::kNumber, range};
}
AttributeSpec Integer(const char* name, double lo) {
  return {name, Kind::kInteger, Closed(lo, kMaxCount)};
}
AttributeSpec Text(const char* name) { return {name, Kind::kText, kAnyNumber}; }

// THE TABLE: every element of a scenario file and every attribute it may have, with the range
// of each number. Anything else in a file is an error naming it, its element, file and line.
// A new attribute is one line here, read in the element's parser below with Get*().
const std::vector<ElementSpec>& Elements() {
  const Eigen::Vector4d lo = hopper::InputLowerBound(), hi = hopper::InputUpperBound();
  static const std::vector<ElementSpec> table = {
      {"ddoc_scenario", false, {Text("name")}},
      {"robot", false, {Text("mjcf")}},
      {"model", false,
       {Text("mjcf"), Number("M", kPositive), Number("J_body", kPositive),
        Number("J_leg", kPositive), Number("r0", kPositive), Number("c_d", kNonNegative),
        Number("beta", kPositive), Number("g", kPositive), Number("b_leg", kNonNegative),
        Number("b_hip", kNonNegative),
        Number("slope", {-HopperParams::kMaxSlope, HopperParams::kMaxSlope, true, true})}},
      {"method", false, {Text("name")}},
      {"duration", false, {Integer("hops", 0), Number("seconds", kNonNegative)}},
      {"push", true,
       {Number("time", kNonNegative), Integer("hop", 1), Number("phase", {0.0, 1.0, false, true}),
        Number("force"), Number("duration", kPositive)}},
      {"learning", false,
       {Number("c", kPositive), Number("gamma", {0.0, 1.0, true, true}),
        Number("epsilon", kPositive), Number("alpha_min", kPositive),
        Number("max_duration_step", kPositive), Number("regularization", kNonNegative),
        Number("alpha_initial", {0.0, 1.0, true, false}), Number("cyclic_value", Closed(0, 1)),
        Text("terminal"), Text("reference"), Number("anchor_weight", Closed(0, 1)),
        Number("reference_filter", {0.0, 1.0, true, false}),
        Number("overspeed_latch", kNonNegative),
        Text("alpha_after_accept"), Integer("delta_i", 1),
        Integer("initial_hops", 1), Text("preset"), Text("remeasure"),
        Number("noise_margin", kNonNegative), Integer("hops_per_trial", 1),
        Text("blend_feedback"), Text("blend_feedforward"),
        Number("min_predicted_decrease", kNonNegative), Text("start_correction"),
        Number("restart_alpha", {0.0, 1.0, true, false}), Integer("verify_hops", 0),
        Number("verify_margin", kNonNegative), Text("verify_debias"), Text("verify_interleave"),
        Text("verify_log"), Text("verify_when"), Integer("watch_hops", 0),
        Number("watch_ratio", kNonNegative), Text("watch_u0"), Number("watch_max_mass", kNonNegative),
        Number("curvature_scale_min", {0.0, 1.0, true, false})}},
      {"experiment", false,
       {Number("flight_pitch_feedback", Closed(0, 1)), Integer("from_hop", 1)}},
      {"contact", false, {Text("substep_events")}},
      {"identification", false,
       {Text("mass"), Text("terms"), Text("terms_acted"), Integer("settle_hops", 0),
        Number("settle_cost", kNonNegative), Integer("settle_hops_max", 0),
        Number("resolve_latency", kNonNegative), Text("model_law"),
        Number("min_predicted_decrease", kNonNegative)}},
      {"gait", false,
       {Number("speed"), Number("k0_hip", Closed(lo(hopper::kK0hip), hi(hopper::kK0hip))),
        Number("k0_leg", Closed(lo(hopper::kK0leg), hi(hopper::kK0leg)))}},
  };
  return table;
}

const ElementSpec* FindElement(const std::string& name) {
  for (const ElementSpec& spec : Elements()) {
    if (name == spec.name) return &spec;
  }
  return nullptr;
}

const AttributeSpec& FindAttribute(const Element* e, const char* attr) {
  const ElementSpec* spec = FindElement(e->Name());
  for (const AttributeSpec& a : spec->attributes) {
    if (std::string(attr) == a.name) return a;
  }
  throw std::logic_error(std::string("scenario.cc: <") + e->Name() + "> " + attr +
                         " is not in the attribute table");
}

std::string Where(const Element* e) { return "<" + std::string(e->Name()) + ">"; }

// Every attribute of e must be in its table row; e has no child elements and no text.
// A removed attribute is named with where it went.
void CheckElement(const std::string& file, const Element* e, const ElementSpec& spec) {
  for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a != nullptr; a = a->Next()) {
    const std::string name = a->Name();
    bool ok = false;
    std::string list;
    for (const AttributeSpec& k : spec.attributes) {
      ok = ok || name == k.name;
      list += (list.empty() ? "" : ", ") + std::string(k.name);
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
         Where(e) + " has an unknown attribute " + name + " (expected " + list + ")" + hint);
  }
  const bool root = std::string(e->Name()) == "ddoc_scenario";  // its children: the elements
  for (const tinyxml2::XMLNode* n = e->FirstChild(); n != nullptr; n = n->NextSibling()) {
    if (const Element* child = n->ToElement(); child != nullptr && !root) {
      Fail(file, child->GetLineNum(),
           Where(e) + " has a child element <" + child->Name() + ">; " + Where(e) +
               " takes attributes only");
    }
    const tinyxml2::XMLText* text = n->ToText();
    if (text != nullptr &&
        std::string(text->Value()).find_first_not_of(" \t\r\n") != std::string::npos) {
      Fail(file, n->GetLineNum(),
           Where(e) + " has text \"" + text->Value() + "\"; " + Where(e) + " takes " +
               (root ? "elements" : "attributes") + " only");
    }
  }
}

// A number attribute of the table, checked against its range. nullopt when absent.
std::optional<double> GetNumber(const std::string& file, const Element* e, const char* attr) {
  const AttributeSpec& spec = FindAttribute(e, attr);
  const char* text = e->Attribute(attr);
  if (text == nullptr) return std::nullopt;
  double value = 0.0;
  if (!ParseFiniteNumber(text, &value)) {
    Fail(file, e->GetLineNum(),
         Where(e) + " attribute " + attr + "=\"" + text + "\" is not a finite number");
  }
  if (spec.kind == Kind::kInteger) {
    const std::string expected = "an integer >= " + std::to_string(static_cast<int>(spec.range.lo)) +
                                 " and <= " + std::to_string(static_cast<int>(kMaxCount));
    if (value != std::floor(value)) {
      Fail(file, e->GetLineNum(),
           Where(e) + " " + attr + " = " + text + " is not an integer: expected " + expected);
    }
    if (!spec.range.Contains(value)) {
      Fail(file, e->GetLineNum(),
           Where(e) + " " + attr + " = " + text + " is out of range: expected " + expected);
    }
  } else if (!spec.range.Contains(value)) {
    Fail(file, e->GetLineNum(),
         Where(e) + " " + attr + " = " + text + " is out of range: expected a value " +
             spec.range.Text());
  }
  return value;
}

std::optional<int> GetInteger(const std::string& file, const Element* e, const char* attr) {
  const std::optional<double> value = GetNumber(file, e, attr);
  if (!value) return std::nullopt;
  return static_cast<int>(*value);  // in range of int: kMaxCount
}

double RequiredNumber(const std::string& file, const Element* e, const char* attr) {
  auto value = GetNumber(file, e, attr);
  if (!value) Fail(file, e->GetLineNum(), Where(e) + " is missing attribute " + attr);
  return *value;
}

// attr="first" or attr="second"; anything else fails naming both.
std::optional<std::string> GetChoice(const std::string& file, const Element* e, const char* attr,
                                     std::initializer_list<const char*> choices) {
  (void)FindAttribute(e, attr);
  const char* text = e->Attribute(attr);
  if (text == nullptr) return std::nullopt;
  const std::string v = text;
  if (std::find(choices.begin(), choices.end(), v) == choices.end()) {
    std::string expected;  // "a or b", "a, b or c"
    for (size_t i = 0; i < choices.size(); ++i) {
      if (i > 0) expected += i + 1 == choices.size() ? " or " : ", ";
      expected += choices.begin()[i];
    }
    Fail(file, e->GetLineNum(),
         Where(e) + " " + attr + "=\"" + v + "\" (expected " + expected + ")");
  }
  return v;
}

std::optional<std::string> GetChoice(const std::string& file, const Element* e, const char* attr,
                                     const char* first, const char* second) {
  return GetChoice(file, e, attr, {first, second});
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

void ParseModel(const std::string& path, const Element* e, Scenario* s) {
  if (const char* mjcf = e->Attribute("mjcf")) s->model_mjcf = ResolvePath(path, mjcf);
  ModelNumbers& n = s->model_numbers;
  n.mass = GetNumber(path, e, "M");
  n.j_body = GetNumber(path, e, "J_body");
  n.j_leg = GetNumber(path, e, "J_leg");
  n.r0 = GetNumber(path, e, "r0");
  n.drag = GetNumber(path, e, "c_d");
  n.beta = GetNumber(path, e, "beta");
  n.gravity = GetNumber(path, e, "g");
  n.b_leg = GetNumber(path, e, "b_leg");
  n.b_hip = GetNumber(path, e, "b_hip");
  n.slope = GetNumber(path, e, "slope");
}

void ParseLearning(const std::string& path, const Element* e, LearningOverrides* l) {
  if (auto v = GetChoice(path, e, "preset", "default", "paper")) l->paper = *v == "paper";
  l->c = GetNumber(path, e, "c");
  l->gamma = GetNumber(path, e, "gamma");
  l->epsilon = GetNumber(path, e, "epsilon");
  l->alpha_min = GetNumber(path, e, "alpha_min");
  l->max_duration_step = GetNumber(path, e, "max_duration_step");
  l->regularization = GetNumber(path, e, "regularization");
  l->alpha_initial = GetNumber(path, e, "alpha_initial");
  l->cyclic_value = GetNumber(path, e, "cyclic_value");
  if (auto v = GetChoice(path, e, "terminal", "time", "event")) {
    l->terminal_event = *v == "event";
  }
  if (auto v = GetChoice(path, e, "reference", "own", "gait")) {
    l->anchor_reference = *v == "gait";
  }
  l->anchor_weight = GetNumber(path, e, "anchor_weight");
  l->reference_filter = GetNumber(path, e, "reference_filter");
  l->overspeed_latch = GetNumber(path, e, "overspeed_latch");
  if (auto v = GetChoice(path, e, "alpha_after_accept", "reset", "grow")) {
    l->reset_alpha_on_accept = *v == "reset";
  }
  l->delta_i = GetInteger(path, e, "delta_i");
  l->initial_hops = GetInteger(path, e, "initial_hops");
  if (auto v = GetChoice(path, e, "remeasure", "off", "on")) l->remeasure = *v == "on";
  l->noise_margin = GetNumber(path, e, "noise_margin");
  l->hops_per_trial = GetInteger(path, e, "hops_per_trial");
  if (auto v = GetChoice(path, e, "blend_feedback", "off", "on")) l->blend_feedback = *v == "on";
  if (auto v = GetChoice(path, e, "blend_feedforward", "off", "on")) {
    l->blend_feedforward = *v == "on";
  }
  l->min_predicted_decrease = GetNumber(path, e, "min_predicted_decrease");
  if (auto v = GetChoice(path, e, "start_correction", "off", "on")) {
    l->start_correction = *v == "on";
  }
  l->restart_alpha = GetNumber(path, e, "restart_alpha");
  l->verify_hops = GetInteger(path, e, "verify_hops");
  l->verify_margin = GetNumber(path, e, "verify_margin");
  l->watch_hops = GetInteger(path, e, "watch_hops");
  if (auto v = GetChoice(path, e, "verify_debias", "off", "on")) l->verify_debias = *v == "on";
  if (auto v = GetChoice(path, e, "verify_interleave", "off", "on")) {
    l->verify_interleave = *v == "on";
  }
  if (auto v = GetChoice(path, e, "verify_log", "off", "on")) l->verify_log = *v == "on";
  if (auto v = GetChoice(path, e, "verify_when", {"always", "worse", "never"})) {
    l->verify_when_worse = *v == "worse";
    l->verify_when_never = *v == "never";
  }
  l->watch_ratio = GetNumber(path, e, "watch_ratio");
  if (auto v = GetChoice(path, e, "watch_u0", "off", "on")) l->watch_u0 = *v == "on";
  l->watch_max_mass = GetNumber(path, e, "watch_max_mass");
  l->curvature_scale_min = GetNumber(path, e, "curvature_scale_min");
}

// <push time=.../> or <push hop=... phase=.../>, with force and duration.
void ParsePushElement(const std::string& path, const Element* e, Scenario* s) {
  const bool by_time = e->Attribute("time") != nullptr;
  if (by_time == (e->Attribute("hop") != nullptr || e->Attribute("phase") != nullptr)) {
    Fail(path, e->GetLineNum(), "<push> needs either time or hop and phase");
  }
  const double force = RequiredNumber(path, e, "force");
  const double duration = RequiredNumber(path, e, "duration");
  if (by_time) {
    s->pushes.push_back({RequiredNumber(path, e, "time"), force, duration});
    return;
  }
  const std::optional<int> hop = GetInteger(path, e, "hop");
  if (!hop) Fail(path, e->GetLineNum(), "<push> is missing attribute hop");
  s->hop_pushes.push_back({*hop, RequiredNumber(path, e, "phase"), force, duration});
}

// One child element of <ddoc_scenario>, already checked against the table.
void ParseElement(const std::string& path, const Element* e, Scenario* s) {
  const std::string tag = e->Name();
  const int line = e->GetLineNum();
  if (tag == "robot") {
    const char* mjcf = e->Attribute("mjcf");
    if (mjcf == nullptr) Fail(path, line, "<robot> is missing attribute mjcf");
    s->robot_mjcf = ResolvePath(path, mjcf);
  } else if (tag == "model") {
    ParseModel(path, e, s);
  } else if (tag == "method") {
    const char* name = e->Attribute("name");
    if (name == nullptr) Fail(path, line, "<method> is missing attribute name");
    try {
      s->method = ParseMethod(name);
    } catch (const ScenarioError& err) {
      Fail(path, line, err.what());
    }
  } else if (tag == "duration") {
    s->hops = GetInteger(path, e, "hops").value_or(0);
    s->seconds = GetNumber(path, e, "seconds").value_or(0.0);
  } else if (tag == "push") {
    ParsePushElement(path, e, s);
  } else if (tag == "learning") {
    ParseLearning(path, e, &s->learning);
  } else if (tag == "experiment") {
    s->experiment.flight_pitch_feedback = GetNumber(path, e, "flight_pitch_feedback");
    s->experiment.from_hop = GetInteger(path, e, "from_hop");
  } else if (tag == "contact") {
    if (auto v = GetChoice(path, e, "substep_events", "off", "on")) s->substep_events = *v == "on";
  } else if (tag == "identification") {
    if (auto v = GetChoice(path, e, "mass", "off", "on")) s->identify_mass = *v == "on";
    if (auto v = GetChoice(path, e, "terms", "off", "on")) s->identify_terms = *v == "on";
    if (const char* list = e->Attribute("terms_acted")) {
      try {
        s->identify_terms_acted = ParseActedTerms(list);
      } catch (const InvalidArgument& error) {
        Fail(path, e->GetLineNum(), Where(e) + " terms_acted: " + error.what());
      }
    }
    s->settle_hops = GetInteger(path, e, "settle_hops");
    s->settle_cost = GetNumber(path, e, "settle_cost");
    s->settle_hops_max = GetInteger(path, e, "settle_hops_max");
    s->resolve_latency = GetNumber(path, e, "resolve_latency");
    if (auto v = GetChoice(path, e, "model_law", "off", "on")) s->model_law = *v == "on";
    s->id_min_predicted_decrease = GetNumber(path, e, "min_predicted_decrease");
  } else if (tag == "gait") {
    s->forward_speed = GetNumber(path, e, "speed").value_or(0.0);
    s->gait_k0_hip = GetNumber(path, e, "k0_hip");
    s->gait_k0_leg = GetNumber(path, e, "k0_leg");
  }
}

// The children of <ddoc_scenario>: known elements (the table), each checked, the singletons at
// most once; then parsed.
void ParseChildren(const std::string& path, const Element* root, Scenario* s) {
  std::vector<std::pair<std::string, int>> seen;  // element, line of its first appearance
  for (const Element* e = root->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
    const std::string tag = e->Name();
    const ElementSpec* spec = tag == "ddoc_scenario" ? nullptr : FindElement(tag);
    if (spec == nullptr) {
      Fail(path, e->GetLineNum(),
           "unknown element <" + tag + "> (expected robot, model, method, duration, push, "
           "learning, experiment, contact, identification or gait)");
    }
    for (const auto& [name, line] : seen) {
      if (name == tag && !spec->repeatable) {
        Fail(path, e->GetLineNum(),
             "<" + tag + "> is given twice (first at line " + std::to_string(line) +
                 "); give it once");
      }
    }
    seen.emplace_back(tag, e->GetLineNum());
    CheckElement(path, e, *spec);
    ParseElement(path, e, s);
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
  CheckElement(path, root, *FindElement("ddoc_scenario"));
  Scenario s;
  s.file = path;
  s.name = root->Attribute("name") ? root->Attribute("name") : fs::path(path).stem().string();
  ParseChildren(path, root, &s);
  std::sort(s.pushes.begin(), s.pushes.end(),
            [](const Push& a, const Push& b) { return a.time < b.time; });
  std::stable_sort(s.hop_pushes.begin(), s.hop_pushes.end(), [](const HopPush& a, const HopPush& b) {
    return a.hop < b.hop || (a.hop == b.hop && a.phase < b.phase);
  });
  ValidateScenario(s);
  return s;
}

void ValidateScenario(const Scenario& s) {
  // What the command line can change (the files, hops, seconds, pushes); the ranges of the other
  // fields are checked where the file gives them (the attribute table), naming the line.
  const std::string& f = s.file;
  if (s.robot_mjcf.empty()) Fail(f, 0, "no robot MJCF given (<robot mjcf=...>)");
  if (!fs::is_regular_file(s.robot_mjcf)) {
    Fail(f, 0, "robot MJCF \"" + s.robot_mjcf + "\" does not exist");
  }
  if (!s.model_mjcf.empty() && !fs::is_regular_file(s.model_mjcf)) {
    Fail(f, 0, "model MJCF \"" + s.model_mjcf + "\" does not exist");
  }
  if (s.hops < 0) Fail(f, 0, "hops must be >= 0, got " + std::to_string(s.hops));
  if (!(s.seconds >= 0.0) || !std::isfinite(s.seconds)) {
    Fail(f, 0, "seconds must be a finite number >= 0");
  }
  if (s.hops == 0 && s.seconds == 0.0) Fail(f, 0, "give a number of hops or of seconds");
  for (const Push& p : s.pushes) {
    if (!(p.time >= 0.0) || !std::isfinite(p.time)) Fail(f, 0, "push time must be >= 0");
    if (!(p.duration > 0.0) || !std::isfinite(p.duration)) {
      Fail(f, 0, "push duration must be > 0");
    }
    if (!std::isfinite(p.force)) Fail(f, 0, "push force must be a finite number");
  }
  for (const HopPush& p : s.hop_pushes) {
    if (p.hop < 1) Fail(f, 0, "push hop must be >= 1 (hop 0 has no previous hop)");
    if (!(p.phase >= 0.0 && p.phase < 1.0)) Fail(f, 0, "push phase must be in [0, 1)");
    if (!(p.duration > 0.0)) Fail(f, 0, "push duration must be > 0");
  }
}

bool ParseFiniteNumber(const std::string& text, double* value) {
  // Digits, sign, point and exponent only: no "nan", "inf", hex, or trailing characters.
  const size_t begin = text.find_first_not_of(" \t\n\r");
  if (begin == std::string::npos) return false;
  const size_t end = text.find_last_not_of(" \t\n\r") + 1;
  const std::string number = text.substr(begin, end - begin);
  if (number.find_first_not_of("0123456789+-.eE") != std::string::npos) return false;
  char* stop = nullptr;
  errno = 0;
  const double v = std::strtod(number.c_str(), &stop);
  if (stop != number.c_str() + number.size() || errno == ERANGE || !std::isfinite(v)) {
    return false;
  }
  *value = v;
  return true;
}

std::vector<double> ParseNumberList(const std::string& text, size_t n, const char* option) {
  std::vector<double> v;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? comma : comma - start);
    double value = 0.0;
    if (!ParseFiniteNumber(item, &value)) {
      throw ScenarioError(std::string(option) + ": '" + item + "' is not a finite number");
    }
    v.push_back(value);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (v.size() != n) {
    throw ScenarioError(std::string(option) + ": got " + std::to_string(v.size()) +
                        " values, expected " + std::to_string(n));
  }
  return v;
}

Push ParsePush(const std::string& text) {
  std::vector<double> v;
  try {
    v = ParseNumberList(text, 3, "--push");
  } catch (const ScenarioError& e) {
    const std::string why = std::string(e.what()).substr(std::string("--push: ").size());
    throw ScenarioError("--push \"" + text + "\": " + why + "; expected TIME,FORCE,DURATION");
  }
  const Push p{v[0], v[1], v[2]};
  if (!(p.time >= 0.0) || !(p.duration > 0.0)) {
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
