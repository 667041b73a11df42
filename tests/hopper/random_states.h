// Random but physically sensible flight and stance states and inputs of the analytic hopper (the
// caller's fixed-seed generator), shared by the model's derivative tests.
#pragma once

#include <random>

#include <Eigen/Core>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc::testing {

inline Eigen::Matrix<double, 14, 1> RandomFlight(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix<double, 14, 1> x;
  x << 0.3 * u(*rng), 0.8 + 0.1 * u(*rng), 0.3 * u(*rng), 0.2 * u(*rng), 0.7 + 0.02 * u(*rng),
      80 + 50 * u(*rng), 2000 + 200 * u(*rng), u(*rng), u(*rng), u(*rng), u(*rng), 0.5 * u(*rng),
      10 * u(*rng), 100 * u(*rng);
  return x;
}

inline Eigen::Matrix<double, 10, 1> RandomStance(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix<double, 10, 1> x;
  x << 0.3 * u(*rng), 0.2 * u(*rng), 0.65 + 0.04 * u(*rng), 80 + 50 * u(*rng),
      2000 + 200 * u(*rng), u(*rng), u(*rng), u(*rng), 10 * u(*rng), 100 * u(*rng);
  return x;
}

// An input drawn uniformly inside Table I's box.
inline Eigen::Vector4d RandomInput(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector4d lo = hopper::InputLowerBound(), hi = hopper::InputUpperBound();
  Eigen::Vector4d v;
  for (int i = 0; i < 4; ++i) v(i) = lo(i) + (hi(i) - lo(i)) * u(*rng);
  return v;
}

}  // namespace ddoc::testing
