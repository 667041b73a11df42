// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The switching-time update (31): the duration QP with the final-time (sum) constraint against
// brute-force enumeration of active sets, bounds that the nominal sits on up to rounding, and a
// fixed final time through SolveSwitchingTimeUpdate.
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "ddoc/switching_time_update.h"
#include "test_systems.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// min 1/2 x'Hx + g'x, lo <= x <= hi, s_lo <= 1'x <= s_hi by enumerating, for every variable,
// {lower, upper, free} and for the sum {inactive, at s_lo, at s_hi}, solving the KKT system of
// each assignment and keeping the feasible point with the lowest objective (an independent
// reference; 3^(n+1) systems, so small n only).
Vector BruteForce(const Matrix& H, const Vector& g, const Vector& lo, const Vector& hi,
                  double s_lo, double s_hi) {
  const int n = static_cast<int>(g.size());
  int combos = 1;
  for (int i = 0; i < n; ++i) combos *= 3;
  Vector best;
  double best_value = kInf;
  for (int sum_mode = 0; sum_mode < 3; ++sum_mode) {
    if (sum_mode == 1 && !std::isfinite(s_lo)) continue;
    if (sum_mode == 2 && !std::isfinite(s_hi)) continue;
    for (int c = 0; c < combos; ++c) {
      Vector x = Vector::Zero(n);
      std::vector<int> fr;
      int code = c;
      bool ok = true;
      for (int i = 0; i < n; ++i, code /= 3) {
        if (code % 3 == 0) {
          if (!std::isfinite(lo(i))) ok = false;
          x(i) = lo(i);
        } else if (code % 3 == 1) {
          if (!std::isfinite(hi(i))) ok = false;
          x(i) = hi(i);
        } else {
          fr.push_back(i);
        }
      }
      if (!ok) continue;
      const int nf = static_cast<int>(fr.size());
      const int rows = nf + (sum_mode > 0 ? 1 : 0);
      if (rows > 0) {
        Matrix A = Matrix::Zero(rows, rows);
        Vector b = Vector::Zero(rows);
        for (int a = 0; a < nf; ++a) {
          b(a) = -g(fr[a]);
          for (int i = 0; i < n; ++i) {
            if (std::find(fr.begin(), fr.end(), i) == fr.end()) b(a) -= H(fr[a], i) * x(i);
          }
          for (int bb = 0; bb < nf; ++bb) A(a, bb) = H(fr[a], fr[bb]);
          if (sum_mode > 0) A(a, nf) = A(nf, a) = 1.0;
        }
        if (sum_mode > 0) {
          double fixed = 0;
          for (int i = 0; i < n; ++i) {
            if (std::find(fr.begin(), fr.end(), i) == fr.end()) fixed += x(i);
          }
          b(nf) = (sum_mode == 1 ? s_lo : s_hi) - fixed;
        }
        Eigen::FullPivLU<Matrix> lu(A);
        if (lu.rank() < rows) continue;
        const Vector sol = lu.solve(b);
        for (int a = 0; a < nf; ++a) x(fr[a]) = sol(a);
      }
      bool feasible = true;
      for (int i = 0; i < n; ++i) feasible &= x(i) >= lo(i) - 1e-10 && x(i) <= hi(i) + 1e-10;
      feasible &= x.sum() >= s_lo - 1e-10 && x.sum() <= s_hi + 1e-10;
      const double value = 0.5 * x.dot(H * x) + g.dot(x);
      if (feasible && value < best_value - 1e-14) {
        best_value = value;
        best = x;
      }
    }
  }
  return best;
}

// A random duration QP of size n: a box of -(margin + |N|) .. margin + |N| around 0.
RandomBoxQp RandomDurationQp(int n, double shift, double margin, std::mt19937* rng) {
  return DrawRandomBoxQp(rng, n, shift, 2.0, 1.0, margin);
}

