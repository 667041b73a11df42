// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// TrialDriver on ModelPlant with known answers: episodic Algorithm 1 and mRL follow
// Learner::Solve trial for trial, the three methods agree with an exact model, online trials
// start where the last one ended, and warm-up, the fallback law, freezing and bad settings
// behave as documented.
#include "ddoc/trial_driver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "ddoc/cost.h"
#include "ddoc/quadratic_cost.h"
#include "test_util.h"
#include "two_mode_lq.h"

namespace ddoc {
namespace testing {
namespace {

TrialDriverSettings DriverSettings(Method method) {
  TrialDriverSettings s;
  s.method = method;
  s.learner = LqTestSettings();
  return s;
}

// Algorithm 1 with the median watch: accepted laws kept on their own trials, a window of 3,
// watch_ratio 1.5, challenges of 3 runs.
TrialDriverSettings MedianWatchSettings() {
  TrialDriverSettings s = DriverSettings(Method::kAlg1);
  s.guard.verify_trials = 3;
  s.guard.watch_trials = 3;
  s.guard.watch_ratio = 1.5;
  s.guard.verify_accepted = false;
  return s;
}

// u^0 = 0.3 with planned durations (1, 1): an initial law whose trial depends on the input
// gain, so that the model's prediction differs from the plant's measurement.
FunctionPolicy ConstantInputPolicy() {
  return FunctionPolicy(Eigen::Vector2d(1.0, 1.0), [](int, double, const ConstVectorRef&,
                                                       VectorRef u) { u.setConstant(0.3); });
}

// Costs of the accepted nominals, the initial one first, as Learner::Solve reports them.
std::vector<double> AcceptedCosts(const std::vector<TrialOutcome>& outcomes) {
  std::vector<double> costs;
  for (const TrialOutcome& o : outcomes) {
    if (o.learned && o.accepted) costs.push_back(o.cost);
  }
  return costs;
}

// The guarded run's learning trials (`judged`, re-runs left out) decide as the unguarded run's
// (`a`), trial for trial; returns the accepted learning trials.
int ExpectSameDecisions(const std::vector<const TrialOutcome*>& judged,
                        const std::vector<TrialOutcome>& a) {
  int accepted = 0;
  for (size_t i = 0; i < judged.size() && i < a.size(); ++i) {
    EXPECT_EQ(judged[i]->accepted, a[i].accepted) << "trial " << i;
    EXPECT_EQ(judged[i]->cost, a[i].cost) << "trial " << i;
    accepted += a[i].accepted && a[i].learned ? 1 : 0;
  }
  return accepted;
}

// Every accepted learning trial i of `o` is followed by 6 re-runs (k = 1..6: u^0's where
// u0_turn(k), else the accepted law's, each judged as that law judges from x0) and abandoned
// after the sixth; returns the accepted learning trials.
int ExpectEveryAcceptedLawAbandoned(const std::vector<TrialOutcome>& o, double u0_judged,
                                    const std::function<bool(size_t)>& u0_turn) {
  int accepted = 0;
  for (size_t i = 1; i < o.size(); ++i) {
    if (!o[i].learned || !o[i].accepted) continue;
    if (i + 6 >= o.size()) {
      ADD_FAILURE() << "trial " << i << " accepted without its 6 re-runs";
      break;
    }
    ++accepted;
    for (size_t j = i + 1; j <= i + 6; ++j) {
      const bool u0 = u0_turn(j - i);
      EXPECT_TRUE(o[j].remeasured) << "trial " << j;
      EXPECT_FALSE(o[j].learned) << "trial " << j;
      EXPECT_EQ(o[j].ran_fallback, u0) << "trial " << j;
      EXPECT_EQ(o[j].judged_cost, u0 ? u0_judged : o[i].judged_cost) << "trial " << j;
      EXPECT_EQ(o[j].reverted, j == i + 6) << "trial " << j;
    }
    EXPECT_GT(o[i].judged_cost, u0_judged) << "trial " << i;
    i += 6;
  }
  return accepted;
}

// The same exact problem run by Algorithm 1 without and with a guard.
struct GuardedRuns {
  std::vector<TrialOutcome> unguarded, guarded;
  int reverts = 0;    // the guarded driver's
  int verifying = 0;  // the guarded driver's re-runs left at the end
};

// The exact two-mode LQ problem, its plant and u^0 = 0 as the fallback law.
class TrialDriverTest : public ::testing::Test {
 protected:
  // `trials` trials without a guard, `guarded_trials` with `guard`.
  GuardedRuns RunWithAndWithoutGuard(const HarmGuardSettings& guard, int trials,
                                     int guarded_trials) {
    TrialDriverSettings settings = DriverSettings(Method::kAlg1);
    TrialDriver unguarded(p.problem, settings, fallback);
    settings.guard = guard;
    TrialDriver guarded(p.problem, settings, fallback);
    GuardedRuns r;
    r.unguarded = unguarded.Run(plant, lq.x0, trials);
    r.guarded = guarded.Run(plant, lq.x0, guarded_trials);
    r.reverts = guarded.reverts();
    r.verifying = guarded.verifying();
    return r;
  }

