// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/backward_pass.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "small_product.h"
#include "symmetric_update.h"

namespace ddoc {

// The nonzero patterns of the interval's [D f_x, f] (n x (n+1)) and D f_u (n x m). A mode whose
// first interval (in a sweep) has dense Jacobians keeps full patterns for the rest of the sweep:
// finding the zeros of a dense matrix every interval costs more than it saves.
struct BackwardPass::Sparsity {
  internal::ColumnPattern fx, fu;
  bool first = true;   // the next Evaluate is the first interval of its mode in this sweep
  bool full = false;   // this mode's patterns are full for the rest of the sweep
};

// The coefficients of all the intervals of a Run, evaluated by whole-mode batch calls when the
// system (system = true) or the cost (cost = true) prefers_batch(). Mode k's intervals j = 0 ..
// N_k - 2 are the columns of n_k-row blocks starting at its first sample s0 = index(k, 0):
// mode k's part of a quantity with r rows per interval (at most r_max) is the r x (N_k - 1)
// matrix at data() + s0 r_max (columns of r entries, so mode k needs no more than its samples'
// share).
struct BackwardPass::Batch {
  bool system = false, cost = false;
  Vector x;    // n_max S: the intervals' midpoints (x_j + x_{j+1}) / 2
  Vector f;    // n_max S: f_k
  Vector fx;   // n_max^2 S: f_x, n x n per interval
  Vector fu;   // n_max m S: f_u, n x m
  Vector l;    // S: l_k
  Vector lx;   // n_max S
  Vector lu;   // m S
  Vector lxx;  // n_max^2 S
  Vector luu;  // m^2 S
  Vector lux;  // m n_max S: m x n per interval
  // Mode k's rows x (N_k - 1) block of `v` (r_max rows per sample at most).
  static Eigen::Map<Matrix> Block(Vector& v, int r_max, int s0, int rows, int cols) {
    return Eigen::Map<Matrix>(v.data() + static_cast<Eigen::Index>(s0) * r_max, rows, cols);
  }
  // Interval j's rows x cols entries of `v` in mode k (first sample s0).
  static Eigen::Map<const Matrix> At(const Vector& v, int r_max, int s0, int j, int rows,
                                     int cols) {
    return Eigen::Map<const Matrix>(
        v.data() + static_cast<Eigen::Index>(s0) * r_max +
            static_cast<Eigen::Index>(j) * rows * cols,
        rows, cols);
  }
};

BackwardPass::BackwardPass() : sparsity_(std::make_unique<Sparsity>()) {}
BackwardPass::~BackwardPass() = default;

void BackwardPass::Interval::Allocate(int n, int m) {
  f.setZero(n);
  fx.setZero(n, n + 1);
  fu.setZero(n, m);
  fx_unit.setZero(n, n);
  fu_unit.setZero(n, m);
  lx.setZero(n);
  lu.setZero(m);
  lxx.setZero(n, n);
  lux.setZero(m, n);
  H.setZero(m, m);
  Hinv.setZero(m, m);
  kc.setZero(m);
  lo.setZero(m);
  hi.setZero(m);
}

void BackwardPass::Allocate(const Problem& problem, int max_samples,
                            const BackwardPassSettings& settings) {
  problem.Validate();
  if (max_samples < 2) {
    throw InvalidArgument("BackwardPass::Allocate: max_samples = " + std::to_string(max_samples) +
                          ", expected >= 2");
  }
  if (!(settings.cyclic_value >= 0.0 && settings.cyclic_value <= 1.0)) {
    throw InvalidArgument("BackwardPassSettings: cyclic_value = " +
                          std::to_string(settings.cyclic_value) + ", expected in [0, 1]");
  }
  if (settings.cyclic_max_sweeps < 1 || !(settings.cyclic_tolerance > 0)) {
    throw InvalidArgument(
        "BackwardPassSettings: cyclic_max_sweeps must be >= 1 and "
        "cyclic_tolerance > 0");
  }
  if (settings.max_substeps < 1) {
    throw InvalidArgument("BackwardPassSettings: max_substeps = " +
                          std::to_string(settings.max_substeps) + ", expected >= 1");
  }
  if (settings.min_substeps < 1) {
    throw InvalidArgument("BackwardPassSettings: min_substeps = " +
                          std::to_string(settings.min_substeps) + ", expected >= 1");
  }
  problem_ = &problem;
  settings_ = settings;
  const SwitchedSystem& sys = *problem.system;
  K_ = sys.num_modes();
  m_ = sys.input_dim();
  n_max_ = sys.max_state_dim();
  nz_max_ = n_max_ + K_;
  max_samples_ = max_samples;
  layout_.Allocate(sys, max_samples, "BackwardPass::Allocate");
  box_ = false;
  on_bound_tol_.resize(m_);
  for (int i = 0; i < m_; ++i) {
    box_ = box_ || std::isfinite(problem.bounds.u_min(i)) || std::isfinite(problem.bounds.u_max(i));
    const double range = problem.bounds.u_max(i) - problem.bounds.u_min(i);
    on_bound_tol_(i) = kOnBoundTolerance * (std::isfinite(range) ? std::max(1.0, range) : 1.0);
  }
  int s_max = 1;
  for (int k = 0; k < K_; ++k) s_max = std::max(s_max, sys.surface_dim(k));
  tau_.setZero(max_samples);
  P_store_.setZero(nz_max_ * nz_max_, max_samples);
  p_store_.setZero(nz_max_, max_samples);
  gain_store_.setZero(m_ * nz_max_, max_samples);
  ff_store_.setZero(m_, max_samples);
  grad_store_.setZero(m_, max_samples);
  step_store_.setZero(m_, max_samples);
  h_store_.setZero(m_ * m_, max_samples);
  gradient_T_.setZero(K_);
  c_.Allocate(n_max_, m_);
  sparsity_->fx.Allocate(n_max_, n_max_ + 1);
  sparsity_->fu.Allocate(n_max_, m_);
  xmid_.setZero(n_max_);
  phiz_.setZero(n_max_);
  phizz_.setZero(n_max_, n_max_);
  gx_.setZero(n_max_, n_max_);
  h_.setZero(s_max);
  hx_.setZero(s_max, n_max_);
  P_.setZero(nz_max_, nz_max_);
  Ps_.setZero(nz_max_, nz_max_);
  p_.setZero(nz_max_);
  ps_.setZero(nz_max_);
  lam_.setZero(nz_max_);
  lams_.setZero(nz_max_);
  for (int i = 0; i < 4; ++i) {
    dP_[i].setZero(nz_max_, nz_max_);
    dp_[i].setZero(nz_max_);
    dlam_[i].setZero(nz_max_);
  }
  Z_.setZero(nz_max_, n_max_);
  w_.setZero(nz_max_);
  M_.setZero(nz_max_, m_);
  W_.setZero(nz_max_, m_);
  Mt_.setZero(m_, nz_max_);
  hx_curv_.setZero(n_max_);
  hu_curv_.setZero(m_);
  gu_.setZero(m_);
  k_.setZero(m_);
  tmpm_.setZero(m_);
  tmp_.setZero(nz_max_, nz_max_);
  llt_ = Eigen::LLT<Matrix>(m_);
  hff_.setZero(m_, m_);
  stiff_gain_.setZero(m_, n_max_);
  stiff_k_.setZero(m_, n_max_);
  stiff_acl_.setZero(n_max_, n_max_);
  stiff_scale_.setOnes(n_max_);
  stiff_rows_.setZero(n_max_, 2);
  free_.assign(m_, 0);
  qp_.Allocate(m_);
  event_f_.setZero(n_max_);
  event_hx_.setZero(n_max_);
  event_Pi_.setZero(n_max_, n_max_);
  cyclic_P0_.setZero(n_max_, n_max_);
  cyclic_G_.setZero(n_max_, n_max_);
  cyclic_tmp_.setZero(n_max_, n_max_);
  cyclic_valid_ = false;
  valid_ = false;
  total_substeps_ = 0;
  batch_.reset();
  if (sys.prefers_batch() || problem.cost->prefers_batch()) {
    batch_ = std::make_unique<Batch>();
    Batch& b = *batch_;
    b.system = sys.prefers_batch();
    b.cost = problem.cost->prefers_batch();
    const Eigen::Index S = max_samples, n = n_max_, m = m_;
    b.x.setZero(n * S);
    if (b.system) {
      b.f.setZero(n * S);
      b.fx.setZero(n * n * S);
      b.fu.setZero(n * m * S);
    }
    if (b.cost) {
      b.l.setZero(S);
      b.lx.setZero(n * S);
      b.lu.setZero(m * S);
      b.lxx.setZero(n * n * S);
      b.luu.setZero(m * m * S);
      b.lux.setZero(m * n * S);
    }
  }
}

Eigen::Map<const Matrix> BackwardPass::P(int k, int j) const {
  if (!settings_.keep_P_trajectory && j != 0 && j != layout_.count(k) - 1) {
    throw InvalidArgument("BackwardPass::P(" + std::to_string(k) + ", " + std::to_string(j) +
                          "): only the first and last sample of a mode are kept (set "
                          "BackwardPassSettings::keep_P_trajectory)");
  }
  const int nz = augmented_dim(k);
  return Eigen::Map<const Matrix>(P_store_.col(index(k, j)).data(), nz, nz);
}
Eigen::Map<const Vector> BackwardPass::p(int k, int j) const {
  return Eigen::Map<const Vector>(p_store_.col(index(k, j)).data(), augmented_dim(k));
}
Eigen::Map<const Matrix> BackwardPass::Gain(int k, int j) const {
  return Eigen::Map<const Matrix>(gain_store_.col(index(k, j)).data(), m_, augmented_dim(k));
}
Eigen::Map<const Vector> BackwardPass::Feedforward(int k, int j) const {
  return Eigen::Map<const Vector>(ff_store_.col(index(k, j)).data(), m_);
}
Eigen::Map<const Matrix> BackwardPass::Hessian(int k, int j) const {
  return Eigen::Map<const Matrix>(h_store_.col(index(k, j)).data(), m_, m_);
}
Eigen::Map<const Vector> BackwardPass::Gradient(int k, int j) const {
  return Eigen::Map<const Vector>(grad_store_.col(index(k, j)).data(), m_);
}
Eigen::Map<const Vector> BackwardPass::Step(int k, int j) const {
  return Eigen::Map<const Vector>(step_store_.col(index(k, j)).data(), m_);
}
Eigen::Map<const Vector> BackwardPass::p2_initial() const {
  return Eigen::Map<const Vector>(p_store_.col(0).data() + layout_.dim(0), K_);
}
Matrix BackwardPass::P22_initial() const { return P(0, 0).bottomRightCorner(K_, K_); }

Matrix BackwardPass::cyclic_value() const {
  if (!cyclic_valid_ || problem_ == nullptr) return Matrix();
  const int n0 = problem_->system->state_dim(0);
  return cyclic_P0_.topLeftCorner(n0, n0);
}

void BackwardPass::SeedCyclicValue(const Matrix& P0) {
  if (problem_ == nullptr) {
    throw InvalidArgument("BackwardPass::SeedCyclicValue: call Allocate first");
  }
  const int n0 = problem_->system->state_dim(0);
  if (P0.rows() != n0 || P0.cols() != n0) {
    throw InvalidArgument("BackwardPass::SeedCyclicValue: P0 is " + std::to_string(P0.rows()) +
                          "x" + std::to_string(P0.cols()) + ", expected n_0 x n_0 = " +
                          std::to_string(n0) + "x" + std::to_string(n0));
  }
  if (!P0.allFinite()) {
    throw InvalidArgument("BackwardPass::SeedCyclicValue: P0 has a non-finite entry");
  }
  cyclic_P0_.topLeftCorner(n0, n0) = P0;
  cyclic_valid_ = true;
}

namespace {

// y = A^T x for column-major A (one contiguous dot product per column of A).
template <class MatA, class VecX, class VecY>
inline void TransposeTimes(const MatA& A, const VecX& x, VecY&& y) {
  for (Eigen::Index i = 0; i < A.cols(); ++i) y(i) = A.col(i).dot(x);
}

}  // namespace

void BackwardPass::Evaluate(int k, const Trajectory& nominal, int j, const Matrix* du_prev) {
  // Interval j of mode k: u_j held on [t_j, t_{j+1}], coefficients at the midpoint state.
  const SwitchedSystem& sys = *problem_->system;
  const SwitchedCost& cost = *problem_->cost;
  const int n = layout_.dim(k);
  const ModeTrajectory& mode = nominal.modes[k];
  auto xm = xmid_.head(n);
  xm = 0.5 * (mode.x.col(j) + mode.x.col(j + 1));
  const auto u = mode.u.col(j);
  const double D = nominal.T(k) - (k == 0 ? 0.0 : nominal.T(k - 1));
  c_.D = D;
  auto f = c_.f.head(n);
  auto fx = c_.fx.topLeftCorner(n, n);
  auto fu = c_.fu.topRows(n);
  const int s0 = index(k, 0);
  if (batch_ && batch_->system) {  // EvaluateBatch's values at this interval's midpoint
    const int nm = n_max_;
    f = Batch::At(batch_->f, nm, s0, j, n, 1);
    fx = Batch::At(batch_->fx, nm * nm, s0, j, n, n);
    fu = Batch::At(batch_->fu, nm * m_, s0, j, n, m_);
  } else {
    sys.Flow(k, xm, u, f);
    sys.FlowDerivatives(k, xm, u, fx, fu);
  }
  if (D == 0) {  // a vanished mode: D f_x = 0 loses the per-unit-time derivatives it needs
    c_.fx_unit.topLeftCorner(n, n) = fx;
    c_.fu_unit.topRows(n) = fu;
  }
  fx *= D;
  fu *= D;
  c_.fx.col(n).head(n) = f;  // [D f_x, f]: one product gives P(:, 0:n) D f_x and P(:, 0:n) f
  Sparsity& sp = *sparsity_;
  if (!sp.full) {
    sp.fx.Find(n, n + 1, c_.fx.data(), static_cast<int>(c_.fx.outerStride()));
    sp.fu.Find(n, m_, c_.fu.data(), static_cast<int>(c_.fu.outerStride()));
    if (sp.first && sp.fx.dense() && (m_ == 0 || sp.fu.dense())) {
      sp.fx.SetFull(n, n + 1);
      sp.fu.SetFull(n, m_);
      sp.full = true;
    }
    sp.first = false;
  }
  auto lx = c_.lx.head(n);
  auto lxx = c_.lxx.topLeftCorner(n, n);
  auto lux = c_.lux.leftCols(n);
  // lxx: D is applied in SymmetricStage.
  if (batch_ && batch_->cost) {  // EvaluateBatch's values at this interval's midpoint
    const int nm = n_max_;
    c_.l = batch_->l(s0 + j);
    lx = Batch::At(batch_->lx, nm, s0, j, n, 1);
    c_.lu = Batch::At(batch_->lu, m_, s0, j, m_, 1);
    lxx = Batch::At(batch_->lxx, nm * nm, s0, j, n, n);
    c_.H = Batch::At(batch_->luu, m_ * m_, s0, j, m_, m_);
    lux = Batch::At(batch_->lux, m_ * nm, s0, j, m_, n);
  } else {
    c_.l = cost.Running(k, xm, u);
    cost.RunningDerivatives(k, xm, u, lx, c_.lu, lxx, c_.H, lux);
  }
  lux *= D;
  if (D > 0) {
    c_.H *= D;
    if (m_ > 0) luu_scale_ = std::max(luu_scale_, c_.H.diagonal().cwiseAbs().maxCoeff());
  }  // else a vanished mode: H = l_uu + mu I per unit time, for its Hamiltonian step (FreeSet)
  c_.H.diagonal().array() += mu_;
  if (m_ > 0) {
    c_.lo = problem_->bounds.u_min - u;
    c_.hi = problem_->bounds.u_max - u;
    // A nominal input on (or, measured, slightly beyond) its bound: the step may not leave it.
    // Within kOnBoundTolerance of the range it is on the bound: rounding in the measured input
    // must not make it free (full feedback, one side of which the plant's QP clips).
    for (int i = 0; i < m_; ++i) {
      if (c_.lo(i) > -on_bound_tol_(i)) c_.lo(i) = 0.0;
      if (c_.hi(i) < on_bound_tol_(i)) c_.hi(i) = 0.0;
    }
  }
  du_prev_ = du_prev;
  du_index_ = index(k, j);
}

void BackwardPass::EvaluateBatch(const Trajectory& nominal) {
  // Every interval of every mode, at the midpoint Evaluate would use, in one call per mode
  // and quantity: a Python system pays one call per mode and Run instead of one per interval
  // and sweep (the cyclic value sweeps several times over the same coefficients).
  Batch& b = *batch_;
  const int nm = n_max_, m = m_;
  for (int k = 0; k < K_; ++k) {
    const int n = layout_.dim(k);
    const int intervals = layout_.count(k) - 1;
    if (intervals <= 0) continue;
    const int s0 = index(k, 0);
    const ModeTrajectory& mode = nominal.modes[k];
    auto X = Batch::Block(b.x, nm, s0, n, intervals);
    for (int j = 0; j < intervals; ++j) X.col(j) = 0.5 * (mode.x.col(j) + mode.x.col(j + 1));
    const auto U = mode.u.leftCols(intervals);
    if (b.system) {
      problem_->system->FlowBatch(k, X, U, Batch::Block(b.f, nm, s0, n, intervals));
      problem_->system->FlowDerivativesBatch(k, X, U,
                                             Batch::Block(b.fx, nm * nm, s0, n, n * intervals),
                                             Batch::Block(b.fu, nm * m, s0, n, m * intervals));
    }
    if (b.cost) {
      const SwitchedCost& cost = *problem_->cost;
      cost.RunningBatch(k, X, U, b.l.segment(s0, intervals));
      cost.RunningDerivativesBatch(k, X, U, Batch::Block(b.lx, nm, s0, n, intervals),
                                   Batch::Block(b.lu, m, s0, m, intervals),
                                   Batch::Block(b.lxx, nm * nm, s0, n, n * intervals),
                                   Batch::Block(b.luu, m * m, s0, m, m * intervals),
                                   Batch::Block(b.lux, m * nm, s0, m, n * intervals));
    }
  }
}

bool BackwardPass::FreeSet(int n, const ConstMatrixRef& /*P*/, const ConstVectorRef& p) {
  // The full step k of the interval with the current p (the right end of the interval) fixes
  // which inputs are free (box-constrained DDP: clamped inputs get no feedback).
  const int m = m_;
  if (m == 0) return true;
  if (c_.D == 0 && settings_.equation == BackwardEquation::kRiccati) return VanishedStep(n, p);
  gu_.noalias() = c_.D * c_.lu;
  gu_.noalias() += c_.fu.topRows(n).transpose() * p.head(n);
  if (settings_.equation != BackwardEquation::kRiccati) {
    // kLyapunov needs no H^{-1}; H must still be positive definite for (33).
    llt_.compute(c_.H);
    return llt_.info() == Eigen::Success;
  }
  int nf = 0;
  c_.kc.setZero();
  if (box_ && settings_.box_aware) {
    if (qp_.Solve(c_.H, gu_, c_.lo, c_.hi, k_) == BoxQPStatus::kNotPositiveDefinite) return false;
    for (int i = 0; i < m; ++i) {
      if (k_(i) <= c_.lo(i) || k_(i) >= c_.hi(i)) {
        c_.kc(i) = k_(i);
      } else {
        free_[nf++] = i;
      }
    }
  } else {
    for (int i = 0; i < m; ++i) free_[nf++] = i;
  }
  // Hinv = H_FF^{-1} embedded (zeros on the clamped rows and columns).
  auto hff = hff_.topLeftCorner(nf, nf);
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b < nf; ++b) hff(a, b) = c_.H(free_[a], free_[b]);
  }
  c_.Hinv.setZero();
  if (nf == 0) return true;
  if (nf == m) {
    llt_.compute(c_.H);
    if (llt_.info() != Eigen::Success) return false;
    c_.Hinv.setIdentity();
    llt_.solveInPlace(c_.Hinv);
    return true;
  }
  Eigen::LLT<Eigen::Ref<Matrix>> llt(hff);  // in place on hff_
  if (llt.info() != Eigen::Success) return false;
  auto inv = tmp_.topLeftCorner(nf, nf);
  inv.setIdentity();
  llt.solveInPlace(inv);
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b < nf; ++b) c_.Hinv(free_[a], free_[b]) = inv(a, b);
  }
  return true;
}