TEST(DurationQp, MatchesBruteForceWithTheSumConstraint) {
  std::mt19937 rng(21);
  std::normal_distribution<double> normal;
  int sum_active = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 5;
    RandomBoxQp qp = RandomDurationQp(n, 0.2, 0.2, &rng);
    const Matrix& H = qp.H;
    const Vector& g = qp.g;
    const Vector& lo = qp.lo;
    Vector& hi = qp.hi;
    if (trial % 7 == 0) hi.setConstant(kInf);  // one-sided boxes too
    // A sum box that is sometimes an equality (a fixed final time: here 1^T dD = 0).
    double s_lo = -0.3 * std::abs(normal(rng)), s_hi = 0.3 * std::abs(normal(rng));
    if (trial % 3 == 0) s_lo = s_hi = 0.0;
    if (trial % 5 == 4) s_hi = kInf;
    Vector x;
    SolveDurationQp(H, g, lo, hi, s_lo, s_hi, &x);
    const Vector ref = BruteForce(H, g, lo, hi, s_lo, s_hi);
    ASSERT_EQ(ref.size(), n) << "trial " << trial;
    EXPECT_LT((x - ref).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial;
    EXPECT_GE(x.sum(), s_lo - 1e-12);
    EXPECT_LE(x.sum(), s_hi + 1e-12);
    for (int i = 0; i < n; ++i) {
      EXPECT_GE(x(i), lo(i) - 1e-15);
      EXPECT_LE(x(i), hi(i) + 1e-15);
    }
    if (std::abs(x.sum() - s_lo) < 1e-9 || std::abs(x.sum() - s_hi) < 1e-9) ++sum_active;
  }
  EXPECT_GT(sum_active, 100);
}

// The minimizer of (cH, cg) is that of (H, g) for every c > 0. The QP's polish once dropped the
// sum constraint for |H| ~ 1e7 (its KKT border of ones fell below the LU's rank threshold).
TEST(DurationQp, TheAnswerDoesNotDependOnTheScaleOfTheObjective) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 60; ++trial) {
    const int n = 2 + trial % 4;
    const RandomBoxQp qp = RandomDurationQp(n, 0.05, 0.5, &rng);
    const Matrix& H = qp.H;
    const Vector& g = qp.g;
    const Vector& lo = qp.lo;
    const Vector& hi = qp.hi;
    const Vector ref = BruteForce(H, g, lo, hi, 0.0, 0.0);
    ASSERT_EQ(ref.size(), n) << "trial " << trial;
    for (const double c : {1e-6, 1e3, 1e8}) {
      Vector x;
      SolveDurationQp(c * H, c * g, lo, hi, 0.0, 0.0, &x);
      EXPECT_LT((x - ref).cwiseAbs().maxCoeff(), 1e-7) << "trial " << trial << ", scale " << c;
      EXPECT_LT(std::abs(x.sum()), 1e-9) << "trial " << trial << ", scale " << c;
    }
  }
}

// The duration QP that exp0 with |u| <= 3 posed at its first trial (P22 of the Lyapunov pass,
// two modes at D = (1, 1) s, a fixed final time): H = S^T P22 S has a negative eigenvalue that
// the spectrum floor mirrors. With the sum fixed, dD = t (1, -1), and t minimizes the
// one-dimensional quadratic 1/2 t^2 v^T H v + t v^T g, v = (1, -1).
TEST(DurationQp, AFixedFinalTimeHoldsWithCurvaturesOfTenMillion) {
  Matrix H(2, 2);
  H << 6.94782e+07, 7.06735e+07, 7.06735e+07, 7.77571e+07;
  const Vector g = (Vector(2) << 2.89656e+06, 1.95264e+06).finished();
  const Vector lo = Vector::Constant(2, -0.99), hi = Vector::Constant(2, 1.0);
  const Vector v = (Vector(2) << 1.0, -1.0).finished();
  const double t = -v.dot(g) / v.dot(H * v);
  ASSERT_GT(t * v(0), lo(0));  // the closed form is inside the box
  ASSERT_LT(t * v(1), hi(1));
  Vector x;
  SolveDurationQp(H, g, lo, hi, 0.0, 0.0, &x);
  EXPECT_LT(std::abs(x.sum()), 1e-12);
  EXPECT_LT((x - t * v).cwiseAbs().maxCoeff(), 1e-10);
}

