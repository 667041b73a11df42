// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/problem.h"

#include <cmath>
#include <sstream>

namespace ddoc {
namespace {

void Fail(const std::string& what) { throw InvalidArgument("Problem: " + what); }

void CheckVector(const char* name, const Vector& v, Eigen::Index expected, const char* meaning) {
  if (v.size() == 0) {
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
    if (!std::isfinite(v(i))) {
      std::ostringstream os;
      os << name << "(" << i << ") = " << v(i) << " is not finite";
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
  CheckVector("bounds.u_min", bounds.u_min, m, "m inputs");
  CheckVector("bounds.u_max", bounds.u_max, m, "m inputs");
  CheckVector("bounds.duration_min", bounds.duration_min, K, "K modes");
  CheckVector("bounds.duration_max", bounds.duration_max, K, "K modes");
  CheckVector("surface_weights", surface_weights, K, "K modes");
  for (int i = 0; i < m; ++i) {
    if (bounds.u_min(i) > bounds.u_max(i)) {
      std::ostringstream os;
      os << "reversed input bounds: u_min(" << i << ") = " << bounds.u_min(i) << " > u_max(" << i
         << ") = " << bounds.u_max(i);
      Fail(os.str());
    }
  }
  for (int k = 0; k < K; ++k) {
    if (bounds.duration_min(k) <= 0) {
      std::ostringstream os;
      os << "duration_min(" << k << ") = " << bounds.duration_min(k) << ", expected > 0";
      Fail(os.str());
    }
    if (bounds.duration_min(k) > bounds.duration_max(k)) {
      std::ostringstream os;
      os << "reversed duration bounds: duration_min(" << k << ") = " << bounds.duration_min(k)
         << " > duration_max(" << k << ") = " << bounds.duration_max(k);
      Fail(os.str());
    }
    if (surface_weights(k) < 0) {
      std::ostringstream os;
      os << "surface_weights(" << k << ") = " << surface_weights(k) << ", expected >= 0";
      Fail(os.str());
    }
    if (surface_weights(k) > 0 && system->surface_dim(k) == 0) {
      std::ostringstream os;
      os << "surface_weights(" << k << ") = " << surface_weights(k)
         << " > 0 but mode " << k << " has no switching surface (s_k = 0)";
      Fail(os.str());
    }
  }
}

}  // namespace ddoc
