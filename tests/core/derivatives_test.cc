// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Finite-difference checks of every derivative: the user models (through AutoDiff and the
// shipped CheckDerivatives), and the time normalization (12)-(17) with resets and costs.
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/check_derivatives.h"
#include "ddoc/time_normalization.h"
#include "test_systems.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {

TEST(Derivatives, AutoDiffModelPassesCheckDerivativesInEveryMode) {
  NonlinearSystem sys;
  NonlinearCost cost;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> dist(-1.0, 1.0);
  for (int k = 0; k < sys.num_modes(); ++k) {
    for (int trial = 0; trial < 3; ++trial) {
      Vector x(sys.state_dim(k)), u(2);
      for (int i = 0; i < x.size(); ++i) x(i) = dist(rng);
      for (int i = 0; i < u.size(); ++i) u(i) = dist(rng);
      const DerivativeCheckReport report = CheckDerivatives(sys, &cost, k, x, u);
      for (const auto& e : report.entries) {
        EXPECT_LT(e.max_rel_error, 1e-7) << "mode " << k << " derivative " << e.name;
      }
      EXPECT_TRUE(report.PassedPerEntry()) << "mode " << k << ": " << report.max_entry_error();
      // Every expected entry is present.
      for (const char* name : {"fx", "fu", "lx", "lu", "lxx", "luu", "lux", "phix", "phixx"}) {
        EXPECT_NE(report.Find(name), nullptr) << name;
      }
      EXPECT_EQ(report.Find("gx") != nullptr, k < 2);
      EXPECT_EQ(report.Find("hx") != nullptr, k != 1);
    }
  }
}

// A model whose hand-written f_x is wrong in one entry: the checker must say so.
class WrongJacobian : public LinearSwitchedSystem {
 public:
  using LinearSwitchedSystem::LinearSwitchedSystem;

 protected:
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override {
    LinearSwitchedSystem::DoFlowDerivatives(k, x, u, fx, fu);
    fx(0, 1) += 0.01;
  }
};

TEST(Derivatives, CheckDerivativesFlagsAWrongJacobian) {
  Matrix A(2, 2), B(2, 1), E = Matrix::Identity(2, 2);
  A << 0, 1, -2, -0.3;
  B << 0, 1;
  WrongJacobian wrong({A, A}, {B, B}, {E, E});
  LinearSwitchedSystem right({A, A}, {B, B}, {E, E});
  const Vector x = Vector::Constant(2, 0.3), u = Vector::Constant(1, 0.1);
  const DerivativeCheckReport bad = CheckDerivatives(wrong, nullptr, 0, x, u);
  const DerivativeCheckReport good = CheckDerivatives(right, nullptr, 0, x, u);
  ASSERT_NE(bad.Find("fx"), nullptr);
  EXPECT_NEAR(bad.Find("fx")->max_abs_error, 0.01, 1e-7);
  EXPECT_FALSE(bad.Passed(1e-4));
  EXPECT_TRUE(good.Passed(1e-8));
}

// A Jacobian with entries of very different sizes (as the hopper's, where stiffness entries
// reach ~2000): an error of 10 % in a small entry is 5e-8 of the largest one, so the relative
// error scaled by the whole matrix lets it pass a 1e-6 check; the per-entry check does not.
TEST(Derivatives, PerEntryToleranceHoldsSmallEntriesToTheirOwnSize) {
  Matrix exact(2, 2), wrong(2, 2);
  exact << 2000.0, 1e-3, -0.5, 3.0;
  wrong = exact;
  wrong(0, 1) *= 1.1;
  EXPECT_LT(RelativeError(wrong, exact), 1e-6);
  EXPECT_GT(EntryError(wrong, exact, 1e-6, 1e-6), 1.0);
  // An error of the differences' size (1e-9 relative) passes in every entry.
  Matrix close = exact * (1.0 + 1e-9);
  EXPECT_LE(EntryError(close, exact, 1e-6, 1e-6), 1.0);
  ExpectThrowsWith([&] { EntryError(exact, Matrix::Zero(2, 3), 1e-6, 1e-6); }, "sizes");
  ExpectThrowsWith([&] { EntryError(exact, exact, 0.0, 0.0); }, "tolerances");
}

class TimeNormalizationTest : public ::testing::TestWithParam<int> {};

