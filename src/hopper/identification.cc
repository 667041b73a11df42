// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/identification.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "ddoc/types.h"

namespace ddoc {

OriginRegression::OriginRegression(const Settings& settings) : settings_(settings) {
  if (!(settings.gate > 0) || !std::isfinite(settings.gate)) {
    throw InvalidArgument("OriginRegression: gate = " + std::to_string(settings.gate) +
                          ", expected a finite number > 0");
  }
  if (!(settings.relative_floor >= 0) || !std::isfinite(settings.relative_floor)) {
    throw InvalidArgument("OriginRegression: relative_floor = " +
                          std::to_string(settings.relative_floor) + ", expected >= 0");
  }
  if (settings.min_samples < 2) {
    throw InvalidArgument("OriginRegression: min_samples = " +
                          std::to_string(settings.min_samples) + ", expected >= 2");
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
  if (n_ < settings_.min_samples) return std::numeric_limits<double>::infinity();
  return Spread() / std::sqrt(spp_);
}

bool OriginRegression::Add(double phi, double y) {
  if (!std::isfinite(phi) || !std::isfinite(y) || phi == 0.0) return false;
  if (n_ >= settings_.min_samples) {
    const double fit = theta() * phi;
    const double spread = std::max(Spread(), settings_.relative_floor * std::abs(fit));
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

}  // namespace ddoc
