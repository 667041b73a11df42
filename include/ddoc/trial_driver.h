// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The trial driver: runs Algorithm 1, mRL or OC-FB over trials on a plant, episodic (every trial
// from the same start) or online (each trial starts where the last one ended).
#ifndef DDOC_TRIAL_DRIVER_H_
#define DDOC_TRIAL_DRIVER_H_

#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "ddoc/learner.h"
#include "ddoc/plant.h"
#include "ddoc/policy.h"
#include "ddoc/problem.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// The three methods of Section V; they differ only in where the trajectories of the learner
/// come from.
enum class Method {
  kAlg1,  ///< Algorithm 1: direction (30) and line search (36) from the measured trial
  kMrl,   ///< mRL: direction from the prediction plant's re-run of the law from the measured
          ///< start; line search on the measured cost
  kOcfb,  ///< OC-FB: the fallback law u^0 (a model-based optimum) every trial, no learning
};

/// The harm guard of TrialDriver (docs/engine.md, "Never keeping harm"): each accepted law is
/// re-run before it is kept, and one that measures worse than the law it replaced, or than u^0,
/// is abandoned for the better of the two. A default-constructed HarmGuardSettings is the guard
/// off; the hopper's default turns it on (HopperTrialSettings).
struct HarmGuardSettings {
  /// Re-runs of each accepted law; their judged costs (the reported cost, TrialDriver::
  /// CostReference with for_learner = false) are compared with the kept law's and u^0's. 0 = off
  /// (default), else >= 2 (the spread is estimated from them).
  int verify_trials = 0;
  /// A law is abandoned when its mean judged cost exceeds the other's by more than `margin`
  /// standard errors of the difference (spread pooled over every law's re-runs), >= 0.
  /// Default 2.
  double margin = 2.0;
  /// The watch: the last this many judged costs of a kept law's learning trials are compared
  /// with the law it replaced and u^0; 0 = no watch (default), else >= 2. The hopper's default
  /// watches 8 in the median form (watch_ratio; HopperTrialSettings).
  int watch_trials = 0;
  /// true: a kept law's I^i becomes the mean learner cost of its re-runs instead of the accepted
  /// trial's own cost, which its selection biased low. Default false (on the hopper's mass map
  /// it learns more and survives less: docs/experiments.md, "The harm guard").
  bool debias = false;
  /// true: the re-runs alternate with runs of the law the accepted one replaced (the kept law,
  /// u^0 before any): new, old, new, old, ..., verify_trials of each, so both start from states
  /// the other left; the new law is abandoned when the mean of the paired differences of judged
  /// cost exceeds `margin` standard errors of it (spread pooled over the run's comparisons).
  /// No watch. Default false.
  bool interleave = false;
  /// true: the comparisons take the logarithm of each judged cost (a positive cost whose
  /// run-to-run spread grows with its size; TrialOutcome::judged_cost stays the cost itself).
  /// A judged cost <= 0 then throws InvalidArgument. Default false.
  bool log_cost = false;
  /// true: an accepted law re-runs only when its trial's judged cost exceeds the mean judged
  /// cost of the law it replaced or of u^0 (the reported cost contradicts the learner's
  /// acceptance); otherwise it is kept on that one run and learning goes on. Default false.
  bool only_when_worse = false;
  /// false: an accepted law is kept on its own trial, without re-runs (the watch is then the
  /// guard; needs verify_trials >= 2 for the watch's challenges, excludes only_when_worse and
  /// interleave). Default true.
  bool verify_accepted = true;
  /// 0 (default): the watch compares the window's mean with `margin` standard errors. >= 1:
  /// the window's median judged cost above watch_ratio x the mean judged cost of the law to go
  /// back to makes that law run verify_trials times, and the kept law is abandoned when their
  /// median is below the window's and below that of every judged cost of the kept law since it
  /// was kept (a few pushed hops hardly move a median, a pushed stretch moves the window and not
  /// the record). Needs watch_trials.
  double watch_ratio = 0.0;
  /// false: the watch goes back only to the law the kept one replaced, never to u^0 (whose few
  /// fresh runs look good on a robot where it has no stable hop). Default true. A user can also
  /// suspend the watch while the run goes on: TrialDriver::SetWatching.
  bool watch_initial = true;
};

