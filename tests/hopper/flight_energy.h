// Mechanical energy of the analytic hopper's flight state, shared by the analytic model's tests
// and the MuJoCo agreement tests (an independent check of (38) and of the hip-torque sign).
#pragma once

#include <Eigen/Core>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc::testing {

// Flight-state energy with constant stiffnesses (kd = 0) and input u: the Lagrangian of
// the design notes (docs/hopper.md) plus the VSA spring potentials
//   V = -tau0 (phi - theta) + 1/2 k_hip (phi - theta)^2 - F0 r + 1/2 k_leg (r - r0)^2.
inline double FlightEnergy(const HopperParams& p, const Eigen::Matrix<double, 14, 1>& x,
                           const Eigen::Vector4d& u) {
  const double q = x(3) - x(2);
  return 0.5 * p.M * (x(7) * x(7) + x(8) * x(8)) + 0.5 * p.J_leg * x(9) * x(9) +
         0.5 * p.J_body * x(10) * x(10) + p.M * p.g * x(1) - u(0) * q + 0.5 * x(5) * q * q -
         u(1) * x(4) + 0.5 * x(6) * (x(4) - p.r0) * (x(4) - p.r0);
}

}  // namespace ddoc::testing
