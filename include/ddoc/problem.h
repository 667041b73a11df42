// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The optimal control problem (9)-(10): a switched system, its costs, the input and
// duration bounds (6)-(7), and the surface-penalty weights w_k of (8).
#ifndef DDOC_PROBLEM_H_
#define DDOC_PROBLEM_H_

#include <limits>

#include "ddoc/switched_system.h"

namespace ddoc {

/// Input bounds (6), per-mode duration bounds (7) and an optional box on the final time.
///
///   u_min <= u(t) <= u_max                                         (6)
///   duration_min(k) <= T_k - T_{k-1} <= duration_max(k),  T_{-1} = 0  (7)
///   final_time_min <= T_{K-1} <= final_time_max
///
/// Zero-based modes: T_k is the end of mode k, T_{K-1} the end of the trial.
/// Equal lower and upper bounds are allowed (a fixed input, a fixed duration, a fixed final time).
/// Input bounds may be infinite (an unbounded input); with m = 0 they are empty.
struct Bounds {
  Vector u_min;         ///< m, entries in [-inf, inf), default none (set them)
  Vector u_max;         ///< m, entries in (-inf, inf], >= u_min
  /// K, s, each >= 0 (no default: set it); 0 lets mode k vanish (a legal zero-duration mode).
  Vector duration_min;
  /// K, each >= duration_min, finite; with a finite final_time_max entries may be +inf or the
  /// vector empty (default): the duration is then bounded by the final time (MaxDuration).
  Vector duration_max;
  double final_time_min = 0.0;  ///< s, lower bound on T_{K-1}; default 0 (none)
  double final_time_max = std::numeric_limits<double>::infinity();  ///< s; default inf (none)

  /// Fixes the final time: final_time_min = final_time_max = t_final (s).
  void FixFinalTime(double t_final) { final_time_min = final_time_max = t_final; }
  /// The upper bound of mode k's duration in effect: min(duration_max(k) (inf when
  /// duration_max is empty), final_time_max), in s.
  double MaxDuration(int k) const {
    const double d = duration_max.size() > k ? duration_max(k)
                                             : std::numeric_limits<double>::infinity();
    return d < final_time_max ? d : final_time_max;
  }
  /// True when the final time is boxed (a finite upper or a positive lower bound).
  bool final_time_bounded() const {
    return final_time_min > 0.0 || final_time_max < std::numeric_limits<double>::infinity();
  }
};

/// The problem (9)-(10). Non-owning: `system` and `cost` must outlive the Problem and every
/// object built from it (BackwardPass, OnlineController, Learner, ModelPlant).
struct Problem {
  const SwitchedSystem* system = nullptr;  ///< the (possibly inexact) model f_k, g_k, h_k
  const SwitchedCost* cost = nullptr;      ///< l_k, phi_k
  Bounds bounds;                           ///< (6)-(7)
  /// w_k of (8), size K, >= 0; 0 = no penalty. Empty (the default) = all 0, allowed when no
  /// mode has a switching surface.
  Vector surface_weights;

  /// Throws InvalidArgument naming the first problem found: null system/cost, K == 0,
  /// size mismatches (u bounds vs m, duration bounds and weights vs K), reversed bounds
  /// (min > max), NaN bounds, u_min = +inf or u_max = -inf, non-finite duration bounds or
  /// weights, duration_min < 0, negative weights, a positive weight on a mode without surface
  /// (s_k == 0), a final-time box that is reversed, negative or NaN, or one that the duration
  /// bounds cannot meet (sum of duration_min > final_time_max or sum of duration_max <
  /// final_time_min), a cost defined for another number of modes than the system
  /// (SwitchedCost::num_modes), or a QuadraticTrackingCost whose R_k is singular in a direction
  /// of an unbounded input.
  void Validate() const;

  int num_modes() const { return system->num_modes(); }
  int input_dim() const { return system->input_dim(); }
  /// w_k (0 when surface_weights is empty).
  double SurfaceWeight(int k) const { return surface_weights.size() > k ? surface_weights(k) : 0.0; }
};

}  // namespace ddoc

#endif  // DDOC_PROBLEM_H_