bool BackwardPass::VanishedStep(int n, const ConstVectorRef& p) {
  // A mode of zero duration: its inputs do not act on the cost (F_u = L_u = 0), so they get no
  // feedback (no free input, no Riccati term) and the step is the pointwise minimizer of the
  // mode's Hamiltonian l + p_x^T f over the box, k = argmin 1/2 k^T (l_uu + mu) k + k^T (l_u +
  // f_u^T p_x): free of cost now, it makes the next pass's gradient w.r.t. D_k the one-sided
  // derivative min_u H_k (docs/engine.md, "Modes of zero duration").
  c_.Hinv.setZero();
  gu_ = c_.lu;
  gu_.noalias() += c_.fu_unit.topRows(n).transpose() * p.head(n);
  k_.setZero();
  if (qp_.Solve(c_.H, gu_, c_.lo, c_.hi, k_) == BoxQPStatus::kNotPositiveDefinite) return false;
  c_.kc = k_;  // all inputs "clamped" at the step: Derivative's k = kc
  return true;
}

void BackwardPass::Product(int rows, int depth, const double* X, int ldx, bool fx, double* Y,
                           int ldy) {
  // The model's Jacobians are sparse (the hopper's D f_x: 17 of 196 entries in flight); the
  // sparse kernel skips exact zeros and gives the dense kernel's bits. Dense where they are not.
  const internal::ColumnPattern& pattern = fx ? sparsity_->fx : sparsity_->fu;
  const double* A = fx ? c_.fx.data() : c_.fu.data();
  const int lda = static_cast<int>(fx ? c_.fx.outerStride() : c_.fu.outerStride());
  if (!pattern.dense()) {
    internal::SparseProduct(rows, X, ldx, A, lda, pattern, Y, ldy);
  } else {
    internal::SmallProduct(rows, pattern.cols, depth, X, ldx, A, lda, Y, ldy);
  }
}

