// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#ifndef DDOC_TESTS_CORE_TEST_UTIL_H_
#define DDOC_TESTS_CORE_TEST_UTIL_H_

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "ddoc/problem.h"
#include "ddoc/switched_system.h"

namespace ddoc {
namespace testing {

/// Poses a one-mode problem on a fixed horizon (the LQR-type problems): `inputs` unbounded
/// inputs, the mode's duration fixed at T, no switching surfaces. System and cost are the caller's.
inline void PoseFixedHorizon(Problem* problem, int inputs, double T) {
  const double inf = std::numeric_limits<double>::infinity();
  problem->bounds.u_min = Vector::Constant(inputs, -inf);
  problem->bounds.u_max = Vector::Constant(inputs, inf);
  problem->bounds.duration_min = Vector::Constant(1, T);
  problem->bounds.duration_max = Vector::Constant(1, T);
  problem->surface_weights = Vector::Zero(1);
}

/// Runs f and expects an InvalidArgument whose message contains `text`.
inline void ExpectThrowsWith(const std::function<void()>& f, const std::string& text) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected one with \"" << text << "\"";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}

inline Vector Scalar(double v) {
  Vector out(1);
  out(0) = v;
  return out;
}

/// 1/2 x'Hx + g'x.
inline double QpObjective(const Matrix& H, const Vector& g, const Vector& x) {
  return 0.5 * x.dot(H * x) + g.dot(x);
}

/// A random box QP of size n: H = M M^T + shift I (M standard normal), g = g_scale N(0, 1) and
/// lo = -box (offset + |N(0, 1)|), hi = box (offset + |N(0, 1)|), drawn M first, then g, lo, hi
/// variable by variable.
struct RandomBoxQp {
  Matrix H;
  Vector g, lo, hi;
};
inline RandomBoxQp DrawRandomBoxQp(std::mt19937* rng, int n, double shift, double g_scale,
                                   double box, double offset) {
  std::normal_distribution<double> normal;
  RandomBoxQp c;
  Matrix M(n, n);
  for (int i = 0; i < n * n; ++i) M.data()[i] = normal(*rng);
  c.H = M * M.transpose() + shift * Matrix::Identity(n, n);
  c.g.resize(n);
  c.lo.resize(n);
  c.hi.resize(n);
  for (int i = 0; i < n; ++i) {
    c.g(i) = g_scale * normal(*rng);
    c.lo(i) = -box * (offset + std::abs(normal(*rng)));
    c.hi(i) = box * (offset + std::abs(normal(*rng)));
  }
  return c;
}

/// Box QP min 1/2 x'Hx + g'x, lo <= x <= hi, by brute force (an independent check of BoxQP):
/// every assignment of each variable to {lower, upper, free}; solve the free block; keep the
/// feasible point with the lowest objective. 3^n candidates, so for small n only.
inline Vector BruteForceBoxQp(const Matrix& H, const Vector& g, const Vector& lo, const Vector& hi) {
  const int n = static_cast<int>(g.size());
  int combos = 1;
  for (int i = 0; i < n; ++i) combos *= 3;
  Vector best;
  double best_value = 1e300;
  for (int c = 0; c < combos; ++c) {
    Vector x = Vector::Zero(n);
    std::vector<int> free_idx;
    std::vector<bool> is_free(n, false);
    int code = c;
    for (int i = 0; i < n; ++i, code /= 3) {
      if (code % 3 == 0) x(i) = lo(i);
      if (code % 3 == 1) x(i) = hi(i);
      if (code % 3 == 2) {
        free_idx.push_back(i);
        is_free[i] = true;
      }
    }
    const int nf = static_cast<int>(free_idx.size());
    if (nf > 0) {
      Matrix Hff(nf, nf);
      Vector rhs(nf);
      for (int a = 0; a < nf; ++a) {
        rhs(a) = -g(free_idx[a]);
        for (int i = 0; i < n; ++i) {
          if (!is_free[i]) rhs(a) -= H(free_idx[a], i) * x(i);
        }
        for (int b = 0; b < nf; ++b) Hff(a, b) = H(free_idx[a], free_idx[b]);
      }
      const Vector xf = Hff.ldlt().solve(rhs);
      for (int a = 0; a < nf; ++a) x(free_idx[a]) = xf(a);
    }
    bool feasible = true;
    for (int i = 0; i < n; ++i) feasible &= x(i) >= lo(i) - 1e-12 && x(i) <= hi(i) + 1e-12;
    const double value = QpObjective(H, g, x);
    if (feasible && value < best_value) {
      best_value = value;
      best = x;
    }
  }
  return best;
}

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_TEST_UTIL_H_
