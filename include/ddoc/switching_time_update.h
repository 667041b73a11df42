// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The switching-time update (31).
#ifndef DDOC_SWITCHING_TIME_UPDATE_H_
#define DDOC_SWITCHING_TIME_UPDATE_H_

#include <limits>

#include "ddoc/box_qp.h"
#include "ddoc/problem.h"

namespace ddoc {

/// Settings of the switching-time update.
struct SwitchingTimeSettings {
  /// Levenberg-Marquardt-type floor on the spectrum of the reduced Hessian H = S^T P22 S:
  /// eigenvalues below floor = relative_regularization * max|lambda(H)| become
  /// max(|lambda|, floor).
  double relative_regularization = 1e-3;
  /// Additional cap |dD_k| <= max_duration_step on each duration change (s); default none.
  double max_duration_step = std::numeric_limits<double>::infinity();
};

/// Result of (31).
struct SwitchingTimeStep {
  Vector dT;                  ///< K: delta T_alpha
  Vector T_planned;           ///< K: T^{i+1} = T^i + dT
  double regularization = 0;  ///< largest eigenvalue increase applied (0: H was used as is)
  /// Predicted cost change of the step, 1/2 dT^T P22 dT + p2^T dT (the modified P22, full p2).
  double model_change = 0;
  BoxQPStatus status = BoxQPStatus::kConverged;
};

/// min 1/2 x^T H x + g^T x  s.t.  lo <= x <= hi,  sum_lo <= 1^T x <= sum_hi  (H positive
/// definite, bounds may be infinite). The sum constraint is met through its multiplier nu:
/// 1^T x(nu) of the box QP with g + nu 1 is non-increasing in nu and is bisected to the active
/// bound, then the equality-constrained KKT system on the free variables is solved exactly.
/// x is resized to the problem size. Allocates (between trials).
BoxQPStatus SolveDurationQp(const Matrix& H, const Vector& g, const Vector& lo, const Vector& hi,
                            double sum_lo, double sum_hi, Vector* x);

/// Solves (31):  min_dT 1/2 dT^T P22(0) dT + alpha p2(0)^T dT  subject to (7) at T^i + dT and
/// the final-time box final_time_min <= T_{K-1}^i + dT_{K-1} <= final_time_max.
///
/// The bounds (7) are on durations D_k = T_k - T_{k-1}, not on T, so the QP is solved in the
/// duration change dD (dT = S dD, S lower triangular ones): H = S^T P22 S, g = alpha S^T p2,
/// box duration_min - D^i <= dD <= duration_max - D^i (the paper's (25) writes the box on T
/// directly, which only holds for K = 1), and the final time is the sum constraint of
/// SolveDurationQp. A nominal duration within rounding (1e-12 relative) of its bound is on it.
///
/// P22 comes from the Lyapunov-type (30) and need not be positive definite (it is often
/// singular: the Lyapunov P22 has no curvature in D_0 when l does not depend on time). Regularized
/// Newton step (Levenberg-Marquardt type, eigenvalue modification): with H = V diag(lambda) V^T
/// and floor = relative_regularization * max|lambda| (1 when H = 0), every lambda_i < floor is
/// replaced by max(|lambda_i|, floor). Positive definite H are used unchanged (exact Newton step
/// in the box); negative curvature is mirrored, so the step stays a descent direction whose length
/// scales with alpha (a plain shift H + mu I would make the step huge along the shifted
/// directions).
///
/// Not allocation-free (runs between trials).
SwitchingTimeStep SolveSwitchingTimeUpdate(const Problem& problem, const ConstVectorRef& T_nominal,
                                           const ConstMatrixRef& P22, const ConstVectorRef& p2,
                                           double alpha, const SwitchingTimeSettings& settings = {});

}  // namespace ddoc

#endif  // DDOC_SWITCHING_TIME_UPDATE_H_
