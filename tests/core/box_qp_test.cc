// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// BoxQP against the KKT conditions and against brute-force enumeration of active sets.
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "ddoc/box_qp.h"
#include "malloc_counter.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {


// KKT residual of a box QP: free components need grad = 0, lower-bound components grad >= 0,
// upper-bound components grad <= 0.
double KktResidual(const Matrix& H, const Vector& g, const Vector& lo, const Vector& hi,
                   const Vector& x) {
  const Vector grad = H * x + g;
  double worst = 0;
  for (int i = 0; i < x.size(); ++i) {
    if (x(i) < lo(i) - 1e-14 || x(i) > hi(i) + 1e-14) return 1e300;  // infeasible
    double r;
    // A bound counts as active within 1e-14 (rounding of the bounds themselves).
    if (x(i) <= lo(i) + 1e-14) {
      r = std::max(0.0, -grad(i));
    } else if (x(i) >= hi(i) - 1e-14) {
      r = std::max(0.0, grad(i));
    } else {
      r = std::abs(grad(i));
    }
    worst = std::max(worst, r);
  }
  return worst;
}

using Case = RandomBoxQp;

Case RandomCase(std::mt19937* rng, int n, double box) {
  return DrawRandomBoxQp(rng, n, 0.1, 3.0, box, 0.2);
}

TEST(BoxQP, MatchesBruteForceAndKkt) {
  std::mt19937 rng(3);
  int with_active = 0, all_inactive = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + trial % 6;
    const double box = trial % 4 == 0 ? 100.0 : 0.5;  // wide boxes: unconstrained optimum
    const Case c = RandomCase(&rng, n, box);
    BoxQP qp(8);
    Vector x = Vector::Zero(n);
    ASSERT_EQ(qp.Solve(c.H, c.g, c.lo, c.hi, x), BoxQPStatus::kConverged) << "trial " << trial;
    const Vector ref = testing::BruteForceBoxQp(c.H, c.g, c.lo, c.hi);
    EXPECT_LT((x - ref).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial;
    EXPECT_LT(KktResidual(c.H, c.g, c.lo, c.hi, x), 1e-9) << "trial " << trial;
    int active = 0;
    for (int i = 0; i < n; ++i) active += (x(i) <= c.lo(i) || x(i) >= c.hi(i));
    (active > 0 ? with_active : all_inactive)++;
  }
  // Both regimes were exercised.
  EXPECT_GT(with_active, 50);
  EXPECT_GT(all_inactive, 20);
}

// Bounds that sit at the start point up to rounding (offsets of 1e-16, as a subtraction such as
// duration_min - D leaves them) must be treated as bounds: the solver converges to the KKT point
// instead of stopping with a zero step (the plain active set, which held a variable only when x
// was exactly on its bound, stopped with kNoProgress at x = 0 here).
TEST(BoxQP, BoundsAtTheStartUpToRoundingAreHeld) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  int pushed_out = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 2 + trial % 5;
    Case c = RandomCase(&rng, n, 1.0);
    // Every variable starts (x = 0) within +-1e-16 of one of its bounds.
    for (int i = 0; i < n; ++i) {
      const double offset = (trial + i) % 3 == 0 ? -1e-16 : ((trial + i) % 3 == 1 ? 1e-16 : 0.0);
      if (normal(rng) > 0) {
        c.lo(i) = offset;
      } else {
        c.hi(i) = offset;
      }
      if (c.lo(i) > c.hi(i)) std::swap(c.lo(i), c.hi(i));
    }
    BoxQP qp(8);
    Vector x = Vector::Zero(n);
    const BoxQPStatus status = qp.Solve(c.H, c.g, c.lo, c.hi, x);
    ASSERT_EQ(status, BoxQPStatus::kConverged) << "trial " << trial << " kkt " << qp.kkt();
    const Vector ref = testing::BruteForceBoxQp(c.H, c.g, c.lo, c.hi);
    EXPECT_LT((x - ref).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial;
    EXPECT_LT(KktResidual(c.H, c.g, c.lo, c.hi, x), 1e-9) << "trial " << trial;
    pushed_out += x.norm() > 1e-3;
  }
  EXPECT_GT(pushed_out, 100);
}

TEST(BoxQP, InfiniteBoundsAndZeroSize) {
  Matrix H(2, 2);
  H << 4, 1, 1, 3;
  Vector g(2);
  g << 1, -2;
  const double inf = std::numeric_limits<double>::infinity();
  Vector lo = Vector::Constant(2, -inf), hi = Vector::Constant(2, inf), x = Vector::Zero(2);
  BoxQP qp(2);
  ASSERT_EQ(qp.Solve(H, g, lo, hi, x), BoxQPStatus::kConverged);
  EXPECT_LT((x + H.llt().solve(g)).norm(), 1e-12);
  // One-sided: x_1 <= 0 active.
  hi(1) = 0;
  x.setZero();
  ASSERT_EQ(qp.Solve(H, g, lo, hi, x), BoxQPStatus::kConverged);
  EXPECT_EQ(x(1), 0.0);
  EXPECT_NEAR(x(0), -0.25, 1e-12);
  Vector empty;
  Matrix H0(0, 0);
  EXPECT_EQ(qp.Solve(H0, empty, empty, empty, empty), BoxQPStatus::kConverged);
}

