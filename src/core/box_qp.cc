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
  for (int i = 0; i < n; ++i) x(i) = std::min(std::max(x(i), lo(i)), hi(i));
  if (n == 0) return BoxQPStatus::kConverged;
  const double gscale = 1.0 + g.cwiseAbs().maxCoeff();

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
    // Projected gradient test and the free set.
    double pg = 0;
    int nf = 0;
    for (int i = 0; i < n; ++i) {
      const double proj = std::min(std::max(x(i) - grad(i), lo(i)), hi(i));
      pg = std::max(pg, std::abs(x(i) - proj));
      const bool held = (x(i) <= lo(i) && grad(i) > 0) || (x(i) >= hi(i) && grad(i) < 0);
      if (!held) free_[nf++] = i;
    }
    if (pg <= settings_.tolerance * gscale) {
      status = BoxQPStatus::kConverged;
      break;
    }
    // Cholesky of H_FF (lower triangle, in place in chol_).
    for (int a = 0; a < nf; ++a) {
      for (int b = 0; b <= a; ++b) {
        double s = H(free_[a], free_[b]);
        for (int c = 0; c < b; ++c) s -= chol_(a, c) * chol_(b, c);
        if (a == b) {
          if (!(s > 0)) return BoxQPStatus::kNotPositiveDefinite;
          chol_(a, a) = std::sqrt(s);
        } else {
          chol_(a, b) = s / chol_(b, b);
        }
      }
    }
    // Solve L L^T d_F = -grad_F.
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
    direction_.head(n).setZero();
    for (int a = 0; a < nf; ++a) direction_(free_[a]) = rhs_(a);

    // Projected Armijo line search along clamp(x + s d).
    const double f0 = Objective(H, g, x.data(), n);
    double step = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < settings_.max_line_search_steps; ++ls) {
      double decrease = 0;
      for (int i = 0; i < n; ++i) {
        trial_(i) = std::min(std::max(x(i) + step * direction_(i), lo(i)), hi(i));
        decrease += grad(i) * (trial_(i) - x(i));
      }
      const double f1 = Objective(H, g, trial_.data(), n);
      if (f1 <= f0 + settings_.armijo * decrease) {
        accepted = true;
        break;
      }
      step *= settings_.backtrack;
    }
    if (!accepted) {
      status = BoxQPStatus::kNoProgress;
      break;
    }
    x = trial_.head(n);
  }
  return status;
}

}  // namespace ddoc