TEST_P(TimeNormalizationTest, EveryDerivativeMatchesCentralDifferences) {
  const int k = GetParam();
  NonlinearSystem sys;
  NonlinearCost cost;
  const Problem problem = MakeNonlinearProblem(sys, cost);
  TimeNormalization tn(problem);
  const int K = 3, m = 2;
  const int n = sys.state_dim(k), nz = n + K;
  Vector z(nz), u(m);
  std::mt19937 rng(11 + k);
  std::uniform_real_distribution<double> dist(-0.8, 0.8);
  for (int i = 0; i < n; ++i) z(i) = dist(rng);
  z.tail(K) << 0.4, 0.9, 1.7;  // T_0 < T_1 < T_2
  u << 0.3, -0.6;

  // F_z, F_u.
  Matrix Fz(nz, nz), Fu(nz, m);
  tn.FlowDerivatives(k, z, u, Fz, Fu);
  auto F_of_z = [&](const Vector& zz) { Vector F(nz); tn.Flow(k, zz, u, F); return F; };
  auto F_of_u = [&](const Vector& uu) { Vector F(nz); tn.Flow(k, z, uu, F); return F; };
  EXPECT_LT(RelativeError(Fz, CentralDifferenceJacobian(F_of_z, z)), 1e-8) << "F_z";
  EXPECT_LT(RelativeError(Fu, CentralDifferenceJacobian(F_of_u, u)), 1e-8) << "F_u";
  // The T columns: dF/dT_k = [f; 0], dF/dT_{k-1} = [-f; 0].
  Vector F(nz);
  tn.Flow(k, z, u, F);
  const double D = tn.Duration(k, z);
  EXPECT_LT((Fz.col(n + k).head(n) - F.head(n) / D).norm(), 1e-12);
  if (k > 0) EXPECT_LT((Fz.col(n + k - 1).head(n) + F.head(n) / D).norm(), 1e-12);

  // L_z, L_u, L_zz, L_uu, L_uz.
  Vector Lz(nz), Lu(m);
  Matrix Lzz(nz, nz), Luu(m, m), Luz(m, nz);
  tn.RunningDerivatives(k, z, u, Lz, Lu, Lzz, Luu, Luz);
  auto L_of_z = [&](const Vector& zz) { return Scalar(tn.Running(k, zz, u)); };
  auto L_of_u = [&](const Vector& uu) { return Scalar(tn.Running(k, z, uu)); };
  EXPECT_LT(RelativeError(Lz.transpose(), CentralDifferenceJacobian(L_of_z, z)), 1e-8) << "L_z";
  EXPECT_LT(RelativeError(Lu.transpose(), CentralDifferenceJacobian(L_of_u, u)), 1e-8) << "L_u";
  auto Lz_of_z = [&](const Vector& zz) {
    Vector a(nz), b(m);
    Matrix c(nz, nz), d(m, m), e(m, nz);
    tn.RunningDerivatives(k, zz, u, a, b, c, d, e);
    return a;
  };
  auto Lu_of_u = [&](const Vector& uu) {
    Vector a(nz), b(m);
    Matrix c(nz, nz), d(m, m), e(m, nz);
    tn.RunningDerivatives(k, z, uu, a, b, c, d, e);
    return b;
  };
  auto Lu_of_z = [&](const Vector& zz) {
    Vector a(nz), b(m);
    Matrix c(nz, nz), d(m, m), e(m, nz);
    tn.RunningDerivatives(k, zz, u, a, b, c, d, e);
    return b;
  };
  EXPECT_LT(RelativeError(Lzz, CentralDifferenceJacobian(Lz_of_z, z)), 1e-7) << "L_zz";
  EXPECT_LT(RelativeError(Luu, CentralDifferenceJacobian(Lu_of_u, u)), 1e-7) << "L_uu";
  EXPECT_LT(RelativeError(Luz, CentralDifferenceJacobian(Lu_of_z, z)), 1e-7) << "L_uz";

  // G_z (rectangular for k = 0: 2+3 x 3+3, k = 1: 3+3 x 2+3).
  if (k < K - 1) {
    const int nzn = sys.state_dim(k + 1) + K;
    Matrix Gz(nzn, nz);
    tn.ResetDerivative(k, z, Gz);
    auto G_of_z = [&](const Vector& zz) { Vector g(nzn); tn.Reset(k, zz, g); return g; };
    EXPECT_LT(RelativeError(Gz, CentralDifferenceJacobian(G_of_z, z)), 1e-8) << "G_z";
    Vector g(nzn);
    tn.Reset(k, z, g);
    EXPECT_EQ(g.tail(K), z.tail(K));
  }

  // Phi_z, Phi_zz (Gauss-Newton in the surface penalty: exact for affine h).
  Vector Phiz(nz);
  Matrix Phizz(nz, nz);
  tn.SwitchingDerivatives(k, z, Phiz, Phizz);
  auto Phi_of_z = [&](const Vector& zz) { return Scalar(tn.Switching(k, zz)); };
  auto Phiz_of_z = [&](const Vector& zz) {
    Vector a(nz);
    Matrix b(nz, nz);
    tn.SwitchingDerivatives(k, zz, a, b);
    return a;
  };
  EXPECT_LT(RelativeError(Phiz.transpose(), CentralDifferenceJacobian(Phi_of_z, z)), 1e-8)
      << "Phi_z";
  Matrix expected = CentralDifferenceJacobian(Phiz_of_z, z);
  if (k == 2) {
    // h = x0^2 + x2 - 0.2 is not affine: the omitted term is 2 w h h_xx, h_xx(0,0) = 2.
    const double h = z(0) * z(0) + z(2) - 0.2;
    expected(0, 0) -= 2.0 * problem.surface_weights(2) * h * 2.0;
  }
  EXPECT_LT(RelativeError(Phizz, expected), 1e-7) << "Phi_zz";
}

