// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The numbers of the standard problems, shared by their ddoc definitions
// (standard_problems.cc) and by the independent reference solvers (standard_references.cc),
// so that both solve the same problem while neither uses the other's code.
#ifndef DDOC_TESTS_CORE_STANDARD_PROBLEM_DATA_H_
#define DDOC_TESTS_CORE_STANDARD_PROBLEM_DATA_H_

#include <vector>

#include "ddoc/types.h"

namespace ddoc {
namespace testing {

/// A switched linear-quadratic problem with time-based switching and a fixed final time:
///
///   xdot = A_k x + B_k u                      in mode k, x in R^{n_k}, u in R^m
///   x^+ = E_k x^-                             at the end of mode k < K-1
///   l_k = 1/2 (x - r_k)' Q_k (x - r_k) + 1/2 u' R_k u + rho_k
///   phi_k = 1/2 (x - s_k)' S_k (x - s_k)       at the end of mode k (phi_{K-1}: terminal)
///   u_min <= u <= u_max,  T_{K-1} = final_time
///
/// m = 0 (no input) is allowed: then B_k is n_k x 0 and R_k is 0 x 0.
struct LinearQuadraticData {
  std::vector<Matrix> A;  ///< K, n_k x n_k
  std::vector<Matrix> B;  ///< K, n_k x m
  std::vector<Matrix> E;  ///< K - 1, n_{k+1} x n_k (rectangular when n_k != n_{k+1})
  std::vector<Matrix> Q;  ///< K, n_k x n_k, symmetric >= 0
  std::vector<Vector> r;  ///< K, n_k: running-cost reference
  std::vector<Matrix> R;  ///< K, m x m, symmetric > 0
  std::vector<double> rho;  ///< K: constant running cost (a price on the time spent in mode k)
  std::vector<Matrix> S;  ///< K, n_k x n_k, symmetric >= 0
  std::vector<Vector> s;  ///< K, n_k: switching/terminal-cost reference
  Vector u_min;           ///< m, may be -inf
  Vector u_max;           ///< m, may be +inf
  Vector x0;              ///< n_0
  double final_time = 1;  ///< s, T_{K-1}

  int num_modes() const { return static_cast<int>(A.size()); }
  int input_dim() const { return B.empty() ? 0 : static_cast<int>(B[0].cols()); }
  int state_dim(int k) const { return static_cast<int>(A[k].rows()); }
};

/// The Lotka-Volterra fishing problem with a fixed 0/1 fishing sequence (Sager's benchmark
/// library; SwitchTimeOpt.jl's nonlinear example), K = fishing.size() modes:
///
///   x0dot = x0 - x0 x1 - c0 x0 w_k,   x1dot = -x1 + x0 x1 - c1 x1 w_k,   w_k in {0, 1}
///   l = weight ((x0 - 1)^2 + (x1 - 1)^2),  identity resets, no switching or terminal cost.
struct FishingData {
  double c0 = 0.4;                 ///< fishing rate of the prey
  double c1 = 0.2;                 ///< fishing rate of the predator
  double weight = 0.5;             ///< cost weight (SwitchTimeOpt's 1/2 x'Qx)
  std::vector<double> fishing;     ///< K: w_k of mode k
  Vector x0;                       ///< 2: initial prey and predator biomass
  double final_time = 12;          ///< s
};

/// The three-mode nonlinear problem of Xu & Antsaklis (2004), OCS2's "EXP1":
///
///   mode 0: xdot = ( x0 + u sin x0, -x1 - u cos x1)
///   mode 1: xdot = ( x1 + u sin x1, -x0 - u cos x0)
///   mode 2: xdot = (-x0 - u sin x0,  x1 + u cos x1)
///   l = 1/2 |x - target|^2 + 1/2 u^2,  phi_2 = 1/2 |x - target|^2, identity resets.
struct Exp1Data {
  Vector target;           ///< 2
  Vector x0;               ///< 2
  double final_time = 3;   ///< s
};

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_STANDARD_PROBLEM_DATA_H_
