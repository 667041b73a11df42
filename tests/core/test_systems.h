// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Switched systems and costs shared by the core tests.
#ifndef DDOC_TESTS_CORE_TEST_SYSTEMS_H_
#define DDOC_TESTS_CORE_TEST_SYSTEMS_H_

#include <cmath>
#include <vector>

#include "ddoc/autodiff.h"
#include "ddoc/problem.h"

namespace ddoc {
namespace testing {

/// xdot = A_k x + B_k u + c_k, x+ = E_k x, optional affine surface h_k = C_k x - d_k (s_k rows).
/// Hand-written derivatives. cycle_reset: E_{K-1} is the cycle reset (last mode -> mode 0).
class LinearSwitchedSystem : public SwitchedSystem {
 public:
  LinearSwitchedSystem(std::vector<Matrix> A, std::vector<Matrix> B, std::vector<Matrix> E,
                       std::vector<Matrix> C = {}, std::vector<Vector> d = {},
                       std::vector<Vector> c = {}, bool cycle_reset = false)
      : SwitchedSystem(Dims(A), static_cast<int>(B[0].cols()), SurfaceDims(A, C), cycle_reset),
        A_(std::move(A)), B_(std::move(B)), E_(std::move(E)), C_(std::move(C)), d_(std::move(d)),
        c_(std::move(c)) {}

  std::vector<Matrix> A_, B_, E_, C_;
  std::vector<Vector> d_, c_;

 protected:
  static std::vector<int> Dims(const std::vector<Matrix>& A) {
    std::vector<int> n;
    for (const auto& a : A) n.push_back(static_cast<int>(a.rows()));
    return n;
  }
  static std::vector<int> SurfaceDims(const std::vector<Matrix>& A, const std::vector<Matrix>& C) {
    std::vector<int> s(A.size(), 0);
    for (size_t k = 0; k < C.size(); ++k) s[k] = static_cast<int>(C[k].rows());
    return s;
  }
  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override {
    xdot.noalias() = A_[k] * x;
    xdot.noalias() += B_[k] * u;
    if (!c_.empty()) xdot += c_[k];
  }
  void DoFlowDerivatives(int k, const ConstVectorRef&, const ConstVectorRef&, MatrixRef fx,
                         MatrixRef fu) const override {
    fx = A_[k];
    fu = B_[k];
  }
  void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const override {
    x_next.noalias() = E_[k] * x;
  }
  void DoResetDerivative(int k, const ConstVectorRef&, MatrixRef gx) const override {
    gx = E_[k];
  }
  void DoSurface(int k, const ConstVectorRef& x, VectorRef h) const override {
    h.noalias() = C_[k] * x;
    h -= d_[k];
  }
  void DoSurfaceDerivative(int k, const ConstVectorRef&, MatrixRef hx) const override {
    hx = C_[k];
  }
};

/// l_k = 1/2 x'Q_k x + 1/2 u'R_k u + rho_k,  phi_k = 1/2 (x - r_k)' S_k (x - r_k).
class QuadraticCost : public SwitchedCost {
 public:
  QuadraticCost(std::vector<Matrix> Q, std::vector<Matrix> R, std::vector<double> rho,
                std::vector<Matrix> S, std::vector<Vector> r)
      : Q_(std::move(Q)), R_(std::move(R)), rho_(std::move(rho)), S_(std::move(S)),
        r_(std::move(r)) {}
  std::vector<Matrix> Q_, R_;
  std::vector<double> rho_;
  std::vector<Matrix> S_;
  std::vector<Vector> r_;

 protected:
  // Allocation-free quadratic forms (the engine's no-allocation tests use this cost).
  static double Quad(const Matrix& M, const ConstVectorRef& a) {
    double v = 0;
    for (int j = 0; j < a.size(); ++j) {
      for (int i = 0; i < a.size(); ++i) v += a(i) * M(i, j) * a(j);
    }
    return v;
  }
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    return 0.5 * Quad(Q_[k], x) + 0.5 * Quad(R_[k], u) + rho_[k];
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    lx.noalias() = Q_[k] * x;
    lu.noalias() = R_[k] * u;
    lxx = Q_[k];
    luu = R_[k];
    lux.setZero();
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    double v = 0;
    for (int j = 0; j < x.size(); ++j) {
      for (int i = 0; i < x.size(); ++i) v += (x(i) - r_[k](i)) * S_[k](i, j) * (x(j) - r_[k](j));
    }
    return 0.5 * v;
  }
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    phix.noalias() = S_[k] * x;
    phix.noalias() -= S_[k] * r_[k];
    phixx = S_[k];
  }
};

