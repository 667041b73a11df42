// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/trial_driver.h"

#include <algorithm>
#include <cmath>
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
  if (settings.guard.verify_trials < 0 || settings.guard.verify_trials == 1) {
    throw InvalidArgument("TrialDriverSettings: guard.verify_trials = " +
                          std::to_string(settings.guard.verify_trials) +
                          ", expected 0 (off) or >= 2 (the spread is estimated from the re-runs)");
  }
  if (settings.guard.watch_trials < 0 || settings.guard.watch_trials == 1) {
    throw InvalidArgument("TrialDriverSettings: guard.watch_trials = " +
                          std::to_string(settings.guard.watch_trials) +
                          ", expected 0 (no watch) or >= 2");
  }
  const HarmGuardSettings& g = settings.guard;
  if (!(std::isfinite(g.watch_ratio) && (g.watch_ratio == 0 || g.watch_ratio >= 1))) {
    throw InvalidArgument("TrialDriverSettings: guard.watch_ratio = " +
                          std::to_string(g.watch_ratio) + ", expected 0 (the mean form) or >= 1");
  }
  if (g.watch_ratio > 0 && (g.watch_trials == 0 || g.verify_trials == 0)) {
    throw InvalidArgument("TrialDriverSettings: guard.watch_ratio needs guard.watch_trials >= 2 "
                          "and guard.verify_trials >= 2 (watch_trials = " +
                          std::to_string(g.watch_trials) + ", verify_trials = " +
                          std::to_string(g.verify_trials) +
                          "); to turn the whole guard off, assign guard = HarmGuardSettings{}");
  }
  if (!g.verify_accepted && (g.only_when_worse || g.interleave)) {
    throw InvalidArgument("TrialDriverSettings: guard.verify_accepted = false excludes "
                          "guard.only_when_worse and guard.interleave (no re-runs to decide on)");
  }
  if (settings.guard.only_when_worse && settings.guard.verify_trials == 0) {
    throw InvalidArgument("TrialDriverSettings: guard.only_when_worse needs guard.verify_trials "
                          ">= 2 (verify_trials = 0)");
  }
  if (settings.guard.interleave &&
      (settings.guard.verify_trials == 0 || settings.guard.watch_trials != 0)) {
    throw InvalidArgument("TrialDriverSettings: guard.interleave needs guard.verify_trials >= 2 "
                          "and guard.watch_trials = 0 (verify_trials = " +
                          std::to_string(settings.guard.verify_trials) + ", watch_trials = " +
                          std::to_string(settings.guard.watch_trials) + ")");
  }
  if (!(settings.guard.margin >= 0) || !std::isfinite(settings.guard.margin)) {
    throw InvalidArgument("TrialDriverSettings: guard.margin = " +
                          std::to_string(settings.guard.margin) + ", expected finite and >= 0");
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
    if (cyclic_seed_.size() > 0) learner_->SeedCyclicValue(cyclic_seed_);
  }
  trial_ = 0;
  warmup_trials_ = settings_.warmup_trials;
  frozen_ = false;
  runs_ = 0;
  run_cost_sum_ = 0;
  verify_left_ = 0;
  new_runs_ = initial_runs_ = kept_runs_ = previous_runs_ = other_runs_ = warmup_runs_ = Runs{};
  phase_ = Phase::kNone;
  window_.assign(static_cast<size_t>(settings_.guard.watch_trials), 0.0);
  window_count_ = 0;
  kept_record_.clear();
  challenge_.clear();
  new_learner_sum_ = 0;
  initial_ = kept_ = previous_ = LearnerCheckpoint{};
  pooled_ = PooledSpread{};
  pending_law_ = nullptr;
  reverts_ = 0;
  new_turn_ = true;
  pair_diffs_ = Runs{};
  pooled_diffs_ = PooledSpread{};
  UseFallback();
}

void TrialDriver::SeedCyclicValue(const Matrix& P0) {
  if (P0.size() > 0 && learner_ != nullptr) learner_->SeedCyclicValue(P0);  // throws first
  cyclic_seed_ = P0;
}

void TrialDriver::Runs::Add(double x) {
  // Welford: the mean and the squared deviations from it.
  ++n;
  const double delta = x - (n > 1 ? sum / (n - 1) : x);
  sum += x;
  ss += delta * (x - sum / n);
}