  TwoModeLq lq;
  LqProblem p{lq};
  ModelPlant plant{p.problem};
  FunctionPolicy fallback = ZeroInputPolicy();
};

// Algorithm 1 (real, real) and mRL (model, real) by Learner::Solve and by the episodic driver
// (warm-up 1, fallback = Solve's initial policy) on an inexact plant: the same trials in the
// same order, so the same accepted costs and the same final nominal, bit for bit.
class TrialDriverVersusSolve : public ::testing::TestWithParam<Method> {};

TEST_P(TrialDriverVersusSolve, EpisodicRunFollowsSolveTrialForTrial) {
  TwoModeLq model_lq, true_lq;
  true_lq.b_scale = 1.6;
  LqProblem model(model_lq), truth(true_lq);
  ModelPlant model_plant(model.problem);
  ModelPlant real_plant(truth.sys, model.problem.bounds);
  const bool mrl = GetParam() == Method::kMrl;

  FunctionPolicy initial = ConstantInputPolicy();
  Learner learner(model.problem, LqTestSettings());
  const SolveResult solved =
      learner.Solve(mrl ? model_plant : real_plant, real_plant, model_lq.x0, initial);
  ASSERT_GT(solved.iterations, 5);

  FunctionPolicy fallback = ConstantInputPolicy();
  TrialDriver driver(model.problem, DriverSettings(GetParam()), fallback,
                     mrl ? &model_plant : nullptr);
  const std::vector<TrialOutcome> outcomes =
      driver.Run(real_plant, model_lq.x0, solved.trials + 1);
  EXPECT_EQ(AcceptedCosts(outcomes), solved.cost_history);
  EXPECT_EQ(driver.learner()->nominal().T, solved.T);
  EXPECT_EQ(driver.learner()->status(), solved.status);
  EXPECT_EQ(driver.learner()->iteration(), solved.iterations);
  EXPECT_TRUE(outcomes[0].ran_fallback);
  EXPECT_FALSE(outcomes[1].ran_fallback);
}

INSTANTIATE_TEST_SUITE_P(Alg1AndMrl, TrialDriverVersusSolve,
                         ::testing::Values(Method::kAlg1, Method::kMrl));

TEST(TrialDriver, AllThreeMethodsAgreeWithAnExactModel) {
  // u^0 is the OC-FB law of a model solve. With an exact model the plant measures what the model
  // predicts, so OC-FB's trial cost is the model optimum, and Algorithm 1 and mRL, started from
  // that law, stay at it.
  TwoModeLq lq;
  LqProblem model(lq), truth(lq);
  ModelPlant model_plant(model.problem);
  ModelPlant real_plant(truth.sys, model.problem.bounds);
  FunctionPolicy initial = ZeroInputPolicy();
  Learner ocfb(model.problem, LqTestSettings());
  const SolveResult solved = ocfb.Solve(model_plant, model_plant, lq.x0, initial);
  ASSERT_EQ(solved.status, LearnerStatus::kConverged);
  OnlineController& u0 = ocfb.ConvergedPolicy();

  std::vector<double> last;
  for (Method method : {Method::kAlg1, Method::kMrl, Method::kOcfb}) {
    TrialDriver driver(model.problem, DriverSettings(method), u0, &model_plant);
    const std::vector<TrialOutcome> outcomes = driver.Run(real_plant, lq.x0, 6);
    for (const TrialOutcome& o : outcomes) {
      EXPECT_NEAR(o.cost, solved.cost, 1e-6 * solved.cost) << "trial " << o.trial;
    }
    last.push_back(outcomes.back().cost);
    EXPECT_EQ(driver.learner() == nullptr, method == Method::kOcfb);
  }
  EXPECT_NEAR(last[0], last[2], 1e-6 * last[2]);
  EXPECT_NEAR(last[1], last[2], 1e-6 * last[2]);
}

// blend_feedback through the driver: before any accepted trial the learner's nominal law is the
// fallback u^0 (an OnlineController here, with mu = 2 gains), so ten rejections later the trial
// at alpha = 1/1024 from another start runs u^0's feedback: its inputs follow u^0's from there.
TEST(TrialDriver, BlendedFeedbackStartsFromTheFallbacksGains) {
  TwoModeLq lq;
  LqProblem p(lq);
  ModelPlant plant(p.problem);
  FunctionPolicy zero = ZeroInputPolicy();
  Trajectory nominal, reference, measured;
  plant.Run(lq.x0, zero, &nominal);
  OnlineController u0 = StiffFeedbackLaw(p.problem, nominal);
  const Vector x1 = lq.x0 + Eigen::Vector2d(0.5, 0.5);
  plant.Run(x1, u0, &reference);
  double distance[2] = {0, 0};
  for (const bool blend : {false, true}) {
    TrialDriverSettings settings = DriverSettings(Method::kAlg1);
    settings.learner.c = 1e6;  // every trial is rejected; alpha halves from 1
    settings.learner.gamma = 0.5;
    settings.learner.interpolate_backtracking = false;
    settings.learner.alpha_min = 1e-4;
    settings.learner.start_correction = false;
    settings.learner.blend_feedback = blend;
    TrialDriver driver(p.problem, settings, u0);
    for (int i = 0; i < 11; ++i) driver.RunTrial(plant, lq.x0, &measured);
    ASSERT_DOUBLE_EQ(driver.learner()->alpha(), 1.0 / 1024);
    plant.Run(x1, driver.law(), &measured);
    distance[blend] = MaxInputDifferenceInMode0(measured, reference);
  }
  EXPECT_GT(distance[0], 0.1);
  EXPECT_LT(distance[1], 0.02 * distance[0]);
}

TEST_F(TrialDriverTest, OnlineTrialsStartWhereTheLastOneEnded) {
  // Identity reset: the next trial starts at the last measured state.
  std::vector<Vector> ends;
  const TrialDriver::NextStart next = [&ends](const Trajectory& t) {
    ends.push_back(t.modes.back().x.rightCols(1));
    return ends.back();
  };
  TrialDriver driver(p.problem, DriverSettings(Method::kAlg1), fallback);
  Trajectory measured;
  std::vector<Vector> starts;
  Vector x = lq.x0;
  for (int i = 0; i < 5; ++i) {
    driver.RunTrial(plant, x, &measured);
    starts.push_back(measured.x0);
    x = next(measured);
  }
  EXPECT_EQ(starts[0], lq.x0);
  for (int i = 1; i < 5; ++i) EXPECT_EQ(starts[i], ends[static_cast<size_t>(i - 1)]);

  // Run(..., next_start) is the same loop.
  TrialDriver again(p.problem, DriverSettings(Method::kAlg1), fallback);
  ends.clear();
  const std::vector<TrialOutcome> outcomes = again.Run(plant, lq.x0, 5, next);
  ASSERT_EQ(outcomes.size(), 5u);
  EXPECT_EQ(again.learner()->nominal_cost(), driver.learner()->nominal_cost());
  EXPECT_EQ(again.learner()->nominal().x0, driver.learner()->nominal().x0);
  // An online run with next_start = x0 is the episodic run.
  TrialDriver online(p.problem, DriverSettings(Method::kAlg1), fallback);
  TrialDriver episodic(p.problem, DriverSettings(Method::kAlg1), fallback);
  const Vector x0 = lq.x0;
  const auto a = online.Run(plant, x0, 8, [&x0](const Trajectory&) { return x0; });
  const auto b = episodic.Run(plant, x0, 8);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].cost, b[i].cost) << "trial " << i;
}

TEST_F(TrialDriverTest, WarmupTrialsRunTheFallbackAndTheLastOneInitializes) {
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.warmup_trials = 3;
  std::vector<bool> for_learner;
  TrialDriver driver(p.problem, settings, fallback, nullptr,
                     [&for_learner](const Trajectory&, bool learns) {
                       for_learner.push_back(learns);
                     });
  Trajectory measured;
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(driver.runs_fallback());
    EXPECT_EQ(&driver.law(), &fallback);
    EXPECT_EQ(driver.CompletionLearns(), i == 2);
    const TrialOutcome o = driver.RunTrial(plant, lq.x0, &measured);
    EXPECT_EQ(o.trial, i);
    EXPECT_TRUE(o.ran_fallback);
    EXPECT_TRUE(o.accepted);
    EXPECT_EQ(o.learned, i == 2);
    EXPECT_DOUBLE_EQ(o.cost, EvaluateCost(p.problem, measured).total);
  }
  // Trial 2 initialized the learner: x^0 is its measurement, the next law is the learner's.
  EXPECT_EQ(driver.learner()->nominal().T, measured.T);
  EXPECT_FALSE(driver.runs_fallback());
  ASSERT_NE(driver.learned_law(), nullptr);
  EXPECT_EQ(&driver.law(), driver.learned_law());
  EXPECT_EQ(for_learner, (std::vector<bool>{false, false, true}));
  const TrialOutcome o = driver.RunTrial(plant, lq.x0, &measured);
  EXPECT_FALSE(o.ran_fallback);
  EXPECT_TRUE(o.learned);
  EXPECT_EQ(driver.learner()->trials(), 1);
}

// DelayInitialize before the Initialize trial: one more trial of u^0, which then initializes;
// after it, and for OC-FB, nothing changes; Reset returns to the settings' warm-up.
TEST_F(TrialDriverTest, DelayInitializeRunsTheFallbackOneTrialMore) {
  TrialDriver driver(p.problem, DriverSettings(Method::kAlg1), fallback);
  Trajectory measured;
  EXPECT_TRUE(driver.CompletionLearns());
  driver.DelayInitialize();
  driver.DelayInitialize();  // twice before the same trial: still one trial more
  EXPECT_FALSE(driver.CompletionLearns());
  TrialOutcome o = driver.RunTrial(plant, lq.x0, &measured);
  EXPECT_FALSE(o.learned);
  EXPECT_FALSE(driver.initialized());
  EXPECT_TRUE(driver.runs_fallback());
  driver.DelayInitialize();
  o = driver.RunTrial(plant, lq.x0, &measured);
  EXPECT_FALSE(o.learned);
  EXPECT_TRUE(driver.CompletionLearns());
  o = driver.RunTrial(plant, lq.x0, &measured);  // trial 2 initializes
  EXPECT_TRUE(o.learned);
  EXPECT_TRUE(driver.initialized());
  EXPECT_EQ(driver.learner()->nominal().T, measured.T);
  driver.DelayInitialize();  // after Initialize: no effect
  EXPECT_TRUE(driver.CompletionLearns());
  EXPECT_FALSE(driver.runs_fallback());
  driver.Reset();
  EXPECT_TRUE(driver.CompletionLearns());

  TrialDriver ocfb(p.problem, DriverSettings(Method::kOcfb), fallback);
  ocfb.DelayInitialize();
  EXPECT_FALSE(ocfb.initialized());
  EXPECT_TRUE(ocfb.RunTrial(plant, lq.x0, &measured).accepted);
}