/// A nonlinear 3-mode system with state dims 3, 2, 3 (rectangular resets), m = 2, an affine
/// surface on mode 0 and a nonlinear one on mode 2. Written once, derivatives by AutoDiff.
class NonlinearSystem : public AutoDiffSystem<NonlinearSystem> {
 public:
  explicit NonlinearSystem(double gain = 1.0)
      : AutoDiffSystem<NonlinearSystem>({3, 2, 3}, 2, {1, 0, 1}), gain_(gain) {}
  double gain_;

  template <class S>
  void Dynamics(int k, const VectorX<S>& x, const VectorX<S>& u, VectorX<S>& xdot) const {
    using std::cos;
    using std::sin;
    if (k == 0) {
      xdot(0) = x(1);
      xdot(1) = -sin(x(0)) + gain_ * u(0) * (1.0 + 0.1 * x(2) * x(2));
      xdot(2) = u(1) - 0.5 * x(2) * x(1);
    } else if (k == 1) {
      xdot(0) = x(1) + 0.2 * u(1);
      xdot(1) = -x(0) - 0.1 * x(1) * x(1) * x(1) + gain_ * u(0);
    } else {
      xdot(0) = x(1);
      xdot(1) = -2.0 * x(0) + gain_ * u(0) + 0.3 * u(1) * x(2);
      xdot(2) = -x(2) + 0.1 * u(1) * u(1);
    }
  }
  template <class S>
  void ResetMap(int k, const VectorX<S>& x, VectorX<S>& x_next) const {
    using std::cos;
    using std::sin;
    if (k == 0) {
      x_next(0) = x(0) + 0.1 * x(2) * x(2);
      x_next(1) = x(1) * cos(x(2));
    } else {
      x_next(0) = x(0);
      x_next(1) = x(1);
      x_next(2) = sin(x(0) * x(1));
    }
  }
  template <class S>
  void SurfaceMap(int k, const VectorX<S>& x, VectorX<S>& h) const {
    if (k == 0) {
      h(0) = x(0) + 0.5 * x(1) - 0.5;  // affine: the Gauss-Newton Phi_zz is exact
    } else {
      h(0) = x(0) * x(0) + x(2) - 0.2;
    }
  }
};

/// A non-quadratic cost for NonlinearSystem, derivatives by nested AutoDiff.
class NonlinearCost : public AutoDiffCost<NonlinearCost> {
 public:
  template <class S>
  S RunningCost(int k, const VectorX<S>& x, const VectorX<S>& u) const {
    using std::cos;
    S value = 0.5 * x.squaredNorm() + 0.05 * (k + 1) * u.squaredNorm() +
              0.1 * x(0) * x(0) * u(0) * u(0) + 0.05 * cos(x(1)) + 0.3;
    return value;
  }
  template <class S>
  S SwitchingCost(int k, const VectorX<S>& x) const {
    S value = 0.1 * x(0) * x(0) * x(0) + 0.02 * (k + 1) * x(0);
    for (int i = 0; i < x.size(); ++i) value += 0.5 * (x(i) - 0.3) * (x(i) - 0.3);
    return value;
  }
};

/// The engine's calls of a BatchingSystem or BatchingCost: per point (outside a batch) and
/// batches, with the batches' points.
struct CallCounter {
  mutable int point_calls = 0;   ///< per-point calls outside a batch
  mutable int batch_calls = 0;   ///< batch calls
  mutable int batch_points = 0;  ///< points of those calls

 protected:
  void Point() const { point_calls += in_batch_ ? 0 : 1; }
  // Counts a batch of `points` around `evaluate` (the default per-point loop).
  template <class F>
  void Batch(Eigen::Index points, F&& evaluate) const {
    ++batch_calls;
    batch_points += static_cast<int>(points);
    in_batch_ = true;
    evaluate();
    in_batch_ = false;
  }

 private:
  mutable bool in_batch_ = false;
};

/// `inner` seen through the batch interface: with batch = true it prefers_batch(), so the
/// engine evaluates it by FlowBatch / FlowDerivativesBatch, whose default per-point loop gives
/// inner's values. Counts the engine's calls: per point (outside a batch) and batches.
class BatchingSystem : public SwitchedSystem, public CallCounter {
 public:
  explicit BatchingSystem(const SwitchedSystem& inner, bool batch = true)
      : SwitchedSystem(Dims(inner), inner.input_dim(), SurfaceDims(inner),
                       inner.has_cycle_reset()),
        inner_(inner), batch_(batch) {}
  bool prefers_batch() const override { return batch_; }