double TrialDriver::JudgedCost(const Trajectory& measured, bool learns) {
  if (!reference_) return EvaluateCost(*problem_, measured).total;
  reference_(measured, false);
  const double cost = EvaluateCost(*problem_, measured).total;
  reference_(measured, learns);  // leaves the reference the learner works with set
  return cost;
}

double TrialDriver::Compared(double judged) const {
  if (!settings_.guard.log_cost || !std::isfinite(judged)) return judged;
  if (!(judged > 0)) {
    throw InvalidArgument("TrialDriver: guard.log_cost needs positive judged costs, trial " +
                          std::to_string(trial_) + " judged " + std::to_string(judged));
  }
  return std::log(judged);
}

bool TrialDriver::WorseThan(const Runs& a, const Runs& b) const {
  if (a.n == 0 || b.n == 0) return false;
  // The spread pooled over every finished law's runs and these two.
  const double spread = pooled_.With(a, &b);
  const double se = spread * std::sqrt(1.0 / a.n + 1.0 / b.n);
  return !(a.mean() <= b.mean() + settings_.guard.margin * se);
}

void TrialDriver::PooledSpread::Add(const Runs& runs) {
  if (runs.n < 2 || !std::isfinite(runs.ss)) return;
  ss += runs.ss;
  df += runs.n - 1;
}

double TrialDriver::PooledSpread::With(const Runs& a, const Runs* b) const {
  double total = ss + a.ss;
  int dof = df + a.n - 1;
  if (b != nullptr) {
    total += b->ss;
    dof += b->n - 1;
  }
  return dof > 0 && std::isfinite(total) ? std::sqrt(total / dof) : 0.0;
}

void TrialDriver::RunLaw(Target t) {
  if (t == Target::kInitial) {
    UseFallback();
  } else {
    UseLearnedLaw(t == Target::kKept ? kept_.law : previous_.law);
  }
}

const LearnerCheckpoint& TrialDriver::Checkpoint(Target t) const {
  return t == Target::kInitial ? initial_ : t == Target::kKept ? kept_ : previous_;
}

TrialDriver::Runs& TrialDriver::RunsOf(Target t) {
  return t == Target::kInitial ? initial_runs_ : t == Target::kKept ? kept_runs_ : previous_runs_;
}

void TrialDriver::Challenge(Target against, bool watch) {
  // The law `against` runs verify_trials times now, in the robot's present conditions, and the
  // law on trial (new_runs_) is compared with those runs.
  target_ = against;
  watch_ = watch;
  phase_ = Phase::kChallenge;
  other_runs_ = Runs{};
  challenge_.clear();
  verify_left_ = settings_.guard.verify_trials;
  RunLaw(against);
}

namespace {
double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
}  // namespace

void TrialDriver::Watch(double judged) {
  // The kept law's trials: a window of their last watch_trials judged costs. Worse than the
  // law it replaced or u^0: that law runs again.
  const HarmGuardSettings& g = settings_.guard;
  kept_record_.push_back(judged);
  window_[static_cast<size_t>(window_count_ % g.watch_trials)] = judged;
  if (++window_count_ < g.watch_trials || !watching_) return;
  Runs recent;
  for (double c : window_) recent.Add(c);
  bool to_initial = false;
  const bool initial = g.watch_initial && initial_runs_.n > 0;  // u^0 a law to go back to
  if (g.watch_ratio > 0) {
    // The median form: against the better of the replaced law's and u^0's records, by a ratio.
    const bool previous = previous_.valid && previous_runs_.n > 0;
    if (!initial && !previous) return;
    to_initial = initial && (!previous || initial_runs_.mean() <= previous_runs_.mean());
    const double best = to_initial ? initial_runs_.mean() : previous_runs_.mean();
    if (!(Median(window_) > g.watch_ratio * best)) return;
  } else {
    const bool suspect = (previous_.valid && WorseThan(recent, previous_runs_)) ||
                         (initial && WorseThan(recent, initial_runs_));
    if (!suspect) return;
    to_initial = initial && (!previous_.valid || initial_runs_.mean() <= previous_runs_.mean());
  }
  new_runs_ = recent;
  window_count_ = 0;
  pending_law_ = learned_;
  Challenge(to_initial ? Target::kInitial : Target::kPrevious, true);
}