void BackwardPass::Derivative(int k, int n, const ConstMatrixRef& P, const ConstVectorRef& p,
                              const ConstVectorRef& lam, MatrixRef dP, VectorRef dp, VectorRef dlam,
                              bool store_mid, int s) {
  const int K = K_;
  const int nz = n + K;
  const int m = m_;
  const bool riccati = settings_.equation == BackwardEquation::kRiccati;
  const double D = c_.D;
  riccati_term_ = false;
  const auto px = p.head(n);
  const int ldP = static_cast<int>(P.outerStride());
  const int ldd = static_cast<int>(dP.outerStride());
  const int ldfx = static_cast<int>(c_.fx.outerStride());
  const int ldfu = static_cast<int>(c_.fu.outerStride());
  // dP is returned as its "half" Y with dP = Y + Y^T + D l_xx - M_F H_FF^{-1} M_F^T
  // (SymmetricStage forms the sum fused with the stage update; the last term is left in tmp_).
  // P F_z = [P(:, 0:n) D f_x, w c^T] with w = P(:, 0:n) f: the product goes straight into the
  // left columns of Y, w into column n+k (and -w into n+k-1).
  Product(nz, n, P.data(), ldP, true, dP.data(), ldd);
  // Column n now holds w; move it to column n + k, -w to n + k - 1, zeros elsewhere.
  {
    double* y = dP.data();
    double* wn = y + static_cast<Eigen::Index>(n) * ldd;
    if (k > 0) {
      double* wk = y + static_cast<Eigen::Index>(n + k) * ldd;
      double* wk1 = wk - ldd;
      for (int i = 0; i < nz; ++i) {
        const double v = wn[i];
        wk[i] = v;  // n + k > n: read before it is cleared below
        wk1[i] = -v;
      }
    }
    for (int c = n; c < nz; ++c) {
      if (c == n + k || (k > 0 && c == n + k - 1)) continue;
      double* yc = y + static_cast<Eigen::Index>(c) * ldd;
      for (int i = 0; i < nz; ++i) yc[i] = 0.0;
    }
  }
  // + (l_x + time curvature p_x^T f_x) c^T in the (x, T) column(s) (the symmetric sum adds
  // its transpose; D l_xx is added there too).
  auto hx = hx_curv_.head(n);
  if (settings_.time_curvature && D == 0) {  // a vanished mode: f_x, f_u per unit time
    TransposeTimes(c_.fx_unit.topLeftCorner(n, n), px, hx);
    TransposeTimes(c_.fu_unit.topRows(n), px, hu_curv_);
  } else if (settings_.time_curvature) {
    internal::SparseTransposeTimes(c_.fx.data(), ldfx, sparsity_->fx, n, px.data(), hx.data());
    hx *= 1.0 / D;
    internal::SparseTransposeTimes(c_.fu.data(), ldfu, sparsity_->fu, m, px.data(),
                                   hu_curv_.data());
    hu_curv_ *= 1.0 / D;
  } else {
    hx.setZero();
    hu_curv_.setZero();
  }
  for (int i = 0; i < n; ++i) {  // l_x + p_x^T f_x
    const double v = c_.lx(i) + hx(i);
    dP(i, n + k) += v;
    if (k > 0) dP(i, n + k - 1) -= v;
  }
  // dp = F_z^T p + L_z: x part D f_x^T p_x + D l_x, T part c (f^T p_x + l); the transposed
  // product over [D f_x, f] gives D f_x^T p_x and f^T p_x (into dp(n)) at once.
  auto adjoint_rate = [&](const ConstVectorRef& v, VectorRef dv) {
    internal::SparseTransposeTimes(c_.fx.data(), ldfx, sparsity_->fx, n + 1, v.data(), dv.data());
    const double vt = dv(n) + c_.l;
    for (int i = 0; i < n; ++i) dv(i) += D * c_.lx(i);
    dv.tail(K).setZero();
    dv(n + k) = vt;
    if (k > 0) dv(n + k - 1) = -vt;
  };
  adjoint_rate(p, dp);
  // M = P F_u + L_zu (nz x m): needed by kRiccati, by use_previous_du and for the gain output.
  const bool need_M = riccati || store_mid || (settings_.use_previous_du && du_prev_ != nullptr);
  auto M = M_.topRows(nz);
  const int ldM = static_cast<int>(M_.outerStride());
  if (need_M && m > 0) {
    Product(nz, n, P.data(), ldP, false, M_.data(), ldM);
    for (int j = 0; j < m; ++j) {
      double* mj = M_.data() + static_cast<Eigen::Index>(j) * ldM;
      for (int i = 0; i < n; ++i) mj[i] += c_.lux(j, i);
      const double h = hu_curv_(j) + c_.lu(j);  // l_u + p_x^T f_u: the row of L_uz for T_k
      hu_curv_(j) = h;
      mj[n + k] += h;
      if (k > 0) mj[n + k - 1] -= h;
    }
  }
  if (m > 0) {
    internal::SparseTransposeTimes(c_.fu.data(), ldfu, sparsity_->fu, m, px.data(), gu_.data());
  }
  for (int i = 0; i < m; ++i) gu_(i) += D * c_.lu(i);
  if (riccati && m > 0) {
    // k = kc - Hinv (g_u + H kc), dP -= (M Hinv) M^T (its upper triangle, all SymmetricStage
    // reads), dp += M k.
    for (int i = 0; i < m; ++i) {
      double t = gu_(i);
      for (int j = 0; j < m; ++j) t += c_.H(i, j) * c_.kc(j);
      tmpm_(i) = t;
    }
    for (int i = 0; i < m; ++i) {
      double t = 0.0;
      for (int j = 0; j < m; ++j) t += c_.Hinv(i, j) * tmpm_(j);
      k_(i) = c_.kc(i) - t;
    }
    const int ldW = static_cast<int>(W_.outerStride());
    internal::SmallProduct(nz, m, m, M_.data(), ldM, c_.Hinv.data(),
                           static_cast<int>(c_.Hinv.outerStride()), W_.data(), ldW);
    double* mt = Mt_.data();  // M^T, m x nz (leading dimension m)
    for (int j = 0; j < m; ++j) {
      const double* mj = M_.data() + static_cast<Eigen::Index>(j) * ldM;
      for (int i = 0; i < nz; ++i) mt[i * m + j] = mj[i];
    }
    const int ldt = static_cast<int>(tmp_.outerStride());
    for (int c = 0; c < nz; c += 4) {  // blocks of 4 columns, down to the diagonal
      const int cols = std::min(4, nz - c);
      internal::SmallProduct(c + cols, cols, m, W_.data(), ldW, mt + c * m, m,
                             tmp_.data() + c * ldt, ldt);
    }
    riccati_term_ = true;  // SymmetricStage subtracts tmp_
    for (int j = 0; j < m; ++j) {  // dp += M k
      const double* mj = M_.data() + static_cast<Eigen::Index>(j) * ldM;
      const double kj = k_(j);
      for (int r = 0; r < nz; ++r) dp(r) += mj[r] * kj;
    }
  } else if (settings_.use_previous_du && du_prev_ != nullptr && m > 0) {
    dp.noalias() += M * du_prev_->col(du_index_);
  }
  // The gradient adjoint: dlam = F_z^T lam + L_z (aliases p when the p-equation is the adjoint).
  const bool separate_lambda = riccati || settings_.use_previous_du;
  if (separate_lambda) adjoint_rate(lam, dlam);
  if (store_mid) {
    Eigen::Map<Matrix> gain(gain_store_.col(s).data(), m, nz);
    if (m > 0) gain = M.transpose();
    if (riccati) {
      // Box-constrained DDP: the inputs clamped on this interval get no feedback (their rows of
      // the gain are zero), as P assumed.
      for (int i = 0; i < m; ++i) {
        if (c_.Hinv(i, i) == 0.0) gain.row(i).setZero();
      }
    }
    ff_store_.col(s) = gu_;
    auto grad = grad_store_.col(s);
    if (m > 0) {
      internal::SparseTransposeTimes(c_.fu.data(), ldfu, sparsity_->fu, m,
                                     separate_lambda ? lam.data() : px.data(), grad.data());
    }
    grad += D * c_.lu;
    if (riccati) {
      if (box_ && settings_.box_aware && m > 0 && D > 0) {
        // The stored step is the box QP's at this (midpoint) gradient: the free set was fixed at
        // the interval's right end, and the free inputs' Newton step at the midpoint can leave
        // the box; the plant's QP (33) would clamp it, and the prediction would count what the
        // plant cannot apply. From k_ as the warm start; it stays feasible and k^T g_u <= 0.
        if (qp_.Solve(c_.H, gu_, c_.lo, c_.hi, k_) == BoxQPStatus::kNotPositiveDefinite) {
          k_ = k_.cwiseMax(c_.lo).cwiseMin(c_.hi);
        }
      }
      step_store_.col(s) = k_;
    } else {
      step_store_.col(s).setZero();
    }
    Eigen::Map<Matrix>(h_store_.col(s).data(), m, m) = c_.H;
  }
}

