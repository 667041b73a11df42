// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/box_qp.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace ddoc {

BoxQP::BoxQP(int max_size, const BoxQPSettings& settings) : settings_(settings) {
  Allocate(max_size);
}

void BoxQP::Allocate(int max_size) {
  if (max_size < 0) throw InvalidArgument("BoxQP::Allocate: negative max_size");
  max_size_ = max_size;
  grad_.resize(max_size);
  direction_.resize(max_size);
  trial_.resize(max_size);
  rhs_.resize(max_size);
  chol_.resize(max_size, max_size);
  free_.assign(max_size, 0);
}

double BoxQP::Objective(const ConstMatrixRef& H, const ConstVectorRef& g, const double* x,
                        int n) const {
  // 1/2 x^T H x + g^T x without temporaries.
  double value = 0;
  for (int j = 0; j < n; ++j) {
    double hx = 0;
    for (int i = 0; i < n; ++i) hx += H(i, j) * x[i];
    value += x[j] * (0.5 * hx + g(j));
  }
  return value;
}

bool BoxQP::FactorFree(const ConstMatrixRef& H, int nf) {
  // Cholesky of H_FF (lower triangle, in place in chol_).
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b <= a; ++b) {
      double s = H(free_[a], free_[b]);
      for (int c = 0; c < b; ++c) s -= chol_(a, c) * chol_(b, c);
      if (a == b) {
        if (!(s > 0)) return false;
        chol_(a, a) = std::sqrt(s);
      } else {
        chol_(a, b) = s / chol_(b, b);
      }
    }
  }
  return true;
}

bool BoxQP::ProjectedSearch(const ConstMatrixRef& H, const ConstVectorRef& g,
                            const ConstVectorRef& lo, const ConstVectorRef& hi, double step,
                            VectorRef x) {
  // Armijo test along the projection clamp(x + s d) (Bertsekas 1982): sufficient decrease
  // measured by the first-order change grad^T (x(s) - x).
  const int n = static_cast<int>(g.size());
  const double f0 = Objective(H, g, x.data(), n);
  for (int ls = 0; ls < settings_.max_line_search_steps; ++ls) {
    double decrease = 0;
    bool moved = false;
    for (int i = 0; i < n; ++i) {
      trial_(i) = std::min(std::max(x(i) + step * direction_(i), lo(i)), hi(i));
      decrease += grad_(i) * (trial_(i) - x(i));
      moved = moved || trial_(i) != x(i);
    }
    if (!moved) return false;
    const double f1 = Objective(H, g, trial_.data(), n);
    if (decrease < 0 && f1 <= f0 + settings_.armijo * decrease) {
      x = trial_.head(n);
      return true;
    }
    step *= settings_.backtrack;
  }
  return false;
}

