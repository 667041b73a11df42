// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A problem posed as a user writes it (issue 47, item 2): the input-state cross term of
// QuadraticTrackingCost, the feedback law in physical time against an independent
// continuous-time LQR (CARE) solution, defaults that need no lines, and bad input named up
// front.
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/check_derivatives.h"
#include "ddoc/learner.h"
#include "ddoc/linear_system.h"
#include "ddoc/plant.h"
#include "ddoc/quadratic_cost.h"
#include "standard_problems.h"
#include "standard_references.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Matrix M(int rows, int cols, std::initializer_list<double> values) {
  Matrix out(rows, cols);
  auto it = values.begin();
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) out(i, j) = *it++;
  }
  return out;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// The cross term u' N (x - r).

TEST(QuadraticTrackingCostCrossTerm, ValueAndDerivativesMatchTheFormula) {
  // Two modes of different state sizes, two inputs.
  const Matrix Q0 = M(2, 2, {2, 0.3, 0.3, 1});
  const Matrix Q1 = M(3, 3, {3, 0, 0.1, 0, 2, 0, 0.1, 0, 1});
  const Matrix R = M(2, 2, {1, 0.2, 0.2, 2});
  const Matrix N0 = M(2, 2, {0.3, -0.2, 0.1, 0.4});
  const Matrix N1 = M(2, 3, {0.2, 0.1, -0.3, 0.0, 0.5, 0.2});
  const Vector r0 = Eigen::Vector2d(0.5, -1), r1 = Eigen::Vector3d(1, 0, 2);
  QuadraticTrackingCost cost({Q0, Q1}, {r0, r1}, {R, R}, {0.1, 0.2},
                             {Matrix::Zero(2, 2), Matrix::Identity(3, 3)},
                             {Vector::Zero(2), Vector::Zero(3)}, {N0, N1});
  // A system of the right sizes for CheckDerivatives (its own derivatives are not the point).
  LinearSystem system({M(2, 2, {0, 1, -1, 0}), Matrix::Identity(3, 3)},
                       {M(2, 2, {1, 0, 0, 1}), M(3, 2, {1, 0, 0, 1, 1, 1})},
                       {M(3, 2, {1, 0, 0, 1, 0, 0})});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> dist(-2.0, 2.0);
  for (int k = 0; k < 2; ++k) {
    const Matrix& Q = k == 0 ? Q0 : Q1;
    const Matrix& N = k == 0 ? N0 : N1;
    const Vector& r = k == 0 ? r0 : r1;
    for (int trial = 0; trial < 3; ++trial) {
      Vector x(Q.rows()), u(2);
      for (int i = 0; i < x.size(); ++i) x(i) = dist(rng);
      for (int i = 0; i < u.size(); ++i) u(i) = dist(rng);
      const double expected = 0.5 * (x - r).dot(Q * (x - r)) + 0.5 * u.dot(R * u) +
                              u.dot(N * (x - r)) + (k == 0 ? 0.1 : 0.2);
      EXPECT_NEAR(cost.Running(k, x, u), expected, 1e-12);
      const DerivativeCheckReport report = CheckDerivatives(system, &cost, k, x, u);
      for (const char* name : {"lx", "lu", "lxx", "luu", "lux"}) {
        const DerivativeError* e = report.Find(name);
        ASSERT_NE(e, nullptr) << name;
        EXPECT_LT(e->max_rel_error, 1e-7) << "mode " << k << " " << name;
      }
      EXPECT_TRUE(report.PassedPerEntry()) << report.max_entry_error();
    }
  }
}

