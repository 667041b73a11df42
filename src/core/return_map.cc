// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/return_map.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace ddoc {

ReturnMapFit FitReturnMap(const Matrix& from, const Matrix& to, const Vector& fixed_point,
                          const Vector& scale) {
  const Eigen::Index n = fixed_point.size();
  auto fail = [](const std::string& what) { throw InvalidArgument("FitReturnMap: " + what); };
  if (n == 0) fail("fixed_point is empty");
  if (scale.size() != n) {
    fail("scale has " + std::to_string(scale.size()) + " entries, fixed_point " +
         std::to_string(n));
  }
  if (from.rows() != n || to.rows() != n) {
    fail("from/to have " + std::to_string(from.rows()) + "/" + std::to_string(to.rows()) +
         " rows, fixed_point " + std::to_string(n) + " entries");
  }
  if (from.cols() != to.cols()) {
    fail("from has " + std::to_string(from.cols()) + " samples, to " + std::to_string(to.cols()));
  }
  if (from.cols() < n) {
    fail(std::to_string(from.cols()) + " samples cannot determine a " + std::to_string(n) + " x " +
         std::to_string(n) + " map");
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(scale(i) > 0.0) || !std::isfinite(scale(i))) {
      fail("scale(" + std::to_string(i) + ") must be a finite number > 0");
    }
  }
  if (!fixed_point.allFinite()) fail("fixed_point is not finite");
  if (!from.allFinite()) fail("from has a non-finite sample");
  if (!to.allFinite()) fail("to has a non-finite sample");

  const Vector inv = scale.cwiseInverse();
  // Scaled deviations, one sample per row: X A_s^T = Y.
  const Matrix X = (inv.asDiagonal() * (from.colwise() - fixed_point)).transpose();
  const Matrix Y = (inv.asDiagonal() * (to.colwise() - fixed_point)).transpose();
  const Eigen::ColPivHouseholderQR<Matrix> qr(X);
  if (qr.rank() < n) {
    fail("the deviations x_k - x* span only " + std::to_string(qr.rank()) + " of " +
         std::to_string(n) + " directions; perturb every component");
  }
  const Matrix As = qr.solve(Y).transpose();

  ReturnMapFit fit;
  fit.samples = static_cast<int>(from.cols());
  const Matrix residual = X * As.transpose() - Y;
  const double count = static_cast<double>(residual.size());
  fit.residual_rms = std::sqrt(residual.squaredNorm() / count);
  fit.target_rms = std::sqrt(Y.squaredNorm() / count);
  fit.A = scale.asDiagonal() * As * inv.asDiagonal();

  const Eigen::EigenSolver<Matrix> eig(As);
  std::vector<Eigen::Index> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) {
    return std::abs(eig.eigenvalues()(a)) > std::abs(eig.eigenvalues()(b));
  });
  fit.eigenvalues.resize(n);
  fit.eigenvectors.resize(n, n);
  for (Eigen::Index j = 0; j < n; ++j) {
    fit.eigenvalues(j) = eig.eigenvalues()(order[static_cast<size_t>(j)]);
    fit.eigenvectors.col(j) = eig.eigenvectors().col(order[static_cast<size_t>(j)]).normalized();
  }
  return fit;
}

}  // namespace ddoc
