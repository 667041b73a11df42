// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Modes of zero duration (issue 47): Bounds::duration_min = 0 makes a vanished mode a legal
// point. Posing, the one-sided gradient w.r.t. a zero duration against finite differences, a
// mode that should vanish and one that should grow again (docs/engine.md, "Modes of zero
// duration").
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/ddoc.h"
#include "standard_problems.h"
#include "standard_references.h"

namespace ddoc {
namespace testing {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void ExpectError(const std::function<void()>& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected one with \"" << needle << "\"";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

bool AllFinite(const Trajectory& t) {
  bool ok = t.T.allFinite() && t.x0.allFinite();
  for (const ModeTrajectory& m : t.modes) ok = ok && m.t.allFinite() && m.x.allFinite() && m.u.allFinite();
  return ok;
}

// EXP0 (Xu & Antsaklis, example 1) with a copy of its mode 0 inserted after it that charges
// `price` per second: J3(D0, D1, D2) = J2(D0 + D1, D2) + price D1, so every optimum has
// D1 = 0 and (D0, D2) optimal for EXP0 itself.
LinearQuadraticData Exp0WithAPricedCopy(double price) {
  const LinearQuadraticData e = Exp0Data(kInf);
  LinearQuadraticData d = e;
  d.A = {e.A[0], e.A[0], e.A[1]};
  d.B = {e.B[0], e.B[0], e.B[1]};
  d.E = {Matrix::Identity(2, 2), e.E[0]};
  d.Q = {e.Q[0], e.Q[0], e.Q[1]};
  d.r = {e.r[0], e.r[0], e.r[1]};
  d.R = {e.R[0], e.R[0], e.R[1]};
  d.rho = {e.rho[0], e.rho[0] + price, e.rho[1]};
  d.S = {e.S[0], e.S[0], e.S[1]};
  d.s = {e.s[0], e.s[0], e.s[1]};
  return d;
}

// Algorithm 1 on the exact model, trial by trial, failing on any non-finite quantity.
struct RunResult {
  LearnerStatus status = LearnerStatus::kRunning;
  double cost = 0;
  Vector T;
  int trials = 0;
};
RunResult SolveChecked(const Problem& problem, const Vector& x0, Policy& initial, int max_trials) {
  ModelPlant plant(problem);
  LearnerSettings settings;
  Learner learner(problem, settings);
  Trajectory measured;
  plant.Run(x0, initial, &measured);
  EXPECT_TRUE(AllFinite(measured));
  learner.Initialize(measured);
  while (learner.status() == LearnerStatus::kRunning && learner.trials() < max_trials) {
    OnlineController& law = learner.NextTrial();
    EXPECT_TRUE(law.planned_T().allFinite());
    plant.Run(x0, law, &measured);
    EXPECT_TRUE(AllFinite(measured)) << "trial " << learner.trials() + 1;
    const TrialResult r = learner.CompleteTrial(measured);
    EXPECT_TRUE(std::isfinite(r.cost) && std::isfinite(r.predicted) &&
                std::isfinite(r.optimality))
        << "trial " << r.trial << ": cost " << r.cost << ", predicted " << r.predicted
        << ", optimality " << r.optimality;
    EXPECT_TRUE(learner.backward_pass().gradient_T().allFinite());
    EXPECT_TRUE(learner.backward_pass().P22_initial().allFinite());
  }
  RunResult out;
  out.status = learner.status();
  out.cost = learner.nominal_cost();
  out.T = learner.nominal().T;
  out.trials = learner.trials();
  return out;
}

TEST(ZeroDuration, AStandardProblemIsPosedWithDurationMinZero) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("sto9_linear");
  Problem& p = sp->problem;
  p.bounds.duration_min.setZero();
  p.Validate();  // before: "duration_min(0) = 0, expected > 0"
  ModelPlant plant(p);
  FunctionPolicy initial = sp->InitialPolicy();
  const SolveResult r = SolveOnModel(*sp, initial, LearnerSettings{});
  EXPECT_EQ(r.status, LearnerStatus::kConverged) << r.stop_reason;
  EXPECT_NEAR(r.cost, sp->reference_cost, 1e-3 * sp->reference_cost);
  EXPECT_LE((r.T - sp->reference_T).cwiseAbs().maxCoeff(), 1e-3);
  // A negative lower bound stays an error that names the entry.
  p.bounds.duration_min(3) = -0.01;
  ExpectError([&] { p.Validate(); }, "duration_min(3) = -0.01, expected >= 0");
  ExpectError([&] { ModelPlant bad(*sp->system, p.bounds); }, "duration_min(3) = -0.01");
  // A policy may plan a mode of zero duration, not a negative one.
  auto none = [](int, double, const ConstVectorRef&, VectorRef) {};
  EXPECT_NO_THROW(FunctionPolicy(Eigen::Vector2d(0.0, 1.0), none));
  ExpectError([&] { FunctionPolicy(Eigen::Vector2d(-0.5, 1.5), none); },
              "planned duration of mode 0 is -0.500000, expected >= 0");
}

// The gradient of the cost w.r.t. T_1 where mode 1 has zero duration, against one-sided finite
// differences of the plant's cost from D_1 = 0+ (T_0 and the final time held): the one-sided
// derivative H_1 - H_2 at the switch, the Hamiltonian difference of the vanished mode and the
// mode that gives up the time, with the inputs held as the nominal's.
TEST(ZeroDuration, TheGradientAtAZeroDurationIsTheOneSidedDerivative) {
  const LinearQuadraticData d = Exp0WithAPricedCopy(0.3);
  std::unique_ptr<StandardProblem> sp = StandardProblemFromLq(d);
  Problem& p = sp->problem;
  p.bounds.duration_min.setZero();
  ModelPlantSettings plant_settings;
  plant_settings.dt = 1e-3;
  ModelPlant plant(p, plant_settings);
  // Held inputs per mode (mode 1's differs from mode 0's), zero-order hold.
  const double u_mode[3] = {0.8, -1.7, 0.4};
  auto cost_at = [&](double D1, Trajectory* out) {
    FunctionPolicy policy(Eigen::Vector3d(0.6, D1, 1.4 - D1),
                          [&](int k, double, const ConstVectorRef&, VectorRef u) {
                            u(0) = u_mode[k];
                          });
    plant.Run(sp->x0, policy, out);
    return EvaluateCost(p, *out).total;
  };
  Trajectory nominal;
  const double J0 = cost_at(0.0, &nominal);
  ASSERT_EQ(nominal.T(1), nominal.T(0));  // mode 1 vanished: two samples at one instant
  ASSERT_EQ(nominal.modes[1].num_samples(), 2);
  for (BackwardEquation equation : {BackwardEquation::kRiccati, BackwardEquation::kLyapunov}) {
    BackwardPassSettings bs;
    bs.equation = equation;
    BackwardPass pass;
    pass.Allocate(p, 10000, bs);
    ASSERT_TRUE(pass.Run(nominal, 0.0));
    const double gradient = pass.gradient_T()(1);
    ASSERT_TRUE(std::isfinite(gradient));
    EXPECT_TRUE(pass.P22_initial().allFinite());
    // One-sided, second order: (-3 J(0) + 4 J(h) - J(2h)) / (2h); h a multiple of dt, so the
    // plant's grid of mode 2 moves with T_1 without a change in its step count.
    const double h = 1e-3;
    Trajectory scratch;
    const double fd = (-3 * J0 + 4 * cost_at(h, &scratch) - cost_at(2 * h, &scratch)) / (2 * h);
    EXPECT_NEAR(gradient, fd, 1e-3 * std::abs(fd))
        << (equation == BackwardEquation::kRiccati ? "kRiccati" : "kLyapunov");
  }
}

// (31) with the lower bound 0 active ends the mode exactly where it starts: T + S dD in floating
// point would leave modes of 1e-17 s, whose 1 / D-scaled terms the next backward pass would see.
TEST(ZeroDuration, TheSwitchingTimeUpdatePutsAVanishingModeOnExactlyZero) {
  std::unique_ptr<StandardProblem> sp = StandardProblemFromLq(Exp0WithAPricedCopy(1.0));
  sp->problem.bounds.duration_min.setZero();
  ModelPlant plant(sp->problem);
  BackwardPass pass;
  pass.Allocate(sp->problem, 10000);
  OnlineController law;
  law.Allocate(sp->problem, 10000);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const double t0 = 0.1 + 0.8 * unit(rng), t1 = t0 + 0.05 + 0.5 * unit(rng);
    const Eigen::Vector3d T(t0, t1, 2.0);
    // A steep price on D_1 (its gradient 1e3) and a generic pull on T_0.
    const Eigen::Vector3d p2(unit(rng) - 0.5 - 1e3, 1e3, 0.0);
    const SwitchingTimeStep step =
        SolveSwitchingTimeUpdate(sp->problem, T, Matrix::Identity(3, 3), p2, 1.0);
    ASSERT_NEAR(step.T_planned(1) - step.T_planned(0), 0.0, 1e-12) << "trial " << trial;
    EXPECT_EQ(step.T_planned(1), step.T_planned(0)) << "trial " << trial;
    // The controller plans T + dT (rounded again): a vanished mode plans exactly 0.
    FunctionPolicy nominal_law(Eigen::Vector3d(t0, t1 - t0, 2.0 - t1),
                               [](int, double, const ConstVectorRef&, VectorRef u) { u(0) = 0.3; });
    Trajectory nominal;
    plant.Run(sp->x0, nominal_law, &nominal);
    ASSERT_TRUE(pass.Run(nominal));
    law.Load(nominal, pass, 1.0, step.dT);
    EXPECT_EQ(law.PlannedDuration(1), 0.0) << "trial " << trial;
  }
}

// A mode that should vanish: with duration_min = 0 the engine ends at D_1 = 0 and EXP0's
// optimal cost and instant, computed here without the engine (LqReference on EXP0 itself).
// With duration_min = 0.01 s (the suite's) the best it can do is 0.01 price above.
TEST(ZeroDuration, AModeThatShouldVanishConvergesToZeroDuration) {
  const double price = 2.0;
  const LinearQuadraticData d = Exp0WithAPricedCopy(price);
  const ReferenceOptimum exp0 = LqReference(Exp0Data(kInf), Eigen::Vector2d(0.2, 2.0), 0.01);
  std::unique_ptr<StandardProblem> sp = StandardProblemFromLq(d);
  sp->problem.bounds.duration_min.setZero();
  FunctionPolicy initial(Eigen::Vector3d(0.3, 0.4, 1.3),
                         [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); });
  const RunResult r = SolveChecked(sp->problem, sp->x0, initial, 60);
  EXPECT_EQ(r.status, LearnerStatus::kConverged);
  EXPECT_EQ(r.T(1) - r.T(0), 0.0) << "mode 1 lasts " << r.T(1) - r.T(0) << " s";
  EXPECT_NEAR(r.T(0), exp0.T(0), 1e-3);
  // The plant's zero-order hold costs 4.5e-7 relative on EXP0 (docs/standard_problems.md).
  EXPECT_NEAR(r.cost, exp0.cost, 1e-5 * exp0.cost) << "I* = " << exp0.cost;
}

// A mode at zero duration whose one-sided gradient says grow: the engine leaves the bound and
// reaches the interior optimum (sto2_linear without inputs, exp0 with an input whose value in
// the vanished mode is first set by the Hamiltonian's minimizer).
TEST(ZeroDuration, AModeAtZeroGrowsWhenItsGradientSaysSo) {
  for (const std::string name : {"sto2_linear", "exp0"}) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    sp->problem.bounds.duration_min.setZero();
    FunctionPolicy initial(Eigen::Vector2d(0.0, sp->final_time()), sp->initial_input);
    const RunResult r = SolveChecked(sp->problem, sp->x0, initial, 60);
    EXPECT_EQ(r.status, LearnerStatus::kConverged) << name;
    EXPECT_NEAR(r.cost, sp->reference_cost, 1e-5 * sp->reference_cost) << name;
    EXPECT_NEAR(r.T(0), sp->reference_T(0), 1e-3) << name;
  }
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
