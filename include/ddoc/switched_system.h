// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The user-facing description of a switched system (paper Section II):
// K modes visited in order k = 0..K-1 (the paper's k = 1..K), each with its own
// state dimension n_k, a common input dimension m, dynamics f_k, a reset g_k
// into the next mode, and an optional switching surface h_k.
#ifndef DDOC_SWITCHED_SYSTEM_H_
#define DDOC_SWITCHED_SYSTEM_H_

#include <string>
#include <vector>

#include "ddoc/types.h"

namespace ddoc {

/// A switched system with K modes visited in a fixed sequence (paper eq. (1)-(3)).
///
///   xdot = f_k(x, u),            t in [T_{k-1}, T_k],   x in R^{n_k}, u in R^m   (1)
///   x^+(T_k) = g_k(x^-(T_k)),    g_k : R^{n_k} -> R^{n_{k+1}}                     (2)
///   h_k(x^-(T_k)) = 0            optional, R^{n_k} -> R^{s_k}                      (3)
///
/// Mode indices are zero-based here. For k < K-1, g_k maps mode k into mode k+1.
/// g_{K-1} (the "cycle reset") maps the last mode back into mode 0; it is optional,
/// never differentiated by the engine, and used only by plants that repeat the
/// sequence (a hopper hops again). A system without a cycle reset reports
/// has_cycle_reset() == false.
///
/// Public methods check sizes and finiteness in one place and then call the
/// protected virtual Do... methods, which subclasses implement (Drake's pattern).
/// The checks are O(n) and allocation-free, so the engine calls the public
/// methods inside its hot loops.
class SwitchedSystem {
 public:
  virtual ~SwitchedSystem() = default;

  /// K, the number of modes in the sequence.
  int num_modes() const { return static_cast<int>(state_dims_.size()); }
  /// m, the input dimension (shared by all modes).
  int input_dim() const { return input_dim_; }
  /// n_k, the state dimension of mode k.
  int state_dim(int k) const;
  /// s_k, the dimension of the switching surface h_k at the end of mode k (0 = none).
  int surface_dim(int k) const;
  /// n_max = max_k n_k.
  int max_state_dim() const;
  /// True when g_{K-1} (last mode -> mode 0) is implemented.
  bool has_cycle_reset() const { return has_cycle_reset_; }

  /// xdot = f_k(x, u). xdot must have size n_k.
  void Flow(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef xdot) const;
  /// fx = df_k/dx (n_k x n_k), fu = df_k/du (n_k x m).
  void FlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                       MatrixRef fu) const;
  /// x_next = g_k(x), x_next in R^{n_{(k+1) mod K}}.
  void Reset(int k, const ConstVectorRef& x, VectorRef x_next) const;
  /// gx = dg_k/dx, n_{(k+1) mod K} x n_k (rectangular when the dimensions differ).
  void ResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const;
  /// h = h_k(x) in R^{s_k}. Only for s_k > 0.
  void Surface(int k, const ConstVectorRef& x, VectorRef h) const;
  /// hx = dh_k/dx, s_k x n_k. Only for s_k > 0.
  void SurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const;
  /// Optional, for plants whose switches are triggered by a state event: hx = d gamma_k / dx
  /// (size n_k) of the scalar guard gamma_k(x, u) whose zero crossing ends mode k on the plant
  /// (a hopper's foot height at touchdown, its leg force at takeoff). Returns false when the
  /// system does not provide it (the default). Used by
  /// BackwardPassSettings::terminal_event. Unlike Surface, it adds no cost.
  bool GuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef hx) const;

  /// Whole-mode evaluation, for systems whose per-point call is expensive (Python callables):
  /// true asks the backward pass to evaluate the flow and its derivatives at all the intervals
  /// of a mode with one FlowBatch and one FlowDerivativesBatch call per Run (not per point and
  /// sweep). Default false: the engine calls Flow / FlowDerivatives per point.
  virtual bool prefers_batch() const { return false; }
  /// F.col(j) = f_k(X.col(j), U.col(j)) for the N = X.cols() points: X n_k x N, U m x N,
  /// F n_k x N. The default is DoFlow per point.
  void FlowBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U, MatrixRef F) const;
  /// Block j of FX (n_k x n_k N, columns j n_k .. j n_k + n_k - 1) = df_k/dx at point j, of FU
  /// (n_k x m N, columns j m ..) = df_k/du. The default is DoFlowDerivatives per point.
  void FlowDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U, MatrixRef FX,
                            MatrixRef FU) const;

 protected:
  /// state_dims: n_k for each mode (non-empty, each > 0); input_dim: m >= 0 (0: no inputs,
  /// pure switching-time optimization);
  /// surface_dims: s_k for each mode (empty means all zero).
  SwitchedSystem(std::vector<int> state_dims, int input_dim, std::vector<int> surface_dims = {},
                 bool has_cycle_reset = false);

  virtual void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                      VectorRef xdot) const = 0;
  virtual void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                 MatrixRef fx, MatrixRef fu) const = 0;
  virtual void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const = 0;
  virtual void DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const = 0;
  virtual void DoSurface(int k, const ConstVectorRef& x, VectorRef h) const;
  virtual void DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const;
  virtual bool DoGuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                               VectorRef hx) const;
  /// Called with checked sizes and finite X, U. Default: DoFlow per column.
  virtual void DoFlowBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                           MatrixRef F) const;
  /// Called with checked sizes and finite X, U. Default: DoFlowDerivatives per column.
  virtual void DoFlowDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                      MatrixRef FX, MatrixRef FU) const;

 private:
  std::vector<int> state_dims_;    // n_k, size K
  std::vector<int> surface_dims_;  // s_k, size K
  int input_dim_ = 0;              // m
  bool has_cycle_reset_ = false;
};

