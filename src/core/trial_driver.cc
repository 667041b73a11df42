// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/trial_driver.h"

#include <limits>
#include <optional>
#include <string>

#include "ddoc/cost.h"

namespace ddoc {

TrialDriver::TrialDriver(const Problem& problem, const TrialDriverSettings& settings,
                         Policy& fallback, Plant* prediction, CostReference reference)
    : problem_(&problem),
      settings_(settings),
      fallback_(&fallback),
      prediction_(prediction),
      reference_(std::move(reference)) {
  problem.Validate();
  if (settings.warmup_trials < 1) {
    throw InvalidArgument("TrialDriverSettings: warmup_trials = " +
                          std::to_string(settings.warmup_trials) + ", expected >= 1");
  }
  if (settings.runs_per_trial < 1) {
    throw InvalidArgument("TrialDriverSettings: runs_per_trial = " +
                          std::to_string(settings.runs_per_trial) + ", expected >= 1");
  }
  if (settings.method == Method::kMrl && prediction == nullptr) {
    throw InvalidArgument("TrialDriver: method kMrl needs a prediction plant (the model)");
  }
  Reset();
}

void TrialDriver::Reset() {
  learner_.reset();
  if (settings_.method != Method::kOcfb) {
    learner_ = std::make_unique<Learner>(*problem_, settings_.learner);
    // blend_feedback before the first accepted trial: u^0's own feedback, when it has one.
    learner_->SetInitialLaw(dynamic_cast<const OnlineController*>(fallback_));
  }
  trial_ = 0;
  frozen_ = false;
  runs_ = 0;
  run_cost_sum_ = 0;
  UseFallback();
}

void TrialDriver::UseFallback() {
  law_ = fallback_;
  learned_ = nullptr;
}

void TrialDriver::UseLearnedLaw(OnlineController& law) {
  law_ = &law;
  learned_ = &law;
}

bool TrialDriver::CompletionLearns() const {
  return learner_ != nullptr && !frozen_ && trial_ + 1 >= settings_.warmup_trials;
}

TrialOutcome TrialDriver::CompleteTrial(const Trajectory& measured) {
  TrialOutcome out;
  out.trial = trial_;
  out.ran_fallback = runs_fallback();
  const bool learns = CompletionLearns();
  if (reference_) reference_(measured, learns);
  // runs_per_trial: the runs of a law the learner judges are averaged; all but the last only
  // report, and the law runs again.
  std::optional<double> mean_cost;
  if (learns && settings_.runs_per_trial > 1) {
    const double cost = EvaluateCost(*problem_, measured).total;
    run_cost_sum_ += cost;
    if (++runs_ < settings_.runs_per_trial) {
      out.repeats = true;
      out.cost = cost;
      out.status = learner_->status();
      ++trial_;
      return out;
    }
    mean_cost = run_cost_sum_ / runs_;
    runs_ = 0;
    run_cost_sum_ = 0;
  }
  if (!learns) {
    // Warm-up, OC-FB or frozen: report the measured cost; the law stays (u^0 unless frozen).
    out.accepted = true;
    out.cost = EvaluateCost(*problem_, measured).total;
    if (learner_) out.status = learner_->status();
  } else if (!learner_->initialized()) {
    // This trial ran u^0, T^0: Algorithm 1's "Initialize" (x^0, I^0, then (30)).
    if (settings_.method == Method::kMrl) {
      Trajectory predicted;
      prediction_->Run(measured.x0, *fallback_, &predicted);
      learner_->Initialize(measured, &predicted, mean_cost);
    } else {
      learner_->Initialize(measured, nullptr, mean_cost);
    }
    out.learned = true;
    out.accepted = true;
    out.cost = learner_->nominal_cost();
    out.status = learner_->status();
    out.nominal_cost = learner_->nominal_cost();
    out.predicted = 0;
    out.optimality = learner_->optimality().total;
    UseLearnedLaw(learner_->NextTrial());
  } else {
    const TrialResult r = learner_->CompleteTrial(
        measured, settings_.method == Method::kMrl ? prediction_ : nullptr, mean_cost);
    out.learned = true;
    out.accepted = r.accepted;
    out.cost = r.cost;
    out.status = r.status;
    out.start_shift = r.start_shift;
    out.restarted = r.restarted;
    out.remeasured = r.remeasured;
    out.nominal_cost = r.nominal_cost;
    out.predicted = r.predicted;
    out.optimality = r.optimality;
    UseLearnedLaw(learner_->NextTrial());
    // Terminated, or re-measuring the nominal, before any trial passed (36): the law of
    // iteration 0 is u^0, which produced the nominal, not a replay of the nominal's inputs
    // (Learner::NextTrial).
    const bool replay =
        learner_->status() == LearnerStatus::kLineSearchFailed || learner_->remeasuring();
    if (replay && learner_->iteration() == 0) UseFallback();
  }
  if (!learns && !frozen_) UseFallback();
  ++trial_;
  return out;
}

TrialOutcome TrialDriver::RunTrial(Plant& plant, const ConstVectorRef& x0, Trajectory* measured) {
  plant.Run(x0, law(), measured);
  return CompleteTrial(*measured);
}

std::vector<TrialOutcome> TrialDriver::Run(Plant& plant, const ConstVectorRef& x0, int trials,
                                           const NextStart& next_start) {
  if (trials < 0) {
    throw InvalidArgument("TrialDriver::Run: trials = " + std::to_string(trials) +
                          ", expected >= 0");
  }
  std::vector<TrialOutcome> outcomes;
  outcomes.reserve(static_cast<size_t>(trials));
  Vector start = x0;
  Trajectory measured;
  for (int i = 0; i < trials; ++i) {
    outcomes.push_back(RunTrial(plant, start, &measured));
    if (next_start) start = next_start(measured);
  }
  return outcomes;
}

}  // namespace ddoc