/// Settings of TrialDriver.
struct TrialDriverSettings {
  Method method = Method::kAlg1;  ///< which of the three methods; default Algorithm 1
  /// Trials run with the fallback law u^0 before learning starts, >= 1; the last of them is
  /// Algorithm 1's "Initialize" trial (x^0, I^0). Default 1 = Algorithm 1 as printed.
  int warmup_trials = 1;
  /// Runs of each law the learner judges (u^0 of "Initialize" and every trial), >= 1: the
  /// trial's cost is the mean of their measured costs, its trajectory the last run's (docs/
  /// engine.md, "Trials of several runs"). Warm-up runs before "Initialize" count once. Default 1.
  int runs_per_trial = 1;
  LearnerSettings learner;  ///< Algorithm 1 (unused by kOcfb); default LearnerSettings{}
  HarmGuardSettings guard;  ///< re-runs of accepted laws and going back; default off
};

/// What the driver made of one completed trial.
struct TrialOutcome {
  int trial = 0;              ///< 0-based index of the trial
  bool ran_fallback = false;  ///< the trial ran the fallback law u^0
  bool learned = false;       ///< the learner saw the trial (Initialize or CompleteTrial)
  /// (36) held. True for trials the line search does not judge: warm-up, "Initialize", OC-FB
  /// and frozen trials.
  bool accepted = false;
  /// Measured cost: the learner's I of the trial when it learned, else EvaluateCost (inf for a
  /// trial that could not be measured).
  double cost = 0;
  LearnerStatus status = LearnerStatus::kRunning;  ///< the learner's status after the trial
  double start_shift = 0;  ///< TrialResult::start_shift (0 for trials the learner did not judge)
  bool restarted = false;  ///< TrialResult::restarted: the line search restarted after it
  bool remeasured = false; ///< TrialResult::remeasured: it re-ran the nominal's law
  /// TrialResult::nominal_cost, the I^i the trial was compared with (the Initialize trial: its
  /// own I^0); NaN for trials the learner did not see.
  double nominal_cost = std::numeric_limits<double>::quiet_NaN();
  /// TrialResult::predicted, dI_pred(alpha) of the trial (0 for the Initialize trial); NaN for
  /// trials the learner did not see.
  double predicted = std::numeric_limits<double>::quiet_NaN();
  /// TrialResult::optimality, the nominal's first-order optimality measure after the trial
  /// (ComputeOptimality); NaN for trials the learner did not see.
  double optimality = std::numeric_limits<double>::quiet_NaN();
  /// The harm guard's judged cost of this trial: the reported cost (CostReference with
  /// for_learner = false); NaN when the guard is off.
  double judged_cost = std::numeric_limits<double>::quiet_NaN();
  /// The guard abandoned the law after this trial (a re-run showed it worse than the kept law
  /// or u^0) and the learner went back to the better one.
  bool reverted = false;
  /// runs_per_trial > 1: this run is not the trial's last; the law runs again and the learner
  /// has not seen the run yet (`cost` is this run's).
  bool repeats = false;
};

/// Runs the trials of one of the three methods (Section V) with one engine, whatever the plant.
///
/// It owns the Learner (and with it the step-size state alpha), the warm-up trials, the
/// fallback law u^0 and freezing. The law it hands out for the next trial is:
///   - u^0 (the `fallback` given at construction) for the warm-up trials, for every OC-FB trial,
///     and after the learner terminated (alpha < alpha_min) before any trial passed (36):
///     u^0 is the law that produced x^0, i.e. Algorithm 1's "control law of the previous
///     accepted iteration" for i = 0 (Learner::NextTrial would replay x^0's inputs instead);
///   - otherwise Learner::NextTrial(): (31) and the law (33)-(34) around the nominal.
/// After Freeze() every trial runs the law of the trial that ran when Freeze() was called.
///
/// Trials follow one another on a plant that is not reset (online learning: each trial starts
/// where the last ended; the feedback of (34) absorbs the start deviation) or over resets
/// (episodic). What is plant-specific is given by the caller: mRL's prediction plant, and
/// `reference`, called before any cost of a trial is evaluated (for costs whose reference
/// depends on the trial, e.g. the hopper's I1 measured against the trial's own start).
///
/// One object, one thread: CompleteTrial (the offline part: (36), (30), (31)) may run on a
/// worker thread while the caller steps another policy; the caller must not step law() or the
/// fallback meanwhile (CompleteTrial re-loads the learner's laws and, for mRL, runs u^0 on the
/// prediction plant).
class TrialDriver {
 public:
  /// Called with the trial before its cost is evaluated; for_learner is true when the cost
  /// goes to the learner ((36), (30)), false when it is only reported.
  using CostReference = std::function<void(const Trajectory& trial, bool for_learner)>;
  /// The start state of the next online trial from the measured trial.
  using NextStart = std::function<Vector(const Trajectory& trial)>;