TrialOutcome TrialDriver::Verify(const Trajectory& measured) {
  TrialOutcome out;
  out.trial = trial_;
  out.accepted = true;
  out.remeasured = true;
  out.ran_fallback = runs_fallback();
  out.judged_cost = JudgedCost(measured, true);  // then the learner's reference for out.cost
  out.cost = EvaluateCost(*problem_, measured).total;
  out.nominal_cost = learner_->nominal_cost();
  out.status = learner_->status();
  const double judged = std::isfinite(out.judged_cost) ? Compared(out.judged_cost)
                                                       : std::numeric_limits<double>::infinity();
  ++trial_;
  if (settings_.guard.interleave) return Interleaved(judged, out);
  if (phase_ == Phase::kVerify) {
    new_runs_.Add(judged);
    new_learner_sum_ += out.cost;
  } else {
    other_runs_.Add(judged);
    challenge_.push_back(judged);
  }
  if (--verify_left_ > 0) return out;
  if (phase_ == Phase::kVerify) {
    // The accepted law's re-runs are in. Worse than the law it replaced or u^0 as they measured
    // before: that law runs again now (the robot's conditions may have changed since).
    const Target replaced = kept_.valid ? Target::kKept : Target::kInitial;
    const bool suspect = WorseThan(new_runs_, RunsOf(replaced)) ||
                         WorseThan(new_runs_, initial_runs_);
    if (!suspect) {
      KeepNew();
      return out;
    }
    const Target against = replaced == Target::kKept && kept_runs_.mean() < initial_runs_.mean()
                                ? Target::kKept
                                : Target::kInitial;
    if (std::isfinite(new_runs_.mean())) {
      Challenge(against, false);
      return out;
    }
    target_ = against;  // not even finite: abandoned at once
    watch_ = false;
    other_runs_ = RunsOf(against);
  }
  // The other law's fresh runs are in: the law on trial is abandoned when it is worse. The
  // median form: worse than the window and than the kept law's whole record since it was kept
  // (a pushed stretch moves the window, not the record).
  phase_ = Phase::kNone;
  const bool worse = watch_ && settings_.guard.watch_ratio > 0
                         ? !challenge_.empty() && Median(window_) > Median(challenge_) &&
                               Median(kept_record_) > Median(challenge_)
                         : WorseThan(new_runs_, other_runs_);
  Pool(other_runs_);
  RunsOf(target_) = other_runs_;
  if (!worse) {
    if (watch_) {
      Pool(new_runs_);
      kept_runs_ = new_runs_;  // the kept law as it measures now
      UseLearnedLaw(*pending_law_);
      pending_law_ = nullptr;
    } else {
      KeepNew();
    }
    return out;
  }
  Pool(new_runs_);
  Abandon(out);
  return out;
}

void TrialDriver::Abandon(TrialOutcome& out) {
  learner_->Restore(Checkpoint(target_));  // (30) under the learner's reference, still set
  if (target_ == Target::kInitial) {
    kept_ = previous_ = LearnerCheckpoint{};
  } else if (target_ == Target::kPrevious) {
    kept_ = std::move(previous_);
    kept_runs_ = previous_runs_;
    previous_ = LearnerCheckpoint{};
  }
  ++reverts_;
  out.reverted = true;
  pending_law_ = nullptr;
  window_count_ = 0;
  kept_record_.clear();
  UseLearnedLaw(learner_->NextTrial());
}

TrialOutcome& TrialDriver::Interleaved(double judged, TrialOutcome& out) {
  // Runs alternate: the law on trial (new_turn_), then the law it replaced, and so on; each
  // paired difference is a run of the first minus the run of the second that follows it.
  if (new_turn_) {
    new_runs_.Add(judged);
    new_learner_sum_ += out.cost;
    pair_new_ = judged;
  } else {
    other_runs_.Add(judged);
    pair_diffs_.Add(pair_new_ - judged);
  }
  const bool fell = new_turn_ && !std::isfinite(judged);  // the law on trial is out at once
  if (--verify_left_ > 0 && !fell) {
    new_turn_ = !new_turn_;
    if (new_turn_) {
      UseLearnedLaw(learner_->nominal_law());
    } else {
      RunLaw(target_);
    }
    return out;
  }
  phase_ = Phase::kNone;
  new_turn_ = true;
  bool worse = fell;
  if (!fell) {
    // Mean difference against margin standard errors of it, the spread of the differences
    // pooled over this comparison and the run's earlier ones.
    const Runs& d = pair_diffs_;
    const double spread = pooled_diffs_.With(d);
    worse = !(d.mean() <= settings_.guard.margin * spread / std::sqrt(d.n));
    pooled_diffs_.Add(d);
  }
  if (other_runs_.n > 0) RunsOf(target_) = other_runs_;
  pair_diffs_ = Runs{};
  other_runs_ = Runs{};
  if (worse) {
    Abandon(out);
  } else {
    KeepNew();
  }
  return out;
}