void BackwardPass::StoreState(int k, int j) {
  const int nz = layout_.dim(k) + K_;
  const int s = index(k, j);
  p_store_.col(s).head(nz) = p_.head(nz);
  if (!settings_.keep_P_trajectory && j != 0 && j != layout_.count(k) - 1) return;
  Eigen::Map<Matrix>(P_store_.col(s).data(), nz, nz) = P_.topLeftCorner(nz, nz);
}

void BackwardPass::CopyOutputs(int from, int to) {
  gain_store_.col(to) = gain_store_.col(from);
  ff_store_.col(to) = ff_store_.col(from);
  grad_store_.col(to) = grad_store_.col(from);
  step_store_.col(to) = step_store_.col(from);
  h_store_.col(to) = h_store_.col(from);
}

bool BackwardPass::EventProjection(int k, const Trajectory& nominal) {
  const SwitchedSystem& sys = *problem_->system;
  const int n = layout_.dim(k);
  const ModeTrajectory& mode = nominal.modes[k];
  const int last = mode.num_samples() - 1;
  auto hx = event_hx_.head(n);
  if (!sys.GuardGradient(k, mode.x.col(last), mode.u.col(last), hx)) return false;
  auto f = event_f_.head(n);
  sys.Flow(k, mode.x.col(last), mode.u.col(last), f);
  const double rate = hx.dot(f);  // d gamma / dt at the switch
  if (!(std::abs(rate) > 1e-9 * (hx.norm() * f.norm() + 1e-300))) return false;
  event_cost_rate_ = problem_->cost->Running(k, mode.x.col(last), mode.u.col(last)) / rate;
  auto Pi = event_Pi_.topLeftCorner(n, n);
  Pi.setIdentity();
  for (int j = 0; j < n; ++j) Pi.col(j) -= f * (hx(j) / rate);
  return true;
}