  /// Validates the settings (InvalidArgument naming the field: warmup_trials < 1, kMrl without
  /// a prediction plant, the learner's settings) and starts at trial 0 with u^0. `problem`,
  /// `fallback` and `prediction` must outlive the driver.
  TrialDriver(const Problem& problem, const TrialDriverSettings& settings, Policy& fallback,
              Plant* prediction = nullptr, CostReference reference = nullptr);

  /// Restarts from trial 0 with u^0 and a fresh learner; unfreezes. Allocates.
  void Reset();
  /// The learner's first pass (and every fresh learner's after Reset) starts its cyclic value
  /// from `P0` (Learner::SeedCyclicValue): u^0's, from the model solve that produced it; an
  /// empty matrix: fresh learners start from 0. Throws InvalidArgument on a wrong size or a
  /// non-finite entry (checked when there is a learner).
  void SeedCyclicValue(const Matrix& P0);

  /// The law of the current trial.
  Policy& law() { return *law_; }
  /// The law of the current trial when it is one the learner made, else null (u^0).
  OnlineController* learned_law() { return learned_; }
  bool runs_fallback() const { return learned_ == nullptr; }
  /// 0-based index of the current trial.
  int trial() const { return trial_; }
  /// True when completing the current trial runs the learner (and so changes law()): not
  /// OC-FB, not frozen, the warm-up is over or ends with this trial.
  bool CompletionLearns() const;

  /// Ends the current trial with its measurement: the offline part for the next trial (cost,
  /// (36) and backtracking, (30) on an accepted trial, (31) and the next law). Allocates.
  TrialOutcome CompleteTrial(const Trajectory& measured);

  /// True once the learner has its "Initialize" trial (false for OC-FB).
  bool initialized() const { return learner_ != nullptr && learner_->initialized(); }
  /// Before "Initialize": one more warm-up trial of u^0 (the current trial does not initialize);
  /// no effect after it or for OC-FB. Reset() returns to settings().warmup_trials.
  void DelayInitialize();

  /// From now on every trial runs the current law; CompleteTrial only reports. Reset() undoes it.
  void Freeze() { frozen_ = true; }
  bool frozen() const { return frozen_; }

  /// false: the harm guard's watch (HarmGuardSettings::watch_trials) still records the kept
  /// law's judged costs but goes back to no law until set true again, for a user who learns
  /// during the run that no earlier law may hold the plant (the hopper: a robot heavier than its
  /// model, docs/hopper.md). Reset() leaves it. Default true.
  void SetWatching(bool watching) { watching_ = watching; }
  bool watching() const { return watching_; }

  /// One trial on a plant from x0: runs law() (the plant calls BeginTrial), then CompleteTrial.
  /// The measured trajectory is returned in *measured.
  TrialOutcome RunTrial(Plant& plant, const ConstVectorRef& x0, Trajectory* measured);
  /// `trials` trials on a plant: every one from x0 (episodic, next_start empty), or trial 0
  /// from x0 and trial i+1 from next_start(trial i) (online).
  std::vector<TrialOutcome> Run(Plant& plant, const ConstVectorRef& x0, int trials,
                                const NextStart& next_start = nullptr);

  /// Re-runs of the last accepted law still to come (harm guard); 0 when not verifying.
  int verifying() const { return verify_left_; }
  /// Laws the harm guard abandoned so far.
  int reverts() const { return reverts_; }

  /// The learner (null for OC-FB).
  const Learner* learner() const { return learner_.get(); }
  /// The learner's Learner::integration_steps() (0 for OC-FB): the backward passes' work.
  long integration_steps() const { return learner_ ? learner_->integration_steps() : 0; }
  const TrialDriverSettings& settings() const { return settings_; }

 private:
  void UseFallback();
  void UseLearnedLaw(OnlineController& law);