 protected:
  static std::vector<int> Dims(const SwitchedSystem& s) {
    std::vector<int> n;
    for (int k = 0; k < s.num_modes(); ++k) n.push_back(s.state_dim(k));
    return n;
  }
  static std::vector<int> SurfaceDims(const SwitchedSystem& s) {
    std::vector<int> d;
    for (int k = 0; k < s.num_modes(); ++k) d.push_back(s.surface_dim(k));
    return d;
  }
  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override {
    Point();
    inner_.Flow(k, x, u, xdot);
  }
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override {
    Point();
    inner_.FlowDerivatives(k, x, u, fx, fu);
  }
  void DoFlowBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                   MatrixRef F) const override {
    Batch(X.cols(), [&] { SwitchedSystem::DoFlowBatch(k, X, U, F); });
  }
  void DoFlowDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                              MatrixRef FX, MatrixRef FU) const override {
    Batch(X.cols(), [&] { SwitchedSystem::DoFlowDerivativesBatch(k, X, U, FX, FU); });
  }
  void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const override {
    inner_.Reset(k, x, x_next);
  }
  void DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const override {
    inner_.ResetDerivative(k, x, gx);
  }
  void DoSurface(int k, const ConstVectorRef& x, VectorRef h) const override {
    inner_.Surface(k, x, h);
  }
  void DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const override {
    inner_.SurfaceDerivative(k, x, hx);
  }
  bool DoGuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                       VectorRef hx) const override {
    return inner_.GuardGradient(k, x, u, hx);
  }

 private:
  const SwitchedSystem& inner_;
  bool batch_;
};

/// `inner` seen through the batch interface, as BatchingSystem (RunningBatch /
/// RunningDerivativesBatch with the default per-point loop); counts the calls.
class BatchingCost : public SwitchedCost, public CallCounter {
 public:
  explicit BatchingCost(const SwitchedCost& inner, bool batch = true)
      : inner_(inner), batch_(batch) {}
  bool prefers_batch() const override { return batch_; }

 protected:
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    Point();
    return inner_.Running(k, x, u);
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    Point();
    inner_.RunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    return inner_.Switching(k, x);
  }
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    inner_.SwitchingDerivatives(k, x, phix, phixx);
  }
  void DoRunningBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                      VectorRef l) const override {
    Batch(X.cols(), [&] { SwitchedCost::DoRunningBatch(k, X, U, l); });
  }
  void DoRunningDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                 MatrixRef LX, MatrixRef LU, MatrixRef LXX, MatrixRef LUU,
                                 MatrixRef LUX) const override {
    Batch(X.cols(), [&] { SwitchedCost::DoRunningDerivativesBatch(k, X, U, LX, LU, LXX, LUU, LUX); });
  }

 private:
  const SwitchedCost& inner_;
  bool batch_;
};

/// A problem over `sys` and `cost` with the box |u_i| <= u_bound on every input, every mode's
/// duration in [d_min, d_max] and no surface penalties. The system and cost must outlive it.
inline Problem BoxProblem(const SwitchedSystem& sys, const SwitchedCost& cost, double u_bound,
                          double d_min, double d_max) {
  Problem p;
  p.system = &sys;
  p.cost = &cost;
  const int m = sys.input_dim(), K = sys.num_modes();
  p.bounds.u_min = Vector::Constant(m, -u_bound);
  p.bounds.u_max = Vector::Constant(m, u_bound);
  p.bounds.duration_min = Vector::Constant(K, d_min);
  p.bounds.duration_max = Vector::Constant(K, d_max);
  p.surface_weights = Vector::Zero(K);
  return p;
}

/// The 3-mode nonlinear problem of the derivative and backward-pass tests: |u_i| <= 5, mode
/// durations in [0.1, 2], surface penalties (0.7, 0, 0.4). `sys` has NonlinearSystem's dimensions.
inline Problem MakeNonlinearProblem(const SwitchedSystem& sys, const SwitchedCost& cost) {
  Problem p;
  p.system = &sys;
  p.cost = &cost;
  p.bounds.u_min = Vector::Constant(2, -5);
  p.bounds.u_max = Vector::Constant(2, 5);
  p.bounds.duration_min = Vector::Constant(3, 0.1);
  p.bounds.duration_max = Vector::Constant(3, 2.0);
  p.surface_weights = Vector(3);
  p.surface_weights << 0.7, 0.0, 0.4;
  return p;
}

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_TEST_SYSTEMS_H_
