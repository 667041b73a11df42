// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Derivatives by automatic differentiation (Eigen's unsupported AutoDiff module): write the
// model once, templated on the scalar, and get every derivative the engine needs.
#ifndef DDOC_AUTODIFF_H_
#define DDOC_AUTODIFF_H_

#include <string>

#include <Eigen/Dense>  // before the unsupported module, which needs Eigen/Core
#include <unsupported/Eigen/AutoDiff>

#include "ddoc/switched_system.h"

namespace ddoc {

/// Column vector of scalar S.
template <class S>
using VectorX = Eigen::Matrix<S, Eigen::Dynamic, 1>;

/// CRTP base: a SwitchedSystem whose derivatives come from forward-mode AutoDiff.
///
/// Derived implements (templated on the scalar S; output vectors arrive sized):
///
///   template <class S> void Dynamics(int k, const VectorX<S>& x, const VectorX<S>& u,
///                                    VectorX<S>& xdot) const;              // f_k, n_k
///   template <class S> void ResetMap(int k, const VectorX<S>& x,
///                                    VectorX<S>& x_next) const;            // g_k, n_{k+1}
///   template <class S> void SurfaceMap(int k, const VectorX<S>& x,
///                                      VectorX<S>& h) const;               // h_k, s_k (optional)
///
/// Each derivative call allocates (dynamic-size derivative vectors): fine for prototyping and
/// between trials; hand-written derivatives are faster for the 1 kHz path.
template <class Derived>
class AutoDiffSystem : public SwitchedSystem {
 public:
  using SwitchedSystem::SwitchedSystem;
  using AD = Eigen::AutoDiffScalar<Eigen::VectorXd>;

  /// Default surface: none (only reached when s_k > 0 and Derived has no SurfaceMap).
  template <class S>
  void SurfaceMap(int k, const VectorX<S>&, VectorX<S>&) const {
    throw InvalidArgument("AutoDiffSystem: s_" + std::to_string(k) +
                          " > 0 but the model has no SurfaceMap");
  }

 protected:
  const Derived& derived() const { return static_cast<const Derived&>(*this); }

  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override {
    VectorX<double> xv = x, uv = u, out(x.size());
    derived().template Dynamics<double>(k, xv, uv, out);
    xdot = out;
  }
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override {
    const int n = static_cast<int>(x.size()), m = static_cast<int>(u.size());
    VectorX<AD> xa(n), ua(m), out(n);
    for (int i = 0; i < n; ++i) xa(i) = AD(x(i), n + m, i);
    for (int i = 0; i < m; ++i) ua(i) = AD(u(i), n + m, n + i);
    derived().template Dynamics<AD>(k, xa, ua, out);
    for (int r = 0; r < n; ++r) {
      const Eigen::VectorXd& d = out(r).derivatives();
      if (d.size() == 0) {  // constant output
        fx.row(r).setZero();
        fu.row(r).setZero();
      } else {
        fx.row(r) = d.head(n).transpose();
        fu.row(r) = d.tail(m).transpose();
      }
    }
  }
  void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const override {
    VectorX<double> xv = x, out(x_next.size());
    derived().template ResetMap<double>(k, xv, out);
    x_next = out;
  }
  void DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const override {
    const int n = static_cast<int>(x.size());
    VectorX<AD> xa(n), out(gx.rows());
    for (int i = 0; i < n; ++i) xa(i) = AD(x(i), n, i);
    derived().template ResetMap<AD>(k, xa, out);
    for (int r = 0; r < gx.rows(); ++r) {
      if (out(r).derivatives().size() == 0) {
        gx.row(r).setZero();
      } else {
        gx.row(r) = out(r).derivatives().transpose();
      }
    }
  }
  void DoSurface(int k, const ConstVectorRef& x, VectorRef h) const override {
    VectorX<double> xv = x, out(h.size());
    derived().template SurfaceMap<double>(k, xv, out);
    h = out;
  }
  void DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const override {
    const int n = static_cast<int>(x.size());
    VectorX<AD> xa(n), out(hx.rows());
    for (int i = 0; i < n; ++i) xa(i) = AD(x(i), n, i);
    derived().template SurfaceMap<AD>(k, xa, out);
    for (int r = 0; r < hx.rows(); ++r) {
      if (out(r).derivatives().size() == 0) {
        hx.row(r).setZero();
      } else {
        hx.row(r) = out(r).derivatives().transpose();
      }
    }
  }
};

/// CRTP base: a SwitchedCost whose gradients and Hessians come from nested forward-mode
/// AutoDiff (second order).
///
/// Derived implements:
///
///   template <class S> S RunningCost(int k, const VectorX<S>& x, const VectorX<S>& u) const;
///   template <class S> S SwitchingCost(int k, const VectorX<S>& x) const;
template <class Derived>
class AutoDiffCost : public SwitchedCost {
 public:
  using Inner = Eigen::AutoDiffScalar<Eigen::VectorXd>;
  using Outer = Eigen::AutoDiffScalar<VectorX<Inner>>;

 protected:
  const Derived& derived() const { return static_cast<const Derived&>(*this); }

  // Seeds z (size N) for a Hessian: value z_i with inner derivative e_i, outer derivative e_i.
  static VectorX<Outer> Seed(const Eigen::VectorXd& z) {
    const int N = static_cast<int>(z.size());
    VectorX<Outer> out(N);
    for (int i = 0; i < N; ++i) {
      VectorX<Inner> d(N);
      for (int j = 0; j < N; ++j) d(j) = Inner(i == j ? 1.0 : 0.0, Eigen::VectorXd::Zero(N));
      out(i) = Outer(Inner(z(i), N, i), d);
    }
    return out;
  }
  // Extracts value, gradient and Hessian of an Outer scalar.
  static void Extract(const Outer& r, int N, Eigen::VectorXd* grad, Eigen::MatrixXd* hess) {
    grad->setZero(N);
    hess->setZero(N, N);
    if (r.value().derivatives().size() == N) *grad = r.value().derivatives();
    if (r.derivatives().size() == N) {
      for (int i = 0; i < N; ++i) {
        if (r.derivatives()(i).derivatives().size() == N) {
          hess->row(i) = r.derivatives()(i).derivatives().transpose();
        }
      }
    }
  }

  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    VectorX<double> xv = x, uv = u;
    return derived().template RunningCost<double>(k, xv, uv);
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    const int n = static_cast<int>(x.size()), m = static_cast<int>(u.size());
    Eigen::VectorXd z(n + m);
    z << x, u;
    const VectorX<Outer> za = Seed(z);
    const VectorX<Outer> xa = za.head(n), ua = za.tail(m);
    const Outer r = derived().template RunningCost<Outer>(k, xa, ua);
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
    Extract(r, n + m, &grad, &hess);
    lx = grad.head(n);
    lu = grad.tail(m);
    lxx = hess.topLeftCorner(n, n);
    luu = hess.bottomRightCorner(m, m);
    lux = hess.bottomLeftCorner(m, n);
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    VectorX<double> xv = x;
    return derived().template SwitchingCost<double>(k, xv);
  }
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    const int n = static_cast<int>(x.size());
    const VectorX<Outer> xa = Seed(x);
    const Outer r = derived().template SwitchingCost<Outer>(k, xa);
    Eigen::VectorXd grad;
    Eigen::MatrixXd hess;
    Extract(r, n, &grad, &hess);
    phix = grad;
    phixx = hess;
  }
};

}  // namespace ddoc

#endif  // DDOC_AUTODIFF_H_
