// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The start correction (LearnerSettings::start_correction, docs/engine.md "Trials from other
// starts") when the cost's reference moves between trials. Its learner_test cases keep the
// reference still, so the reference term of Learner::StartShift (the nominal's cost under the
// current reference minus the one it was adopted with) is always 0 there.
#include <cmath>

#include <gtest/gtest.h>

#include "ddoc/cost.h"
#include "ddoc/learner.h"
#include "test_systems.h"
#include "two_mode_lq.h"

namespace ddoc {
namespace testing {
namespace {

// The two-mode LQ problem and a learner initialized on the zero-input law's trajectory.
struct InitializedLearner {
  explicit InitializedLearner(const LearnerSettings& settings) : learner(p.problem, settings) {
    FunctionPolicy initial = ZeroInputPolicy();
    plant.Run(lq.x0, initial, &nominal);
    learner.Initialize(nominal);
  }
  TwoModeLq lq;
  LqProblem p{lq};
  ModelPlant plant{p.problem};
  Trajectory nominal;
  Learner learner;
};

// A terminal target that moves after the nominal was adopted (as the hopper's I1 is measured
// against each trial's own start): the nominal law run again from the nominal's start costs
// its cost under the moved target, and StartShift must predict that change; from another start
// the shift moves by exactly the nominal's cost change, whatever dx.
TEST(StartCorrection, AMovedReferenceShiftsThePredictedCostOfTheNominalLaw) {
  LearnerSettings settings = LqTestSettings();
  settings.start_correction = true;
  InitializedLearner t(settings);
  const TwoModeLq& lq = t.lq;
  LqProblem& p = t.p;
  ModelPlant& plant = t.plant;
  Learner& learner = t.learner;
  Trajectory measured;
  const double cost0 = learner.nominal_cost();
  const Vector x1 = lq.x0 + Eigen::Vector2d(0.3, -0.4);
  const double shift_x1_still = learner.StartShift(x1);
  EXPECT_EQ(learner.StartShift(lq.x0), 0.0) << "same start, same reference";

  p.cost.r_[1] = Eigen::Vector2d(0.6, -0.3);  // the terminal target moves
  const double moved_nominal_cost = EvaluateCost(p.problem, learner.nominal()).total;
  ASSERT_GT(std::abs(moved_nominal_cost - cost0), 0.05 * cost0) << "the move must matter";
  // The nominal law from the nominal's own start: the measured cost under the moved target.
  plant.Run(lq.x0, learner.ConvergedPolicy(0.0), &measured);
  const double truth = EvaluateCost(p.problem, measured).total - cost0;
  EXPECT_NEAR(learner.StartShift(lq.x0), truth, 1e-6 * std::abs(truth));
  // From x1: the same quadratic value term, plus the nominal's cost change.
  EXPECT_NEAR(learner.StartShift(x1) - shift_x1_still, moved_nominal_cost - cost0,
              1e-9 * std::abs(moved_nominal_cost - cost0));

  // (36) compares a trial from the nominal's start with the nominal's cost under the moved
  // target, not with the cost it was adopted with.
  plant.Run(lq.x0, learner.NextTrial(), &measured);
  const TrialResult r = learner.CompleteTrial(measured);
  EXPECT_NEAR(r.start_shift, moved_nominal_cost - cost0, 1e-9 * std::abs(truth));
  EXPECT_NEAR(r.decrease, r.cost - moved_nominal_cost, 1e-9 * std::abs(truth));
}

// reference_shift alone (start_correction off): the shift is the nominal's cost change under
// the moved target and nothing of the start, so a trial from another start is compared with
// the nominal's moved cost as it is; without either setting the shift stays 0.
TEST(StartCorrection, TheReferenceShiftAloneIsTheNominalsCostChange) {
  for (bool on : {false, true}) {
    LearnerSettings settings = LqTestSettings();
    settings.start_correction = false;
    settings.reference_shift = on;
    InitializedLearner t(settings);
    const TwoModeLq& lq = t.lq;
    LqProblem& p = t.p;
    Learner& learner = t.learner;
    Trajectory measured;
    const double cost0 = learner.nominal_cost();
    const Vector x1 = lq.x0 + Eigen::Vector2d(0.3, -0.4);
    EXPECT_EQ(learner.StartShift(x1), 0.0) << "reference still, on " << on;

    p.cost.r_[1] = Eigen::Vector2d(0.6, -0.3);  // the terminal target moves
    const double change = EvaluateCost(p.problem, learner.nominal()).total - cost0;
    ASSERT_GT(std::abs(change), 0.05 * cost0) << "the move must matter";
    EXPECT_NEAR(learner.StartShift(x1), on ? change : 0.0, 1e-12 * std::abs(change))
        << "on " << on;
    t.plant.Run(x1, learner.NextTrial(), &measured);
    const TrialResult r = learner.CompleteTrial(measured);
    EXPECT_NEAR(r.start_shift, on ? change : 0.0, 1e-12 * std::abs(change)) << "on " << on;
    EXPECT_NEAR(r.decrease, r.cost - (cost0 + (on ? change : 0.0)), 1e-12 * std::abs(change))
        << "on " << on;
  }
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