bool TrialDriver::KeepIfReportAgrees(double judged_cost, double learner_cost) {
  // only_when_worse: the accepted trial's own judged cost, no higher than the replaced law's
  // and u^0's means, keeps the law on that one run (true); else the re-runs follow (false).
  const HarmGuardSettings& g = settings_.guard;
  if ((!g.only_when_worse && g.verify_accepted) || !std::isfinite(judged_cost)) return false;
  const double judged = Compared(judged_cost);
  const Runs& replaced = RunsOf(kept_.valid ? Target::kKept : Target::kInitial);
  if (g.verify_accepted && ((replaced.n > 0 && judged > replaced.mean()) ||
                            (initial_runs_.n > 0 && judged > initial_runs_.mean()))) {
    return false;
  }
  new_runs_ = Runs{};
  new_runs_.Add(judged);
  new_learner_sum_ = learner_cost;
  pending_law_ = learned_;
  KeepNew();
  return true;
}

void TrialDriver::KeepNew() {
  // Kept: its cost is the mean of the re-runs, free of the selection that accepted it; the law
  // it replaced is remembered.
  phase_ = Phase::kNone;
  Pool(new_runs_);
  if (settings_.guard.debias) learner_->SetNominalCost(new_learner_sum_ / new_runs_.n);
  previous_ = std::move(kept_);
  previous_runs_ = kept_runs_;
  kept_ = learner_->Save();
  kept_runs_ = new_runs_;
  window_count_ = 0;
  kept_record_.clear();
  UseLearnedLaw(*pending_law_);
  pending_law_ = nullptr;
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
  return learner_ != nullptr && !frozen_ && trial_ + 1 >= warmup_trials_;
}

void TrialDriver::DelayInitialize() {
  if (learner_ == nullptr || learner_->initialized()) return;
  warmup_trials_ = std::max(warmup_trials_, trial_ + 2);
}

TrialOutcome TrialDriver::CompleteTrial(const Trajectory& measured) {
  if (phase_ != Phase::kNone && !frozen_) return Verify(measured);
  TrialOutcome out;
  out.trial = trial_;
  out.ran_fallback = runs_fallback();
  const bool learns = CompletionLearns();
  const bool guard = settings_.guard.verify_trials > 0 && learner_ != nullptr && !frozen_;
  if (guard) {
    out.judged_cost = JudgedCost(measured, learns);  // leaves the learner's reference set
  } else if (reference_) {
    reference_(measured, learns);
  }
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
    // A warm-up trial ran u^0: a sample of its cost for the guard's spread.
    if (guard && !learner_->initialized()) warmup_runs_.Add(Compared(out.judged_cost));
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
    if (guard) {
      // u^0's record starts here: the warm-up hops before it (a transient of u^0, e.g. after a
      // re-solve) count towards the spread, not towards the cost a kept law is watched against.
      warmup_runs_.Add(Compared(out.judged_cost));
      Pool(warmup_runs_);
      initial_runs_.Add(Compared(out.judged_cost));  // empty until now (warm-ups went above)
      initial_ = learner_->Save();
    }
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
    if (replay && learner_->nominal_is_initial()) UseFallback();
    if (guard && r.accepted && !KeepIfReportAgrees(out.judged_cost, out.cost)) {
      // The harm guard: the accepted law runs again before it is kept; the learner's next
      // trial waits.
      pending_law_ = learned_;
      phase_ = Phase::kVerify;
      verify_left_ = settings_.guard.verify_trials;
      if (settings_.guard.interleave) {
        verify_left_ *= 2;  // as many runs of the replaced law, alternating
        target_ = kept_.valid ? Target::kKept : Target::kInitial;
        new_turn_ = true;
        pair_diffs_ = Runs{};
        other_runs_ = Runs{};
      }
      new_runs_ = Runs{};
      new_learner_sum_ = 0;
      UseLearnedLaw(learner_->nominal_law());
    } else if (guard && settings_.guard.watch_trials > 0 && kept_.valid &&
               !learner_->nominal_is_initial() && learned_) {
      Watch(std::isfinite(out.judged_cost) ? Compared(out.judged_cost)
                                           : std::numeric_limits<double>::infinity());
    }
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
