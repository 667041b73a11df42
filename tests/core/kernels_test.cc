// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The backward pass's private kernels (src/core/small_product.h, symmetric_update.h) against
// plain Eigen expressions, at every size from 1 to 17 (whole and partial packets).
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "ddoc/types.h"
#include "small_product.h"
#include "symmetric_update.h"

namespace ddoc {
namespace internal {
namespace {

// A matrix with about `density` of its entries nonzero.
Matrix Sparse(int rows, int cols, double density, std::mt19937* rng) {
  std::uniform_real_distribution<double> value(-2.0, 2.0), keep(0.0, 1.0);
  Matrix A(rows, cols);
  for (int c = 0; c < cols; ++c) {
    for (int r = 0; r < rows; ++r) A(r, c) = keep(*rng) < density ? value(*rng) : 0.0;
  }
  return A;
}

TEST(Kernels, TheSparseProductIsTheDenseProductBitForBit) {
  std::mt19937 rng(3);
  for (int rows = 1; rows <= 17; ++rows) {
    for (int depth : {1, 4, 14}) {
      for (double density : {0.0, 0.1, 0.5, 1.0}) {
        const int cols = depth + 1;
        const Matrix X = Sparse(rows, depth, 1.0, &rng);
        const Matrix A = Sparse(depth, cols, density, &rng);
        ColumnPattern pattern;
        pattern.Allocate(depth, cols);
        pattern.Find(depth, cols, A.data(), depth);
        int nonzeros = 0;
        for (int i = 0; i < A.size(); ++i) nonzeros += A.data()[i] != 0.0;
        ASSERT_EQ(pattern.nonzeros(), nonzeros);
        Matrix dense(rows, cols), sparse(rows, cols);
        SmallProduct(rows, cols, depth, X.data(), rows, A.data(), depth, dense.data(), rows);
        SparseProduct(rows, X.data(), rows, A.data(), depth, pattern, sparse.data(), rows);
        // Equal entries (a skipped term adds an exact zero; only a zero's sign may differ).
        for (int i = 0; i < dense.size(); ++i) {
          ASSERT_EQ(sparse.data()[i], dense.data()[i]) << rows << " x " << depth << ", " << density;
        }
        EXPECT_LE((dense - X * A).cwiseAbs().maxCoeff(), 1e-13 * (1.0 + (X * A).norm()));
        Vector x = Sparse(depth, 1, 1.0, &rng), y(cols);
        SparseTransposeTimes(A.data(), depth, pattern, cols, x.data(), y.data());
        EXPECT_LE((y - A.transpose() * x).cwiseAbs().maxCoeff(),
                  1e-13 * (1.0 + x.norm() * A.norm()));
      }
    }
  }
}

// The expressions SymmetricStage stands for, on the upper triangle of L and R as documented.
Matrix Derivative(const Matrix& Y, const Matrix& L, double q, const Matrix& R, int n) {
  const int nz = static_cast<int>(Y.rows());
  Matrix d(nz, nz);
  for (int c = 0; c < nz; ++c) {
    for (int r = 0; r <= c; ++r) {
      double v = Y(r, c) + Y(c, r) + (c < n ? q * L(r, c) : 0.0) - (R.size() > 0 ? R(r, c) : 0.0);
      d(r, c) = d(c, r) = v;
    }
  }
  return d;
}

TEST(Kernels, TheSymmetricStageIsItsExpression) {
  std::mt19937 rng(5);
  for (int nz = 1; nz <= 17; ++nz) {
    for (bool riccati : {false, true}) {
      const int n = std::max(1, nz - 2);
      const Matrix Y0 = Sparse(nz, nz, 1.0, &rng);
      const Matrix L = Sparse(n, n, 1.0, &rng);  // not symmetric: only its upper part counts
      const Matrix R = riccati ? Sparse(nz, nz, 1.0, &rng) : Matrix();
      Matrix P = Sparse(nz, nz, 1.0, &rng);
      P = (0.5 * (P + P.transpose())).eval();
      P(0, nz - 1) += 1e-3;  // a P asymmetric at the rounding level, exaggerated
      const double q = 0.7, a = 0.3;
      const Matrix d = Derivative(Y0, L, q, R, n);
      auto terms = [&](Matrix* Y) {
        SymmetricTerms t;
        t.nz = nz;
        t.n = n;
        t.Y = Y->data();
        t.ldy = nz;
        t.L = L.data();
        t.ldl = n;
        t.q = q;
        t.R = riccati ? R.data() : nullptr;
        t.ldr = nz;
        return t;
      };
      const double tol = 1e-14 * (1.0 + P.norm() + d.norm());
      {  // kStage: out = P + a dP, each triangle of P its own
        Matrix Y = Y0, out(nz, nz);
        SymmetricStage(terms(&Y), SymmetricUpdate::kStage, P.data(), nz, out.data(), nz, a);
        EXPECT_LE((out - (P + a * d)).cwiseAbs().maxCoeff(), tol) << nz;
      }
      {  // kStep: P(r, c) = P(c, r) = P(r, c) + a dP (the upper triangle of P)
        Matrix Y = Y0, Pm = P;
        SymmetricStage(terms(&Y), SymmetricUpdate::kStep, Pm.data(), nz, nullptr, 0, a);
        Matrix expect = P + a * d;
        for (int c = 0; c < nz; ++c) {
          for (int r = c + 1; r < nz; ++r) expect(r, c) = expect(c, r);
        }
        EXPECT_LE((Pm - expect).cwiseAbs().maxCoeff(), tol) << nz;
        EXPECT_EQ(Pm, Pm.transpose()) << nz;
      }
      {  // kRk4Stage, then kRk4Final with three stored stages
        Matrix Ys[3], outs[3];
        const double as[3] = {0.5, 0.5, 1.0};
        Matrix ds[3];
        for (int i = 0; i < 3; ++i) {
          Ys[i] = Sparse(nz, nz, 1.0, &rng);
          ds[i] = Derivative(Ys[i], L, q, R, n);
          outs[i].resize(nz, nz);
          SymmetricStage(terms(&Ys[i]), SymmetricUpdate::kRk4Stage, P.data(), nz, outs[i].data(),
                         nz, as[i]);
          EXPECT_LE((outs[i] - (P + as[i] * ds[i])).cwiseAbs().maxCoeff(), tol) << nz;
          for (int c = 0; c < nz; ++c) {  // dP's upper triangle left in Y
            for (int r = 0; r <= c; ++r) {
              EXPECT_NEAR(Ys[i](r, c), ds[i](r, c), tol) << nz << " " << r << " " << c;
            }
          }
        }
        Matrix Y = Y0, Pm = P;
        const double h6 = 0.1 / 6.0;
        SymmetricStage(terms(&Y), SymmetricUpdate::kRk4Final, Pm.data(), nz, nullptr, 0, h6,
                       Ys[0].data(), Ys[1].data(), Ys[2].data(), nz);
        const Matrix expect = P + h6 * (ds[0] + 2.0 * ds[1] + 2.0 * ds[2] + d);
        EXPECT_LE((Pm - expect).cwiseAbs().maxCoeff(), tol) << nz;
      }
    }
  }
}

}  // namespace
}  // namespace internal
}  // namespace ddoc