TEST_F(TrialDriverTest, LearnerThatStopsBeforeAcceptingFallsBackToTheInitialLaw) {
  // (36) can never hold and alpha_min lies just below alpha_0: the first trial terminates the
  // line search with no accepted iteration, and from then on u^0 runs (not Learner::NextTrial's
  // replay of x^0's inputs).
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.learner.c = 1e12;
  settings.learner.alpha_min = 0.6;
  settings.learner.failure_raises = 0;
  TrialDriver driver(p.problem, settings, fallback);
  const std::vector<TrialOutcome> o = driver.Run(plant, lq.x0, 4);
  EXPECT_TRUE(o[0].ran_fallback);
  EXPECT_FALSE(o[1].ran_fallback);
  EXPECT_FALSE(o[1].accepted);
  EXPECT_EQ(o[1].status, LearnerStatus::kLineSearchFailed);
  EXPECT_TRUE(o[2].ran_fallback);
  EXPECT_TRUE(o[3].ran_fallback);
  EXPECT_TRUE(driver.runs_fallback());
  EXPECT_EQ(driver.learner()->iteration(), 0);
  // u^0 from the same start measures the cost of x^0 again.
  EXPECT_DOUBLE_EQ(o[2].cost, o[0].cost);
}

TEST_F(TrialDriverTest, FreezeKeepsTheCurrentLawAndStopsLearning) {
  TrialDriver driver(p.problem, DriverSettings(Method::kAlg1), fallback);
  driver.Run(plant, lq.x0, 4);
  Policy* law = &driver.law();
  const int iteration = driver.learner()->iteration();
  const int trials = driver.learner()->trials();
  const double nominal = driver.learner()->nominal_cost();
  driver.Freeze();
  EXPECT_TRUE(driver.frozen());
  EXPECT_FALSE(driver.CompletionLearns());
  const std::vector<TrialOutcome> frozen = driver.Run(plant, lq.x0, 3);
  for (const TrialOutcome& o : frozen) {
    EXPECT_TRUE(o.accepted);
    EXPECT_FALSE(o.learned);
    EXPECT_EQ(&driver.law(), law);
    EXPECT_DOUBLE_EQ(o.cost, frozen[0].cost);  // the same law from the same start
  }
  EXPECT_EQ(driver.learner()->iteration(), iteration);
  EXPECT_EQ(driver.learner()->trials(), trials);
  EXPECT_EQ(driver.learner()->nominal_cost(), nominal);
  driver.Reset();
  EXPECT_FALSE(driver.frozen());
  EXPECT_TRUE(driver.runs_fallback());
  EXPECT_EQ(driver.trial(), 0);
}

TEST_F(TrialDriverTest, OcfbRunsTheFallbackEveryTrial) {
  TrialDriver driver(p.problem, DriverSettings(Method::kOcfb), fallback);
  EXPECT_EQ(driver.learner(), nullptr);
  EXPECT_FALSE(driver.CompletionLearns());
  for (const TrialOutcome& o : driver.Run(plant, lq.x0, 3)) {
    EXPECT_TRUE(o.ran_fallback);
    EXPECT_TRUE(o.accepted);
    EXPECT_FALSE(o.learned);
    EXPECT_EQ(o.status, LearnerStatus::kRunning);
  }
  EXPECT_EQ(&driver.law(), &fallback);
}

TEST_F(TrialDriverTest, ASeededCyclicValueReachesEveryFreshLearner) {
  // The seed (u^0's model solve's cyclic value) is where the learner's first pass starts, for
  // the driver's learner and for the fresh one of every Reset; a wrong size is named.
  TrialDriver driver(p.problem, DriverSettings(Method::kAlg1), fallback);
  const int n0 = p.problem.system->state_dim(0);
  const Matrix seed = Matrix::Identity(n0, n0) * 3.0;
  driver.SeedCyclicValue(seed);
  ASSERT_NE(driver.learner(), nullptr);
  EXPECT_TRUE(driver.learner()->backward_pass().cyclic_value() == seed);
  driver.Reset();
  EXPECT_TRUE(driver.learner()->backward_pass().cyclic_value() == seed);
  EXPECT_THROW(driver.SeedCyclicValue(Matrix::Identity(n0 + 1, n0 + 1)), InvalidArgument);
  driver.SeedCyclicValue(Matrix());  // no seed: fresh learners start from 0
  driver.Reset();
  EXPECT_EQ(driver.learner()->backward_pass().cyclic_value().size(), 0);
  TrialDriver ocfb(p.problem, DriverSettings(Method::kOcfb), fallback);
  EXPECT_NO_THROW(ocfb.SeedCyclicValue(seed));  // no learner: nothing to seed
}

TEST_F(TrialDriverTest, BadSettingsAreNamed) {
  TrialDriverSettings zero = DriverSettings(Method::kAlg1);
  zero.warmup_trials = 0;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, zero, fallback); },
                   "TrialDriverSettings: warmup_trials = 0, expected >= 1");
  ExpectThrowsWith([&] { TrialDriver d(p.problem, DriverSettings(Method::kMrl), fallback); },
                   "method kMrl needs a prediction plant");
  TrialDriverSettings bad_gamma = DriverSettings(Method::kAlg1);
  bad_gamma.learner.gamma = 2.0;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, bad_gamma, fallback); }, "gamma");
  TrialDriver d(p.problem, DriverSettings(Method::kAlg1), fallback);
  ExpectThrowsWith([&] { d.Run(plant, lq.x0, -1); }, "trials = -1");
  TrialDriverSettings no_runs = DriverSettings(Method::kAlg1);
  no_runs.runs_per_trial = 0;
  ExpectThrowsWith([&] { TrialDriver e(p.problem, no_runs, fallback); },
                   "TrialDriverSettings: runs_per_trial = 0, expected >= 1");
}

// runs_per_trial = 2 from alternating starts: every law the learner judges runs twice in a
// row; the first run only reports (repeats), and the cost the learner gets is the mean of the
// two runs' costs, computed here from the measured trajectories. The trajectory it keeps is the
// second run's.
TEST_F(TrialDriverTest, TrialsOfSeveralRunsAreJudgedOnTheirMeanCost) {
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.runs_per_trial = 2;
  TrialDriver driver(p.problem, settings, fallback);
  Trajectory measured;
  const Vector other = 1.2 * lq.x0;
  double previous_cost = 0;
  const Policy* previous_law = nullptr;
  for (int i = 0; i < 12; ++i) {
    const Policy* law = &driver.law();
    plant.Run(i % 2 == 0 ? Vector(lq.x0) : other, driver.law(), &measured);
    const double cost = EvaluateCost(p.problem, measured).total;
    const TrialOutcome o = driver.CompleteTrial(measured);
    if (i % 2 == 0) {  // the first run of a law
      EXPECT_TRUE(o.repeats) << "run " << i;
      EXPECT_FALSE(o.learned);
      EXPECT_EQ(o.cost, cost);
      EXPECT_EQ(&driver.law(), law) << "the same law runs again";
    } else {
      EXPECT_FALSE(o.repeats) << "run " << i;
      EXPECT_TRUE(o.learned);
      EXPECT_EQ(law, previous_law);
      const double mean = 0.5 * (previous_cost + cost);
      if (i == 1) {  // Initialize: I^0 is the mean of u^0's two runs, x^0 the second run
        EXPECT_DOUBLE_EQ(driver.learner()->nominal_cost(), mean);
        EXPECT_EQ(driver.learner()->nominal().x0, other);
      } else {
        EXPECT_DOUBLE_EQ(o.cost, mean);
        if (o.accepted) EXPECT_DOUBLE_EQ(driver.learner()->nominal_cost(), mean);
      }
    }
    previous_cost = cost;
    previous_law = law;
  }
  EXPECT_EQ(driver.learner()->trials(), 5);  // 6 judged laws: Initialize and 5 trials
  // From one start (a deterministic plant) the two runs are equal: the learner sees what it
  // sees with one run per trial, trial for trial.
  TrialDriver once(p.problem, DriverSettings(Method::kAlg1), fallback);
  TrialDriver twice(p.problem, settings, fallback);
  const std::vector<TrialOutcome> a = once.Run(plant, lq.x0, 6);
  const std::vector<TrialOutcome> b = twice.Run(plant, lq.x0, 12);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].cost, b[2 * i + 1].cost) << "trial " << i;
    EXPECT_EQ(a[i].accepted, b[2 * i + 1].accepted) << "trial " << i;
  }
  EXPECT_EQ(once.learner()->nominal_cost(), twice.learner()->nominal_cost());
}

