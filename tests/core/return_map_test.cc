// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// FitReturnMap against maps whose spectrum is known by construction.
#include "ddoc/return_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace ddoc {
namespace {

// A = V diag(lambda) V^-1 with a fixed, well-conditioned V: eigenvalues known exactly.
Matrix MapWithEigenvalues(const Vector& lambda) {
  const Eigen::Index n = lambda.size();
  Matrix V(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) V(i, j) = (i == j ? 2.0 : 0.3 * std::sin(1.0 + i + 2 * j));
  }
  return V * lambda.asDiagonal() * V.inverse();
}

// Samples: random deviations in units `scale`, pushed through A (plus optional noise).
void Sample(const Matrix& A, const Vector& x_star, const Vector& scale, int count, double noise,
            Matrix* from, Matrix* to) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Index n = x_star.size();
  from->resize(n, count);
  to->resize(n, count);
  for (int j = 0; j < count; ++j) {
    Vector dx(n), e(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      dx(i) = scale(i) * normal(rng);
      e(i) = noise * scale(i) * normal(rng);
    }
    from->col(j) = x_star + dx;
    to->col(j) = x_star + A * dx + e;
  }
}

TEST(ReturnMapTest, RecoversAMapAndItsSpectrumExactly) {
  Vector lambda(4);
  lambda << -0.95, 0.6, 0.3, -0.1;
  const Matrix A = MapWithEigenvalues(lambda);
  Vector x_star(4), scale(4);
  x_star << 1.0, -2.0, 50.0, 2000.0;
  scale << 0.01, 0.1, 1.0, 20.0;  // components of very different size, as on the hopper
  // The map acts in raw units; make it consistent with the scales (A_raw = S A S^-1).
  const Matrix A_raw = scale.asDiagonal() * A * scale.cwiseInverse().asDiagonal();
  Matrix from, to;
  Sample(A_raw, x_star, scale, 12, 0.0, &from, &to);
  const ReturnMapFit fit = FitReturnMap(from, to, x_star, scale);
  EXPECT_EQ(fit.samples, 12);
  EXPECT_LT((fit.A - A_raw).norm() / A_raw.norm(), 1e-10);
  EXPECT_LT(fit.residual_rms, 1e-10 * fit.target_rms);
  for (int j = 0; j < 4; ++j) {
    EXPECT_NEAR(fit.eigenvalues(j).real(), lambda(j), 1e-9) << j;  // sorted by modulus
    EXPECT_NEAR(fit.eigenvalues(j).imag(), 0.0, 1e-9) << j;
  }
  EXPECT_NEAR(fit.spectral_radius(), 0.95, 1e-9);
  // Eigenvector of -0.95 in scaled units: A_s v = lambda v, unit norm.
  const Eigen::VectorXcd v = fit.eigenvectors.col(0);
  EXPECT_NEAR(v.norm(), 1.0, 1e-12);
  EXPECT_LT((A.cast<std::complex<double>>() * v - fit.eigenvalues(0) * v).norm(), 1e-9);
}

TEST(ReturnMapTest, ComplexPairAndNoisySamples) {
  // A rotation-contraction block (eigenvalues 0.8 e^{+-0.5i}) and a real -0.5; 400 samples with 1 %
  // noise: the least-squares estimate is within a few percent.
  Matrix A = Matrix::Zero(3, 3);
  A(0, 0) = 0.8 * std::cos(0.5);
  A(0, 1) = -0.8 * std::sin(0.5);
  A(1, 0) = 0.8 * std::sin(0.5);
  A(1, 1) = 0.8 * std::cos(0.5);
  A(2, 2) = -0.5;
  const Vector x_star = Vector::Zero(3), scale = Vector::Ones(3);
  Matrix from, to;
  Sample(A, x_star, scale, 400, 0.01, &from, &to);
  const ReturnMapFit fit = FitReturnMap(from, to, x_star, scale);
  EXPECT_NEAR(std::abs(fit.eigenvalues(0)), 0.8, 0.01);
  EXPECT_NEAR(std::abs(fit.eigenvalues(1)), 0.8, 0.01);
  EXPECT_NEAR(std::abs(std::arg(fit.eigenvalues(0))), 0.5, 0.02);
  EXPECT_NEAR(fit.eigenvalues(0).imag(), -fit.eigenvalues(1).imag(), 1e-12);
  EXPECT_NEAR(fit.eigenvalues(2).real(), -0.5, 0.01);
  EXPECT_NEAR(fit.residual_rms, 0.01, 0.002);
}

TEST(ReturnMapTest, BadInputIsNamed) {
  const Vector x = Vector::Zero(2), s = Vector::Ones(2);
  const Matrix ok = Matrix::Identity(2, 2);
  auto message = [&](const Matrix& from, const Matrix& to, const Vector& xs, const Vector& sc) {
    try {
      FitReturnMap(from, to, xs, sc);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(ok, ok, x, Vector::Ones(3)).find("scale has 3 entries"), std::string::npos);
  EXPECT_NE(message(Matrix::Identity(3, 3), ok, x, s).find("rows"), std::string::npos);
  EXPECT_NE(message(ok, Matrix::Identity(2, 3), x, s).find("samples"), std::string::npos);
  EXPECT_NE(message(Matrix::Zero(2, 1), Matrix::Zero(2, 1), x, s).find("1 samples cannot"),
            std::string::npos);
  Vector bad_scale = s;
  bad_scale(1) = 0.0;
  EXPECT_NE(message(ok, ok, x, bad_scale).find("scale(1)"), std::string::npos);
  Matrix nan = ok;
  nan(0, 1) = std::nan("");
  EXPECT_NE(message(nan, ok, x, s).find("from has a non-finite"), std::string::npos);
  Matrix same(2, 3);
  same << 1, 2, 3, 1, 2, 3;  // every deviation along (1, 1)
  EXPECT_NE(message(same, same, x, s).find("span only 1 of 2"), std::string::npos);
  EXPECT_EQ(message(ok, ok, x, s), "no error");
}

}  // namespace
}  // namespace ddoc