BoxQPStatus BoxQP::Solve(const ConstMatrixRef& H, const ConstVectorRef& g,
                         const ConstVectorRef& lo, const ConstVectorRef& hi, VectorRef x) {
  const int n = static_cast<int>(g.size());
  if (n > max_size_ || H.rows() != n || H.cols() != n || lo.size() != n || hi.size() != n ||
      x.size() != n) {
    std::ostringstream os;
    os << "BoxQP::Solve: sizes H " << H.rows() << "x" << H.cols() << ", g " << g.size() << ", lo "
       << lo.size() << ", hi " << hi.size() << ", x " << x.size()
       << " must agree and be <= max_size " << max_size_;
    throw InvalidArgument(os.str());
  }
  for (int i = 0; i < n; ++i) {
    if (!(lo(i) <= hi(i))) {
      std::ostringstream os;
      os << "BoxQP::Solve: lo(" << i << ") = " << lo(i) << " > hi(" << i << ") = " << hi(i);
      throw InvalidArgument(os.str());
    }
  }
  iterations_ = 0;
  kkt_ = 0;
  for (int i = 0; i < n; ++i) {
    x(i) = std::min(std::max(x(i), lo(i)), hi(i));
    if (!std::isfinite(x(i))) x(i) = std::isfinite(lo(i)) ? lo(i) : (std::isfinite(hi(i)) ? hi(i) : 0.0);
  }
  if (n == 0) return BoxQPStatus::kConverged;
  const double gscale = 1.0 + g.cwiseAbs().maxCoeff();
  double hscale = 0;
  for (int i = 0; i < n; ++i) hscale = std::max(hscale, std::abs(H(i, i)));
  // The same residual with the gradient divided by the curvature scale h = max H_ii is in units
  // of x, so (cH, cg) stops where (H, g) does; both must hold (the plain one alone accepted a
  // warm start 1e-3 off for |g| ~ 1e-9 or 1e9).
  const double inv_h = hscale > 0 && std::isfinite(hscale) ? 1.0 / hscale : 1.0;
  const double scaled_gscale = 1.0 + inv_h * g.cwiseAbs().maxCoeff();

  Vector& grad = grad_;
  BoxQPStatus status = BoxQPStatus::kMaxIterations;
  for (int it = 0; it < settings_.max_iterations; ++it) {
    iterations_ = it + 1;
    // grad = H x + g
    for (int i = 0; i < n; ++i) {
      double s = g(i);
      for (int j = 0; j < n; ++j) s += H(i, j) * x(j);
      grad(i) = s;
    }
    // Projected-gradient (KKT) residuals w = ||x - clamp(x - grad)||_inf and w_h with grad / h.
    double w = 0, w_h = 0;
    for (int i = 0; i < n; ++i) {
      const double proj = std::min(std::max(x(i) - grad(i), lo(i)), hi(i));
      w = std::max(w, std::abs(x(i) - proj));
      const double proj_h = std::min(std::max(x(i) - inv_h * grad(i), lo(i)), hi(i));
      w_h = std::max(w_h, std::abs(x(i) - proj_h));
    }
    kkt_ = w;
    if (w <= settings_.tolerance * gscale && w_h <= settings_.tolerance * scaled_gscale) {
      status = BoxQPStatus::kConverged;
      break;
    }
    // The epsilon-active set (Bertsekas 1982): a variable within eps = min(w, eps_max) of a
    // bound whose gradient pushes outward is held. A variable at a bound up to rounding (an
    // offset of 1e-16 from a subtraction) is thereby held instead of blocking the Newton step.
    int nf = 0;
    for (int i = 0; i < n; ++i) {
      const double eps = std::min(w, settings_.active_set_margin * (1.0 + std::abs(x(i))));
      const bool held = (x(i) - lo(i) <= eps && grad(i) > 0) || (hi(i) - x(i) <= eps && grad(i) < 0);
      if (!held) free_[nf++] = i;
    }
    if (!FactorFree(H, nf)) return BoxQPStatus::kNotPositiveDefinite;
    // Solve L L^T d_F = -grad_F; held variables take a diagonally scaled gradient step, which
    // the projection puts onto their bound.
    for (int a = 0; a < nf; ++a) {
      double s = -grad(free_[a]);
      for (int c = 0; c < a; ++c) s -= chol_(a, c) * rhs_(c);
      rhs_(a) = s / chol_(a, a);
    }
    for (int a = nf - 1; a >= 0; --a) {
      double s = rhs_(a);
      for (int c = a + 1; c < nf; ++c) s -= chol_(c, a) * rhs_(c);
      rhs_(a) = s / chol_(a, a);
    }
    for (int i = 0; i < n; ++i) {
      direction_(i) = -grad(i) / std::max(std::abs(H(i, i)), 1e-300 + 1e-12 * hscale);
    }
    for (int a = 0; a < nf; ++a) direction_(free_[a]) = rhs_(a);
    if (ProjectedSearch(H, g, lo, hi, 1.0, x)) continue;
    // Fallback: a projected steepest-descent step (step 1/max|H_ii| first).
    for (int i = 0; i < n; ++i) direction_(i) = -grad(i);
    if (ProjectedSearch(H, g, lo, hi, 1.0 / std::max(hscale, 1e-300), x)) continue;
    status = BoxQPStatus::kNoProgress;
    break;
  }
  return status;
}

}  // namespace ddoc
