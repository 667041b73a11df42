// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/identification.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "ddoc/types.h"

namespace ddoc {

OriginRegression::OriginRegression(const Settings& settings) : settings_(settings) {
  if (!(settings.gate > 0) || !std::isfinite(settings.gate)) {
    throw InvalidArgument("OriginRegression: gate = " + std::to_string(settings.gate) +
                          ", expected a finite number > 0");
  }
  for (const auto& [name, value] : {std::pair{"relative_floor", settings.relative_floor},
                                    {"absolute_floor", settings.absolute_floor}}) {
    if (!(value >= 0) || !std::isfinite(value)) {
      throw InvalidArgument(std::string("OriginRegression: ") + name + " = " +
                            std::to_string(value) + ", expected a finite number >= 0");
    }
  }
  if (settings.min_samples < 2) {
    throw InvalidArgument("OriginRegression: min_samples = " +
                          std::to_string(settings.min_samples) + ", expected >= 2");
  }
  if (settings.decide_after < 1 ||
      (settings.decide_after == 1 && settings.absolute_floor == 0 &&
       settings.relative_floor == 0)) {
    throw InvalidArgument("OriginRegression: decide_after = " +
                          std::to_string(settings.decide_after) +
                          ", expected >= 2, or 1 with a floor > 0");
  }
}

void OriginRegression::Reset() {
  n_ = rejected_ = 0;
  spp_ = spy_ = syy_ = 0;
}

double OriginRegression::theta() const {
  return n_ > 0 ? spy_ / spp_ : std::numeric_limits<double>::quiet_NaN();
}

double OriginRegression::Spread() const {
  if (n_ < 2) return 0.0;
  // sum((y - theta phi)^2) at the least-squares theta.
  const double rss = std::max(0.0, syy_ - spy_ * spy_ / spp_);
  return std::sqrt(rss / (n_ - 1));
}

double OriginRegression::standard_error() const {
  if (n_ < settings_.decide_after) return std::numeric_limits<double>::infinity();
  const double relative = settings_.relative_floor * std::abs(theta()) * std::sqrt(spp_ / n_);
  return std::max({Spread(), settings_.absolute_floor, relative}) / std::sqrt(spp_);
}

bool OriginRegression::Add(double phi, double y) {
  if (!std::isfinite(phi) || !std::isfinite(y) || phi == 0.0) return false;
  if (n_ >= settings_.min_samples) {
    const double fit = theta() * phi;
    const double spread = std::max({Spread(), settings_.relative_floor * std::abs(fit),
                                    settings_.absolute_floor});
    if (std::abs(y - fit) > settings_.gate * spread) {
      ++rejected_;
      return false;
    }
  }
  ++n_;
  spp_ += phi * phi;
  spy_ += phi * y;
  syy_ += y * y;
  return true;
}

MassIdentification::MassIdentification(const Settings& settings)
    : settings_(settings), mass_(settings.regression) {
  for (const auto& [name, value] : {std::pair{"z", settings.z},
                                    {"relative_tolerance", settings.relative_tolerance}}) {
    if (!(value >= 0) || !std::isfinite(value)) {
      throw InvalidArgument(std::string("MassIdentification: ") + name + " = " +
                            std::to_string(value) + ", expected a finite number >= 0");
    }
  }
}

void MassIdentification::Add(const HopIdentificationData& hop) {
  mass_.Add(hop.stance_velocity, hop.stance_impulse);  // impulse = M (dyd + g T_stance)
}

MassIdentification::Estimate MassIdentification::estimate() const {
  Estimate e;
  e.mass = mass_.theta();
  e.mass_se = mass_.standard_error();
  e.hops = mass_.samples();
  e.rejected = mass_.rejected();
  return e;
}

bool MassIdentification::LeavesModel(double model_mass) const {
  const Estimate e = estimate();
  if (!std::isfinite(e.mass_se)) return false;
  const double tolerance =
      std::max(settings_.z * e.mass_se, settings_.relative_tolerance * std::abs(model_mass));
  return std::abs(e.mass - model_mass) > tolerance;
}

BlockRegression::BlockRegression(const Settings& settings) : settings_(settings) {
  if (!(settings.gate > 0) || !std::isfinite(settings.gate)) {
    throw InvalidArgument("BlockRegression: gate = " + std::to_string(settings.gate) +
                          ", expected a finite number > 0");
  }
  if (!(settings.absolute_floor >= 0) || !std::isfinite(settings.absolute_floor)) {
    throw InvalidArgument("BlockRegression: absolute_floor = " +
                          std::to_string(settings.absolute_floor) + ", expected >= 0");
  }
  if (settings.min_blocks < 1) {
    throw InvalidArgument("BlockRegression: min_blocks = " + std::to_string(settings.min_blocks) +
                          ", expected >= 1");
  }
}

void BlockRegression::Reset() {
  sum_ = Block();
  blocks_ = rejected_ = 0;
}

namespace {

// theta of the normal equations, or NaN when aa is (numerically) singular.
BlockRegression::Vec Solve(const BlockRegression::Block& b) {
  const Eigen::LDLT<BlockRegression::Mat> ldlt(b.aa);
  const double scale = b.aa.diagonal().maxCoeff();
  const auto d = ldlt.vectorD();
  if (b.n < 2 || !(scale > 0) || ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-12 * scale)) {
    return BlockRegression::Vec::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return ldlt.solve(b.ay);
}

}  // namespace

BlockRegression::Vec BlockRegression::theta() const { return Solve(sum_); }

double BlockRegression::Spread() const {
  if (sum_.n <= 2) return 0.0;
  const Vec t = theta();
  return t.allFinite() ? std::sqrt(sum_.Rss(t) / (sum_.n - 2)) : 0.0;
}

BlockRegression::Vec BlockRegression::standard_error() const {
  const Vec t = theta();
  if (blocks_ < settings_.min_blocks || !t.allFinite()) {
    return Vec::Constant(std::numeric_limits<double>::infinity());
  }
  const Mat inverse = sum_.aa.inverse();
  return std::max(Spread(), settings_.absolute_floor) * inverse.diagonal().cwiseSqrt();
}

bool BlockRegression::Add(const Block& block) {
  if (block.n < 2 || !block.aa.allFinite() || !block.ay.allFinite() || !std::isfinite(block.yy)) {
    return false;
  }
  if (blocks_ >= settings_.min_blocks) {
    const Vec t = theta();
    const double rms = std::sqrt(block.Rss(t) / block.n);
    if (rms > settings_.gate * std::max(Spread(), settings_.absolute_floor)) {
      ++rejected_;
      return false;
    }
  }
  Block sum = sum_;
  sum.aa += block.aa;
  sum.ay += block.ay;
  sum.yy += block.yy;
  sum.n += block.n;
  if (!Solve(sum).allFinite()) return false;  // nothing determined yet
  sum_ = sum;
  ++blocks_;
  return true;
}

namespace {

// A regression that decides after one sample, its spread floored at the measurement's
// resolution `floor` (y's unit); the gate from the third sample.
OriginRegression::Settings OneSampleRegression(double floor) {
  OriginRegression::Settings s;
  s.min_samples = 2;
  s.decide_after = 1;
  s.absolute_floor = floor;
  return s;
}

}  // namespace

OriginRegression::Settings TermsIdentification::Settings::DefaultLeg() {
  return OneSampleRegression(5e-3);  // J
}

BlockRegression::Settings TermsIdentification::Settings::DefaultHip() {
  BlockRegression::Settings s;
  s.min_blocks = 1;
  s.absolute_floor = 1e-6;  // N m s
  return s;
}

OriginRegression::Settings TermsIdentification::Settings::DefaultDrag() {
  return OneSampleRegression(2e-5);  // N s
}

OriginRegression::Settings TermsIdentification::Settings::DefaultSlope() {
  return OneSampleRegression(5e-4);  // m
}

TermsIdentification::TermsIdentification(const Settings& settings)
    : settings_(settings),
      leg_(settings.leg),
      drag_(settings.drag),
      slope_(settings.slope),
      hip_(settings.hip) {
  for (const auto& [name, value] : {std::pair{"z", settings.z},
                                    {"b_leg_tolerance", settings.b_leg_tolerance},
                                    {"b_hip_tolerance", settings.b_hip_tolerance},
                                    {"inertia_tolerance", settings.inertia_tolerance},
                                    {"drag_tolerance", settings.drag_tolerance},
                                    {"slope_tolerance", settings.slope_tolerance}}) {
    if (!(value >= 0) || !std::isfinite(value)) {
      throw InvalidArgument(std::string("TermsIdentification: ") + name + " = " +
                            std::to_string(value) + ", expected a finite number >= 0");
    }
  }
}

void TermsIdentification::Reset() {
  leg_.Reset();
  hip_.Reset();
  drag_.Reset();
  slope_.Reset();
}

void TermsIdentification::Add(const HopIdentificationData& hop, double mass) {
  if (std::isfinite(mass)) {
    leg_.Add(hop.leg_rate_sq, hop.leg_work - mass * hop.leg_motion);  // = b_leg leg_rate_sq
    drag_.Add(hop.flight_drag, -(mass * hop.flight_dxd + hop.flight_foot_dp));  // = c_d drag
  }
  hip_.Add(hop.hip);
  slope_.Add(hop.end_foot_x - hop.start_foot_x, hop.end_foot_y - hop.start_foot_y);
}

namespace {

TermsIdentification::Term TermOf(const OriginRegression& r) {
  TermsIdentification::Term t;
  t.value = r.theta();
  t.se = r.standard_error();
  t.samples = r.samples();
  t.rejected = r.rejected();
  return t;
}

TermsIdentification::Term TermOf(const BlockRegression& r, int i) {
  TermsIdentification::Term t;
  t.value = r.theta()(i);
  t.se = r.standard_error()(i);
  t.samples = r.blocks();
  t.rejected = r.rejected();
  return t;
}

// |value - model's| beyond max(z se, tolerance), for a determined term.
bool Leaves(const TermsIdentification::Term& t, double model_value, double z, double tolerance) {
  return t.determined() && std::abs(t.value - model_value) > std::max(z * t.se, tolerance);
}

double Rounded(double v, double step) { return std::round(v / step) * step; }

}  // namespace

TermsIdentification::Estimate TermsIdentification::estimate() const {
  Estimate e;
  e.b_leg = TermOf(leg_);
  e.j_body = TermOf(hip_, 0);
  e.b_hip = TermOf(hip_, 1);
  e.c_d = TermOf(drag_);
  e.slope = TermOf(slope_);
  // slope = atan(tan(slope)); se through the derivative 1 / (1 + tan^2).
  const double tan_slope = e.slope.value;
  e.slope.value = std::atan(tan_slope);
  e.slope.se /= 1.0 + tan_slope * tan_slope;
  return e;
}

bool TermsIdentification::Determined() const {
  const Estimate e = estimate();
  return e.b_leg.determined() && e.b_hip.determined() && e.j_body.determined() &&
         e.c_d.determined() && e.slope.determined();
}

bool TermsIdentification::LeavesModel(const HopperParams& model) const {
  const Estimate e = estimate();
  const double z = settings_.z, rel = settings_.inertia_tolerance;
  const Settings::Acted& a = settings_.acted;
  return (a.b_leg && Leaves(e.b_leg, model.b_leg, z, settings_.b_leg_tolerance)) ||
         (a.b_hip && Leaves(e.b_hip, model.b_hip, z, settings_.b_hip_tolerance)) ||
         (a.j_body && Leaves(e.j_body, model.J_body, z, rel * model.J_body)) ||
         (a.c_d && Leaves(e.c_d, model.c_d, z, settings_.drag_tolerance)) ||
         (a.slope && Leaves(e.slope, model.slope, z, settings_.slope_tolerance));
}

HopperParams TermsIdentification::Identified(const HopperParams& model,
                                             const Resolution& resolution) const {
  const Estimate e = estimate();
  const double z = settings_.z;
  const Settings::Acted& a = settings_.acted;
  HopperParams p = model;
  if (a.b_leg && Leaves(e.b_leg, model.b_leg, z, settings_.b_leg_tolerance)) {
    p.b_leg = std::max(0.0, Rounded(e.b_leg.value, resolution.b_leg));
  }
  if (a.b_hip && Leaves(e.b_hip, model.b_hip, z, settings_.b_hip_tolerance)) {
    p.b_hip = std::max(0.0, Rounded(e.b_hip.value, resolution.b_hip));
  }
  if (a.j_body && Leaves(e.j_body, model.J_body, z, settings_.inertia_tolerance * model.J_body)) {
    // A weaker hip motor reads as J_body / g: J_leg / g with it (the leg's own flight balance
    // reads J_leg 1 % low on the robot, too coarse for a decision at 1 %).
    const double ratio = std::max(0.01, Rounded(e.j_body.value / model.J_body, resolution.inertia));
    p.J_body = ratio * model.J_body;
    p.J_leg = ratio * model.J_leg;
  }
  if (a.c_d && Leaves(e.c_d, model.c_d, z, settings_.drag_tolerance)) {
    p.c_d = std::max(0.0, Rounded(e.c_d.value, resolution.c_d));
  }
  if (a.slope && Leaves(e.slope, model.slope, z, settings_.slope_tolerance)) {
    const double limit = 0.9 * HopperParams::kMaxSlope;  // what the model accepts, with a margin
    p.slope = std::min(limit, std::max(-limit, Rounded(e.slope.value, resolution.slope)));
  }
  return p;
}

namespace {

// The acted-on flags by name, in ActedTermsName's order.
std::array<std::pair<const char*, bool TermsIdentification::Settings::Acted::*>, 5> ActedFields() {
  using A = TermsIdentification::Settings::Acted;
  return {{{"b_leg", &A::b_leg}, {"b_hip", &A::b_hip}, {"j_body", &A::j_body}, {"c_d", &A::c_d},
           {"slope", &A::slope}}};
}

}  // namespace

TermsIdentification::Settings::Acted ParseActedTerms(const std::string& list) {
  using A = TermsIdentification::Settings::Acted;
  if (list == "all") return A();
  A a;
  for (const auto& [name, field] : ActedFields()) a.*field = false;
  if (list == "none") return a;
  std::array<bool, 5> seen{};
  size_t begin = 0;
  while (true) {
    const size_t end = std::min(list.find(',', begin), list.size());
    const std::string name = list.substr(begin, end - begin);
    bool known = false;
    const auto fields = ActedFields();
    for (size_t i = 0; i < fields.size(); ++i) {
      if (name != fields[i].first) continue;
      if (seen[i]) {
        throw InvalidArgument("terms acted on: \"" + name + "\" is named twice in \"" + list +
                              "\"");
      }
      seen[i] = known = true;
      a.*fields[i].second = true;
    }
    if (!known) {
      throw InvalidArgument("terms acted on: unknown term \"" + name + "\" in \"" + list +
                            "\", expected all, none or a comma-separated list of b_leg, b_hip, "
                            "j_body, c_d, slope");
    }
    if (end == list.size()) break;
    begin = end + 1;
  }
  return a;
}

std::string ActedTermsName(const TermsIdentification::Settings::Acted& acted) {
  std::string names;
  int count = 0;
  for (const auto& [name, field] : ActedFields()) {
    if (!(acted.*field)) continue;
    names += (count++ ? "," : "") + std::string(name);
  }
  if (count == 0) return "none";
  return count == 5 ? "all" : names;
}

std::optional<HopperParams> IdentifiedModel(const HopperParams& model,
                                            const MassIdentification& mass, bool act_on_mass,
                                            double mass_resolution,
                                            const TermsIdentification& terms, bool act_on_terms,
                                            const TermsIdentification::Resolution& resolution) {
  // Decided once the mass (when acted on) is determined; a term joins once it is (the slope
  // needs a hop between two takeoffs), until then it keeps the model's value.
  if (act_on_mass && !std::isfinite(mass.estimate().mass_se)) return std::nullopt;
  const bool mass_leaves = act_on_mass && mass.LeavesModel(model.M);
  if (!mass_leaves && !(act_on_terms && terms.LeavesModel(model))) return std::nullopt;
  HopperParams p = model;
  if (mass_leaves) {
    p.M = std::max(mass_resolution,
                   std::round(mass.estimate().mass / mass_resolution) * mass_resolution);
  }
  if (act_on_terms) p = terms.Identified(p, resolution);
  return p;
}

}  // namespace ddoc