// remeasure_nominal with restarts before any accepted trial: the trial that re-measures the
// nominal at iteration 0 runs u^0, the law that produced x^0 (Learner::NextTrial would replay
// x^0's inputs with the pass's feedback instead). (36) never holds and alpha_min lies just below
// alpha_0, so every learned trial ends its line search and restarts it; the re-measurements
// start elsewhere (x1), where u^0 = 0 and the replay (0 + K dx) differ, and must cost what u^0
// costs from x1.
TEST_F(TrialDriverTest, RemeasuringAtIterationZeroRunsTheInitialLaw) {
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.learner.c = 1e12;
  settings.learner.alpha_min = 0.6;
  settings.learner.failure_raises = 0;
  settings.learner.restart_on_failure = true;
  settings.learner.remeasure_nominal = true;
  TrialDriver driver(p.problem, settings, fallback);
  const Vector x1 = lq.x0 + Eigen::Vector2d(0.5, -0.5);
  Trajectory measured, u0_from_x1;
  plant.Run(x1, fallback, &u0_from_x1);
  const double u0_cost_from_x1 = EvaluateCost(p.problem, u0_from_x1).total;
  std::vector<TrialOutcome> o;
  int remeasured = 0;
  for (int i = 0; i < 7; ++i) {
    const bool remeasuring = driver.learner()->initialized() && driver.learner()->remeasuring();
    EXPECT_EQ(driver.runs_fallback(), i == 0 || remeasuring) << "trial " << i;
    o.push_back(driver.RunTrial(plant, remeasuring ? x1 : Vector(lq.x0), &measured));
    EXPECT_EQ(o.back().remeasured, remeasuring) << "trial " << i;
    if (remeasuring) {
      ++remeasured;
      EXPECT_TRUE(o.back().ran_fallback) << "trial " << i << " re-measured with the replay";
      EXPECT_DOUBLE_EQ(o.back().cost, u0_cost_from_x1) << "trial " << i;
      // I^i is the mean of the re-measurements taken back to x^0's start (the measured cost
      // minus the start correction); x^0's own cost is dropped. All of them are equal here.
      ASSERT_GT(std::abs(o.back().start_shift), 0.01 * o.back().cost) << "x1 must matter";
      EXPECT_NEAR(driver.learner()->nominal_cost(), o.back().cost - o.back().start_shift,
                  1e-12 * o.back().cost)
          << "trial " << i;
    }
  }
  // Trials 1, 3, 5 are rejected and restart the search; 2, 4, 6 re-measure with u^0.
  EXPECT_EQ(remeasured, 3);
  for (int i : {1, 3, 5}) {
    EXPECT_FALSE(o[static_cast<size_t>(i)].ran_fallback) << "trial " << i;
    EXPECT_FALSE(o[static_cast<size_t>(i)].accepted) << "trial " << i;
    EXPECT_TRUE(o[static_cast<size_t>(i)].restarted) << "trial " << i;
  }
  for (int i : {2, 4, 6}) EXPECT_TRUE(o[static_cast<size_t>(i)].remeasured) << "trial " << i;
  EXPECT_EQ(driver.learner()->iteration(), 0);
}

// After accepted iterations a terminated learner's law is the one that produced the last
// accepted trial (Learner::NextTrial's replay), not u^0: the driver falls back to u^0 only at
// iteration 0. On this deterministic plant the replay reproduces the nominal's cost.
TEST_F(TrialDriverTest, TerminationAfterAcceptedTrialsReplaysTheLastAcceptedLaw) {
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.learner.alpha_min = 0.3;  // two rejections in a row terminate
  settings.learner.alpha_after_accept = AlphaAfterAccept::kReset;
  TrialDriver driver(p.problem, settings, fallback);
  Trajectory measured;
  int trials = 0;
  while (driver.learner()->status() != LearnerStatus::kLineSearchFailed && trials < 500) {
    driver.RunTrial(plant, lq.x0, &measured);
    ++trials;
  }
  ASSERT_EQ(driver.learner()->status(), LearnerStatus::kLineSearchFailed);
  ASSERT_GT(driver.learner()->iteration(), 3);
  for (int i = 0; i < 2; ++i) {
    EXPECT_FALSE(driver.runs_fallback()) << "replay " << i;
    const TrialOutcome o = driver.RunTrial(plant, lq.x0, &measured);
    EXPECT_FALSE(o.ran_fallback) << "replay " << i;
    EXPECT_NEAR(o.cost, driver.learner()->nominal_cost(), 1e-9 * driver.learner()->nominal_cost())
        << "replay " << i;
  }
}


// The harm guard's bad settings are named.
TEST_F(TrialDriverTest, BadGuardSettingsAreNamed) {
  TrialDriverSettings one = DriverSettings(Method::kAlg1);
  one.guard.verify_trials = 1;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, one, fallback); },
                   "guard.verify_trials = 1, expected 0 (off) or >= 2");
  TrialDriverSettings watch = DriverSettings(Method::kAlg1);
  watch.guard.watch_trials = 1;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, watch, fallback); },
                   "guard.watch_trials = 1, expected 0 (no watch) or >= 2");
  TrialDriverSettings margin = DriverSettings(Method::kAlg1);
  margin.guard.verify_trials = 2;
  margin.guard.margin = -1;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, margin, fallback); },
                   "guard.margin = -1.000000, expected finite and >= 0");
  TrialDriverSettings interleave = DriverSettings(Method::kAlg1);
  interleave.guard.interleave = true;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, interleave, fallback); },
                   "guard.interleave needs guard.verify_trials >= 2 and guard.watch_trials = 0 "
                   "(verify_trials = 0, watch_trials = 0)");
  interleave.guard.verify_trials = 3;
  interleave.guard.watch_trials = 3;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, interleave, fallback); },
                   "(verify_trials = 3, watch_trials = 3)");
  TrialDriverSettings ratio = DriverSettings(Method::kAlg1);
  ratio.guard.verify_trials = 3;
  ratio.guard.watch_trials = 3;
  ratio.guard.watch_ratio = 0.5;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, ratio, fallback); },
                   "guard.watch_ratio = 0.500000, expected 0 (the mean form) or >= 1");
  ratio.guard.watch_ratio = std::numeric_limits<double>::quiet_NaN();
  ExpectThrowsWith([&] { TrialDriver d(p.problem, ratio, fallback); }, "guard.watch_ratio = nan");
  ratio.guard.watch_ratio = 1.5;
  ratio.guard.watch_trials = 0;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, ratio, fallback); },
                   "guard.watch_ratio needs guard.watch_trials >= 2 and guard.verify_trials >= 2 "
                   "(watch_trials = 0, verify_trials = 3); to turn the whole guard off, assign "
                   "guard = HarmGuardSettings{}");
  ratio.guard = HarmGuardSettings{};  // what the message says turns it off
  EXPECT_NO_THROW({ TrialDriver d(p.problem, ratio, fallback); });
  TrialDriverSettings keep = DriverSettings(Method::kAlg1);
  keep.guard.verify_trials = 3;
  keep.guard.verify_accepted = false;
  keep.guard.only_when_worse = true;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, keep, fallback); },
                   "guard.verify_accepted = false excludes guard.only_when_worse and "
                   "guard.interleave");
  keep.guard.only_when_worse = false;
  keep.guard.interleave = true;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, keep, fallback); },
                   "guard.verify_accepted = false excludes");
  TrialDriverSettings worse = DriverSettings(Method::kAlg1);
  worse.guard.only_when_worse = true;
  ExpectThrowsWith([&] { TrialDriver d(p.problem, worse, fallback); },
                   "guard.only_when_worse needs guard.verify_trials >= 2 (verify_trials = 0)");
}

