// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/switching_time_update.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>

namespace ddoc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Offsets within rounding of zero (a nominal duration on its bound) become exactly zero, so the
// QP sees the variable on its bound.
double Snap(double offset, double scale) {
  return std::abs(offset) <= 1e-12 * std::max(1.0, scale) ? 0.0 : offset;
}

// Box QP with the multiplier nu of the sum constraint folded into the linear term.
double SolveShifted(BoxQP* qp, const Matrix& H, const Vector& g, double nu, const Vector& lo,
                    const Vector& hi, Vector* x) {
  const Vector shifted = g + Vector::Constant(g.size(), nu);
  qp->Solve(H, shifted, lo, hi, *x);
  return x->sum();
}

}  // namespace

BoxQPStatus SolveDurationQp(const Matrix& H, const Vector& g, const Vector& lo, const Vector& hi,
                            double sum_lo, double sum_hi, Vector* x) {
  const int K = static_cast<int>(g.size());
  BoxQP qp(K);
  x->setZero(K);
  BoxQPStatus status = qp.Solve(H, g, lo, hi, *x);
  const double sum0 = x->sum();
  // Tolerance relative to the finite quantities (bounds may be infinite).
  const double tol = 1e-13 * (1.0 + x->cwiseAbs().sum() + std::abs(sum_lo == -kInf ? 0.0 : sum_lo) +
                              std::abs(sum_hi == kInf ? 0.0 : sum_hi));
  if (sum0 >= sum_lo - tol && sum0 <= sum_hi + tol) return status;
  // The sum constraint is active at s: 1^T x(nu) is non-increasing in the multiplier nu of
  // min 1/2 x^T H x + (g + nu 1)^T x over the box, so bisect for 1^T x(nu) = s.
  const double s = sum0 > sum_hi ? sum_hi : sum_lo;
  const double sign = sum0 > sum_hi ? 1.0 : -1.0;
  double a = 0.0, b = sign * std::max(1.0, g.cwiseAbs().maxCoeff());
  Vector xb(K);
  xb = *x;
  for (int i = 0; i < 200 && sign * (SolveShifted(&qp, H, g, b, lo, hi, &xb) - s) > 0; ++i) {
    a = b;
    b *= 2.0;
  }
  Vector xm = xb;
  for (int i = 0; i < 200 && std::abs(b - a) > 1e-15 * std::max(1.0, std::abs(b)); ++i) {
    const double mid = 0.5 * (a + b);
    if (sign * (SolveShifted(&qp, H, g, mid, lo, hi, &xm) - s) > 0) {
      a = mid;
    } else {
      b = mid;
      xb = xm;
    }
  }
  *x = xb;
  // Polish: with the active set of the bisection, solve the equality-constrained KKT system
  //   [H_FF h1; h1^T 0] [x_F; nu/h] = [-g_F - H_FC x_C; h (s - 1^T x_C)]
  // exactly, and keep it when it is feasible. The border is scaled by h = max|H_FF|: with a
  // border of ones and |H| ~ 1e7 the Schur pivot 1^T H_FF^-1 1 falls below FullPivLU's rank
  // threshold, and the solve drops the sum constraint.
  std::vector<int> free;
  for (int k = 0; k < K; ++k) {
    const double w = 1e-12 * std::max(1.0, std::abs((*x)(k)));
    if ((*x)(k) > lo(k) + w && (*x)(k) < hi(k) - w) free.push_back(k);
  }
  const int nf = static_cast<int>(free.size());
  if (nf > 0) {
    Matrix kkt = Matrix::Zero(nf + 1, nf + 1);
    Vector rhs(nf + 1);
    double fixed_sum = 0;
    for (int k = 0; k < K; ++k) {
      if (std::find(free.begin(), free.end(), k) == free.end()) fixed_sum += (*x)(k);
    }
    double h = 0;
    for (int a_i = 0; a_i < nf; ++a_i) {
      for (int b_i = 0; b_i < nf; ++b_i) h = std::max(h, std::abs(H(free[a_i], free[b_i])));
    }
    if (!(h > 0) || !std::isfinite(h)) h = 1.0;
    for (int a_i = 0; a_i < nf; ++a_i) {
      const int i = free[a_i];
      double r = -g(i);
      for (int k = 0; k < K; ++k) {
        if (std::find(free.begin(), free.end(), k) == free.end()) r -= H(i, k) * (*x)(k);
      }
      rhs(a_i) = r;
      for (int b_i = 0; b_i < nf; ++b_i) kkt(a_i, b_i) = H(i, free[b_i]);
      kkt(a_i, nf) = kkt(nf, a_i) = h;
    }
    rhs(nf) = h * (s - fixed_sum);
    const Vector sol = kkt.fullPivLu().solve(rhs);
    bool feasible = sol.allFinite();
    for (int a_i = 0; a_i < nf && feasible; ++a_i) {
      const int i = free[a_i];
      feasible = sol(a_i) >= lo(i) && sol(a_i) <= hi(i);
    }
    // The polished point must meet the sum at least as well as the bisection's.
    if (feasible) {
      const double polished_sum = fixed_sum + sol.head(nf).sum();
      feasible = std::abs(polished_sum - s) <= std::max(std::abs(x->sum() - s), tol);
    }
    if (feasible) {
      for (int a_i = 0; a_i < nf; ++a_i) (*x)(free[a_i]) = sol(a_i);
    }
  }
  status = BoxQPStatus::kConverged;
  return status;
}

