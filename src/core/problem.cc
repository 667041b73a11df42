// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/problem.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "ddoc/quadratic_cost.h"

namespace ddoc {
namespace {

void Fail(const std::string& what) { throw InvalidArgument("Problem: " + what); }

// `infinite_ok`: +-inf entries are allowed (input bounds); NaN never is.
void CheckVector(const char* name, const Vector& v, Eigen::Index expected, const char* meaning,
                 bool infinite_ok = false) {
  if (v.size() == 0 && expected > 0) {
    std::ostringstream os;
    os << name << " is empty, expected size " << expected << " (" << meaning << ")";
    Fail(os.str());
  }
  if (v.size() != expected) {
    std::ostringstream os;
    os << name << " has size " << v.size() << ", expected " << expected << " (" << meaning << ")";
    Fail(os.str());
  }
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (std::isnan(v(i)) || (!infinite_ok && !std::isfinite(v(i)))) {
      std::ostringstream os;
      os << name << "(" << i << ") = " << v(i) << (infinite_ok ? " is NaN" : " is not finite");
      Fail(os.str());
    }
  }
}

}  // namespace

void Problem::Validate() const {
  if (system == nullptr) Fail("system is null");
  if (cost == nullptr) Fail("cost is null");
  const int K = system->num_modes();
  const int m = system->input_dim();
  if (K == 0) Fail("empty mode sequence (K = 0)");
  if (cost->num_modes() > 0 && cost->num_modes() != K) {
    std::ostringstream os;
    os << "the cost has " << cost->num_modes() << " modes, the system " << K
       << " (one cost entry per mode of the system)";
    Fail(os.str());
  }
  CheckVector("bounds.u_min", bounds.u_min, m, "m inputs", true);
  CheckVector("bounds.u_max", bounds.u_max, m, "m inputs", true);
  CheckVector("bounds.duration_min", bounds.duration_min, K, "K modes");
  const bool final_time_finite = std::isfinite(bounds.final_time_max);
  if (!(final_time_finite && bounds.duration_max.size() == 0)) {
    // With a finite final time the durations are bounded by it: +inf entries are allowed.
    CheckVector("bounds.duration_max", bounds.duration_max, K,
                final_time_finite ? "K modes, or empty: bounded by final_time_max"
                                  : "K modes; finite, as final_time_max is inf",
                final_time_finite);
  }
  bool has_surface = false;
  for (int k = 0; k < K; ++k) has_surface = has_surface || system->surface_dim(k) > 0;
  if (surface_weights.size() > 0 || has_surface) {
    CheckVector("surface_weights", surface_weights, K,
                "K modes; may be empty only when no mode has a switching surface");
  }
  for (int i = 0; i < m; ++i) {
    if (bounds.u_min(i) == std::numeric_limits<double>::infinity() ||
        bounds.u_max(i) == -std::numeric_limits<double>::infinity()) {
      std::ostringstream os;
      os << "empty input box: u_min(" << i << ") = " << bounds.u_min(i) << ", u_max(" << i
         << ") = " << bounds.u_max(i);
      Fail(os.str());
    }
    if (bounds.u_min(i) > bounds.u_max(i)) {
      std::ostringstream os;
      os << "reversed input bounds: u_min(" << i << ") = " << bounds.u_min(i) << " > u_max(" << i
         << ") = " << bounds.u_max(i);
      Fail(os.str());
    }
  }
  for (int k = 0; k < K; ++k) {
    if (bounds.duration_min(k) < 0) {
      std::ostringstream os;
      os << "duration_min(" << k << ") = " << bounds.duration_min(k)
         << ", expected >= 0 (0: mode " << k << " may vanish)";
      Fail(os.str());
    }
    if (bounds.duration_min(k) > bounds.MaxDuration(k)) {
      std::ostringstream os;
      os << "reversed duration bounds: duration_min(" << k << ") = " << bounds.duration_min(k)
         << " > the upper bound " << bounds.MaxDuration(k) << " (duration_max(" << k
         << "), or final_time_max when smaller)";
      Fail(os.str());
    }
    if (SurfaceWeight(k) < 0) {
      std::ostringstream os;
      os << "surface_weights(" << k << ") = " << SurfaceWeight(k) << ", expected >= 0";
      Fail(os.str());
    }
    if (SurfaceWeight(k) > 0 && system->surface_dim(k) == 0) {
      std::ostringstream os;
      os << "surface_weights(" << k << ") = " << SurfaceWeight(k)
         << " > 0 but mode " << k << " has no switching surface (s_k = 0)";
      Fail(os.str());
    }
  }
  // A quadratic cost without curvature in an unbounded input: no minimum in that input (the
  // learner's line search used to fail after 27 trials).
  if (const auto* quadratic = dynamic_cast<const QuadraticTrackingCost*>(cost)) {
    for (int k = 0; k < K && m > 0; ++k) {
      const Eigen::SelfAdjointEigenSolver<Matrix> eig(quadratic->R(k));
      const double scale = std::max(1.0, quadratic->R(k).cwiseAbs().maxCoeff());
      for (int j = 0; j < m; ++j) {
        if (eig.eigenvalues()(j) > 1e-12 * scale) continue;
        const Vector v = eig.eigenvectors().col(j);
        for (int i = 0; i < m; ++i) {
          if (std::abs(v(i)) > 1e-6 && (std::isinf(bounds.u_min(i)) || std::isinf(bounds.u_max(i)))) {
            std::ostringstream os;
            os << "R[" << k << "] of the quadratic cost is singular (eigenvalue "
               << eig.eigenvalues()(j) << ") in a direction of input " << i
               << ", which is unbounded (u_min(" << i << ") = " << bounds.u_min(i) << ", u_max("
               << i << ") = " << bounds.u_max(i) << "): the problem has no minimum in u; give "
               << "R > 0 or finite input bounds";
            Fail(os.str());
          }
        }
      }
    }
  }
  const double tf_min = bounds.final_time_min, tf_max = bounds.final_time_max;
  if (std::isnan(tf_min) || std::isnan(tf_max) || tf_min < 0 ||
      tf_min == std::numeric_limits<double>::infinity()) {
    std::ostringstream os;
    os << "final-time bounds [" << tf_min << ", " << tf_max
       << "]: expected 0 <= final_time_min < inf and final_time_max not NaN";
    Fail(os.str());
  }
  if (tf_min > tf_max) {
    std::ostringstream os;
    os << "reversed final-time bounds: final_time_min = " << tf_min << " > final_time_max = "
       << tf_max;
    Fail(os.str());
  }
  double sum_max = 0;
  for (int k = 0; k < K; ++k) sum_max += bounds.MaxDuration(k);
  const double sum_min = bounds.duration_min.sum();
  if (sum_min > tf_max || sum_max < tf_min) {
    std::ostringstream os;
    os << "final-time bounds [" << tf_min << ", " << tf_max
       << "] cannot be met by the duration bounds: their sums allow [" << sum_min << ", "
       << sum_max << "]";
    Fail(os.str());
  }
}

}  // namespace ddoc