void BackwardPass::JumpOrTerminal(int k, const Trajectory& nominal, bool cyclic) {
  // Terminal condition (k = K-1) or the jump at tau = k+1 into the pre-switch sample of mode k:
  //   P^- = Phi_zz + G^T P^+ G,  p^- = Phi_z + G^T p^+,  G = blockdiag(g_x, I_K).
  const SwitchedSystem& sys = *problem_->system;
  const int n = layout_.dim(k);
  const int K = K_;
  const int nz = n + K;
  const ModeTrajectory& mode = nominal.modes[k];
  const auto x = mode.x.col(mode.num_samples() - 1);
  auto phiz = phiz_.head(n);
  auto phizz = phizz_.topLeftCorner(n, n);
  problem_->cost->SwitchingDerivatives(k, x, phiz, phizz);
  const double wk = problem_->SurfaceWeight(k);
  if (wk > 0) {  // surface penalty (8), Gauss-Newton Hessian
    const int sk = sys.surface_dim(k);
    auto h = h_.head(sk);
    auto hx = hx_.topLeftCorner(sk, n);
    sys.Surface(k, x, h);
    sys.SurfaceDerivative(k, x, hx);
    phiz.noalias() += 2.0 * wk * hx.transpose() * h;
    phizz.noalias() += 2.0 * wk * hx.transpose() * hx;
  }
  if (k == K - 1 && terminal_projected_) {
    // The horizon ends at the plant's event: a deviation dx moves the event by
    // -gamma_x dx / (gamma_x f); first order: p_x = Pi^T Phi_x - (l / gamma_x f) gamma_x.
    auto Pi = event_Pi_.topLeftCorner(n, n);
    auto t = tmp_.topLeftCorner(n, n);
    t.noalias() = phizz * Pi;
    phizz.noalias() = Pi.transpose() * t;
    auto v = event_f_.head(n);  // f is no longer needed: scratch for Pi^T Phi_x
    v.noalias() = Pi.transpose() * phiz;
    phiz = v - event_cost_rate_ * event_hx_.head(n);
  }
  if (settings_.psd_switching_hessians) {
    const Matrix sym = 0.5 * (phizz + phizz.transpose());
    Eigen::SelfAdjointEigenSolver<Matrix> eig(sym);
    phizz = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() *
            eig.eigenvectors().transpose();
  }
  if (k == K - 1) {
    P_.topLeftCorner(nz, nz).setZero();
    P_.topLeftCorner(n, n) = phizz;
    p_.head(nz).setZero();
    p_.head(n) = phiz;
    lam_.head(nz) = p_.head(nz);
    if (cyclic) {  // + gamma_c G^T P_0 G: the value of the next cycle
      const int n0 = layout_.dim(0);
      auto G = cyclic_G_.topLeftCorner(n0, n);
      auto t = cyclic_tmp_.topLeftCorner(n0, n);
      t.noalias() = cyclic_P0_.topLeftCorner(n0, n0) * G;
      P_.topLeftCorner(n, n).noalias() += settings_.cyclic_value * (G.transpose() * t);
    }
    return;
  }
  const int n1 = layout_.dim(k + 1);
  const int nz1 = n1 + K;
  auto gx = gx_.topLeftCorner(n1, n);
  sys.ResetDerivative(k, x, gx);
  // tmp = P^+ (nz1 x nz1) before it is overwritten.
  auto Pp = tmp_.topLeftCorner(nz1, nz1);
  Pp = P_.topLeftCorner(nz1, nz1);
  auto Pn = P_.topLeftCorner(nz, nz);
  auto GtP = Ps_.topLeftCorner(n, nz1);  // g_x^T P^+(0:n1, :)
  GtP.noalias() = gx.transpose() * Pp.topRows(n1);
  Pn.topLeftCorner(n, n).noalias() = GtP.leftCols(n1) * gx;
  Pn.topLeftCorner(n, n) += phizz;
  Pn.topRightCorner(n, K) = GtP.rightCols(K);
  Pn.bottomLeftCorner(K, n) = Pn.topRightCorner(n, K).transpose();
  Pn.bottomRightCorner(K, K) = Pp.bottomRightCorner(K, K);
  for (Vector* v : {&p_, &lam_}) {
    auto pp = ps_.head(nz1);
    pp = v->head(nz1);
    v->head(n).noalias() = gx.transpose() * pp.head(n1);
    v->head(n) += phiz;
    v->segment(n, K) = pp.tail(K);
  }
}

