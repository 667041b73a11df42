// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Algorithm 1 end to end: a two-mode linear switched problem with free switching instants whose
// optimum the test computes independently (Riccati for every pair of durations on a dense grid),
// data-driven vs model-based on an inexact model, and the incremental (one trial at a time) API.
#include <cmath>
#include <tuple>

#include <gtest/gtest.h>

#include "ddoc/learner.h"
#include "test_systems.h"
#include "test_util.h"
#include "two_mode_lq.h"

namespace ddoc {
namespace testing {
namespace {

// Riccati in backward time: dS/ds = A'S + SA - S B B' S / r + Q, classical RK4.
Eigen::Matrix2d RiccatiStep(const Eigen::Matrix2d& S, const Eigen::Matrix2d& A,
                            const Eigen::Vector2d& B, const Eigen::Matrix2d& Q, double r,
                            double h) {
  auto f = [&](const Eigen::Matrix2d& X) -> Eigen::Matrix2d {
    return A.transpose() * X + X * A - X * B * B.transpose() * X / r + Q;
  };
  const Eigen::Matrix2d k1 = f(S), k2 = f(S + 0.5 * h * k1), k3 = f(S + 0.5 * h * k2),
                        k4 = f(S + h * k3);
  return S + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
}

struct Optimum {
  double D0, D1, cost;
};

// Dense search: optimal cost of the unconstrained-input LQ problem for every (D0, D1) on a grid
// of spacing `grid` (the input bounds are inactive), each by an exact Riccati solve.
Optimum DenseSearch(const TwoModeLq& lq, double d0_lo, double d0_hi, double d1_lo, double d1_hi,
                    double grid) {
  const double h = grid / 4;
  Optimum best{0, 0, 1e300};
  // Mode 1 sweep from S over D1.
  Eigen::Matrix2d S1 = lq.S;
  double d1 = 0;
  const int n1 = static_cast<int>(std::round(d1_hi / h));
  for (int i1 = 0; i1 <= n1; ++i1, d1 = i1 * h) {
    if (i1 > 0) S1 = RiccatiStep(S1, lq.A1, lq.b_scale * lq.B1, lq.Q1, lq.r, h);
    if (d1 < d1_lo - 1e-12 || i1 % 4 != 0) continue;
    // Mode 0 sweep from S1 (phi_0 = 0, identity reset).
    Eigen::Matrix2d S0 = S1;
    const int n0 = static_cast<int>(std::round(d0_hi / h));
    for (int i0 = 1; i0 <= n0; ++i0) {
      S0 = RiccatiStep(S0, lq.A0, lq.b_scale * lq.B0, lq.Q0, lq.r, h);
      const double d0 = i0 * h;
      if (d0 < d0_lo - 1e-12 || i0 % 4 != 0) continue;
      const double J = 0.5 * lq.x0.dot(S0 * lq.x0) + lq.rho0 * d0 + lq.rho1 * d1;
      if (J < best.cost) best = {d0, d1, J};
    }
  }
  return best;
}

// 0: the default preset; 1: the paper preset.
class TwoModeLqTest : public ::testing::TestWithParam<int> {};

TEST_P(TwoModeLqTest, ReachesTheIndependentOptimum) {
  TwoModeLq lq;
  LqProblem p(lq);
  const Optimum coarse = DenseSearch(lq, 0.2, 2.0, 0.3, 3.0, 0.01);
  // The optimum is interior in both durations (else the test would only check a bound).
  ASSERT_GT(coarse.D0, 0.25);
  ASSERT_LT(coarse.D0, 1.95);
  ASSERT_GT(coarse.D1, 0.35);
  ASSERT_LT(coarse.D1, 2.95);

  ModelPlantSettings ps;
  ps.dt = 1e-3;
  ModelPlant plant(p.problem, ps);
  FunctionPolicy initial = ZeroInputPolicy();
  LearnerSettings settings = GetParam() == 1 ? LearnerSettings::Paper() : LearnerSettings{};
  settings.max_trials = 1500;
  settings.max_samples = 10000;
  Learner learner(p.problem, settings);
  const SolveResult result = learner.Solve(plant, plant, lq.x0, initial);
  std::printf("status %d trials %d iterations %d cost %.6f T %.4f %.4f | optimum D %.3f %.3f cost %.6f\n",
              static_cast<int>(result.status), result.trials, result.iterations, result.cost,
              result.T(0), result.T(1) - result.T(0), coarse.D0, coarse.D1, coarse.cost);
  if (GetParam() == 0) {
    EXPECT_EQ(result.status, LearnerStatus::kConverged);
    EXPECT_LE(result.trials, 30);
  } else {
    EXPECT_NE(result.status, LearnerStatus::kMaxTrials);
  }
  EXPECT_NEAR(result.T(0), coarse.D0, 0.02);
  EXPECT_NEAR(result.T(1) - result.T(0), coarse.D1, 0.02);
  EXPECT_NEAR(result.cost, coarse.cost, 1e-3 * coarse.cost);
  // Monotone decrease of the accepted costs (36).
  for (size_t i = 1; i < result.cost_history.size(); ++i) {
    EXPECT_LE(result.cost_history[i], result.cost_history[i - 1]);
  }
}

struct MethodCosts {
  double alg1, mrl, ocfb;  // true costs
  SolveResult r_alg1, r_mrl, r_ocfb;
};

// Runs the three methods of Section V with `model` as the model and `truth` as the plant.
MethodCosts RunThreeMethods(LqProblem& model, LqProblem& truth) {
  ModelPlant model_plant(model.problem);
  ModelPlant real_plant(truth.sys, model.problem.bounds);
  FunctionPolicy initial = ZeroInputPolicy();
  const Vector x0 = model.lq.x0;
  MethodCosts out;
  // Costs are always evaluated with the same cost functional (the model's; costs are exact).
  {
    Learner alg1(model.problem, LqTestSettings());
    out.r_alg1 = alg1.Solve(real_plant, real_plant, x0, initial);
    out.alg1 = out.r_alg1.cost;
  }
  {
    Learner mrl(model.problem, LqTestSettings());
    out.r_mrl = mrl.Solve(model_plant, real_plant, x0, initial);
    out.mrl = out.r_mrl.cost;
  }
  {
    Learner ocfb(model.problem, LqTestSettings());
    out.r_ocfb = ocfb.Solve(model_plant, model_plant, x0, initial);
    Trajectory applied;
    real_plant.Run(x0, ocfb.ConvergedPolicy(), &applied);
    out.ocfb = EvaluateCost(model.problem, applied).total;
  }
  std::printf("true costs: Algorithm 1 %.6f (%d trials) mRL %.6f (%d) OC-FB %.6f (%d)\n", out.alg1,
              out.r_alg1.trials, out.mrl, out.r_mrl.trials, out.ocfb, out.r_ocfb.trials);
  return out;
}

TEST(Learner, DataDrivenBeatsModelBasedOnAnInexactModel) {
  TwoModeLq model_lq, true_lq;
  true_lq.b_scale = 1.6;  // the real input gain is 60 % higher than modelled
  LqProblem model(model_lq), truth(true_lq);
  const MethodCosts c = RunThreeMethods(model, truth);
  const Optimum true_opt = DenseSearch(true_lq, 0.2, 2.0, 0.3, 3.0, 0.01);
  std::printf("true optimum %.6f\n", true_opt.cost);
  EXPECT_LE(c.alg1, c.ocfb);
  EXPECT_LE(c.mrl, c.ocfb);
  // The model-based policy is clearly worse on the real plant; Algorithm 1 is close to the
  // true optimum although its derivatives come from the wrong model. (With the box-aware
  // Riccati gains of the default preset OC-FB's feedback corrects more of the model error than
  // the Lyapunov-based law did: its excess fell from 0.051 to 0.029, Algorithm 1's is 0.013.)
  EXPECT_GT(c.ocfb - true_opt.cost, 2.0 * (c.alg1 - true_opt.cost));
}

TEST(Learner, AllThreeMethodsAgreeWithAnExactModel) {
  TwoModeLq lq;
  LqProblem model(lq), truth(lq);  // separate but identical systems
  const MethodCosts c = RunThreeMethods(model, truth);
  EXPECT_NEAR(c.alg1, c.ocfb, 1e-5 * c.alg1);
  EXPECT_NEAR(c.mrl, c.alg1, 1e-5 * c.alg1);
  EXPECT_LT((c.r_alg1.T - c.r_ocfb.T).norm(), 1e-6);
  EXPECT_LT((c.r_mrl.T - c.r_alg1.T).norm(), 1e-6);
}

// c so large that no trial can decrease the cost enough: every trial is rejected; alpha halves
// (1, 1/2, 1/4, 1/8) and falls below alpha_min = 0.1 at the fourth rejection.
LearnerSettings RejectEveryTrial() {
  LearnerSettings s = LqTestSettings();
  s.c = 1e6;
  s.gamma = 0.5;
  s.interpolate_backtracking = false;
  s.alpha_min = 0.1;
  s.failure_raises = 0;  // terminate after the first failed search
  return s;
}

// The two-mode LQ problem, its exact model as the plant, and u^0 = 0 run once (`measured`).
struct LqRig {
  TwoModeLq lq;
  LqProblem p{lq};
  ModelPlant plant{p.problem};
  Trajectory measured;
  LqRig() {
    FunctionPolicy initial = ZeroInputPolicy();
    plant.Run(lq.x0, initial, &measured);
  }
};

TEST(Learner, IncrementalRejectedTrialsKeepTheNominalAndShrinkAlpha) {
  LqRig rig;
  TwoModeLq& lq = rig.lq;
  LqProblem& p = rig.p;
  ModelPlant& plant = rig.plant;
  Trajectory& measured = rig.measured;
  Learner learner(p.problem, RejectEveryTrial());
  EXPECT_THROW(learner.NextTrial(), InvalidArgument);  // not initialized
  learner.Initialize(measured);
  const double cost0 = learner.nominal_cost();
  const Vector T0 = learner.nominal().T;
  EXPECT_THROW(learner.CompleteTrial(measured), InvalidArgument);  // no trial pending
  double alpha = 1.0;
  for (int i = 0; i < 4; ++i) {
    OnlineController& policy = learner.NextTrial();
    EXPECT_DOUBLE_EQ(policy.alpha(), alpha);
    plant.Run(lq.x0, policy, &measured);
    const TrialResult r = learner.CompleteTrial(measured);
    EXPECT_FALSE(r.accepted);
    EXPECT_LT(r.decrease, 0.0) << "the trial itself did reduce the cost";
    alpha *= 0.5;
    EXPECT_DOUBLE_EQ(learner.alpha(), alpha);
    EXPECT_EQ(learner.nominal().T, T0);
    EXPECT_EQ(learner.nominal_cost(), cost0);
  }
  EXPECT_EQ(learner.status(), LearnerStatus::kLineSearchFailed);  // 1/16 < 0.1
  // Terminated without an accepted trial: the next policy replays u^0 (alpha = 0).
  OnlineController& replay = learner.NextTrial();
  EXPECT_EQ(replay.alpha(), 0.0);
  plant.Run(lq.x0, replay, &measured);
  EXPECT_NEAR(EvaluateCost(p.problem, measured).total, cost0, 1e-9 * cost0);
  // An aborted trial (robot fell) also counts as rejected.
  Learner other(p.problem, LqTestSettings());
  other.Initialize(measured);
  other.NextTrial();
  const TrialResult aborted = other.AbortTrial();
  EXPECT_FALSE(aborted.accepted);
  EXPECT_DOUBLE_EQ(other.alpha(), 0.1);  // interpolated backtracking: the smallest factor
}

TEST(Learner, TheCurvatureScaleFollowsTheRatioOfMeasuredToPredicted) {
  // curvature_scale_min (kRatio, the default): at alpha_initial, a measured decrease more than
  // 1.5x the predicted one halves sigma, and the next trial steps alpha / sigma with a prediction
  // from the model whose curvature is scaled by sigma; a rejected trial returns to sigma = 1 at
  // the same alpha; sigma never drops below its floor. The measured cost is given
  // (CompleteTrial's cost): far below the nominal's (rho >> 1.5) or above it (rejected).
  LqRig rig;
  Learner learner(rig.p.problem, LearnerSettings{});
  learner.Initialize(rig.measured);
  Trajectory& m = rig.measured;
  auto trial = [&](double expected_step, bool better) {
    OnlineController& policy = learner.NextTrial();
    EXPECT_DOUBLE_EQ(policy.alpha(), expected_step);
    rig.plant.Run(rig.lq.x0, policy, &m);
    const double I = learner.nominal_cost();
    const double cost = I + (better ? -1e3 : 1.0) * std::abs(I);
    return learner.CompleteTrial(m, nullptr, cost);
  };
  EXPECT_DOUBLE_EQ(learner.curvature_scale(), 1.0);
  EXPECT_TRUE(trial(1.0, true).accepted);
  EXPECT_DOUBLE_EQ(learner.curvature_scale(), 0.5);
  EXPECT_TRUE(trial(2.0, true).accepted);
  EXPECT_DOUBLE_EQ(learner.curvature_scale(), 0.25);
  const TrialResult relaxed = trial(4.0, false);  // sigma = 1/4 on this nominal
  EXPECT_FALSE(relaxed.accepted);
  EXPECT_DOUBLE_EQ(learner.curvature_scale(), 1.0);
  EXPECT_DOUBLE_EQ(learner.alpha(), 1.0);
  const TrialResult plain = trial(1.0, false);  // sigma = 1 on the same nominal
  // Without active bounds the model scaled by sigma predicts 1 / sigma times the decrease.
  ASSERT_LT(plain.predicted, 0.0);
  EXPECT_NEAR(relaxed.predicted, 4.0 * plain.predicted, 1e-9 * std::abs(plain.predicted));
  EXPECT_LT(learner.alpha(), 1.0);  // the rejection at sigma = 1 backtracks
  // Below alpha_initial sigma stays; alpha grows back to 1, and from there sigma halves to its
  // floor and stays there.
  for (int i = 0; i < 12; ++i) {
    const double alpha = learner.alpha(), sigma = learner.curvature_scale();
    EXPECT_TRUE(trial(alpha / sigma, true).accepted) << i;
    EXPECT_DOUBLE_EQ(learner.curvature_scale(),
                     alpha < 1.0 ? sigma : std::max(0.5 * sigma, 1.0 / 16)) << i;
  }
  EXPECT_DOUBLE_EQ(learner.curvature_scale(), LearnerSettings{}.curvature_scale_min);
}

TEST(Learner, AFailedLineSearchRaisesMuAndSearchesAgainBeforeItTerminates) {
  // (36) never holds: each search takes 4 trials (alpha 1, 0.5, 0.25, 0.125; 0.0625 < 0.1).
  // failure_raises = 2: after the first and the second failed search mu becomes
  // max(10 mu, L_uu scale), the pass is re-run with it and alpha returns to alpha_initial;
  // the third failed search terminates. The nominal never changes.
  LqRig rig;
  LearnerSettings settings = RejectEveryTrial();
  settings.failure_raises = 2;
  Learner learner(rig.p.problem, settings);
  Trajectory& measured = rig.measured;
  learner.Initialize(measured);
  const double cost0 = learner.nominal_cost();
  const double luu = learner.backward_pass().luu_scale();
  ASSERT_GT(luu, 0.0);
  double mu = learner.regularization();
  double predicted = learner.backward_pass().predicted_linear();
  ASSERT_LT(predicted, 0.0);
  for (int search = 0; search < 3; ++search) {
    for (int i = 0; i < 4; ++i) {
      ASSERT_EQ(learner.status(), LearnerStatus::kRunning)
          << "search " << search << ", trial " << i;
      OnlineController& policy = learner.NextTrial();
      EXPECT_DOUBLE_EQ(policy.alpha(), std::pow(0.5, i));
      rig.plant.Run(rig.lq.x0, policy, &measured);
      EXPECT_FALSE(learner.CompleteTrial(measured).accepted);
      EXPECT_EQ(learner.nominal_cost(), cost0);
    }
    if (search < 2) {
      mu = std::max(10.0 * mu, luu);
      EXPECT_EQ(learner.status(), LearnerStatus::kRunning);
      EXPECT_DOUBLE_EQ(learner.alpha(), 1.0);
      EXPECT_DOUBLE_EQ(learner.regularization(), mu);
      EXPECT_DOUBLE_EQ(learner.backward_pass().regularization(), mu);
      // A larger mu predicts a smaller decrease (a shorter step).
      const double now = learner.backward_pass().predicted_linear();
      EXPECT_LT(now, 0.0);
      EXPECT_GT(now, predicted);
      predicted = now;
    }
  }
  EXPECT_EQ(learner.status(), LearnerStatus::kLineSearchFailed);
  EXPECT_EQ(learner.trials(), 12);
  EXPECT_DOUBLE_EQ(learner.regularization(), mu);  // no third raise
}

TEST(Learner, RecomputeDirectionUsesTheChangedCostAndKeepsTheNominal) {
  // The terminal reference r_1 of the cost changes after Initialize (as the hopper's I1
  // reference does when the next hop's start is measured): RecomputeDirection must give the
  // pass of a learner initialized with the new reference on the same trajectory.
  TwoModeLq lq;
  LqProblem p(lq), q(lq);
  q.cost.r_[1] = Eigen::Vector2d(0.3, -0.2);
  ModelPlant plant(p.problem);
  FunctionPolicy initial = ZeroInputPolicy();
  Trajectory measured;
  plant.Run(lq.x0, initial, &measured);
  Learner learner(p.problem, LqTestSettings()), reference(q.problem, LqTestSettings());
  learner.Initialize(measured);
  reference.Initialize(measured);
  const double cost = learner.nominal_cost();
  const Vector p_before = learner.backward_pass().p(0, 0);
  EXPECT_GT((p_before - reference.backward_pass().p(0, 0)).norm(), 1e-3);
  p.cost.r_[1] = q.cost.r_[1];
  learner.RecomputeDirection();
  EXPECT_LT((learner.backward_pass().p(0, 0) - reference.backward_pass().p(0, 0)).norm(), 1e-12);
  EXPECT_EQ(learner.nominal_cost(), cost);  // the measured I^i is kept
  learner.NextTrial();
  EXPECT_THROW(learner.RecomputeDirection(), InvalidArgument);  // a trial is pending
  Learner fresh(p.problem, LqTestSettings());
  EXPECT_THROW(fresh.RecomputeDirection(), InvalidArgument);   // not initialized
}

TEST(Learner, IncrementalAcceptanceAndTerminationReplaysTheLastAcceptedLaw) {
  TwoModeLq lq;
  LqProblem p(lq);
  ModelPlant plant(p.problem);
  FunctionPolicy initial = ZeroInputPolicy();
  LearnerSettings settings = LqTestSettings();
  settings.alpha_min = 0.3;  // two rejections in a row terminate
  settings.alpha_after_accept = AlphaAfterAccept::kReset;
  Learner learner(p.problem, settings);
  Trajectory measured;
  plant.Run(lq.x0, initial, &measured);
  learner.Initialize(measured);
  int accepted = 0;
  while (learner.status() != LearnerStatus::kLineSearchFailed && learner.trials() < 500) {
    OnlineController& policy = learner.NextTrial();
    const Vector planned = policy.planned_T();
    plant.Run(lq.x0, policy, &measured);
    const double before = learner.nominal_cost();
    const TrialResult r = learner.CompleteTrial(measured);
    if (r.accepted) {
      ++accepted;
      // The measured trial is the new nominal; time-based switching follows the plan.
      EXPECT_LT((learner.nominal().T - planned).norm(), 1e-9);
      EXPECT_EQ(learner.nominal_cost(), r.cost);
      EXPECT_LT(r.cost, before);
      EXPECT_DOUBLE_EQ(learner.alpha(), 1.0);
    }
  }
  ASSERT_EQ(learner.status(), LearnerStatus::kLineSearchFailed);
  ASSERT_GT(accepted, 3);
  // The terminated learner applies the law that produced the last accepted trial: on this
  // deterministic plant it reproduces that trial.
  plant.Run(lq.x0, learner.NextTrial(), &measured);
  EXPECT_NEAR(EvaluateCost(p.problem, measured).total, learner.nominal_cost(),
              1e-9 * learner.nominal_cost());
}

// Trials from other starts (LearnerSettings::start_correction). On a linear system with a
// quadratic cost the cost of an affine law from x0 + dx is exactly quadratic in dx; for the law
// "nominal inputs + the pass's feedback" (ConvergedPolicy(0)) its gradient and Hessian at dx = 0
// are the Riccati pass's p_x(0) and P_xx(0) (docs/engine.md). The known answer is the measured
// cost of that law run from the shifted start.
// The two-mode LQ problem on a fine plant (dt = 2.5e-4) and the nominal of u = 0 from lq.x0.
struct FineLq {
  TwoModeLq lq;
  LqProblem p{lq};
  ModelPlant plant{p.problem, [] {
                     ModelPlantSettings fine;
                     fine.dt = 2.5e-4;
                     return fine;
                   }()};
  Trajectory nominal;
  FineLq() {
    FunctionPolicy initial = ZeroInputPolicy();
    plant.Run(lq.x0, initial, &nominal);
  }
  static LearnerSettings Settings(bool start_correction) {
    LearnerSettings s = LqTestSettings();
    s.max_samples = 20000;
    s.start_correction = start_correction;
    return s;
  }
};

TEST(Learner, StartShiftPredictsTheCostOfTheNominalLawFromAnotherStart) {
  FineLq f;
  const TwoModeLq& lq = f.lq;
  LqProblem& p = f.p;
  ModelPlant& plant = f.plant;
  Trajectory measured;
  Learner learner(p.problem, FineLq::Settings(true));
  learner.Initialize(f.nominal);
  const double cost0 = learner.nominal_cost();
  for (const Eigen::Vector2d dx : {Eigen::Vector2d(0.2, 0), Eigen::Vector2d(0.5, 0.5),
                                   Eigen::Vector2d(0.05, -0.5)}) {
    const Vector x1 = lq.x0 + dx;
    plant.Run(x1, learner.ConvergedPolicy(0.0), &measured);
    const double truth = EvaluateCost(p.problem, measured).total - cost0;
    const double shift = learner.StartShift(x1);
    EXPECT_GT(std::abs(truth), 0.05 * cost0) << "the start matters: dx = " << dx.transpose();
    EXPECT_NEAR(shift, truth, 2e-3 * std::abs(truth)) << "dx = " << dx.transpose();
  }
  EXPECT_EQ(learner.StartShift(Vector::Zero(3)), 0.0);  // another size: no correction
}

// A trial that improves the law but starts from a worse state raises the raw cost: (36) on the
// raw costs rejects it, the corrected test accepts it; its corrected decrease is the measured
// cost minus the counterfactual cost of the nominal law from the same start.
TEST(Learner, AcceptanceComparesTrialsAsIfFromTheSameStart) {
  FineLq f;
  LqProblem& p = f.p;
  ModelPlant& plant = f.plant;
  Trajectory measured, counterfactual;
  const Vector worse = f.lq.x0 + Eigen::Vector2d(2.0, 1.0);
  for (const bool correct : {false, true}) {
    Learner learner(p.problem, FineLq::Settings(correct));
    learner.Initialize(f.nominal);
    const double cost0 = learner.nominal_cost();
    plant.Run(worse, learner.ConvergedPolicy(0.0), &counterfactual);
    const double cost_nominal_law = EvaluateCost(p.problem, counterfactual).total;
    plant.Run(worse, learner.NextTrial(), &measured);
    const TrialResult r = learner.CompleteTrial(measured);
    ASSERT_GT(r.cost, cost0 + 0.1) << "the worse start dominates the raw cost";
    ASSERT_LT(r.cost, cost_nominal_law - 0.1) << "the law did improve";
    EXPECT_EQ(r.accepted, correct);
    if (correct) {
      EXPECT_NEAR(r.decrease, r.cost - cost_nominal_law, 2e-3 * std::abs(r.decrease));
    } else {
      EXPECT_EQ(r.start_shift, 0.0);
    }
  }
}

// blend_feedback: the law at alpha -> 0 is the law that produced the nominal. u^0 here is
// "zero input + the feedback of a pass with mu = 2" (its gains differ from the learner's, mu =
// 0); its run from lq.x0 is the nominal. On this linear plant u^0 from another start x1 is
// u^i(t) + the feedback of u^0 on x - x^i(t), so the blended law at small alpha must reproduce
// u^0's inputs from x1 up to O(alpha); the pass's own gains do not.
TEST(Learner, BlendedFeedbackAtSmallAlphaIsTheNominalLaw) {
  FineLq f;
  ModelPlant& plant = f.plant;
  OnlineController u0 = StiffFeedbackLaw(f.p.problem, f.nominal);
  Trajectory measured, reference, trial;
  plant.Run(f.lq.x0, u0, &measured);
  const Vector x1 = f.lq.x0 + Eigen::Vector2d(0.5, 0.5);
  plant.Run(x1, u0, &reference);
  // Distance from u^0's run from x1.
  auto distance = [&](const Trajectory& t) { return MaxInputDifferenceInMode0(t, reference); };
  const double scale = reference.modes[0].u.cwiseAbs().maxCoeff();
  double at_full_step[2] = {0, 0};
  double at_small_step[2] = {0, 0};
  for (const bool blend : {false, true}) {
    SCOPED_TRACE(blend ? "blended" : "the pass's gains");
    LearnerSettings settings = RejectEveryTrial();
    settings.max_samples = 20000;
    settings.start_correction = false;
    settings.alpha_min = 1e-4;
    settings.blend_feedback = blend;
    Learner learner(f.p.problem, settings);
    learner.SetInitialLaw(&u0);
    learner.Initialize(measured);
    plant.Run(x1, learner.NextTrial(), &trial);
    at_full_step[blend] = distance(trial);
    ASSERT_FALSE(learner.CompleteTrial(trial).accepted);  // every trial is rejected: alpha halves
    for (int i = 0; i < 9; ++i) {
      plant.Run(f.lq.x0, learner.NextTrial(), &trial);
      ASSERT_FALSE(learner.CompleteTrial(trial).accepted);
    }
    ASSERT_DOUBLE_EQ(learner.alpha(), 1.0 / 1024);
    plant.Run(x1, learner.NextTrial(), &trial);
    at_small_step[blend] = distance(trial);
  }
  // At alpha = alpha_initial (w = 1) the blend changes nothing.
  EXPECT_EQ(at_full_step[1], at_full_step[0]);
  EXPECT_GT(at_small_step[0], 0.05 * scale) << "u^0's gains differ from the pass's";
  // O(alpha): the blended law's distance halves with alpha (about 9e-3 at 1/1024 here).
  EXPECT_LT(at_small_step[1], 0.02 * at_small_step[0]);
}

// restart_on_failure: a learner whose every trial is rejected does not terminate; when alpha
// drops below alpha_min the line search restarts around the same nominal. Batch Solve still
// terminates.
TEST(Learner, OnlineLearnerRestartsInsteadOfTerminating) {
  TwoModeLq lq;
  LqProblem p(lq);
  ModelPlant plant(p.problem);
  FunctionPolicy initial = ZeroInputPolicy();
  LearnerSettings settings = RejectEveryTrial();
  settings.acceptance = Acceptance::kSufficientDecrease;
  settings.restart_on_failure = true;
  Learner learner(p.problem, settings);
  Trajectory measured;
  plant.Run(lq.x0, initial, &measured);
  learner.Initialize(measured);
  const double cost0 = learner.nominal_cost();
  int restarts = 0;
  for (int i = 0; i < 12; ++i) {
    plant.Run(lq.x0, learner.NextTrial(), &measured);
    const TrialResult r = learner.CompleteTrial(measured);
    EXPECT_FALSE(r.accepted);
    EXPECT_EQ(r.status, LearnerStatus::kRunning);
    if (r.restarted) {
      ++restarts;
      EXPECT_EQ(i % 4, 3) << "1, 1/2, 1/4, 1/8 < 0.1: the fourth rejection restarts";
      EXPECT_EQ(learner.alpha(), 1.0);
    }
  }
  EXPECT_EQ(restarts, 3);
  EXPECT_EQ(learner.restarts(), 3);
  EXPECT_EQ(learner.nominal_cost(), cost0);  // the nominal is kept
  // Aborted trials (a fall) restart it too.
  for (int i = 0; i < 4; ++i) {
    learner.NextTrial();
    learner.AbortTrial();
  }
  EXPECT_EQ(learner.status(), LearnerStatus::kRunning);
  EXPECT_EQ(learner.restarts(), 4);
  EXPECT_DOUBLE_EQ(learner.alpha(), 1.0);
  // restart_alpha: the restarted line search starts there instead of at alpha_initial.
  settings.restart_alpha = 0.25;
  Learner cautious(p.problem, settings);
  cautious.Initialize(measured);
  for (int i = 0; i < 4; ++i) {
    plant.Run(lq.x0, cautious.NextTrial(), &measured);
    cautious.CompleteTrial(measured);
  }
  EXPECT_EQ(cautious.restarts(), 1);
  EXPECT_DOUBLE_EQ(cautious.alpha(), 0.25);
  settings.restart_alpha = 2.0;
  EXPECT_THROW(Learner(p.problem, settings), InvalidArgument);
  settings.restart_alpha = 0.0;
  for (const double bad : {0.0, 1.5}) {
    settings.curvature_scale_min = bad;
    EXPECT_THROW(Learner(p.problem, settings), InvalidArgument) << bad;
  }
  settings.curvature_scale_min = 1.0 / 16;
  settings.switching.relative_regularization = 0.0;
  EXPECT_THROW(Learner(p.problem, settings), InvalidArgument);
  settings.switching.relative_regularization = 1e-3;
  Learner batch(p.problem, settings);
  FunctionPolicy again = ZeroInputPolicy();
  const SolveResult solved = batch.Solve(plant, plant, lq.x0, again);
  EXPECT_EQ(solved.status, LearnerStatus::kLineSearchFailed);
  EXPECT_EQ(batch.restarts(), 0);
}

// (36) as printed, halving alpha from 1; 1, 1/2, 1/4, 1/8 < alpha_min = 0.1: the fourth
// rejection restarts the line search. No start correction.
LearnerSettings RestartingSettings(bool remeasure, double noise_margin) {
  LearnerSettings s = FineLq::Settings(false);
  s.acceptance = Acceptance::kSufficientDecrease;
  s.c = 1e-7;
  s.gamma = 0.5;
  s.interpolate_backtracking = false;
  s.alpha_min = 0.1;
  s.restart_on_failure = true;
  s.remeasure_nominal = remeasure;
  s.noise_margin = noise_margin;
  return s;
}

// remeasure_nominal: a nominal measured from a lucky start (a third of the usual start, under
// half the cost) makes (36) reject every later trial from the usual start, improvements
// included, and the restarted line search never ends that. Re-running the nominal's law at the
// restart replaces I^i by a fair sample: the known answer is the cost of that law (the
// nominal's inputs with the pass's feedback) run from the usual start, computed here directly;
// the improving trial that follows is accepted.
TEST(Learner, RemeasuringTheNominalEndsTheRuleOfALuckyHop) {
  FineLq f;
  const Vector lucky = f.lq.x0 / 3.0;
  Trajectory first, measured;
  FunctionPolicy zero = ZeroInputPolicy();
  f.plant.Run(lucky, zero, &first);
  for (const bool remeasure : {false, true}) {
    SCOPED_TRACE(remeasure ? "remeasure_nominal" : "the accepted trial's cost");
    Learner learner(f.p.problem, RestartingSettings(remeasure, 0.0));
    learner.Initialize(first);
    const double lucky_cost = learner.nominal_cost();
    f.plant.Run(f.lq.x0, learner.ConvergedPolicy(0.0), &measured);
    const double fair_cost = EvaluateCost(f.p.problem, measured).total;
    ASSERT_GT(fair_cost, 2.0 * lucky_cost);
    int accepted = 0, remeasured = 0;
    for (int i = 0; i < 10; ++i) {
      const bool remeasuring = learner.remeasuring();
      f.plant.Run(f.lq.x0, learner.NextTrial(), &measured);
      const TrialResult r = learner.CompleteTrial(measured);
      EXPECT_EQ(r.remeasured, remeasuring);
      if (r.remeasured) {
        ++remeasured;
        EXPECT_FALSE(r.accepted);
        if (accepted == 0) {  // the first re-measurement replaces the lucky cost
          EXPECT_NEAR(r.cost, fair_cost, 1e-9 * fair_cost);
          EXPECT_NEAR(learner.nominal_cost(), fair_cost, 1e-9 * fair_cost);
          EXPECT_EQ(learner.nominal_samples(), 1);
        }
      }
      if (r.accepted) {
        ++accepted;
        EXPECT_LT(r.cost, fair_cost) << "an improvement of the law, measured from the same start";
        EXPECT_EQ(learner.nominal_samples(), 0);
      }
      if (!remeasure) {
        EXPECT_GT(r.cost, lucky_cost) << "every trial looks worse than the lucky hop";
      }
    }
    EXPECT_EQ(accepted > 0, remeasure);
    EXPECT_EQ(remeasured > 0, remeasure);
    if (!remeasure) EXPECT_EQ(learner.nominal_cost(), lucky_cost);
  }
}

// min_predicted_decrease: a trial at alpha 1e-4 from a luckier start (a third of the usual
// x0) measures far below I^i although its step is predicted to gain almost nothing: without the
// floor (36) accepts it and the nominal becomes that hop; with a floor of 1 % of I^i it is
// rejected, and so is every trial whose |predicted| is below 1 % of I^i. The full step from the
// usual start is predicted to gain more than 1 % and is accepted either way.
TEST(Learner, AStepPredictedBelowTheFloorIsNotAccepted) {
  FineLq f;
  Trajectory measured;
  for (const double floor : {0.0, 0.01}) {
    SCOPED_TRACE(floor);
    LearnerSettings settings = FineLq::Settings(false);
    settings.min_predicted_decrease = floor;
    settings.alpha_initial = 1e-4;
    settings.alpha_min = 1e-6;
    Learner tiny(f.p.problem, settings);
    tiny.Initialize(f.nominal);
    const double nominal = tiny.nominal_cost();
    f.plant.Run(f.lq.x0 / 3.0, tiny.NextTrial(), &measured);
    const TrialResult lucky = tiny.CompleteTrial(measured);
    ASSERT_LT(lucky.decrease, -0.2 * nominal);  // the start, not the step
    ASSERT_GT(lucky.predicted, -0.01 * nominal);
    ASSERT_LT(lucky.predicted, 0.0);
    EXPECT_EQ(lucky.accepted, floor == 0.0);
    EXPECT_EQ(tiny.nominal_cost() == nominal, floor > 0.0);

    settings.alpha_initial = 1.0;
    Learner full(f.p.problem, settings);
    full.Initialize(f.nominal);
    f.plant.Run(f.lq.x0, full.NextTrial(), &measured);
    const TrialResult step = full.CompleteTrial(measured);
    EXPECT_LT(step.predicted, -0.01 * full.nominal_cost() - 1e-12);
    EXPECT_TRUE(step.accepted);
  }
  LearnerSettings bad = FineLq::Settings(false);
  bad.min_predicted_decrease = -0.1;
  ExpectThrowsWith([&] { Learner l(f.p.problem, bad); }, "min_predicted_decrease");
  bad.min_predicted_decrease = std::nan("");
  ExpectThrowsWith([&] { Learner l(f.p.problem, bad); }, "min_predicted_decrease");
  bad = FineLq::Settings(false);
  bad.blend_feedback = false;
  bad.blend_feedforward = true;
  ExpectThrowsWith([&] { Learner l(f.p.problem, bad); }, "blend_feedforward needs blend_feedback");
}

// noise_margin: sigma from the re-measurement (the lucky and the fair cost of the nominal law
// differ by d0: sigma = |d0| / sqrt(2)). The first trial after the re-measurement that passes
// (36) without a margin, decrease d < 0, passes it with a margin of half |d| (a margin only
// rejects more, so the trials before it are the same) and not with twice |d|.
TEST(Learner, NoiseMarginAsksForADecreaseAboveTheMeasuredSpread) {
  FineLq f;
  Trajectory first, measured;
  FunctionPolicy zero = ZeroInputPolicy();
  f.plant.Run(f.lq.x0 / 3.0, zero, &first);
  // The trials after the first re-measurement, until one is accepted or `count` ran; sigma.
  auto trials_after_remeasurement = [&](double margin, int count, double* sigma) {
    Learner learner(f.p.problem, RestartingSettings(true, margin));
    learner.Initialize(first);
    const double lucky = learner.nominal_cost();
    EXPECT_EQ(learner.cost_noise(), 0.0);
    std::vector<TrialResult> after;
    for (int i = 0; i < 30 && static_cast<int>(after.size()) < count; ++i) {
      f.plant.Run(f.lq.x0, learner.NextTrial(), &measured);
      const TrialResult r = learner.CompleteTrial(measured);
      if (r.remeasured && *sigma == 0.0) {
        *sigma = learner.cost_noise();
        EXPECT_NEAR(*sigma, std::abs(r.cost - lucky) / std::sqrt(2.0), 1e-12 * r.cost);
      } else if (*sigma > 0.0) {
        after.push_back(r);
        if (r.accepted) break;
      }
    }
    return after;
  };
  double sigma = 0;
  const std::vector<TrialResult> plain = trials_after_remeasurement(0.0, 30, &sigma);
  ASSERT_FALSE(plain.empty());
  ASSERT_TRUE(plain.back().accepted);
  ASSERT_GT(sigma, 0.0);
  const double d = -plain.back().decrease;
  ASSERT_GT(d, 0.0);
  const int n = static_cast<int>(plain.size());
  double s2 = 0;
  const std::vector<TrialResult> half = trials_after_remeasurement(0.5 * d / sigma, n, &s2);
  ASSERT_EQ(half.size(), plain.size());
  EXPECT_TRUE(half.back().accepted);
  s2 = 0;
  const std::vector<TrialResult> twice = trials_after_remeasurement(2.0 * d / sigma, n, &s2);
  ASSERT_EQ(twice.size(), plain.size());
  EXPECT_FALSE(twice.back().accepted);
  EXPECT_NEAR(twice.back().decrease, -d, 1e-12 * d);  // the same trial, judged with the margin
  LearnerSettings bad = FineLq::Settings(false);
  bad.noise_margin = -1;
  EXPECT_THROW(Learner(f.p.problem, bad), InvalidArgument);
}

INSTANTIATE_TEST_SUITE_P(Presets, TwoModeLqTest, ::testing::Values(0, 1));

// The measured cost change of one trial at step size alpha from the nominal of `initial`.
double MeasuredChange(const Problem& problem, const Plant& /*unused*/, ModelPlant* plant,
                      const Vector& x0, Policy* initial, LearnerSettings settings, double alpha,
                      double* predicted) {
  settings.alpha_initial = alpha;
  settings.alpha_min = 0.0;
  Learner learner(problem, settings);
  Trajectory measured;
  plant->Run(x0, *initial, &measured);
  learner.Initialize(measured);
  plant->Run(x0, learner.NextTrial(), &measured);
  const TrialResult r = learner.CompleteTrial(measured);
  if (predicted != nullptr) *predicted = r.predicted;
  return r.decrease;
}

// The step of each preset is a descent direction: dI/dalpha < 0 as alpha -> 0, measured on
// the plant from several nominals (u = 0, a sinusoid, a constant; different planned durations)
// of the two-mode LQ problem and of the 3-mode nonlinear problem with rectangular resets and
// surface penalties. For the default preset on the linear-quadratic problem (where the LQ
// model is the problem) the predicted slope, the backward pass's linear term plus (31)'s,
// agrees with the measured one.
TEST(Learner, EveryPresetStepsDownhill) {
  TwoModeLq lq;
  LqProblem two(lq);
  NonlinearSystem nl_sys;
  NonlinearCost nl_cost;
  const Problem nl = MakeNonlinearProblem(nl_sys, nl_cost);
  struct Case {
    const Problem* problem;
    Vector x0, durations;
    FunctionPolicy::Function input;
  };
  const Vector x_nl = (Vector(3) << 0.2, -0.1, 0.3).finished();
  const std::vector<Case> cases = {
      {&two.problem, lq.x0, Eigen::Vector2d(1.0, 1.0),
       [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); }},
      {&two.problem, lq.x0, Eigen::Vector2d(0.7, 1.4),
       [](int k, double tau, const ConstVectorRef&, VectorRef u) { u(0) = std::sin(3 * tau) - 0.2 * k; }},
      {&two.problem, lq.x0, Eigen::Vector2d(1.6, 0.5),
       [](int, double, const ConstVectorRef&, VectorRef u) { u(0) = -0.8; }},
      {&nl, x_nl, Eigen::Vector3d(0.5, 0.4, 0.6),
       [](int k, double tau, const ConstVectorRef&, VectorRef u) {
         u(0) = 0.3 * std::sin(2.0 * tau) + 0.1 * k;
         u(1) = 0.2 * std::cos(3.0 * tau) - 0.1;
       }},
      {&nl, x_nl, Eigen::Vector3d(0.3, 0.8, 0.5),
       [](int, double, const ConstVectorRef&, VectorRef u) { u << 0.4, -0.3; }},
  };
  int checked = 0;
  for (const Case& c : cases) {
    ModelPlantSettings ps;
    ps.time_based_only = true;  // the planned durations are the trial's
    ModelPlant plant(*c.problem, ps);
    for (const Preset preset : {Preset::kDefault, Preset::kPaper}) {
      const LearnerSettings settings = PresetSettings(preset);
      FunctionPolicy initial(c.durations, c.input);
      double pred1 = 0, pred2 = 0;
      const double a1 = 2e-3, a2 = 1e-3;
      const double d1 = MeasuredChange(*c.problem, plant, &plant, c.x0, &initial, settings, a1, &pred1);
      const double d2 = MeasuredChange(*c.problem, plant, &plant, c.x0, &initial, settings, a2, &pred2);
      // Richardson: the slope at alpha = 0 from the two secants.
      const double slope = 2.0 * d2 / a2 - d1 / a1;
      const char* name = preset == Preset::kDefault ? "default" : "paper";
      EXPECT_LT(slope, 0.0) << name << " case " << checked / 2;
      EXPECT_LT(d2, 0.0) << name << " case " << checked / 2;
      if (preset == Preset::kDefault && c.problem == &two.problem) {
        const double predicted_slope = 2.0 * pred2 / a2 - pred1 / a1;
        EXPECT_NEAR(slope, predicted_slope, 0.05 * std::abs(predicted_slope))
            << "case " << checked / 2;
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 10);
}

// Defect 2 of issue 17: with a cap on the duration steps, runs that start with a duration on (or
// near) its bound used to stop "converged" with a zero step short of the optimum. From 29 such
// starts the default learner must either reach the optimum or say that it did not converge.
TEST(Learner, NeverConvergesShortOfTheOptimumFromStartsOnABound) {
  TwoModeLq lq;
  LqProblem p(lq);
  const Optimum opt = DenseSearch(lq, 0.2, 2.0, 0.3, 3.0, 0.01);
  ModelPlant plant(p.problem);
  int converged = 0;
  for (int i = 0; i < 29; ++i) {
    const Eigen::Vector2d D = i < 15 ? Eigen::Vector2d(0.2 + 0.12 * i, 0.3)
                                     : Eigen::Vector2d(0.2, 0.3 + 0.19 * (i - 14));
    FunctionPolicy initial(D, [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); });
    LearnerSettings settings;
    settings.switching.max_duration_step = 0.05;
    settings.max_trials = 120;
    settings.max_samples = 10000;
    Learner learner(p.problem, settings);
    const SolveResult r = learner.Solve(plant, plant, lq.x0, initial);
    if (r.status != LearnerStatus::kConverged) continue;
    ++converged;
    EXPECT_NEAR(r.T(0), opt.D0, 0.01) << "start " << D.transpose();
    EXPECT_NEAR(r.T(1) - r.T(0), opt.D1, 0.01) << "start " << D.transpose();
    EXPECT_NEAR(r.cost, opt.cost, 1e-4 * opt.cost) << "start " << D.transpose();
  }
  // And the cap is no obstacle: every start gets there within the trials given.
  EXPECT_EQ(converged, 29);
}

// Defect 4 of issue 17: the regularization must not bias the answer. On a plain LQR (one mode,
// fixed horizon, unbounded input) the default learner converges with mu = 0, and its gain
// L_uz + F_u^T P and cost are the exact LQR ones (an independent RK4 of the Riccati ODE). A
// fixed regularization of 0.1 (the old default) moved the gain by 6-8 %.
TEST(Learner, ConvergedLqrGainIsTheExactOne) {
  Matrix A(2, 2), B(2, 1), Q(2, 2), R(1, 1), S(2, 2);
  A << 0, 1, -2, -0.5;
  B << 0, 1;
  Q << 2, 0, 0, 0.5;
  R << 0.1;
  S << 1, 0, 0, 1;
  const double T = 2.0;
  LinearSwitchedSystem sys({A}, {B}, {Matrix::Identity(2, 2)});
  QuadraticCost cost({Q}, {R}, {0.0}, {S}, {Vector::Zero(2)});
  Problem problem;
  problem.system = &sys;
  problem.cost = &cost;
  PoseFixedHorizon(&problem, 1, T);
  ModelPlant plant(problem);
  FunctionPolicy initial(Vector::Constant(1, T),
                         [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); });
  const Vector x0 = Eigen::Vector2d(1.0, -0.5);
  Learner learner(problem);
  const SolveResult r = learner.Solve(plant, plant, x0, initial);
  ASSERT_EQ(r.status, LearnerStatus::kConverged);
  EXPECT_LE(r.trials, 10);
  EXPECT_EQ(learner.regularization(), 0.0);
  // Independent Riccati: -dP/dt = A'P + PA - P B R^-1 B' P + Q, P(T) = S, fine RK4.
  auto f = [&](const Matrix& P) -> Matrix {
    return A.transpose() * P + P * A - P * B * R.inverse() * B.transpose() * P + Q;
  };
  const int M = 20000;
  const double h = T / M;
  std::vector<Matrix> P_ref(M + 1);
  P_ref[M] = S;
  for (int i = M; i > 0; --i) {
    const Matrix& P = P_ref[i];
    const Matrix k1 = f(P), k2 = f(P + 0.5 * h * k1), k3 = f(P + 0.5 * h * k2), k4 = f(P + h * k3);
    P_ref[i - 1] = P + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  const BackwardPass& pass = learner.backward_pass();
  const int N = pass.num_samples(0);
  for (int j : {0, N / 3, 2 * N / 3, N - 2}) {
    // Interval j's gain is at its midpoint time: D (B^T P) with D = T (tau units).
    const double t_mid = 0.5 * (learner.nominal().modes[0].t(j) + learner.nominal().modes[0].t(j + 1));
    const int i = static_cast<int>(std::round(t_mid / h));
    const Matrix expected = T * B.transpose() * P_ref[i];
    const Matrix gain = pass.Gain(0, j).leftCols(2);
    EXPECT_LT((gain - expected).norm(), 1e-4 * expected.norm()) << "j " << j;
  }
  const double J = 0.5 * x0.dot(P_ref[0] * x0);
  EXPECT_NEAR(r.cost, J, 1e-4 * J);
}

// The line search's acceptance test must ask for a sufficient decrease, not any decrease. A probe
// runs the first trial of the two-mode LQ problem (it does not depend on c) and measures its
// decrease, predicted change and step; learners with c set from the probe then face the same
// trial: with c twice the measured ratio the trial decreased the cost but not enough (rejected,
// alpha shrinks), with half of it the trial is accepted. Both presets: Armijo on the predicted
// change (default, decrease <= c * predicted) and the paper's (36) (decrease <= -c * step).
TEST(Learner, LineSearchTellsSufficientDecreaseFromAnyDecrease) {
  TwoModeLq lq;
  LqProblem p(lq);
  ModelPlant plant(p.problem);
  for (const Preset preset : {Preset::kDefault, Preset::kPaper}) {
    const char* name = preset == Preset::kDefault ? "default" : "paper";
    auto first_trial = [&](double c) {
      LearnerSettings settings = PresetSettings(preset);
      settings.c = c;
      settings.max_samples = 10000;
      Learner learner(p.problem, settings);
      FunctionPolicy initial = ZeroInputPolicy();
      Trajectory measured;
      plant.Run(lq.x0, initial, &measured);
      learner.Initialize(measured);
      const double alpha = learner.alpha();
      plant.Run(lq.x0, learner.NextTrial(), &measured);
      const TrialResult r = learner.CompleteTrial(measured);
      return std::make_tuple(r, alpha, learner.alpha(), learner.iteration());
    };
    const TrialResult probe = std::get<0>(first_trial(1e-4));
    ASSERT_LT(probe.decrease, 0.0) << name;
    ASSERT_GT(probe.step, 0.0) << name;
    ASSERT_LT(probe.predicted, 0.0) << name;
    // The ratio of the measured decrease to what the acceptance test multiplies by c.
    const double ratio = preset == Preset::kDefault ? probe.decrease / probe.predicted
                                                    : -probe.decrease / probe.step;
    ASSERT_GT(ratio, 1e-3) << name;
    {
      const auto [r, alpha_before, alpha_after, iteration] = first_trial(2.0 * ratio);
      EXPECT_DOUBLE_EQ(r.decrease, probe.decrease) << name << ": not the same trial";
      EXPECT_LT(r.decrease, 0.0) << name;
      EXPECT_FALSE(r.accepted) << name << ": a decrease of half the required one was accepted";
      EXPECT_LT(alpha_after, alpha_before) << name;
      EXPECT_EQ(iteration, 0) << name;
    }
    {
      const auto [r, alpha_before, alpha_after, iteration] = first_trial(0.5 * ratio);
      EXPECT_DOUBLE_EQ(r.decrease, probe.decrease) << name << ": not the same trial";
      EXPECT_TRUE(r.accepted) << name << ": twice the required decrease was rejected";
      EXPECT_EQ(iteration, 1) << name;
    }
  }
}

// The step test of Algorithm 1 (paper preset, step_convergence): with the gradient guard
// disabled (optimality_tolerance huge), convergence is decided by int |du|^2 + |dT|^2 <= epsilon
// alone. An epsilon below every step never converges; one above every step converges after
// delta_i accepted trials. And the Levenberg-Marquardt regularization is back on its floor after
// an accepted trial (it only grows when a backward pass fails).
TEST(Learner, StepTestDecidesConvergenceAndRegularizationShrinksOnAcceptance) {
  TwoModeLq lq;
  LqProblem p(lq);
  ModelPlant plant(p.problem);
  for (const double epsilon : {1e-30, 1e30}) {
    LearnerSettings settings = LearnerSettings::Paper();
    settings.optimality_tolerance = 1e30;
    settings.epsilon = epsilon;
    settings.delta_i = 2;
    settings.regularization_min = 1e-3;
    settings.max_samples = 10000;
    Learner learner(p.problem, settings);
    FunctionPolicy initial = ZeroInputPolicy();
    Trajectory measured;
    plant.Run(lq.x0, initial, &measured);
    learner.Initialize(measured);
    int accepted = 0;
    for (int trial = 0; trial < 40 && accepted < 4; ++trial) {
      plant.Run(lq.x0, learner.NextTrial(), &measured);
      const TrialResult r = learner.CompleteTrial(measured);
      if (!r.accepted) continue;
      ++accepted;
      EXPECT_GT(r.step, 1e-20) << "epsilon " << epsilon;
      EXPECT_EQ(learner.regularization(), settings.regularization_min) << "trial " << trial;
      if (epsilon < 1) {
        EXPECT_EQ(r.status, LearnerStatus::kRunning) << "converged with steps above epsilon";
      } else {
        EXPECT_EQ(r.status, accepted >= settings.delta_i ? LearnerStatus::kConverged
                                                         : LearnerStatus::kRunning)
            << "accepted " << accepted;
        if (r.status == LearnerStatus::kConverged) break;
      }
    }
    EXPECT_GE(accepted, 2) << "epsilon " << epsilon;
  }
}

// The optimality measure projects the input gradient on the bounds: an input on its upper bound
// whose gradient asks for more of it contributes nothing. One mode of duration D = 2, xdot = u,
// u <= 1, a terminal cost 1/2 S (x(D) - 5)^2: the gradient per unit time is g = R u + p with the
// constant adjoint p = S (u D - 5). At u = 1, g = 0.1 - 30 < 0 everywhere, so the projected
// measure is 0; at u = 0.5 (interior) it is sqrt(int_0^D g^2 dt) = sqrt(D) |g| (the per-tau
// gradient D g of the pass, with its factor D: mutant bp_gradient_unscaled).
TEST(Learner, OptimalityIgnoresInputsPushedAgainstTheirBounds) {
  LinearSwitchedSystem sys({Matrix::Zero(1, 1)}, {Matrix::Identity(1, 1)},
                           {Matrix::Identity(1, 1)});
  QuadraticCost cost({Matrix::Zero(1, 1)}, {Matrix::Constant(1, 1, 0.1)}, {0.0},
                     {Matrix::Constant(1, 1, 10.0)}, {Vector::Constant(1, 5.0)});
  Problem problem;
  problem.system = &sys;
  problem.cost = &cost;
  problem.bounds.u_min = Vector::Constant(1, -1);
  problem.bounds.u_max = Vector::Constant(1, 1);
  problem.bounds.duration_min = Vector::Constant(1, 0.1);
  problem.bounds.duration_max = Vector::Constant(1, 5);
  problem.surface_weights = Vector::Zero(1);
  for (const double u : {1.0, 0.5}) {
    const int N = 21;
    Trajectory traj;
    traj.modes.resize(1);
    const double D = 2.0;
    traj.modes[0].t = Vector::LinSpaced(N, 0.0, D);
    traj.modes[0].x = u * traj.modes[0].t.transpose();
    traj.modes[0].u = Matrix::Constant(1, N, u);
    traj.T = Vector::Constant(1, D);
    traj.x0 = Vector::Zero(1);
    BackwardPass pass;
    pass.Allocate(problem, N, BackwardPassSettings{});
    ASSERT_TRUE(pass.Run(traj));
    const Optimality o = ComputeOptimality(problem, traj, pass);
    const double g = 0.1 * u + 10.0 * (u * D - 5.0);
    if (u == 1.0) {
      EXPECT_LT(o.inputs, 1e-9) << "an input on its bound, pushed outward, counted";
    } else {
      EXPECT_NEAR(o.inputs, std::sqrt(D) * std::abs(g), 1e-6 * std::abs(g));
    }
  }
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