INSTANTIATE_TEST_SUITE_P(AllModes, TimeNormalizationTest, ::testing::Values(0, 1, 2));

TEST(Derivatives, CentralDifferenceJacobianKnownAnswers) {
  // A quadratic map: central differences are exact up to rounding, with the step relative to
  // max(1, |x_i|).
  const auto fn = [](const Vector& x) {
    Vector f(2);
    f << x(0) * x(0) + 3.0 * x(1), 2.0 * x(0) * x(1) - x(2);
    return f;
  };
  Vector x(3);
  x << 2.0, -1.0, 1e3;
  Matrix exact(2, 3);
  exact << 4.0, 3.0, 0.0, -2.0, 4.0, -1.0;
  const Matrix J = CentralDifferenceJacobian(fn, x);
  EXPECT_LT((J - exact).cwiseAbs().maxCoeff(), 1e-6);  // rounding: eps |f| / h
  EXPECT_EQ(RelativeError(exact, exact), 0.0);
  EXPECT_NEAR(RelativeError(exact + Matrix::Constant(2, 3, 0.4), exact), 0.1, 1e-15);
  // No inputs: a rows x 0 matrix.
  EXPECT_EQ(CentralDifferenceJacobian(fn, Vector::Zero(3)).cols(), 3);
  const auto constant = [](const Vector&) { return Vector::Ones(4); };
  EXPECT_EQ(CentralDifferenceJacobian(constant, Vector(0)).rows(), 4);
  // Bad input is named.
  try {
    CentralDifferenceJacobian(fn, x, 0.0);
    ADD_FAILURE() << "step 0 accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("step"), std::string::npos) << e.what();
  }
  const auto ragged = [](const Vector& x) { return Vector::Zero(x(0) > 0 ? 2 : 3); };
  EXPECT_THROW(CentralDifferenceJacobian(ragged, Vector::Zero(1)), InvalidArgument);
  EXPECT_THROW(RelativeError(Matrix::Zero(2, 2), Matrix::Zero(2, 3)), InvalidArgument);
}

TEST(Derivatives, CentralDifferencePointsGiveCentralDifferenceJacobianBitwise) {
  // The batched central differences (all the perturbed points of N points, then the quotients)
  // are CentralDifferenceJacobian's arithmetic: equal bits, point by point.
  const auto fn = [](const Vector& z) {
    Vector f(2);
    f << std::sin(z(0)) * z(1) + z(2) * z(2), std::exp(0.3 * z(1)) - z(0) * z(2);
    return f;
  };
  Matrix Z(3, 4);
  Z << 0.3, -2.5, 1e3, 0.0,  //
      1.7, 0.2, -0.4, 1e-9,  //
      -0.9, 4.0, 0.5, -3e2;
  for (double step : {1e-6, 1e-4}) {
    const Matrix P = CentralDifferencePoints(Z, step);
    ASSERT_EQ(P.rows(), 3);
    ASSERT_EQ(P.cols(), 2 * 3 * 4);
    Matrix V(2, P.cols());
    for (Eigen::Index c = 0; c < P.cols(); ++c) V.col(c) = fn(P.col(c));
    const Matrix J = CentralDifferenceQuotients(Z, V, step);
    ASSERT_EQ(J.rows(), 2);
    ASSERT_EQ(J.cols(), 3 * 4);
    for (Eigen::Index j = 0; j < Z.cols(); ++j) {
      const Matrix expected = CentralDifferenceJacobian(fn, Z.col(j), step);
      EXPECT_TRUE((J.middleCols(j * 3, 3).array() == expected.array()).all())
          << "point " << j << ":\n" << J.middleCols(j * 3, 3) << "\nvs\n" << expected;
    }
  }
  EXPECT_THROW(CentralDifferencePoints(Z, 0.0), InvalidArgument);
  EXPECT_THROW(CentralDifferenceQuotients(Z, Matrix::Zero(2, 5), 1e-6), InvalidArgument);
}

TEST(Derivatives, TimeNormalizationRejectsWrongSizes) {
  NonlinearSystem sys;
  NonlinearCost cost;
  const Problem problem = MakeNonlinearProblem(sys, cost);
  TimeNormalization tn(problem);
  Vector z(5), F(6), u(2);  // mode 0 needs z of size 3 + 3
  z.setZero();
  u.setZero();
  EXPECT_THROW(tn.Flow(0, z, u, F), InvalidArgument);
  Vector z0 = Vector::Zero(6);
  z0.tail(3) << 1, 2, 3;
  Vector F_bad(5);
  EXPECT_THROW(tn.Flow(0, z0, u, F_bad), InvalidArgument);
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