// A cost that is one of two quadratic costs: the learner's (judge = false) or the one the
// harm guard judges by (judge = true), switched by the driver's cost reference.
class TwoCosts : public SwitchedCost {
 public:
  TwoCosts(const SwitchedCost& learner, const SwitchedCost& judged)
      : learner_(learner), judged_(judged) {}
  bool judge = false;

 protected:
  const SwitchedCost& Active() const { return judge ? judged_ : learner_; }
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    return Active().Running(k, x, u);
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    Active().RunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    return Active().Switching(k, x);
  }
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    Active().SwitchingDerivatives(k, x, phix, phixx);
  }

 private:
  const SwitchedCost& learner_;
  const SwitchedCost& judged_;
};

// The judged cost of the guard tests: the learner's with the input weighed 60x (r = 30). Every
// law the learner accepts uses input that u^0 = 0 does not, so it lowers the learner's cost and
// raises the judged one. `problem` has the two costs; `reference` switches them as a
// CostReference; Judged evaluates the judged one.
struct HeavyInputJudged {
  HeavyInputJudged(const TwoModeLq& lq, const LqProblem& p)
      : heavy_input({Matrix(lq.Q0), Matrix(lq.Q1)}, {Vector::Zero(2), Vector::Zero(2)},
                    {Matrix::Constant(1, 1, 60 * lq.r), Matrix::Constant(1, 1, 60 * lq.r)},
                    {lq.rho0, lq.rho1}, {Matrix::Zero(2, 2), Matrix(lq.S)},
                    {Vector::Zero(2), Vector::Zero(2)}),
        costs(p.cost, heavy_input),
        problem(p.problem) {
    problem.cost = &costs;
  }
  TrialDriver::CostReference reference() {
    return [this](const Trajectory&, bool for_learner) { costs.judge = !for_learner; };
  }
  double Judged(const Trajectory& t) {
    costs.judge = true;
    const double c = EvaluateCost(problem, t).total;
    costs.judge = false;
    return c;
  }
  QuadraticTrackingCost heavy_input;
  TwoCosts costs;
  Problem problem;
};

// The judged cost is the learner's with the input weighed 60x (r = 30): every law the learner
// accepts uses input that u^0 = 0 does not, so it lowers the learner's cost and raises the
// judged one. Without the guard the learner keeps such laws (checked first: the test's premise);
// with it (3 re-runs, deterministic plant: zero spread) every accepted law is re-run, found
// worse than u^0, u^0 is run again, and the law is abandoned; the learner goes on from u^0's
// nominal, and no law it keeps judges worse than u^0.
TEST_F(TrialDriverTest, TheHarmGuardAbandonsALawThatMeasuresWorseThanTheInitialLaw) {
  HeavyInputJudged h(lq, p);
  const Problem& problem = h.problem;
  const TrialDriver::CostReference reference = h.reference();
  auto judged = [&](const Trajectory& t) { return h.Judged(t); };
  Trajectory measured;
  plant.Run(lq.x0, fallback, &measured);
  const double u0_judged = judged(measured);

  TrialDriver unguarded(problem, DriverSettings(Method::kAlg1), fallback, nullptr, reference);
  double kept_judged = u0_judged;  // the judged cost of the nominal the learner keeps
  for (int i = 0; i < 30; ++i) {
    const TrialOutcome o = unguarded.RunTrial(plant, lq.x0, &measured);
    if (o.learned && o.accepted) kept_judged = judged(measured);
  }
  ASSERT_GT(unguarded.learner()->iteration(), 2);
  ASSERT_GT(kept_judged, 1.01 * u0_judged) << "premise: the learner keeps harm unguarded";

  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.guard.verify_trials = 3;
  TrialDriver driver(problem, settings, fallback, nullptr, reference);
  std::vector<TrialOutcome> o;
  for (int i = 0; i < 30 || driver.verifying() > 0; ++i) {  // ends with no law on trial
    o.push_back(driver.RunTrial(plant, lq.x0, &measured));
    EXPECT_EQ(o.back().judged_cost, judged(measured)) << "trial " << i;
  }
  // The accepted law runs 3 times more (the same law from the same start: the same cost);
  // worse than u^0's Initialize trial, u^0 runs 3 times again, and the accepted law is
  // abandoned after the last.
  const int accepted =
      ExpectEveryAcceptedLawAbandoned(o, u0_judged, [](size_t k) { return k > 3; });
  EXPECT_GE(accepted, 2);
  EXPECT_EQ(driver.reverts(), accepted);
  EXPECT_TRUE(driver.learner()->nominal_is_initial());
  EXPECT_EQ(driver.learner()->nominal_cost(), o[0].cost);
}

// The interleaved guard on the same premise: each accepted law's 3 re-runs alternate with 3
// runs of u^0 (new, u^0, new, u^0, new, u^0); every paired difference is the same positive
// number on this deterministic plant (zero spread), so the law is abandoned after the sixth run
// and the learner goes on from u^0's nominal.
TEST_F(TrialDriverTest, TheInterleavedGuardAbandonsALawThatMeasuresWorseThanTheInitialLaw) {
  HeavyInputJudged h(lq, p);
  const Problem& problem = h.problem;
  const TrialDriver::CostReference reference = h.reference();
  Trajectory measured;
  plant.Run(lq.x0, fallback, &measured);
  const double u0_judged = h.Judged(measured);

  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.guard.verify_trials = 3;
  settings.guard.interleave = true;
  TrialDriver driver(problem, settings, fallback, nullptr, reference);
  std::vector<TrialOutcome> o;
  for (int i = 0; i < 40 || driver.verifying() > 0; ++i) {
    o.push_back(driver.RunTrial(plant, lq.x0, &measured));
  }
  const int accepted =
      ExpectEveryAcceptedLawAbandoned(o, u0_judged, [](size_t k) { return k % 2 == 0; });
  EXPECT_GE(accepted, 2);
  EXPECT_EQ(driver.reverts(), accepted);
  EXPECT_TRUE(driver.learner()->nominal_is_initial());
}

// log_cost compares the logarithms of the judged costs: on a deterministic plant (zero spread)
// every decision is the same as on the costs themselves (the log is increasing), trial for
// trial. A judged cost that is not positive has no logarithm: the error names the setting.
TEST_F(TrialDriverTest, TheGuardOnLogCostsDecidesAsOnCostsWithoutSpread) {
  HeavyInputJudged h(lq, p);
  const Problem& problem = h.problem;
  const TrialDriver::CostReference reference = h.reference();
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.guard.verify_trials = 3;
  TrialDriver linear(problem, settings, fallback, nullptr, reference);
  settings.guard.log_cost = true;
  TrialDriver logs(problem, settings, fallback, nullptr, reference);
  Trajectory measured;
  int reverted = 0;
  for (int i = 0; i < 40; ++i) {
    const TrialOutcome a = linear.RunTrial(plant, lq.x0, &measured);
    const TrialOutcome b = logs.RunTrial(plant, lq.x0, &measured);
    EXPECT_EQ(a.judged_cost, b.judged_cost) << "trial " << i;  // the cost, not its log
    EXPECT_EQ(a.accepted, b.accepted) << "trial " << i;
    EXPECT_EQ(a.reverted, b.reverted) << "trial " << i;
    EXPECT_EQ(a.ran_fallback, b.ran_fallback) << "trial " << i;
    reverted += b.reverted ? 1 : 0;
  }
  EXPECT_GE(reverted, 2);  // the decisions compared include abandoned laws

  const int n = 2;
  QuadraticTrackingCost nothing({Matrix::Zero(n, n), Matrix::Zero(n, n)},
                                {Vector::Zero(n), Vector::Zero(n)},
                                {Matrix::Zero(1, 1), Matrix::Zero(1, 1)}, {0.0, 0.0},
                                {Matrix::Zero(n, n), Matrix::Zero(n, n)},
                                {Vector::Zero(n), Vector::Zero(n)});
  TwoCosts zero_judged(p.cost, nothing);
  Problem zero_problem = p.problem;
  zero_problem.cost = &zero_judged;
  auto zero_reference = [&](const Trajectory&, bool for_learner) {
    zero_judged.judge = !for_learner;
  };
  TrialDriver zero(zero_problem, settings, fallback, nullptr, zero_reference);
  ExpectThrowsWith([&] { zero.RunTrial(plant, lq.x0, &measured); },
                   "guard.log_cost needs positive judged costs, trial 0 judged 0");
}