SwitchingTimeStep SolveSwitchingTimeUpdate(const Problem& problem, const ConstVectorRef& T_nominal,
                                           const ConstMatrixRef& P22, const ConstVectorRef& p2,
                                           double alpha, const SwitchingTimeSettings& settings) {
  problem.Validate();
  const int K = problem.num_modes();
  if (T_nominal.size() != K || P22.rows() != K || P22.cols() != K || p2.size() != K) {
    throw InvalidArgument("SolveSwitchingTimeUpdate: T has size " +
                          std::to_string(T_nominal.size()) + ", P22 is " +
                          std::to_string(P22.rows()) + "x" + std::to_string(P22.cols()) +
                          ", p2 has size " + std::to_string(p2.size()) + "; expected K = " +
                          std::to_string(K));
  }
  if (!T_nominal.allFinite() || !P22.allFinite() || !p2.allFinite() || !std::isfinite(alpha)) {
    throw InvalidArgument("SolveSwitchingTimeUpdate: non-finite T, P22, p2 or alpha");
  }
  // Durations and the map dT = S dD.
  Matrix S = Matrix::Zero(K, K);
  for (int r = 0; r < K; ++r) S.row(r).head(r + 1).setOnes();
  Vector D(K);
  for (int k = 0; k < K; ++k) D(k) = T_nominal(k) - (k == 0 ? 0.0 : T_nominal(k - 1));
  Matrix H = S.transpose() * (0.5 * (P22 + P22.transpose())) * S;
  const Vector gD = S.transpose() * p2;
  // Levenberg-Marquardt-type modification of the spectrum: eigenvalues below the floor are
  // replaced by max(|lambda|, floor) (negative curvature mirrored, zero curvature floored), so
  // the step keeps scaling with alpha and stays a descent direction.
  Eigen::SelfAdjointEigenSolver<Matrix> eig(H);
  const Vector& lambda = eig.eigenvalues();
  const double lmax = lambda.cwiseAbs().maxCoeff();
  const double floor = settings.relative_regularization * (lmax > 0 ? lmax : 1.0);
  SwitchingTimeStep out;
  Vector modified = lambda;
  for (int i = 0; i < K; ++i) {
    if (lambda(i) < floor) {
      modified(i) = std::max(std::abs(lambda(i)), floor);
      out.regularization = std::max(out.regularization, modified(i) - lambda(i));
    }
  }
  if (out.regularization > 0) {
    H = eig.eigenvectors() * modified.asDiagonal() * eig.eigenvectors().transpose();
    H = 0.5 * (H + H.transpose());
  }
  Vector lo(K), hi(K);
  for (int k = 0; k < K; ++k) {
    lo(k) = Snap(problem.bounds.duration_min(k) - D(k), D(k));
    hi(k) = Snap(problem.bounds.MaxDuration(k) - D(k), D(k));
    // A measured nominal may violate (7); the box then moves the plan back inside. The
    // optional step cap must not empty the box: then the bound nearest to 0 wins.
    const double l = std::max(lo(k), -settings.max_duration_step);
    const double h = std::min(hi(k), settings.max_duration_step);
    if (l <= h) {
      lo(k) = l;
      hi(k) = h;
    } else {
      lo(k) = hi(k) = (hi(k) < 0 ? hi(k) : lo(k));
    }
  }
  // The final-time box on T_{K-1} = sum of durations.
  const double TK = T_nominal(K - 1);
  const double sum_lo = Snap(problem.bounds.final_time_min - TK, TK);
  const double sum_hi = problem.bounds.final_time_max == std::numeric_limits<double>::infinity()
                            ? std::numeric_limits<double>::infinity()
                            : Snap(problem.bounds.final_time_max - TK, TK);
  Vector dD(K);
  out.status = SolveDurationQp(H, alpha * gD, lo, hi, sum_lo, sum_hi, &dD);
  out.dT = S * dD;
  out.T_planned = T_nominal + out.dT;
  // A mode that may vanish (duration_min = 0) and that the step puts on that bound ends exactly
  // where it starts: T + S dD would leave a 1e-17 s mode, whose terms scaled by 1 / D_k the
  // next backward pass would see.
  for (int k = 0; k < K; ++k) {
    if (problem.bounds.duration_min(k) != 0 ||
        D(k) + dD(k) > 1e-12 * std::max(1.0, std::abs(T_nominal(k)))) {
      continue;
    }
    out.T_planned(k) = k == 0 ? 0.0 : out.T_planned(k - 1);
    out.dT(k) = out.T_planned(k) - T_nominal(k);
  }
  out.model_change = 0.5 * dD.dot(H * dD) + gD.dot(dD);
  return out;
}

}  // namespace ddoc