TEST(QuadraticTrackingCostCrossTerm, BadCrossWeightsAreNamed) {
  const Matrix Q = Matrix::Identity(2, 2), R = Matrix::Identity(1, 1);
  auto make = [&](std::vector<Matrix> N) {
    QuadraticTrackingCost cost({Q, Q}, {Vector::Zero(2), Vector::Zero(2)}, {R, R}, {0, 0},
                               {Q, Q}, {Vector::Zero(2), Vector::Zero(2)}, std::move(N));
  };
  EXPECT_NE(ErrorOf([&] { make({M(1, 2, {0, 0})}); }).find("N has 1 entries, expected 2"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { make({M(1, 2, {0, 0}), M(2, 1, {0, 0})}); })
                .find("N[1] is 2 x 1, expected 1 x 2"),
            std::string::npos);
  // |N| too large for Q and R: the joint form [Q N'; N R] is indefinite.
  EXPECT_NE(ErrorOf([&] { make({M(1, 2, {0, 0}), M(1, 2, {2, 0})}); })
                .find("[Q N'; N R][1] is not positive semidefinite"),
            std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// The feedback law in physical time against the continuous-time LQR.

// CARE with a cross term: A'S + SA - (SB + N')R^-1(B'S + N) + Q = 0, by the standard CARE of
// A - B R^-1 N and Q - N' R^-1 N (standard_references' Hamiltonian solver).
Matrix CareWithCrossTerm(const Matrix& A, const Matrix& B, const Matrix& Q, const Matrix& R,
                         const Matrix& N) {
  const Matrix Ri = R.inverse();
  return SolveContinuousAre(A - B * Ri * N, B, Q - N.transpose() * Ri * N, R);
}

TEST(FeedbackLaw, IsTheContinuousTimeLqrGain) {
  // An unstable two-state plant with two inputs and a cross term; terminal weight S = the CARE
  // solution, so the Riccati solution is S on the whole horizon and K(t) = -R^-1 (B'S + N).
  const Matrix A = M(2, 2, {0, 1, 2, -0.5});
  const Matrix B = M(2, 2, {0, 1, 1, 0.3});
  const Matrix Q = M(2, 2, {2, 0.2, 0.2, 1});
  const Matrix R = M(2, 2, {0.5, 0.1, 0.1, 1});
  const Matrix N = M(2, 2, {0.2, -0.1, 0.3, 0.1});
  const Matrix S = CareWithCrossTerm(A, B, Q, R, N);
  const Matrix K_care = -R.inverse() * (B.transpose() * S + N);
  // The CARE residual: the reference is right.
  const Matrix residual = A.transpose() * S + S * A -
                          (S * B + N.transpose()) * R.inverse() * (B.transpose() * S + N) + Q;
  ASSERT_LT(residual.cwiseAbs().maxCoeff(), 1e-10);

  const double T = 3.0;
  LinearSystem system({A}, {B}, {});
  QuadraticTrackingCost cost({Q}, {Vector::Zero(2)}, {R}, {0.0}, {S}, {Vector::Zero(2)}, {N});
  Problem problem;
  problem.system = &system;
  problem.cost = &cost;
  PoseFixedHorizon(&problem, 2, T);
  ModelPlant plant(problem);
  FunctionPolicy initial(Vector::Constant(1, T),
                         [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); });
  Learner learner(problem);
  const SolveResult r = learner.Solve(plant, plant, Eigen::Vector2d(1, -0.5), initial);
  ASSERT_EQ(r.status, LearnerStatus::kConverged) << r.stop_reason;

  const std::vector<ModeFeedbackLaw> law = learner.FeedbackLaw();
  ASSERT_EQ(law.size(), 1u);
  const ModeFeedbackLaw& mode = law[0];
  ASSERT_EQ(static_cast<int>(mode.K.size()), mode.t.size());
  EXPECT_DOUBLE_EQ(mode.t(0), 0.0);
  EXPECT_NEAR(mode.t(mode.t.size() - 1), T, 1e-12);
  double gain_error = 0, ff = 0;
  for (int j = 0; j < mode.t.size(); ++j) {
    ASSERT_EQ(mode.K[j].rows(), 2);
    ASSERT_EQ(mode.K[j].cols(), 2);
    gain_error = std::max(gain_error, (mode.K[j] - K_care).cwiseAbs().maxCoeff());
    ff = std::max(ff, mode.u_ff.col(j).norm());
  }
  std::printf("max |K(t) - K_care| %.3g (|K_care| %.3g), max |u_ff| %.3g\n", gain_error,
              K_care.cwiseAbs().maxCoeff(), ff);
  // At alpha = 0 the law is exactly "nominal input + K (x - x_nominal)": u_ff + K x_nominal is
  // the nominal input.
  const std::vector<ModeFeedbackLaw> law0 = learner.FeedbackLaw(0.0);
  for (int j = 0; j < mode.t.size(); ++j) {
    EXPECT_LT((law0[0].u_ff.col(j) + law0[0].K[j] * mode.x.col(j) - mode.u.col(j)).norm(), 1e-12);
    EXPECT_EQ(law0[0].K[j], mode.K[j]);
  }
  // The pass integrates the Riccati ODE, which stays at S: the gain is the CARE's to rounding
  // (measured 4e-16).
  EXPECT_LT(gain_error, 1e-9 * K_care.cwiseAbs().maxCoeff()) << "K_care\n" << K_care;
  // The optimal law of an LQR is pure feedback: the feed-forward is ~0 next to |u| ~ |K x0|.
  EXPECT_LT(ff, 1e-2 * (K_care * Eigen::Vector2d(1, -0.5)).norm());
}


// ---------------------------------------------------------------------------------------------
// Defaults that need no lines.

TEST(Defaults, NoSurfacesNeedNoWeightsAndAFixedFinalTimeBoundsTheDurations) {
  // exp0 as a user writes it: no surface_weights, no duration_max, FixFinalTime(2).
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0");
  Problem problem;
  problem.system = sp->system.get();
  problem.cost = sp->cost.get();
  problem.bounds.u_min = Vector::Constant(1, -kInf);
  problem.bounds.u_max = Vector::Constant(1, kInf);
  problem.bounds.duration_min = Vector::Constant(2, 0.01);
  problem.bounds.FixFinalTime(2.0);
  EXPECT_NO_THROW(problem.Validate());
  EXPECT_EQ(problem.SurfaceWeight(1), 0.0);
  EXPECT_EQ(problem.bounds.MaxDuration(0), 2.0);
  // Infinite entries: bounded by the final time as well.
  problem.bounds.duration_max = Vector::Constant(2, kInf);
  EXPECT_NO_THROW(problem.Validate());
  EXPECT_EQ(problem.bounds.MaxDuration(1), 2.0);
  LearnerSettings settings;
  settings.max_trials = sp->trial_budget();
  FunctionPolicy initial = sp->InitialPolicy();
  ModelPlant plant(problem);
  Learner learner(problem, settings);
  const SolveResult r = learner.Solve(plant, plant, sp->x0, initial);
  EXPECT_EQ(r.status, LearnerStatus::kConverged) << r.stop_reason;
  EXPECT_LT(std::abs(r.cost - sp->reference_cost) / sp->reference_cost, 1e-3) << r.cost;
  EXPECT_LT((r.T - sp->reference_T).cwiseAbs().maxCoeff(), 1e-3) << r.T.transpose();
  // Without a final time the durations still need a finite upper bound, named.
  problem.bounds.final_time_min = 0;
  problem.bounds.final_time_max = kInf;
  EXPECT_NE(ErrorOf([&] { problem.Validate(); }).find("bounds.duration_max"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Bad input named up front.

TEST(NamedErrors, ACostWithMoreModesThanTheSystem) {
  // A 3-mode QuadraticCost on the 2-mode EXP0 problem: used to return 8.665 at switch 0.177
  // with the third mode dropped (right: 9.7665 at 0.18967).
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0");
  const LinearQuadraticData d = Exp0Data(kInf);
  QuadraticTrackingCost three({d.Q[0], d.Q[1], d.Q[1]}, {d.r[0], d.r[1], d.r[1]},
                              {d.R[0], d.R[1], d.R[1]}, {0, 0, 0}, {d.S[0], d.S[1], d.S[1]},
                              {d.s[0], d.s[1], d.s[1]});
  sp->problem.cost = &three;
  const std::string error = ErrorOf([&] { sp->problem.Validate(); });
  EXPECT_NE(error.find("the cost has 3 modes, the system 2"), std::string::npos) << error;
  EXPECT_NE(ErrorOf([&] { Learner learner(sp->problem); }).find("3 modes"), std::string::npos);
}

TEST(NamedErrors, AWrongAIsNamedNotB) {
  // A 3x3 A[1] on a mode whose B[1] has 2 rows: the message names A[1] (it blamed B[1]).
  const std::string error = ErrorOf([&] {
    LinearSystem system({Matrix::Identity(2, 2), Matrix::Identity(3, 3)},
                        {Matrix::Ones(2, 1), Matrix::Ones(2, 1)}, {Matrix::Identity(3, 2)});
  });
  EXPECT_NE(error.find("A[1] and B[1] disagree"), std::string::npos) << error;
  EXPECT_NE(error.find("B[1] is (2, 1), expected (3, 1); or A[1] should be (2, 2)"),
            std::string::npos)
      << error;
}

TEST(NamedErrors, InitialDurationsThatMissAFixedFinalTime) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0");  // final time 2 s
  FunctionPolicy initial(Eigen::Vector2d(1.0, 0.5), sp->initial_input);
  const std::string error = ErrorOf([&] { SolveOnModel(*sp, initial, LearnerSettings{}); });
  EXPECT_NE(error.find("initial durations add up to 1.5"), std::string::npos) << error;
  EXPECT_NE(error.find("fixed at 2"), std::string::npos) << error;
}

TEST(NamedErrors, ZeroInputWeightOnAnUnboundedInput) {
  // R = 0 with |u| unbounded: no minimum in u (used to run 27 trials to line_search_failed).
  LinearQuadraticData d = Exp0Data(kInf);
  d.R = {Matrix::Zero(1, 1), Matrix::Zero(1, 1)};
  const std::unique_ptr<StandardProblem> sp = StandardProblemFromLq(d);
  const std::string error = ErrorOf([&] { sp->problem.Validate(); });
  EXPECT_NE(error.find("R[0] of the quadratic cost is singular"), std::string::npos) << error;
  EXPECT_NE(error.find("input 0, which is unbounded"), std::string::npos) << error;
  // With finite input bounds the same R is a (bang-bang) problem with a minimum: accepted.
  sp->problem.bounds.u_min = Vector::Constant(1, -8);
  sp->problem.bounds.u_max = Vector::Constant(1, 8);
  EXPECT_NO_THROW(sp->problem.Validate());
}

// ---------------------------------------------------------------------------------------------
// Buffers sized from the problem and the plant.

TEST(Samples, ALongHorizonAtAFinePlantStepNeedsNoSetting) {
  // 12 s at dt = 5e-4: 24012 samples, more than the default max_samples = 20000 (used to throw
  // "24012 samples, more than max_samples").
  LinearQuadraticData d = LqrData();
  d.final_time = 12;
  const std::unique_ptr<StandardProblem> sp = StandardProblemFromLq(d);
  sp->initial_durations = Vector::Constant(1, 12.0);
  ModelPlantSettings plant_settings;
  plant_settings.dt = 5e-4;
  ModelPlant plant(sp->problem, plant_settings);
  LearnerSettings settings;
  ASSERT_EQ(settings.max_samples, 20000);
  Learner learner(sp->problem, settings);
  FunctionPolicy initial = sp->InitialPolicy();
  const SolveResult r = learner.Solve(plant, plant, sp->x0, initial);
  EXPECT_EQ(r.status, LearnerStatus::kConverged) << r.stop_reason;
  EXPECT_GT(learner.settings().max_samples, 24000);
  EXPECT_NEAR(r.cost, LqOptimalCostRk4(d, Vector::Constant(1, 12.0), 1e-3), 1e-3 * r.cost);
  // The incremental API (no Solve) names the setting to raise.
  Trajectory measured;
  plant.Run(sp->x0, initial, &measured);
  Learner incremental(sp->problem, settings);
  const std::string error = ErrorOf([&] { incremental.Initialize(measured); });
  EXPECT_NE(error.find("LearnerSettings.max_samples"), std::string::npos) << error;
  EXPECT_GT(measured.total_samples(), 24000);
  EXPECT_NE(error.find("at least " + std::to_string(measured.total_samples())), std::string::npos)
      << error;
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
