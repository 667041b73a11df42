// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#ifndef DDOC_TESTS_CORE_TEST_UTIL_H_
#define DDOC_TESTS_CORE_TEST_UTIL_H_

#include <algorithm>
#include <cmath>
#include <functional>

#include "ddoc/switched_system.h"

namespace ddoc {
namespace testing {

/// Central-difference Jacobian of fn at v (step h * max(1, |v_i|)).
inline Matrix FdJacobian(const std::function<Vector(const Vector&)>& fn, const Vector& v,
                         double h = 1e-6) {
  const Vector f0 = fn(v);
  Matrix J(f0.size(), v.size());
  for (int i = 0; i < v.size(); ++i) {
    const double step = h * std::max(1.0, std::abs(v(i)));
    Vector vp = v, vm = v;
    vp(i) += step;
    vm(i) -= step;
    J.col(i) = (fn(vp) - fn(vm)) / (2 * step);
  }
  return J;
}

/// max |a - b| / max(1, max |b|).
inline double RelError(const Matrix& a, const Matrix& b) {
  const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

inline Vector Scalar(double v) {
  Vector out(1);
  out(0) = v;
  return out;
}

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_TEST_UTIL_H_