// With the learner's own cost judged, the interleaved guard keeps every accepted law (each is
// better than the law it replaced, run for run), and the learner decides as without the
// guard, trial for trial; the runs of the replaced law alternate with the new law's.
TEST_F(TrialDriverTest, TheInterleavedGuardKeepsEveryLawThatMeasuresBetter) {
  HarmGuardSettings guard;
  guard.verify_trials = 2;
  guard.interleave = true;
  const GuardedRuns r = RunWithAndWithoutGuard(guard, 40, 40 + 4 * 12);
  const std::vector<TrialOutcome>& a = r.unguarded;
  const std::vector<TrialOutcome>& b = r.guarded;
  std::vector<const TrialOutcome*> judged;
  int old_runs = 0;
  for (size_t i = 0; i < b.size(); ++i) {
    if (!b[i].remeasured) judged.push_back(&b[i]);
    EXPECT_FALSE(b[i].reverted) << "trial " << i;
    if (b[i].remeasured && i > 0 && b[i - 1].remeasured && b[i].cost > b[i - 1].cost) {
      ++old_runs;  // the replaced law's run after the new law's: it costs more
    }
  }
  ASSERT_GE(judged.size(), 30u);
  EXPECT_GE(ExpectSameDecisions(judged, a), 3);
  EXPECT_GE(old_runs, 2 * 3) << "the replaced law ran between the new law's re-runs";
  EXPECT_EQ(r.reverts, 0);
}

// When the judged cost is the learner's, the guard keeps every law the learner accepts, and on
// a deterministic plant the learner decides as without it, trial for trial: the re-runs are
// inserted after each accepted trial and change nothing else.
TEST_F(TrialDriverTest, TheHarmGuardKeepsEveryLawThatMeasuresBetter) {
  HarmGuardSettings guard;
  guard.verify_trials = 2;
  const GuardedRuns r = RunWithAndWithoutGuard(guard, 40, 40 + 2 * 12);
  const std::vector<TrialOutcome>& a = r.unguarded;
  const std::vector<TrialOutcome>& b = r.guarded;
  std::vector<const TrialOutcome*> judged;
  for (const TrialOutcome& o : b) {
    if (!o.remeasured) judged.push_back(&o);
    EXPECT_FALSE(o.reverted) << "trial " << o.trial;
  }
  ASSERT_GE(judged.size(), 30u);
  EXPECT_GE(ExpectSameDecisions(judged, a), 3);
  EXPECT_EQ(r.reverts, 0);
}

// A guarded run with no re-run and no revert that decides trial for trial as the unguarded one
// (at least 3 accepted trials compared).
void ExpectTheUnguardedRun(const GuardedRuns& r) {
  std::vector<const TrialOutcome*> all;
  for (const TrialOutcome& o : r.guarded) {
    EXPECT_FALSE(o.remeasured) << "trial " << o.trial;
    all.push_back(&o);
  }
  EXPECT_GE(ExpectSameDecisions(all, r.unguarded), 3);
  EXPECT_EQ(r.verifying, 0);
  EXPECT_EQ(r.reverts, 0);
}

// only_when_worse re-runs an accepted law only when its trial's judged cost is above the
// replaced law's or u^0's. With the learner's own cost judged every accepted trial agrees with
// the acceptance: no re-run at all, and the run is the unguarded run, trial for trial. With the
// input weighed 60x in the judged cost every accepted trial contradicts it: each is re-run and
// abandoned as by the guard that always re-runs, trial for trial.
TEST_F(TrialDriverTest, TheGuardOnlyWhenWorseReRunsTheLawsTheReportedCostContradicts) {
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.guard.verify_trials = 3;
  settings.guard.only_when_worse = true;
  ExpectTheUnguardedRun(RunWithAndWithoutGuard(settings.guard, 40, 40));

  HeavyInputJudged h(lq, p);
  const TrialDriver::CostReference reference = h.reference();
  TrialDriverSettings always = DriverSettings(Method::kAlg1);
  always.guard.verify_trials = 3;
  TrialDriver every(h.problem, always, fallback, nullptr, reference);
  TrialDriver contradicted(h.problem, settings, fallback, nullptr, reference);
  Trajectory measured;
  for (int i = 0; i < 40; ++i) {
    const TrialOutcome x = every.RunTrial(plant, lq.x0, &measured);
    const TrialOutcome y = contradicted.RunTrial(plant, lq.x0, &measured);
    EXPECT_EQ(x.accepted, y.accepted) << "trial " << i;
    EXPECT_EQ(x.cost, y.cost) << "trial " << i;
    EXPECT_EQ(x.remeasured, y.remeasured) << "trial " << i;
    EXPECT_EQ(x.reverted, y.reverted) << "trial " << i;
  }
  EXPECT_GE(contradicted.reverts(), 2);
  EXPECT_EQ(contradicted.reverts(), every.reverts());
}

// The two-mode LQ with its input gain flipped (a motor wired the other way round), as a plant.
struct FlippedLq {
  static TwoModeLq Flip() {
    TwoModeLq l;
    l.b_scale = -1.0;
    return l;
  }
  LqProblem problem{Flip()};
  mutable ModelPlant plant{problem.problem};
};

// A kept law that later measures worse: the plant's input gain flips after the learner kept a
// law (a motor wired the other way round, an extreme of a weaker motor). u^0 = 0 uses no input
// and does not notice; every law that uses input now costs more. The guard watches the kept
// law's trials (watch_trials = 3): once their last 3 judged costs are worse than u^0's, u^0 runs
// 3 times, and the learner goes back to u^0's nominal. Without the watch (the default) the law
// stays.
TEST_F(TrialDriverTest, TheHarmGuardLeavesAKeptLawThatLaterMeasuresWorse) {
  const FlippedLq flipped;
  ModelPlant& flipped_plant = flipped.plant;
  TrialDriverSettings settings = DriverSettings(Method::kAlg1);
  settings.guard.verify_trials = 3;
  settings.guard.watch_trials = 3;
  TrialDriver driver(p.problem, settings, fallback);
  Trajectory measured;
  int i = 0;
  for (; i < 60 && !(driver.learner()->iteration() >= 2 && driver.verifying() == 0 &&
                     !driver.learner()->nominal_is_initial());
       ++i) {
    driver.RunTrial(plant, lq.x0, &measured);
  }
  ASSERT_FALSE(driver.learner()->nominal_is_initial()) << "premise: a law is kept";
  ASSERT_EQ(driver.reverts(), 0);
  flipped_plant.Run(lq.x0, fallback, &measured);
  const double u0_flipped = EvaluateCost(p.problem, measured).total;
  std::vector<TrialOutcome> o;
  for (int j = 0; j < 20 && driver.reverts() == 0; ++j) {
    o.push_back(driver.RunTrial(flipped_plant, lq.x0, &measured));
  }
  ASSERT_EQ(driver.reverts(), 1);
  ASSERT_GE(o.size(), 6u);
  {
    settings.guard.watch_trials = 0;
    TrialDriver unwatched(p.problem, settings, fallback);
    for (int j = 0; j < i; ++j) unwatched.RunTrial(plant, lq.x0, &measured);
    for (int j = 0; j < 20; ++j) unwatched.RunTrial(flipped_plant, lq.x0, &measured);
    EXPECT_EQ(unwatched.reverts(), 0);
    EXPECT_FALSE(unwatched.learner()->nominal_is_initial());
  }
  // watch_initial = false: the watch may go back to the law the kept one replaced, never to
  // u^0, which runs in none of the trials. Suspended by the user (SetWatching(false)): no
  // challenge and no revert at all.
  for (bool suspended : {false, true}) {
    settings.guard.watch_trials = 3;
    settings.guard.watch_initial = suspended;
    TrialDriver no_u0(p.problem, settings, fallback);
    if (suspended) no_u0.SetWatching(false);
    for (int j = 0; j < i; ++j) no_u0.RunTrial(plant, lq.x0, &measured);
    ASSERT_FALSE(no_u0.learner()->nominal_is_initial()) << "premise: a law is kept";
    for (int j = 0; j < 20; ++j) {
      const TrialOutcome x = no_u0.RunTrial(flipped_plant, lq.x0, &measured);
      EXPECT_FALSE(x.ran_fallback) << "trial " << x.trial << (suspended ? ", suspended" : "");
      if (suspended) EXPECT_FALSE(x.remeasured) << "trial " << x.trial << ", suspended";
    }
    if (suspended) EXPECT_EQ(no_u0.reverts(), 0);
    EXPECT_FALSE(no_u0.learner()->nominal_is_initial());
  }
  // The revert follows 3 runs of u^0 (the challenge), which cost what u^0 costs.
  for (size_t j = o.size() - 3; j < o.size(); ++j) {
    EXPECT_TRUE(o[j].ran_fallback && o[j].remeasured) << "trial " << j;
    EXPECT_EQ(o[j].judged_cost, u0_flipped) << "trial " << j;
  }
  EXPECT_TRUE(o.back().reverted);
  EXPECT_TRUE(driver.learner()->nominal_is_initial());
  // The 3 trials before it were the kept law's and measured worse than u^0.
  for (size_t j = o.size() - 6; j < o.size() - 3; ++j) {
    EXPECT_FALSE(o[j].remeasured) << "trial " << j;
    EXPECT_GT(o[j].judged_cost, u0_flipped) << "trial " << j;
  }
}

