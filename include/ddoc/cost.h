// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The cost (9) of a sampled trajectory, split into its parts.
#ifndef DDOC_COST_H_
#define DDOC_COST_H_

#include "ddoc/problem.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// I = sum_k [ phi_k(x^-(T_k)) + w_k ||h_k(x^-(T_k))||^2 + int_{T_{k-1}}^{T_k} l_k(x, u) dt ]   (9)
struct CostBreakdown {
  Vector running;    ///< K: int l_k dt (trapezoid per sample interval, input held: ZOH)
  Vector switching;  ///< K: phi_k(x^-(T_k))
  Vector surface;    ///< K: w_k ||h_k(x^-(T_k))||^2 (the penalty of (8))
  double total = 0;  ///< sum of all parts
};

/// Evaluates (9) on a (measured or predicted) trajectory. The input u_j of sample j is held on
/// [t_j, t_{j+1}] (zero-order hold, as the plant applies it), so each interval contributes
/// (t_{j+1} - t_j) (l(x_j, u_j) + l(x_{j+1}, u_j)) / 2: second order in the sample spacing for
/// a held input. Validates the problem and the trajectory against it (throws InvalidArgument).
CostBreakdown EvaluateCost(const Problem& problem, const Trajectory& trajectory);

}  // namespace ddoc

#endif  // DDOC_COST_H_