  const Problem* problem_;
  TrialDriverSettings settings_;
  Policy* fallback_;
  Plant* prediction_;
  CostReference reference_;
  std::unique_ptr<Learner> learner_;  // null for OC-FB
  Matrix cyclic_seed_;                // SeedCyclicValue's P0 (empty: none)
  Policy* law_ = nullptr;             // the law of the current trial
  OnlineController* learned_ = nullptr;  // law_ when the learner made it, else null
  int trial_ = 0;
  int warmup_trials_ = 1;  // settings_.warmup_trials plus DelayInitialize's
  bool frozen_ = false;
  bool watching_ = true;  // SetWatching
  // Harm guard: judged costs of a law's runs (count, sum, sum of squared deviations).
  struct Runs {
    int n = 0;
    double sum = 0, ss = 0;
    double mean() const { return sum / n; }
    void Add(double x);
  };
  // Squared deviations pooled over finished runs, and their degrees of freedom.
  struct PooledSpread {
    double ss = 0;
    int df = 0;
    void Add(const Runs& runs);  // runs of fewer than 2 or a non-finite ss add nothing
    // The spread s of the pooled runs with a's (and b's) added (0 without degrees of freedom).
    double With(const Runs& a, const Runs* b = nullptr) const;
  };
  enum class Phase { kNone, kVerify, kChallenge };  // what the guard's runs are
  enum class Target { kInitial, kKept, kPrevious };  // a law the guard may go back to
  // The guard's part of CompleteTrial: a re-run of the accepted law or of the law it is
  // compared with, and the decision after the last.
  TrialOutcome Verify(const Trajectory& measured);
  // The kept law's learning trials: a window of judged costs, and a challenge when it is worse.
  void Watch(double judged);
  // Runs `against` verify_trials times to compare the law on trial (new_runs_) with it.
  void Challenge(Target against, bool watch);
  void KeepNew();  // the accepted law passed: it becomes the kept law
  // HarmGuardSettings::only_when_worse: keeps the accepted law at once and returns true when
  // its trial's judged cost is no higher than the replaced law's and u^0's; with
  // verify_accepted = false whenever that cost is finite.
  bool KeepIfReportAgrees(double judged_cost, double learner_cost);
  double JudgedCost(const Trajectory& measured, bool learns);
  double Compared(double judged) const;  // what the comparisons use: judged, or its log
  // a's mean judged cost exceeds b's by more than margin standard errors.
  bool WorseThan(const Runs& a, const Runs& b) const;
  void Pool(const Runs& runs) { pooled_.Add(runs); }  // a finished law's runs
  void RunLaw(Target t);  // the law of target t runs next (u^0: the fallback)
  // interleave: one run of the alternation, and the decision after the last.
  TrialOutcome& Interleaved(double judged, TrialOutcome& out);
  void Abandon(TrialOutcome& out);  // back to target_'s checkpoint, the learner goes on
  const LearnerCheckpoint& Checkpoint(Target t) const;
  Runs& RunsOf(Target t);
  Phase phase_ = Phase::kNone;
  Target target_ = Target::kInitial;  // the law of a challenge
  bool watch_ = false;         // the challenge came from Watch (else from a verification)
  int verify_left_ = 0;        // runs of the phase still to come
  Runs new_runs_;              // judged costs of the law on trial
  double new_learner_sum_ = 0; // its re-runs' learner costs (I^i of a kept law)
  Runs other_runs_;            // the challenge's fresh runs
  LearnerCheckpoint initial_, kept_, previous_;  // u^0's nominal, the kept one, the one it replaced
  Runs initial_runs_, kept_runs_, previous_runs_;
  // u^0's runs before "Initialize" (warm-up, settling after a re-solve): pooled into the spread
  // at "Initialize", but not u^0's record, which starts with the Initialize hop.
  Runs warmup_runs_;
  std::vector<double> window_;  // Watch: the kept law's last judged costs (a ring)
  int window_count_ = 0;
  std::vector<double> kept_record_;  // Watch: every judged cost of the kept law since it was kept
  std::vector<double> challenge_;  // watch_ratio: the challenge's judged costs (the window
                                   // stays as it was until the decision)
  PooledSpread pooled_;        // within-law deviations of every finished law's runs
  OnlineController* pending_law_ = nullptr;  // the learner's next trial, waiting for the guard
  int reverts_ = 0;
  bool new_turn_ = true;            // interleave: the next run is the law on trial's
  double pair_new_ = 0;             // interleave: the law on trial's last judged cost
  Runs pair_diffs_;                 // interleave: this comparison's paired differences
  PooledSpread pooled_diffs_;       // interleave: every finished comparison's differences
  int runs_ = 0;              // runs of the current law so far (runs_per_trial)
  double run_cost_sum_ = 0;   // their measured costs
};

}  // namespace ddoc

#endif  // DDOC_TRIAL_DRIVER_H_