// verify_accepted = false: every accepted law is kept on its own trial, so without a watch the
// guarded run is the unguarded run, trial for trial, with no re-run and no revert.
TEST_F(TrialDriverTest, TheGuardThatDoesNotVerifyKeepsEveryAcceptedLawOnItsTrial) {
  HarmGuardSettings guard;
  guard.verify_trials = 3;
  guard.verify_accepted = false;
  ExpectTheUnguardedRun(RunWithAndWithoutGuard(guard, 40, 40));
}

// The watch's median form (watch_ratio) on the flipped input gain of the test above, with the
// accepted laws kept on their own trials: the window (the accepted trial, on the unflipped
// plant, and the kept law's next two trials, on the flipped one) has a median above
// watch_ratio x u^0's cost, u^0 runs verify_trials times (the challenge) and the learner goes
// back to it. With watch_initial = false the watch has no law to go back to (u^0 is excluded
// and the kept law replaced none): the law stays. So it does while the user has suspended the
// watch (SetWatching(false)), and once it watches again it goes back to u^0.
TEST_F(TrialDriverTest, TheMedianWatchLeavesAKeptLawThatMeasuresWorseThanARatio) {
  const FlippedLq flipped;
  ModelPlant& flipped_plant = flipped.plant;
  Trajectory measured;
  flipped_plant.Run(lq.x0, fallback, &measured);
  const double u0_cost = EvaluateCost(p.problem, measured).total;  // u^0 = 0: B plays no part
  for (int mode : {0, 1, 2}) {  // u^0 a candidate; watch_initial = false; suspended by the user
    const bool initial = mode == 0;
    TrialDriverSettings settings = MedianWatchSettings();
    settings.guard.watch_initial = mode != 1;
    TrialDriver driver(p.problem, settings, fallback);
    EXPECT_TRUE(driver.watching());
    if (mode == 2) driver.SetWatching(false);
    TrialOutcome accepted;
    for (int i = 0; i < 60 && driver.learner()->nominal_is_initial(); ++i) {
      accepted = driver.RunTrial(plant, lq.x0, &measured);
    }
    ASSERT_FALSE(driver.learner()->nominal_is_initial()) << "premise: a law is kept";
    EXPECT_FALSE(accepted.remeasured);  // kept on its own trial
    std::vector<TrialOutcome> o;
    for (int j = 0; j < 12 && driver.reverts() == 0; ++j) {
      o.push_back(driver.RunTrial(flipped_plant, lq.x0, &measured));
    }
    ASSERT_GE(o.size(), 2u);
    std::vector<double> window = {accepted.judged_cost, o[0].judged_cost, o[1].judged_cost};
    std::sort(window.begin(), window.end());
    ASSERT_GT(window[1], 1.5 * u0_cost) << "premise: the window's median";
    if (initial) {
      ASSERT_EQ(driver.reverts(), 1);
      ASSERT_EQ(o.size(), 5u);
      for (size_t j = 2; j < 5; ++j) {
        EXPECT_TRUE(o[j].ran_fallback && o[j].remeasured) << "trial " << j;
        EXPECT_EQ(o[j].judged_cost, u0_cost) << "trial " << j;
      }
      EXPECT_TRUE(o.back().reverted);
      EXPECT_TRUE(driver.learner()->nominal_is_initial());
    } else {
      EXPECT_EQ(driver.reverts(), 0) << "mode " << mode;
      for (const TrialOutcome& x : o) EXPECT_FALSE(x.remeasured) << "trial " << x.trial;
      EXPECT_FALSE(driver.learner()->nominal_is_initial());
    }
    if (mode == 2) {  // watching again: the watch's next look goes back to u^0
      driver.SetWatching(true);
      for (int j = 0; j < 12 && driver.reverts() == 0; ++j) {
        driver.RunTrial(flipped_plant, lq.x0, &measured);
      }
      EXPECT_EQ(driver.reverts(), 1);
      EXPECT_TRUE(driver.learner()->nominal_is_initial());
    }
  }
}

// Warm-up runs of u^0 are not u^0's record (the hopper's settling hops after a re-solve of u^0,
// issue 45): two warm-up runs from 200 x farther out cost 4e4 x u^0's cost from x0; the Initialize
// run and every later one start at x0. The kept law on the flipped plant is left for u^0 as in the
// test above: the watch compares the window with the Initialize run, not with a mean that the
// transient warm-ups put 2.7e4 x higher.
TEST_F(TrialDriverTest, TheMedianWatchJudgesAgainstTheInitializeRunNotTheWarmUps) {
  const FlippedLq flipped;
  ModelPlant& flipped_plant = flipped.plant;
  TrialDriverSettings settings = MedianWatchSettings();
  settings.warmup_trials = 3;
  TrialDriver driver(p.problem, settings, fallback);
  Trajectory measured;
  std::vector<TrialOutcome> warmup;
  for (int i = 0; i < 2; ++i) warmup.push_back(driver.RunTrial(plant, 200.0 * lq.x0, &measured));
  const TrialOutcome initialize = driver.RunTrial(plant, lq.x0, &measured);
  ASSERT_TRUE(warmup[0].ran_fallback && warmup[1].ran_fallback && initialize.learned);
  ASSERT_GT(warmup[0].judged_cost, 1e4 * initialize.judged_cost) << "premise: a transient";
  for (int i = 0; i < 60 && driver.learner()->nominal_is_initial(); ++i) {
    driver.RunTrial(plant, lq.x0, &measured);
  }
  ASSERT_FALSE(driver.learner()->nominal_is_initial()) << "premise: a law is kept";
  for (int j = 0; j < 12 && driver.reverts() == 0; ++j) {
    driver.RunTrial(flipped_plant, lq.x0, &measured);
  }
  EXPECT_EQ(driver.reverts(), 1);
  EXPECT_TRUE(driver.learner()->nominal_is_initial());
}