void BackwardPass::IntegrateStep(int k, int n, double h, int s, bool store, double interval) {
  // One midpoint (or RK4) step of length h backward from (P_, p_, lam_) with the interval's
  // constant coefficients; `store` writes the mid-stage outputs of sample s, with the predicted
  // decrease weighted by the whole interval's length.
  const int nz = n + K_;
  const bool rk4 = settings_.integrator == BackwardIntegrator::kRk4;
  const bool riccati = settings_.equation == BackwardEquation::kRiccati;
  auto P = P_.topLeftCorner(nz, nz);
  auto p = p_.head(nz);
  auto lam = lam_.head(nz);
  auto Ps = Ps_.topLeftCorner(nz, nz);
  auto ps = ps_.head(nz);
  auto lams = lams_.head(nz);
  auto d0 = dP_[0].topLeftCorner(nz, nz);
  auto d1 = dP_[1].topLeftCorner(nz, nz);
  auto e0 = dp_[0].head(nz);
  auto e1 = dp_[1].head(nz);
  auto l0 = dlam_[0].head(nz);
  auto l1 = dlam_[1].head(nz);
  const bool separate_lambda = riccati || settings_.use_previous_du;
  // Stage 1 at the right end, stage 2 at the midpoint (its outputs are the interval's).
  const int ld = nz_max_;
  const double D = c_.D;
  // dP = Y + Y^T + D l_xx - R of a stage whose Derivative left Y in `Y` (R in tmp_).
  auto terms = [&](MatrixRef Y) {
    internal::SymmetricTerms t;
    t.nz = nz;
    t.n = n;
    t.Y = Y.data();
    t.ldy = ld;
    t.L = c_.lxx.data();
    t.ldl = static_cast<int>(c_.lxx.outerStride());
    t.q = D;
    t.R = riccati_term_ ? tmp_.data() : nullptr;
    t.ldr = static_cast<int>(tmp_.outerStride());
    return t;
  };
  using internal::SymmetricStage;
  using internal::SymmetricUpdate;
  Derivative(k, n, P, p, lam, d0, e0, l0, false, s);
  // RK4 keeps each stage's dP (upper triangle) in its Y for the final combination.
  SymmetricStage(terms(d0), rk4 ? SymmetricUpdate::kRk4Stage : SymmetricUpdate::kStage, P.data(),
                 ld, Ps.data(), ld, 0.5 * h);
  ps = p + (0.5 * h) * e0;
  if (separate_lambda) lams = lam + (0.5 * h) * l0;
  Derivative(k, n, Ps, ps, separate_lambda ? lams : ps, d1, e1, l1, store, s);
  if (riccati && store && D > 0) {  // a vanished mode's step changes no cost
    predicted_linear_ += interval * k_.dot(gu_);
    tmpm_.noalias() = c_.H * k_;
    predicted_quadratic_ += interval * k_.dot(tmpm_);
  }
  if (!rk4) {
    SymmetricStage(terms(d1), SymmetricUpdate::kStep, P.data(), ld, nullptr, 0, h);
    p += h * e1;
    if (separate_lambda) lam += h * l1;
  } else {
    auto d2 = dP_[2].topLeftCorner(nz, nz);
    auto d3 = dP_[3].topLeftCorner(nz, nz);
    auto e2 = dp_[2].head(nz);
    auto e3 = dp_[3].head(nz);
    auto l2 = dlam_[2].head(nz);
    auto l3 = dlam_[3].head(nz);
    SymmetricStage(terms(d1), SymmetricUpdate::kRk4Stage, P.data(), ld, Ps.data(), ld, 0.5 * h);
    ps = p + (0.5 * h) * e1;
    if (separate_lambda) lams = lam + (0.5 * h) * l1;
    Derivative(k, n, Ps, ps, separate_lambda ? lams : ps, d2, e2, l2, false, s);
    SymmetricStage(terms(d2), SymmetricUpdate::kRk4Stage, P.data(), ld, Ps.data(), ld, h);
    ps = p + h * e2;
    if (separate_lambda) lams = lam + h * l2;
    Derivative(k, n, Ps, ps, separate_lambda ? lams : ps, d3, e3, l3, false, s);
    SymmetricStage(terms(d3), SymmetricUpdate::kRk4Final, P.data(), ld, nullptr, 0, h / 6.0,
                   d0.data(), d1.data(), d2.data(), ld);
    p += (h / 6.0) * (e0 + 2.0 * e1 + 2.0 * e2 + e3);
    if (separate_lambda) lam += (h / 6.0) * (l0 + 2.0 * l1 + 2.0 * l2 + l3);
  }
  if (!separate_lambda) lam = p;
}