// Two modes, durations in [0.1, 1], a problem for the checks below.
struct TwoModes {
  LinearSwitchedSystem sys{{Matrix::Zero(1, 1), Matrix::Zero(1, 1)},
                           {Matrix::Ones(1, 1), Matrix::Ones(1, 1)},
                           {Matrix::Identity(1, 1), Matrix::Identity(1, 1)}};
  QuadraticCost cost{{Matrix::Identity(1, 1), Matrix::Identity(1, 1)},
                     {Matrix::Identity(1, 1), Matrix::Identity(1, 1)},
                     {0, 0},
                     {Matrix::Identity(1, 1), Matrix::Identity(1, 1)},
                     {Vector::Zero(1), Vector::Zero(1)}};
  Problem problem;
  TwoModes() {
    problem = BoxProblem(sys, cost, 1, 0.1, 1.0);
  }
};

TEST(DurationQp, UnboundedVariablesWithAFixedSum) {
  // min 1/2 |x|^2 + g^T x with 1^T x = 0 and no box: x = -(g - mean(g)).
  const Vector g = (Vector(3) << 3.0, 1.0, 2.0).finished();
  const Vector lo = Vector::Constant(3, -kInf), hi = Vector::Constant(3, kInf);
  Vector x;
  SolveDurationQp(Matrix::Identity(3, 3), g, lo, hi, 0.0, 0.0, &x);
  EXPECT_LT((x - (Vector(3) << -1.0, 1.0, 0.0).finished()).norm(), 1e-12);
}

TEST(SwitchingTimeUpdate, FixedFinalTimeMovesOnlyTheSwitch) {
  TwoModes t;
  t.problem.bounds.FixFinalTime(1.2);
  Matrix P22(2, 2);
  P22 << 3, 1, 1, 2;
  const Eigen::Vector2d T(0.5, 1.2), p2(0.4, -0.7);
  const SwitchingTimeStep step = SolveSwitchingTimeUpdate(t.problem, T, P22, p2, 1.0);
  EXPECT_EQ(step.T_planned(1), 1.2);  // exactly the final time
  // With T_1 fixed the problem is 1-D in T_0: dT_0 = -p2_0 / P22_00.
  EXPECT_NEAR(step.dT(0), -0.4 / 3.0, 1e-12);
  EXPECT_NEAR(step.model_change, 0.5 * 3.0 * step.dT(0) * step.dT(0) + 0.4 * step.dT(0), 1e-12);
}

TEST(SwitchingTimeUpdate, ANominalOnItsBoundUpToRoundingIsOnIt) {
  TwoModes t;
  // D_0 = 0.1 + 1e-17-ish from the subtraction 0.30000000000000004 - 0.2: on its lower bound.
  const double T0 = 0.1 + 1e-16;
  const Eigen::Vector2d T(T0, T0 + 0.5);
  Matrix P22(2, 2);
  P22 << 2, 0.5, 0.5, 1;
  // The gradient pushes D_0 below its bound and wants D_1 longer: D_0 stays on the bound and
  // the whole step goes into D_1 (box on durations, S^T p2 = (p2_0 + p2_1, p2_1)).
  const Eigen::Vector2d p2(0.3, -0.4);
  const SwitchingTimeStep step = SolveSwitchingTimeUpdate(t.problem, T, P22, p2, 1.0);
  EXPECT_EQ(step.status, BoxQPStatus::kConverged);
  const double D0 = step.T_planned(0), D1 = step.T_planned(1) - step.T_planned(0);
  EXPECT_NEAR(D0, 0.1, 1e-15);
  EXPECT_GT(D1, 0.5 + 1e-3);
}