/// Running costs l_k(x, u) and switching costs phi_k(x^-(T_k)) of problem (4).
/// phi_{K-1} is the terminal cost. The surface penalty w_k ||h_k||^2 of (8) is NOT
/// part of this class: the engine adds it from SwitchedSystem::Surface and the
/// weights in Problem, so that I4-type penalties are reported separately.
///
/// Same check/Do split as SwitchedSystem. All derivatives are dense.
class SwitchedCost {
 public:
  virtual ~SwitchedCost() = default;

  /// Modes the cost is defined for, checked against the system's by Problem::Validate; 0
  /// (default) = any number (a cost that does not know it).
  virtual int num_modes() const { return 0; }

  /// l_k(x, u).
  double Running(int k, const ConstVectorRef& x, const ConstVectorRef& u) const;
  /// lx (n_k), lu (m), lxx (n_k x n_k), luu (m x m), lux (m x n_k).
  void RunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                          VectorRef lu, MatrixRef lxx, MatrixRef luu, MatrixRef lux) const;
  /// phi_k(x), evaluated at x^-(T_k).
  double Switching(int k, const ConstVectorRef& x) const;
  /// phix (n_k), phixx (n_k x n_k).
  void SwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix, MatrixRef phixx) const;

  /// Whole-mode evaluation (see SwitchedSystem::prefers_batch): true asks the backward pass and
  /// EvaluateCost to evaluate the running cost and its derivatives at all the points of a mode
  /// with one RunningBatch / RunningDerivativesBatch call. Default false: per point.
  virtual bool prefers_batch() const { return false; }
  /// l(j) = l_k(X.col(j), U.col(j)) for the N = X.cols() points: X n_k x N, U m x N, l N.
  /// The default is DoRunning per point.
  void RunningBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U, VectorRef l) const;
  /// Per point j: LX.col(j) = l_x (LX n x N), LU.col(j) = l_u (m x N), and blocks j of LXX
  /// (n x n N, columns j n ..) = l_xx, LUU (m x m N, columns j m ..) = l_uu, LUX (m x n N,
  /// columns j n ..) = l_ux. The default is DoRunningDerivatives per point.
  void RunningDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                               MatrixRef LX, MatrixRef LU, MatrixRef LXX, MatrixRef LUU,
                               MatrixRef LUX) const;

 protected:
  virtual double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const = 0;
  virtual void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                    VectorRef lx, VectorRef lu, MatrixRef lxx, MatrixRef luu,
                                    MatrixRef lux) const = 0;
  virtual double DoSwitching(int k, const ConstVectorRef& x) const = 0;
  virtual void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                                      MatrixRef phixx) const = 0;
  /// Called with checked sizes and finite X, U. Default: DoRunning per column.
  virtual void DoRunningBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                              VectorRef l) const;
  /// Called with checked sizes and finite X, U. Default: DoRunningDerivatives per column.
  virtual void DoRunningDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                         MatrixRef LX, MatrixRef LU, MatrixRef LXX,
                                         MatrixRef LUU, MatrixRef LUX) const;
};

}  // namespace ddoc

#endif  // DDOC_SWITCHED_SYSTEM_H_