double BackwardPass::RiccatiStiffness(int n, const ConstMatrixRef& P, double limit) {
  // A bound on the eigenvalues of the closed loop A_cl = D f_x - F_u H_FF^-1 G, G = F_u^T P_xx +
  // L_ux. An explicit Runge-Kutta step commutes with a change of coordinates z -> S z, so its
  // stability and accuracy are those of S^-1 A_cl S for any S: with S diagonal,
  // |S^-1 A_cl S|_inf >= max |lambda_i| bounds the eigenvalues as |A_cl|_inf does, and can be
  // far smaller on a badly scaled system (the hopper's angles against its N/m stiffness
  // commands: ~20 against ~1000, eigenvalues ~5-8, in tau units). S is this mode's from the
  // last balancing (Osborne's iteration in powers of 2, as LAPACK's dgebal), balanced again
  // only when the bound exceeds `limit`. Cheap first: |S^-1 A_cl S| <= |S^-1 D f_x S| +
  // |S^-1 F_u| |H_FF^-1| |G S|, with the nonzero patterns of D f_x and F_u, and |G S| <=
  // |F_u^T| |P_xx S| + |L_ux S| before G itself (an n x n x m product for a dense F_u).
  const int m = m_;
  const double* d = stiff_scale_.data();
  const internal::ColumnPattern& fx_nz = sparsity_->fx;
  const internal::ColumnPattern& fu_nz = sparsity_->fu;
  auto row = stiff_rows_.col(0).head(n);  // row sums of |D f_x S|
  row.setZero();
  for (int c = 0; c < n; ++c) {
    for (int q = fx_nz.start[c]; q < fx_nz.start[c + 1]; ++q) {
      const int l = fx_nz.rows[q];
      row(l) += std::abs(c_.fx(l, c)) * d[c];
    }
  }
  double fx_norm = 0.0, fu_norm = 0.0;
  auto fu_row = stiff_rows_.col(1).head(n);  // row sums of |F_u|
  fu_row.setZero();
  for (int i = 0; i < m; ++i) {
    for (int q = fu_nz.start[i]; q < fu_nz.start[i + 1]; ++q) {
      fu_row(fu_nz.rows[q]) += std::abs(c_.fu(fu_nz.rows[q], i));
    }
  }
  for (int l = 0; l < n; ++l) {
    fx_norm = std::max(fx_norm, row(l) / d[l]);
    fu_norm = std::max(fu_norm, fu_row(l) / d[l]);
  }
  double h_norm = 0.0, fut_norm = 0.0, lux_norm = 0.0;
  for (int i = 0; i < m; ++i) {
    double hr = 0.0, fr = 0.0, lr = 0.0;
    for (int j = 0; j < m; ++j) hr += std::abs(c_.Hinv(i, j));
    for (int q = fu_nz.start[i]; q < fu_nz.start[i + 1]; ++q) {
      fr += std::abs(c_.fu(fu_nz.rows[q], i));
    }
    for (int c = 0; c < n; ++c) lr += std::abs(c_.lux(i, c)) * d[c];
    h_norm = std::max(h_norm, hr);
    fut_norm = std::max(fut_norm, fr);
    lux_norm = std::max(lux_norm, lr);
  }
  double ps_norm = 0.0;  // |P_xx S|_inf
  for (int r = 0; r < n; ++r) {
    double sum = 0.0;
    for (int c = 0; c < n; ++c) sum += std::abs(P(r, c)) * d[c];
    ps_norm = std::max(ps_norm, sum);
  }
  const double coarse = fx_norm + fu_norm * h_norm * (fut_norm * ps_norm + lux_norm);
  if (coarse <= limit || !std::isfinite(coarse)) return coarse;
  auto gain = stiff_gain_.leftCols(n);  // m x n: G
  for (int c = 0; c < n; ++c) {
    const double* pc = P.data() + static_cast<Eigen::Index>(c) * P.outerStride();
    for (int i = 0; i < m; ++i) {
      double t = c_.lux(i, c);
      for (int q = fu_nz.start[i]; q < fu_nz.start[i + 1]; ++q) {
        const int l = fu_nz.rows[q];
        t += c_.fu(l, i) * pc[l];  // P_xx(l, c) = P_xx(c, l) up to rounding
      }
      gain(i, c) = t;
    }
  }
  double g_norm = 0.0;
  for (int i = 0; i < m; ++i) {
    double gr = 0.0;
    for (int c = 0; c < n; ++c) gr += std::abs(gain(i, c)) * d[c];
    g_norm = std::max(g_norm, gr);
  }
  const double bound = fx_norm + fu_norm * h_norm * g_norm;
  if (bound <= limit || !std::isfinite(bound)) return bound;
  // The closed loop itself, scaled: B = S^-1 A_cl S.
  auto kx = stiff_k_.leftCols(n);  // m x n: H_FF^-1 G
  for (int c = 0; c < n; ++c) {
    for (int i = 0; i < m; ++i) {
      double t = 0.0;
      for (int j = 0; j < m; ++j) t += c_.Hinv(i, j) * gain(j, c);
      kx(i, c) = t;
    }
  }
  auto acl = stiff_acl_.topLeftCorner(n, n);
  acl = c_.fx.topLeftCorner(n, n);
  for (int i = 0; i < m; ++i) {
    for (int q = fu_nz.start[i]; q < fu_nz.start[i + 1]; ++q) {
      const int l = fu_nz.rows[q];
      const double a = c_.fu(l, i);
      for (int c = 0; c < n; ++c) acl(l, c) -= a * kx(i, c);
    }
  }
  double* a = acl.data();
  const Eigen::Index lda = acl.outerStride();
  row.setZero();  // row sums of |A_cl S|
  for (int c = 0; c < n; ++c) {
    for (int r = 0; r < n; ++r) row(r) += std::abs(a[c * lda + r]) * d[c];
  }
  double scaled = 0.0;
  for (int r = 0; r < n; ++r) scaled = std::max(scaled, row(r) / d[r]);
  if (scaled <= limit || !std::isfinite(scaled)) return scaled;
  for (int c = 0; c < n; ++c) {
    for (int r = 0; r < n; ++r) a[c * lda + r] *= d[c] / d[r];
  }
  auto norm_inf = [&]() {
    double norm = 0.0;
    for (int r = 0; r < n; ++r) {
      double sum = 0.0;
      for (int c = 0; c < n; ++c) sum += std::abs(a[c * lda + r]);
      norm = std::max(norm, sum);
    }
    return norm;
  };
  // Balance B in place from the current S (S's entries stay powers of 2 times the last S's).
  double* dm = stiff_scale_.data();
  for (int sweep = 0; sweep < 10; ++sweep) {
    bool changed = false;
    for (int i = 0; i < n; ++i) {
      double col = 0.0, rw = 0.0;
      for (int j = 0; j < n; ++j) {
        if (j == i) continue;
        col += std::abs(a[i * lda + j]);
        rw += std::abs(a[j * lda + i]);
      }
      if (!(col > 0.0) || !(rw > 0.0) || !std::isfinite(col + rw)) continue;
      const double before = col + rw;
      double f = 1.0;
      while (col < 0.5 * rw) {
        col *= 2.0;
        rw *= 0.5;
        f *= 2.0;
      }
      while (col >= 2.0 * rw) {
        col *= 0.5;
        rw *= 2.0;
        f *= 0.5;
      }
      if (col + rw < 0.95 * before) {  // column i times f, row i divided by f: S_ii *= f
        changed = true;
        dm[i] *= f;
        for (int j = 0; j < n; ++j) {
          a[i * lda + j] *= f;
          a[j * lda + i] /= f;
        }
      }
    }
    if (!changed) break;
  }
  return norm_inf();
}