// P22 and p2 scaled by c give the same step for every c > 0. Here H = S^T P22 S has one
// negative eigenvalue that the floor mirrors. The floor was relative_regularization
// max(1, lmax): for lmax < 1 it did not shrink with the cost, and at c = 1e-9 it took over H and
// shrank the step (this test failed there).
TEST(SwitchingTimeUpdate, TheStepDoesNotDependOnTheScaleOfTheCost) {
  TwoModes t;  // durations in [0.1, 1], final time free
  const Eigen::Vector2d T(0.5, 1.2), p2(0.03, -0.05);
  Matrix P22(2, 2);
  P22 << 0.4, -0.1, -0.1, -0.02;
  const SwitchingTimeStep ref = SolveSwitchingTimeUpdate(t.problem, T, P22, p2, 0.5);
  ASSERT_GT(ref.regularization, 0.0);  // the floor is active
  ASSERT_GT(ref.dT.norm(), 1e-3);
  for (const double c : {1e-9, 1e-4, 1e-2, 1e3, 1e9}) {
    const SwitchingTimeStep step = SolveSwitchingTimeUpdate(t.problem, T, c * P22, c * p2, 0.5);
    EXPECT_LT((step.dT - ref.dT).cwiseAbs().maxCoeff(), 1e-9 * (1 + ref.dT.norm())) << "c " << c;
    EXPECT_NEAR(step.model_change, c * ref.model_change, 1e-9 * c * std::abs(ref.model_change))
        << "c " << c;
  }
}

// SwitchingTimeSettings::max_duration_step caps each duration change on both sides: the step is
// the duration QP's answer (brute force, an independent reference) on the box (7) intersected
// with |dD_k| <= cap. The gradient wants D_0 longer and D_1 shorter, each by more than the cap
// and less than (7) allows, so both sides of the cap bind; without it the step is longer.
TEST(SwitchingTimeUpdate, MaxDurationStepCapsEachDurationChangeBothWays) {
  TwoModes t;  // durations in [0.1, 1], final time free
  const Eigen::Vector2d T(0.5, 1.0);  // D = (0.5, 0.5)
  Matrix P22(2, 2);
  P22 << 2.0, 0.5, 0.5, 1.0;
  // S^T p2 = (p2_0 + p2_1, p2_1) = (-0.3, 0.25): D_0 up, D_1 down.
  const Eigen::Vector2d p2(-0.55, 0.25);
  Matrix S(2, 2);
  S << 1, 0, 1, 1;
  const Matrix H = S.transpose() * P22 * S;
  const Vector g = S.transpose() * p2;
  const Vector lo7 = (Vector(2) << 0.1 - 0.5, 0.1 - 0.5).finished();
  const Vector hi7 = (Vector(2) << 1.0 - 0.5, 1.0 - 0.5).finished();
  auto durations_change = [](const SwitchingTimeStep& s) {
    return Eigen::Vector2d(s.dT(0), s.dT(1) - s.dT(0));
  };
  const Vector free_step = BruteForce(H, g, lo7, hi7, -kInf, kInf);
  const SwitchingTimeStep uncapped = SolveSwitchingTimeUpdate(t.problem, T, P22, p2, 1.0);
  EXPECT_LT((durations_change(uncapped) - free_step).cwiseAbs().maxCoeff(), 1e-9);
  const double cap = 0.05;
  ASSERT_GT(free_step(0), 2 * cap);
  ASSERT_LT(free_step(1), -2 * cap);
  SwitchingTimeSettings settings;
  settings.max_duration_step = cap;
  const SwitchingTimeStep capped = SolveSwitchingTimeUpdate(t.problem, T, P22, p2, 1.0, settings);
  const Vector lo = lo7.cwiseMax(-cap), hi = hi7.cwiseMin(cap);
  const Vector expected = BruteForce(H, g, lo, hi, -kInf, kInf);
  EXPECT_LT((durations_change(capped) - expected).cwiseAbs().maxCoeff(), 1e-9)
      << "capped dD " << durations_change(capped).transpose() << ", expected "
      << expected.transpose();
  EXPECT_NEAR(durations_change(capped)(0), cap, 1e-12);
  EXPECT_NEAR(durations_change(capped)(1), -cap, 1e-12);
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
