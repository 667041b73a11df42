// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Convergence that does not depend on how bad the start was (issue 47, item 1): an LQR problem
// with an unstable open loop, posed from u^0 = 0 on a 10 s horizon (first cost ~3e46), must
// converge to the optimum computed here without the engine (the continuous algebraic Riccati
// equation and the Riccati ODE), also with its cost scaled by 1e-9 and 1e9; and SolveResult
// says in words why it stopped.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/learner.h"
#include "ddoc/plant.h"
#include "standard_problems.h"
#include "standard_references.h"

namespace ddoc {
namespace testing {
namespace {

// x1' = 5.5 x1 + u (unstable, eigenvalue 5.5 /s), x2' = x1 - x2; l = c/2 (|x|^2 + 0.2 u^2),
// x0 = (1, 0), T = 10 s, no terminal cost. u^0 = 0 costs ~2.8e46 c.
LinearQuadraticData UnstableLqr(double c) {
  LinearQuadraticData d;
  Matrix A(2, 2), B(2, 1);
  A << 5.5, 0, 1, -1;
  B << 1, 0;
  d.A = {A};
  d.B = {B};
  d.Q = {c * Matrix::Identity(2, 2)};
  d.r = {Vector::Zero(2)};
  d.R = {Matrix::Constant(1, 1, 0.2 * c)};
  d.rho = {0.0};
  d.S = {Matrix::Zero(2, 2)};
  d.s = {Vector::Zero(2)};
  d.u_min = Vector::Constant(1, -std::numeric_limits<double>::infinity());
  d.u_max = Vector::Constant(1, std::numeric_limits<double>::infinity());
  d.x0 = Vector::Zero(2);
  d.x0(0) = 1;
  d.final_time = 10;
  return d;
}

TEST(Convergence, TheOptimumOfTheUnstableLqrIsComputedIndependently) {
  const LinearQuadraticData d = UnstableLqr(1.0);
  // The infinite-horizon value 1/2 x0' S x0 (CARE) and the 10 s value (Riccati ODE, RK4) agree:
  // the closed loop decays at ~7.6 /s, so 10 s is infinite to rounding.
  const Matrix S = SolveContinuousAre(d.A[0], d.B[0], d.Q[0], d.R[0]);
  const double care = 0.5 * d.x0.dot(S * d.x0);
  const double ode = LqOptimalCostRk4(d, Vector::Constant(1, 10.0), 1e-3);
  EXPECT_NEAR(care, 1.14956113057, 1e-9);  // scipy.linalg.solve_continuous_are
  EXPECT_LT(std::abs(ode - care) / care, 1e-9);
}

class UnstableLqrScale : public ::testing::TestWithParam<double> {};

TEST_P(UnstableLqrScale, ConvergesToTheOptimumFromAStartOf1e46) {
  const double c = GetParam();
  const LinearQuadraticData d = UnstableLqr(c);
  const std::unique_ptr<StandardProblem> sp = StandardProblemFromLq(d);
  sp->initial_durations = Vector::Constant(1, 10.0);
  const Matrix S = SolveContinuousAre(d.A[0], d.B[0], d.Q[0], d.R[0]);
  const double optimum = 0.5 * d.x0.dot(S * d.x0);
  // What the plant's zero-order hold at dt = 1e-3 s can reach (a 1e-4 relative gap).
  const double held = LqZeroOrderHoldOptimalCost(d, Vector::Constant(1, 10.0), 1e-3);

  LearnerSettings settings;
  settings.max_trials = 60;
  FunctionPolicy initial = sp->InitialPolicy();
  ModelPlant plant(sp->problem);
  Learner learner(sp->problem, settings);
  const SolveResult r = learner.Solve(plant, plant, sp->x0, initial);
  std::printf("cost x %g: %s after %d trials (%d accepted), first cost %.3g, cost %.10g, "
              "optimum %.10g (held %.10g)\n  %s\n",
              c, LearnerStatusName(r.status), r.trials, r.iterations, r.cost_history.front(),
              r.cost, optimum, held, r.stop_reason.c_str());
  EXPECT_GT(r.cost_history.front(), 1e46 * c);
  EXPECT_EQ(r.status, LearnerStatus::kConverged);
  EXPECT_LT(std::abs(r.cost - optimum) / optimum, 1e-3) << "cost " << r.cost;
  EXPECT_LT(std::abs(r.cost - held) / held, 1e-6) << "cost " << r.cost;
  EXPECT_LE(r.trials, 40);
  // The reason names the test that stopped it and the current cost.
  EXPECT_NE(r.stop_reason.find("converged"), std::string::npos) << r.stop_reason;
  EXPECT_NE(r.stop_reason.find("current cost"), std::string::npos) << r.stop_reason;
}

INSTANTIATE_TEST_SUITE_P(Scales, UnstableLqrScale, ::testing::Values(1.0, 1e-9, 1e9));

TEST(Convergence, EveryStatusHasAReason) {
  // A solve cut by max_trials says so, with the budget.
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0");
  LearnerSettings settings;
  settings.max_trials = 1;
  FunctionPolicy initial = sp->InitialPolicy();
  const SolveResult r = SolveOnModel(*sp, initial, settings);
  EXPECT_EQ(r.status, LearnerStatus::kMaxTrials);
  EXPECT_NE(r.stop_reason.find("max_trials = 1"), std::string::npos) << r.stop_reason;
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
