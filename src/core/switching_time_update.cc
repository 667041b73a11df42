// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/switching_time_update.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace ddoc {

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
  Vector g = alpha * (S.transpose() * p2);
  // Levenberg-Marquardt-type modification of the spectrum: eigenvalues below the floor are
  // replaced by max(|lambda|, floor) (negative curvature mirrored, zero curvature floored), so
  // the step keeps scaling with alpha and stays a descent direction.
  Eigen::SelfAdjointEigenSolver<Matrix> eig(H);
  const Vector& lambda = eig.eigenvalues();
  const double lmax = lambda.cwiseAbs().maxCoeff();
  const double floor = settings.relative_regularization * std::max(1.0, lmax);
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
  Vector lo = problem.bounds.duration_min - D;
  Vector hi = problem.bounds.duration_max - D;
  for (int k = 0; k < K; ++k) {
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
  BoxQP qp(K);
  Vector dD = Vector::Zero(K);
  out.status = qp.Solve(H, g, lo, hi, dD);
  out.dT = S * dD;
  out.T_planned = T_nominal + out.dT;
  return out;
}

}  // namespace ddoc