bool BackwardPass::Sweep(const Trajectory& nominal, const Matrix* du_prev, bool cyclic) {
  predicted_linear_ = 0;
  predicted_quadratic_ = 0;
  const bool riccati = settings_.equation == BackwardEquation::kRiccati;
  for (int k = K_ - 1; k >= 0; --k) {
    const int n = layout_.dim(k);
    const int nz = n + K_;
    const int N = layout_.count(k);
    JumpOrTerminal(k, nominal, cyclic);
    StoreState(k, N - 1);
    auto P = P_.topLeftCorner(nz, nz);
    auto p = p_.head(nz);
    stiff_scale_.setOnes();  // each mode balances from S = I (RiccatiStiffness)
    sparsity_->first = true;
    sparsity_->full = false;
    for (int j = N - 2; j >= 0; --j) {
      const int s = index(k, j);
      Evaluate(k, nominal, j, du_prev);
      if (!FreeSet(n, P, p)) {
        status_ = BackwardStatus::kNotPositiveDefinite;
        return false;
      }
      const double h = tau_(s + 1) - tau_(s);
      // Sub-steps where the Riccati equation is stiff for an explicit step: its linearization
      // dP -> A_cl^T dP + dP A_cl has eigenvalues lambda_i + lambda_j of the closed loop A_cl, so
      // h |S^-1 A_cl S|_inf <= 1 (any diagonal S; RiccatiStiffness) keeps h |lambda_i + lambda_j|
      // <= 2 (explicit midpoint's real-axis limit; RK4's is 2.8).
      int substeps = 1;
      if (riccati && m_ > 0 && h > 0 && settings_.max_substeps > 1) {
        const double stiff = RiccatiStiffness(n, P, 1.0 / h);
        if (h * stiff > 1.0) {
          substeps = static_cast<int>(std::min<double>(settings_.max_substeps, std::ceil(h * stiff)));
        }
      }
      substeps = std::max(substeps, settings_.min_substeps);
      substeps_ += substeps;
      total_substeps_ += substeps;
      for (int sub = 0; sub < substeps; ++sub) {
        IntegrateStep(k, n, h / substeps, s, sub == substeps / 2, h);
      }
      StoreState(k, j);
    }
    CopyOutputs(index(k, N - 2), index(k, N - 1));
    if (!P.allFinite() || !p.allFinite()) {
      status_ = BackwardStatus::kNonFinite;
      return false;
    }
  }
  gradient_T_ = lam_.segment(layout_.dim(0), K_);
  return true;
}

bool BackwardPass::Run(const Trajectory& nominal, double regularization, const Matrix* du_prev) {
  if (problem_ == nullptr) throw InvalidArgument("BackwardPass::Run: call Allocate first");
  valid_ = false;
  status_ = BackwardStatus::kOk;
  if (!(regularization >= 0) || !std::isfinite(regularization)) {
    throw InvalidArgument("BackwardPass::Run: regularization = " + std::to_string(regularization) +
                          ", expected finite and >= 0");
  }
  mu_ = regularization;
  luu_scale_ = 0;
  substeps_ = 0;
  // Allocation-free structural checks (the full validation is the caller's job).
  if (nominal.num_modes() != K_ || nominal.T.size() != K_) {
    throw InvalidArgument("BackwardPass::Run: trajectory has " +
                          std::to_string(nominal.num_modes()) + " modes and T of size " +
                          std::to_string(nominal.T.size()) +
                          ", expected K = " + std::to_string(K_));
  }
  const int total = layout_.Assign(nominal, "BackwardPass::Run");
  if (settings_.use_previous_du && du_prev != nullptr &&
      (du_prev->rows() != m_ || du_prev->cols() != total)) {
    throw InvalidArgument("BackwardPass::Run: du_prev is " + std::to_string(du_prev->rows()) + "x" +
                          std::to_string(du_prev->cols()) + ", expected m x samples = " +
                          std::to_string(m_) + "x" + std::to_string(total));
  }
  const Matrix* du = settings_.use_previous_du ? du_prev : nullptr;
  for (int k = 0; k < K_; ++k) {
    for (int j = 0; j < layout_.count(k); ++j) tau_(layout_.index(k, j)) = nominal.Tau(k, j);
  }
  k_.setZero();
  if (batch_) EvaluateBatch(nominal);
  terminal_projected_ = settings_.terminal_event && EventProjection(K_ - 1, nominal);
  const bool cyclic = settings_.cyclic_value > 0 &&
                      settings_.equation == BackwardEquation::kRiccati &&
                      problem_->system->has_cycle_reset();
  if (!cyclic) {
    sweeps_ = 1;
    if (!Sweep(nominal, du, false)) return false;
    valid_ = true;
    return true;
  }
  const int n0 = layout_.dim(0);
  const int nK = layout_.dim(K_ - 1);
  {
    const ModeTrajectory& last = nominal.modes[K_ - 1];
    problem_->system->ResetDerivative(K_ - 1, last.x.col(last.num_samples() - 1),
                                      cyclic_G_.topLeftCorner(n0, nK));
    if (terminal_projected_) {
      auto t = cyclic_tmp_.topLeftCorner(n0, nK);
      t.noalias() = cyclic_G_.topLeftCorner(n0, nK) * event_Pi_.topLeftCorner(nK, nK);
      cyclic_G_.topLeftCorner(n0, nK) = t;
    }
  }
  if (!cyclic_valid_) cyclic_P0_.topLeftCorner(n0, n0).setZero();
  sweeps_ = 0;
  for (int sweep = 0; sweep < settings_.cyclic_max_sweeps; ++sweep) {
    if (!Sweep(nominal, du, true)) {
      cyclic_valid_ = false;
      return false;
    }
    ++sweeps_;
    Eigen::Map<const Matrix> P0(P_store_.col(index(0, 0)).data(), n0 + K_, n0 + K_);
    const double change = (P0.topLeftCorner(n0, n0) - cyclic_P0_.topLeftCorner(n0, n0)).norm();
    const double size = P0.topLeftCorner(n0, n0).norm();
    cyclic_P0_.topLeftCorner(n0, n0) = P0.topLeftCorner(n0, n0);
    if (!std::isfinite(size)) break;
    if (change <= settings_.cyclic_tolerance * std::max(size, 1e-12)) break;
  }
  cyclic_valid_ = cyclic_P0_.topLeftCorner(n0, n0).allFinite();
  valid_ = true;
  return true;
}

}  // namespace ddoc
