// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The optimal control problem (9)-(10): a switched system, its costs, the input and
// duration bounds (6)-(7), and the surface-penalty weights w_k of (8).
#ifndef DDOC_PROBLEM_H_
#define DDOC_PROBLEM_H_

#include "ddoc/switched_system.h"

namespace ddoc {

/// Input bounds (6) and per-mode duration bounds (7).
///
///   u_min <= u(t) <= u_max                                         (6)
///   duration_min(k) <= T_k - T_{k-1} <= duration_max(k),  T_{-1} = 0  (7)
///
/// Zero-based modes: T_k is the end of mode k, T_{K-1} the end of the trial.
/// Equal lower and upper bounds are allowed (a fixed input or a fixed duration).
struct Bounds {
  Vector u_min;         ///< m
  Vector u_max;         ///< m
  Vector duration_min;  ///< K, each > 0
  Vector duration_max;  ///< K, each >= duration_min, finite
};

/// The problem (9)-(10). Non-owning: `system` and `cost` must outlive the Problem and every
/// object built from it (BackwardPass, OnlineController, Learner, ModelPlant).
struct Problem {
  const SwitchedSystem* system = nullptr;  ///< the (possibly inexact) model f_k, g_k, h_k
  const SwitchedCost* cost = nullptr;      ///< l_k, phi_k
  Bounds bounds;                           ///< (6)-(7)
  Vector surface_weights;                  ///< w_k of (8), size K, >= 0; 0 = no penalty

  /// Throws InvalidArgument naming the first problem found: null system/cost, K == 0,
  /// size mismatches (u bounds vs m, duration bounds and weights vs K), reversed bounds
  /// (min > max), empty (size-0) bound vectors, non-finite entries, duration_min <= 0,
  /// negative weights, or a positive weight on a mode without surface (s_k == 0).
  void Validate() const;

  int num_modes() const { return system->num_modes(); }
  int input_dim() const { return system->input_dim(); }
};

}  // namespace ddoc

#endif  // DDOC_PROBLEM_H_