// The other side of the median watch's decision: the same window, but u^0's challenge runs start
// 200 x farther out (u^0 = 0: its cost is 4e4 x its cost from x0): their median is above the
// window's, the kept law stays and the learner goes on from it.
TEST_F(TrialDriverTest, TheMedianWatchKeepsALawWhoseChallengeMeasuresWorse) {
  const FlippedLq flipped;
  ModelPlant& flipped_plant = flipped.plant;
  TrialDriver driver(p.problem, MedianWatchSettings(), fallback);
  Trajectory measured;
  TrialOutcome accepted;
  for (int i = 0; i < 60 && driver.learner()->nominal_is_initial(); ++i) {
    accepted = driver.RunTrial(plant, lq.x0, &measured);
  }
  ASSERT_FALSE(driver.learner()->nominal_is_initial()) << "premise: a law is kept";
  std::vector<double> window = {accepted.judged_cost};
  std::vector<double> challenge;
  for (int j = 0; j < 12 && challenge.size() < 3; ++j) {
    const bool in_challenge = driver.verifying() > 0;
    const TrialOutcome o = driver.RunTrial(
        flipped_plant, in_challenge ? Vector(200.0 * lq.x0) : Vector(lq.x0), &measured);
    if (in_challenge) {
      EXPECT_TRUE(o.ran_fallback && o.remeasured) << "trial " << o.trial;
      challenge.push_back(o.judged_cost);
    } else if (challenge.empty() && window.size() < 3) {
      window.push_back(o.judged_cost);
    }
  }
  ASSERT_EQ(challenge.size(), 3u) << "premise: the window's median starts a challenge";
  std::sort(window.begin(), window.end());
  std::sort(challenge.begin(), challenge.end());
  ASSERT_GT(challenge[1], window[1]) << "premise: u^0's challenge measures worse";
  EXPECT_EQ(driver.reverts(), 0);
  EXPECT_FALSE(driver.learner()->nominal_is_initial());
}

// A pushed stretch: the kept law has measured well for several trials, then two trials on the
// flipped plant fill the window (its median above watch_ratio x the cost of the law to go back
// to, here the law the kept one replaced), and the challenge runs on the plant as it was. The
// challenge measures better than the window but worse than the kept law's record since it was
// kept: the law stays (the window alone would revert).
TEST_F(TrialDriverTest, TheMedianWatchKeepsALawWhoseRecordBeatsTheChallenge) {
  const FlippedLq flipped;
  ModelPlant& flipped_plant = flipped.plant;
  TrialDriver driver(p.problem, MedianWatchSettings(), fallback);
  Trajectory measured;
  // The kept law's record: trials until five in a row keep the same law.
  std::vector<double> record;
  for (int i = 0; i < 300 && record.size() < 5; ++i) {
    const TrialOutcome o = driver.RunTrial(plant, lq.x0, &measured);
    if (driver.learner()->nominal_is_initial()) continue;
    if (o.accepted && o.learned) record.clear();
    record.push_back(o.judged_cost);
  }
  ASSERT_EQ(record.size(), 5u) << "premise: a law kept for five trials";
  std::vector<double> window = {record[3], record[4]};
  std::vector<double> challenge;
  for (int j = 0; j < 12 && challenge.size() < 3; ++j) {
    const bool in_challenge = driver.verifying() > 0;
    const TrialOutcome o = driver.RunTrial(in_challenge ? plant : flipped_plant, lq.x0, &measured);
    if (in_challenge) {
      ASSERT_TRUE(o.remeasured) << "trial " << o.trial;
      challenge.push_back(o.judged_cost);
    } else {
      window.push_back(o.judged_cost);
      record.push_back(o.judged_cost);
    }
  }
  ASSERT_EQ(challenge.size(), 3u) << "premise: the window's median starts a challenge";
  window.erase(window.begin(), window.end() - 3);
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 == 1 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  ASSERT_GT(median(window), median(challenge)) << "premise: the window alone would revert";
  ASSERT_LT(median(record), median(challenge)) << "premise: the record beats u^0";
  EXPECT_EQ(driver.reverts(), 0);
  EXPECT_FALSE(driver.learner()->nominal_is_initial());
}

// A kept law's I^i is the mean learner cost of its re-runs, not the accepted trial's own cost
// (the minimum of a selection). Trials start alternately at x0 and 1.1 x0 so that runs of one
// law differ; with debias = false the accepted trial's cost stays.
TEST_F(TrialDriverTest, AKeptLawsCostIsTheMeanOfItsReRuns) {
  for (bool debias : {true, false}) {
    TrialDriverSettings settings = DriverSettings(Method::kAlg1);
    settings.guard.verify_trials = 3;
    settings.guard.margin = 100;  // keep every law: this test is about I^i
    settings.guard.debias = debias;
    TrialDriver driver(p.problem, settings, fallback);
    Trajectory measured;
    std::vector<TrialOutcome> o;
    size_t kept = 0;
    for (int i = 0; i < 40 && kept == 0; ++i) {
      o.push_back(driver.RunTrial(plant, i % 2 == 0 ? Vector(lq.x0) : Vector(1.1 * lq.x0),
                                  &measured));
      const size_t n = o.size();
      if (n >= 4 && o[n - 4].learned && o[n - 4].accepted && o[n - 1].remeasured &&
          driver.verifying() == 0) {
        kept = n - 4;
      }
    }
    ASSERT_GT(kept, 0u) << "debias " << debias;
    const double mean = (o[kept + 1].cost + o[kept + 2].cost + o[kept + 3].cost) / 3;
    ASSERT_GT(std::abs(mean - o[kept].cost), 1e-6 * mean) << "premise: runs differ";
    EXPECT_DOUBLE_EQ(driver.learner()->nominal_cost(), debias ? mean : o[kept].cost);
  }
}

// Save and Restore: a learner that went on from a checkpoint has the checkpoint's nominal, cost
// and law, restarts its line search, and keeps counting trials and iterations.
TEST_F(TrialDriverTest, ALearnerRestoredFromACheckpointGoesOnFromItsNominal) {
  LearnerSettings settings = LqTestSettings();
  settings.restart_alpha = 0.25;
  Learner learner(p.problem, settings);
  Trajectory measured;
  plant.Run(lq.x0, fallback, &measured);
  learner.Initialize(measured);
  int trials = 0;
  while (learner.iteration() < 2 && trials++ < 50) {
    plant.Run(lq.x0, learner.NextTrial(), &measured);
    learner.CompleteTrial(measured);
  }
  ASSERT_EQ(learner.iteration(), 2);
  const LearnerCheckpoint checkpoint = learner.Save();
  const Trajectory nominal = learner.nominal();
  const double cost = learner.nominal_cost();
  const Matrix p0 = learner.backward_pass().P(0, 0);
  while (learner.iteration() < 4 && trials++ < 100) {
    plant.Run(lq.x0, learner.NextTrial(), &measured);
    learner.CompleteTrial(measured);
  }
  ASSERT_EQ(learner.iteration(), 4);
  const int trials_before = learner.trials();
  learner.NextTrial();  // a pending trial is dropped by Restore
  learner.Restore(checkpoint);
  EXPECT_EQ(learner.nominal().modes[0].x, nominal.modes[0].x);
  EXPECT_EQ(learner.nominal().T, nominal.T);
  EXPECT_EQ(learner.nominal_cost(), cost);
  EXPECT_FALSE(learner.nominal_is_initial());
  EXPECT_TRUE((learner.backward_pass().P(0, 0) - p0).cwiseAbs().maxCoeff() <=
              1e-9 * p0.cwiseAbs().maxCoeff());
  EXPECT_EQ(learner.alpha(), 0.25);
  EXPECT_EQ(learner.status(), LearnerStatus::kRunning);
  EXPECT_EQ(learner.iteration(), 4);
  // The law that produced the checkpoint's nominal reproduces it.
  plant.Run(lq.x0, learner.nominal_law(), &measured);
  EXPECT_NEAR(EvaluateCost(p.problem, measured).total, cost, 1e-9 * cost);
  plant.Run(lq.x0, learner.NextTrial(), &measured);
  learner.CompleteTrial(measured);
  EXPECT_EQ(learner.trials(), trials_before + 1);
  ExpectThrowsWith([&] { learner.Restore(LearnerCheckpoint{}); }, "the checkpoint is empty");
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