TEST(BoxQP, UnconstrainedOptimumIsTheNewtonStep) {
  Matrix H(2, 2);
  H << 4, 1, 1, 3;
  Vector g(2);
  g << 1, -2;
  Vector lo = Vector::Constant(2, -10), hi = Vector::Constant(2, 10), x = Vector::Zero(2);
  BoxQP qp(2);
  ASSERT_EQ(qp.Solve(H, g, lo, hi, x), BoxQPStatus::kConverged);
  const Vector exact = -H.llt().solve(g);
  EXPECT_LT((x - exact).norm(), 1e-12);
}

// The minimizer of (cH, cg) is that of (H, g) for every c > 0, from a warm start near it (the
// previous sample's step, as the pass and (33) warm-start). The plain residual
// ||x - clamp(x - grad)|| <= 1e-12 (1 + ||g||) accepted a warm start 1e-3 off for c = 1e-9 (the
// gradient is tiny) and for c = 1e9 (the threshold is huge).
TEST(BoxQP, TheAnswerDoesNotDependOnTheScaleOfTheObjective) {
  std::mt19937 rng(17);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 60; ++trial) {
    const int n = 1 + trial % 5;
    const Case c = RandomCase(&rng, n, trial % 3 == 0 ? 100.0 : 0.5);
    const Vector ref = testing::BruteForceBoxQp(c.H, c.g, c.lo, c.hi);
    Vector warm = ref;
    for (int i = 0; i < n; ++i) warm(i) += 1e-3 * normal(rng);
    for (const double scale : {1e-9, 1e-3, 1.0, 1e3, 1e9}) {
      BoxQP qp(n);
      Vector x = warm;
      EXPECT_EQ(qp.Solve(scale * c.H, scale * c.g, c.lo, c.hi, x), BoxQPStatus::kConverged)
          << "trial " << trial << ", scale " << scale;
      EXPECT_LT((x - ref).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial << ", scale " << scale;
    }
  }
}

TEST(BoxQP, WarmStartFromAnyPointAndFixedVariables) {
  std::mt19937 rng(5);
  const Case c = RandomCase(&rng, 5, 0.3);
  BoxQP qp(5);
  Vector cold = Vector::Zero(5);
  qp.Solve(c.H, c.g, c.lo, c.hi, cold);
  Vector warm = Vector::Constant(5, 7.0);  // infeasible start gets clamped
  qp.Solve(c.H, c.g, c.lo, c.hi, warm);
  EXPECT_LT((warm - cold).norm(), 1e-9);
  // lo == hi fixes a variable.
  Vector lo = c.lo, hi = c.hi;
  lo(2) = hi(2) = 0.1;
  Vector x = Vector::Zero(5);
  EXPECT_EQ(qp.Solve(c.H, c.g, lo, hi, x), BoxQPStatus::kConverged);
  EXPECT_EQ(x(2), 0.1);
  EXPECT_LT((x - testing::BruteForceBoxQp(c.H, c.g, lo, hi)).norm(), 1e-8);
}

TEST(BoxQP, ReportsIndefiniteHessianAndBadInput) {
  Matrix H(2, 2);
  H << 1, 0, 0, -1;
  Vector g = Vector::Zero(2), lo = Vector::Constant(2, -1), hi = Vector::Constant(2, 1);
  Vector x = Vector::Constant(2, 0.5);
  BoxQP qp(2);
  EXPECT_EQ(qp.Solve(H, g, lo, hi, x), BoxQPStatus::kNotPositiveDefinite);
  Vector bad_lo = lo;
  bad_lo(1) = 2;  // lo > hi
  EXPECT_THROW(qp.Solve(Matrix::Identity(2, 2), g, bad_lo, hi, x), InvalidArgument);
  Vector big = Vector::Zero(3);
  EXPECT_THROW(qp.Solve(Matrix::Identity(3, 3), big, big, big, big), InvalidArgument);
}

TEST(BoxQP, SolveDoesNotAllocate) {
  ASSERT_TRUE(MallocCountingWorks());
  std::mt19937 rng(9);
  const Case c = RandomCase(&rng, 20, 0.2);
  BoxQP qp(20);
  Vector x = Vector::Zero(20);
  MallocCounter counter;
  qp.Solve(c.H, c.g, c.lo, c.hi, x);
  EXPECT_EQ(counter.count(), 0);
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
