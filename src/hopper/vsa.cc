// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/vsa.h"

#include <cmath>
#include <sstream>

#include "ddoc/switched_system.h"

namespace ddoc {

void AdvanceStiffness(double beta, double dt, double k0, double* k, double* kd) {
  // Closed form of the critically damped servo: A = [0 1; -beta^2 -2 beta],
  // exp(A t) = exp(-beta t) [1 + beta t, t; -beta^2 t, 1 - beta t].
  const double e0 = *k - k0;
  const double ed0 = *kd;
  const double decay = std::exp(-beta * dt);
  *k = k0 + decay * ((1.0 + beta * dt) * e0 + dt * ed0);
  *kd = decay * (-beta * beta * dt * e0 + (1.0 - beta * dt) * ed0);
}

Vsa::Vsa(double beta, const VsaState& state) : beta_(beta), state_(state) {
  if (!(std::isfinite(beta) && beta > 0.0)) {
    std::ostringstream os;
    os << "Vsa: beta = " << beta << " rad/s, expected a finite value > 0";
    throw InvalidArgument(os.str());
  }
}

void Vsa::Advance(double dt, double k0_hip, double k0_leg) {
  if (!(dt >= 0.0) || !std::isfinite(dt)) {
    std::ostringstream os;
    os << "Vsa::Advance: dt = " << dt << ", expected a finite value >= 0";
    throw InvalidArgument(os.str());
  }
  AdvanceStiffness(beta_, dt, k0_hip, &state_.k_hip, &state_.kd_hip);
  AdvanceStiffness(beta_, dt, k0_leg, &state_.k_leg, &state_.kd_leg);
}

}  // namespace ddoc
