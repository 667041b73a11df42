// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Algorithm 1: the iteration (backward pass, switching-time update, online control, measured
// cost, sufficient decrease (36), backtracking, convergence), batch or one trial at a time.
#ifndef DDOC_LEARNER_H_
#define DDOC_LEARNER_H_

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ddoc/backward_pass.h"
#include "ddoc/cost.h"
#include "ddoc/online_controller.h"
#include "ddoc/plant.h"
#include "ddoc/problem.h"
#include "ddoc/switching_time_update.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// How a trial is accepted (Algorithm 1's line search).
enum class Acceptance {
  /// (36) as printed: I^{i+1} - I^i <= -c (int |du|^2 dtau + |dT|^2), measured du and dT.
  kSufficientDecrease,
  /// Armijo on the LQ model's prediction (the default): I^{i+1} - I^i <= c * dI_pred(alpha),
  /// dI_pred(alpha) = alpha a + alpha^2 / 2 b + (1/2 dT^T P22 dT + p2^T dT) < 0 from the backward
  /// pass (BackwardPass::predicted_linear/quadratic, SwitchingTimeStep::model_change). Scale-free:
  /// it compares the measured change with what the step was expected to achieve.
  kPredictedDecrease,
};

/// How alpha changes after an accepted trial.
enum class AlphaAfterAccept {
  kReset,  ///< alpha <- alpha_initial: Algorithm 1 as printed
  kGrow,   ///< alpha <- min(alpha_initial, alpha / gamma)
  /// From the ratio rho of the measured to the predicted change (a trust-region rule): rho > 0.75
  /// doubles alpha (capped at alpha_initial), rho < 0.25 halves it, else it stays. With
  /// kSufficientDecrease (no prediction) it is kReset.
  kRatio,
};

/// Settings of Learner (Algorithm 1). `LearnerSettings{}` is the recommended default (box-aware
/// Riccati backward pass with exact time curvature, alpha on the feed-forward, Armijo on the
/// predicted decrease with interpolated backtracking, Levenberg-Marquardt regularization that
/// vanishes at convergence); `LearnerSettings::Paper()` is Algorithm 1 as printed.
/// docs/engine.md derives both.
struct LearnerSettings {
  Acceptance acceptance = Acceptance::kPredictedDecrease;  ///< default kPredictedDecrease
  /// c of (36) (kSufficientDecrease) or the Armijo fraction of the predicted decrease
  /// (kPredictedDecrease), > 0. Default 1e-4.
  double c = 1e-4;
  /// Backtracking: alpha <- gamma alpha (interpolate_backtracking = false), or the upper cap of
  /// the interpolated step. In (0, 1), default 0.5.
  double gamma = 0.5;
  /// After a rejected trial, alpha <- the minimizer of the quadratic through the measured change
  /// and the predicted slope, clamped to [0.1 alpha, gamma alpha] (true, default); false: gamma
  /// alpha (the paper).
  bool interpolate_backtracking = true;
  double alpha_initial = 1.0;   ///< alpha at the start, in (0, 1]
  /// alpha after an accepted trial (AlphaAfterAccept). Default kRatio.
  AlphaAfterAccept alpha_after_accept = AlphaAfterAccept::kRatio;
  double alpha_min = 1e-6;      ///< line search fails (terminated) when alpha drops below
  /// Convergence (default preset): the full step's predicted gain (the Newton decrement,
  /// -dI_pred(1)) at most convergence_tolerance |I| of the current cost, plus the rounding of
  /// the gain's terms (64 eps their magnitude); never relative to the start. Default 1e-9.
  double convergence_tolerance = 1e-9;
  /// Algorithm 1's convergence test instead (the paper preset): int |du|^2 dtau + |dT|^2 <=
  /// epsilon for the last delta_i accepted iterations. Default off.
  bool step_convergence = false;
  double epsilon = 1e-8;        ///< threshold of the step test
  int delta_i = 2;              ///< Delta i of the step test
  /// The guard of the step test (step_convergence): no convergence while the first-order
  /// optimality (ComputeOptimality: the projected gradient w.r.t. u(.) and T) is above this
  /// fraction of its value at the initial nominal. Default 1e-3. (The default preset's
  /// Newton-decrement test is the projected gradient in the model's metric and needs none.)
  double optimality_tolerance = 1e-3;
  /// Floor of the Levenberg-Marquardt regularization mu of H = L_uu + mu I (units of
  /// L_uu = D l_uu): mu starts here, grows 10x when the backward pass fails (not positive
  /// definite, non-finite), shrinks 10x after each accepted trial, never below the floor.
  /// Default 0 (the converged gain is the exact one).
  double regularization_min = 0.0;
  /// Times in a row a line search that would terminate first raises mu to max(10 mu, L_uu
  /// scale) and searches again (docs/engine.md, "A failed line search"). Default 2, Paper() 0.
  int failure_raises = 2;
  /// kRatio: floor of sigma, the scale of the model's curvature (the step is alpha / sigma),
  /// halved when the plant beats the prediction by half (docs/engine.md, "A model that is too
  /// steep"). In (0, 1], 1 = off. Default 1/16.
  double curvature_scale_min = 1.0 / 16;
  /// Compare a trial with the nominal as if both had started from the trial's start: (36) and
  /// the Armijo test use I^i + dI_start, dI_start = p_x(0)^T dx0 + 1/2 dx0^T P_xx(0) dx0 (the
  /// value of the pass, dx0 = trial x0 - nominal x0) plus the nominal's cost change under the
  /// trial's cost reference (docs/engine.md, "Trials from other starts"); with cyclic_value > 0
  /// P(0) also values the following cycles. Default true.
  bool start_correction = true;
  /// Only the second term of start_correction: (36) and the Armijo test use I^i plus the
  /// nominal's cost change under the cost's current reference since the nominal was adopted
  /// (for a reference that moves between trials, e.g. a filtered estimate of the plant's own
  /// state; docs/engine.md, "Trials from other starts"). Implied by start_correction. Default
  /// false.
  bool reference_shift = false;
  /// Online learning: when alpha < alpha_min the line search restarts (alpha <- alpha_initial,
  /// the same nominal and cost) instead of terminating; batch Solve still terminates. Default
  /// false.
  bool restart_on_failure = false;
  /// alpha after a restart of the line search, in [0, 1]; 0 (default) = alpha_initial.
  double restart_alpha = 0.0;
  /// restart_on_failure: before the line search restarts, one trial re-runs the law that
  /// produced the nominal, and I^i becomes the mean of such re-measurements (the accepted
  /// trial's own cost, biased low by its selection, is dropped): docs/engine.md, "A nominal
  /// cost that is measured again". Default false.
  bool remeasure_nominal = false;
  /// remeasure_nominal: (36) asks a trial to beat I^i by noise_margin x sigma, sigma the
  /// run-to-run spread of the nominal's cost estimated from the re-measurements (0 until the
  /// first one). docs/engine.md, "A nominal cost that is measured again". Default 0 (off).
  double noise_margin = 0.0;
  /// A trial's state feedback moves from the nominal law's (the law that produced the nominal:
  /// the accepted trial's, or SetInitialLaw's before any) at alpha = 0 to the pass's at
  /// alpha >= alpha_initial, w = min(1, alpha / alpha_initial) of
  /// OnlineController::BlendStateFeedback; the feed-forward and dT are (33)-(34)'s. Default
  /// false (the pass's gains, the paper). docs/engine.md, "The trial's feedback".
  bool blend_feedback = false;
  /// With blend_feedback: the trial's feed-forward also moves to the nominal law's own command,
  /// by (1 - w) of its difference from the nominal's measured input, so that at alpha = 0 a
  /// trial is pi^i from any start with pi^i's clamping at the input bounds (docs/engine.md,
  /// "The trial's feedback"). Default false.
  bool blend_feedforward = false;
  /// A trial whose predicted decrease is below this fraction of |I^i| is not accepted, whatever
  /// it measured ((36) cannot tell such a step from the noise of the plant); >= 0, default 0.
  double min_predicted_decrease = 0.0;
  int max_trials = 500;         ///< batch Solve: maximum number of trials (plant runs)
  /// Preallocation: most samples of one trajectory (all modes). Solve raises it, before the
  /// first trial, to 1.25x the initial trial's samples + 8 K when that trial has more (e.g. 12 s
  /// at dt = 5e-4: 24012); the incremental API (Initialize) names it in its error. Default 20000.
  int max_samples = 20000;
  BackwardPassSettings backward;         ///< (30)
  SwitchingTimeSettings switching;       ///< (31)
  OnlineControllerSettings controller;   ///< (33)-(34)

  /// The `paper` preset: Algorithm 1 as printed (Lyapunov-type (30) with the previous control
  /// variation driving p, alpha on all of (31) and (33), (36) with gamma backtracking, the
  /// convergence test), with only the L_z erratum of (30) fixed. What the reproduction runs.
  static LearnerSettings Paper();
};

/// The named presets of LearnerSettings.
enum class Preset {
  kDefault,  ///< LearnerSettings{}
  kPaper,    ///< LearnerSettings::Paper()
};
/// The settings of a preset.
LearnerSettings PresetSettings(Preset preset);

enum class LearnerStatus {
  kRunning = 0,      ///< learning continues
  kConverged,        ///< the optimality (and, with step_convergence, the step) test holds
  kLineSearchFailed, ///< alpha < alpha_min: terminated with the previous control law
  kMaxTrials,        ///< batch Solve hit max_trials
};

/// "running", "converged", "line_search_failed" or "max_trials" (logs, tables, Python).
const char* LearnerStatusName(LearnerStatus status);

/// First-order optimality of a nominal: the norm of the gradient of the cost projected onto the
/// feasible directions, ||P(grad_u)||_{L2 in t} for the inputs (components at a bound whose
/// gradient points out of the box removed) and ||P(grad_D)|| for the durations (the tangent cone
/// of (7) and the final-time box). Units: cost per input unit per sqrt(s), and cost per s.
struct Optimality {
  double inputs = 0;  ///< sqrt(int |P(dI/du(t))|^2 dt)
  double times = 0;   ///< |P(dI/dD)|
  double total = 0;   ///< sqrt(inputs^2 + times^2)
};
/// The optimality of `nominal`, from the gradient adjoint of a pass run on it.
Optimality ComputeOptimality(const Problem& problem, const Trajectory& nominal,
                             const BackwardPass& pass);

/// What happened in one trial.
struct TrialResult {
  bool accepted = false;    ///< the acceptance test held; the trial became the new nominal
  double cost = 0;          ///< measured cost I^{i+1} of the trial (inf for an aborted trial)
  double nominal_cost = 0;  ///< cost I^i of the nominal it was compared with
  double decrease = 0;      ///< I^{i+1} - (I^i + start_shift)
  double start_shift = 0;   ///< dI_start of LearnerSettings::start_correction (0 when off)
  bool restarted = false;   ///< restart_on_failure: the line search restarted after this trial
  bool remeasured = false;  ///< remeasure_nominal: the trial re-ran the nominal's law
  double predicted = 0;     ///< the predicted change dI_pred(alpha) (0 for kLyapunov's pass)
  double step = 0;          ///< int |du|^2 dtau + |dT|^2 (measured dT, du vs. nominal inputs)
  double alpha = 0;         ///< alpha used for this trial
  double optimality = 0;    ///< Optimality::total of the nominal after the trial
  int iteration = 0;        ///< accepted iterations so far (i after the trial)
  int trial = 0;            ///< trials so far
  LearnerStatus status = LearnerStatus::kRunning;
  CostBreakdown breakdown;  ///< parts of the measured cost
};

/// Result of a batch Solve.
struct SolveResult {
  LearnerStatus status = LearnerStatus::kRunning;
  int trials = 0;                  ///< plant runs of the cost plant after the initial one
  int iterations = 0;              ///< accepted trials
  double cost = 0;                 ///< cost of the final nominal (as measured by the cost plant)
  Vector T;                        ///< K: switching instants of the final nominal
  Optimality optimality;           ///< of the final nominal
  std::vector<double> cost_history;  ///< cost of the nominal after each accepted trial (incl. 0)
  /// Why it stopped, in words with the figures of the test that decided (Learner::StopReason),
  /// e.g. "converged: the full step's predicted decrease 3e-12 is at most 1.2e-09 (1e-09 of
  /// the current cost 1.18 ...)".
  std::string stop_reason;
};

/// The affine feedback law of one mode in physical time, at the nominal's samples:
///   u(t) = u_ff(t) + K(t) x(t) = u_nominal(t) + K(t) (x(t) - x_nominal(t)) + u_step(t),
/// K = -H^{-1} (L_ux + F_u^T P_xx) (the continuous-time LQR gain -R^{-1} (B^T S + N) for a
/// linear system with a quadratic cost: the time normalization scales H and the gain alike),
/// u_step = -H^{-1} c the remaining feed-forward step of (34) (~0 at convergence). Before the
/// box of (35): an input on a bound is clipped by the plant's QP, not by this law.
struct ModeFeedbackLaw {
  Vector t;               ///< N_k sample times (s, the nominal's)
  Matrix x;               ///< n_k x N_k nominal states
  Matrix u;               ///< m x N_k nominal inputs
  Matrix u_ff;            ///< m x N_k feed-forward: u_nominal + u_step - K x_nominal
  std::vector<Matrix> K;  ///< N_k gains, each m x n_k (input per unit state)
};

/// A nominal the learner can go back to (Learner::Save, Learner::Restore): the trajectory, its
/// cost I^i and the law that produced it. TrialDriver's harm guard keeps two.
struct LearnerCheckpoint {
  bool valid = false;           ///< Save() filled it
  Trajectory nominal;           ///< x^i, u^i, T^i
  double cost = 0;              ///< I^i
  double own_cost = 0;          ///< start_correction, reference_shift: its cost under the reference it was adopted with
  bool initial = true;          ///< produced by the initial law (no accepted trial)
  OnlineController law;         ///< the accepted trial's law that produced it (unused when initial)
  Trajectory previous_nominal;  ///< use_previous_du: the nominal before it
  Matrix du_prev;               ///< use_previous_du: the control variation that led to it
};

/// Algorithm 1 bookkeeping around BackwardPass, SolveSwitchingTimeUpdate and OnlineController.
///
/// Two roles of trajectories (DESIGN.md, "one engine, three methods"):
///   - the *direction* trajectory x^i along which (30) is integrated and around which (33)-(34)
///     feed back dx;
///   - the *cost* trajectory whose measured cost enters (36).
/// Algorithm 1: both are the measured trial. mRL: the direction trajectory is the model's
/// prediction of the accepted policy from the measured initial state. OC-FB: both from the
/// model; afterwards ConvergedPolicy() is applied unchanged to the real plant.
///
/// Incremental use (one trial = one hop on a robot):
///
///   learner.Initialize(measured0);                  // u^0, T^0 ran once: x^0, I^0
///   while (...) {
///     OnlineController& policy = learner.NextTrial();  // (31) and the law (33)-(34)
///     ... run policy on the robot, record `measured` ...
///     TrialResult r = learner.CompleteTrial(measured);  // (36), then (30) if accepted
///   }
///
/// Rejected trials: a trial on a robot has happened even when it fails the acceptance test. The
/// nominal stays the last ACCEPTED trajectory (with its cost I^i), alpha shrinks (backtracking),
/// and the next trial is
/// controlled around that nominal with the smaller alpha, starting from whatever state the
/// robot is in (the feedback in (34) absorbs the initial deviation). When alpha < alpha_min the
/// learner is terminated (kLineSearchFailed): NextTrial() then returns the control law that
/// produced the last accepted trial ("the control law of the previous iteration"), or for
/// i = 0 a replay of the nominal inputs (alpha = 0). A caller that still holds the policy that
/// produced x^0 can run that instead (the hopper plugin runs u^0: runs_initial_law()).
class Learner {
 public:
  /// Validates problem and settings; allocates everything. The problem must outlive this.
  explicit Learner(const Problem& problem, const LearnerSettings& settings = {});

  /// Algorithm 1 "Initialize": the trial of u^0, T^0 measured on the cost plant, and the
  /// direction trajectory (nullptr: the same). Computes I^0 (or takes `cost`, e.g. the mean
  /// over several runs of u^0 of which `measured` is one) and runs (30).
  void Initialize(const Trajectory& measured, const Trajectory* direction = nullptr,
                  std::optional<double> cost = std::nullopt);

  /// The control law for the next trial: (31) with the current alpha, then Load (33)-(34).
  /// The returned controller stays valid until the next NextTrial/CompleteTrial.
  OnlineController& NextTrial();

  /// Ends the trial run with NextTrial(): measured cost, (36), backtracking or acceptance.
  /// On acceptance the new nominal is `measured`, or, when direction_plant is given (mRL), the
  /// same policy re-run on direction_plant from measured.x0. Then (30) runs for the next trial.
  /// `cost`, when given, is the trial's measured cost instead of EvaluateCost(measured) (e.g.
  /// the mean over several runs of the law, of which `measured` is one).
  TrialResult CompleteTrial(const Trajectory& measured, Plant* direction_plant = nullptr,
                            std::optional<double> cost = std::nullopt);

  /// A trial that could not be measured (robot fell, NaN): counts as rejected.
  TrialResult AbortTrial();

  /// Re-runs the backward pass (30) along the current nominal, keeping its measured cost I^i.
  /// For costs whose parameters changed since the nominal was accepted, e.g. a terminal cost
  /// that refers to the next trial's measured initial state (the hopper's I1 with x(0) = the
  /// next hop's takeoff state). The next NextTrial() uses the new pass. Call it between
  /// CompleteTrial (or Initialize) and NextTrial.
  void RecomputeDirection();

  /// Reallocates for trajectories of `samples` samples (+ 25 % + 8 K) when settings().max_samples
  /// is smaller, raising it (Solve calls it with the initial trial's count). Allocates; call
  /// before Initialize (it discards the pass and the loaded laws).
  void ReserveSamples(int samples);

  /// Throws InvalidArgument when the planned durations of `initial_policy` (all finite) do not
  /// add up to a fixed final time (to 1e-9 relative). Solve calls it first.
  void CheckInitialPolicy(const Policy& initial_policy) const;

  /// The current nominal as a checkpoint (copies the trajectory and its law; allocates).
  LearnerCheckpoint Save() const;
  /// Goes back to a checkpoint's nominal: it becomes the nominal with its cost and law, the
  /// pending trial (if any) is dropped, (30) runs along it under the cost's current reference,
  /// and the line search restarts (alpha <- restart_alpha, or alpha_initial when that is 0;
  /// status running). iteration() and trials() keep counting. Allocates. Throws
  /// InvalidArgument for a checkpoint Save() did not fill or whose pass fails.
  void Restore(const LearnerCheckpoint& checkpoint);
  /// Sets I^i, the cost trials are compared with (e.g. the mean of re-runs of the nominal's
  /// law, free of the selection that made the accepted trial look good). Finite.
  void SetNominalCost(double cost);
  /// The law that produced the nominal: the accepted trial's; before any (nominal_is_initial)
  /// the nominal's inputs with the pass's feedback (TrialDriver runs u^0 instead).
  OnlineController& nominal_law() { return NominalLaw(); }
  /// No trial accepted since Initialize (or since Restore of u^0's nominal).
  bool nominal_is_initial() const { return accepted_ < 0; }

  /// The law that produced the initial nominal (u^0), for blend_feedback before the first
  /// accepted trial; nullptr (default): no blend until then. It must stay loaded while used.
  void SetInitialLaw(const OnlineController* law) { initial_law_ = law; }
  /// The first pass's cyclic value starts from `P0` instead of 0 (BackwardPass::SeedCyclicValue;
  /// e.g. the model solve's backward_pass().cyclic_value() of the law u^0 that makes the initial
  /// nominal). Throws InvalidArgument on a wrong size or a non-finite entry.
  void SeedCyclicValue(const Matrix& P0) { pass_.SeedCyclicValue(P0); }

  /// Batch Algorithm 1 / mRL / OC-FB from a fixed initial state: runs `initial_policy` on both
  /// plants, then trials until convergence, line-search failure or max_trials. Pass the same
  /// object twice for Algorithm 1 (real, real) and OC-FB (model, model); (model, real) is mRL.
  SolveResult Solve(Plant& direction_plant, Plant& cost_plant, const ConstVectorRef& x0,
                    Policy& initial_policy);

  /// The converged feed-forward + feedback law: (33)-(34) around the current nominal with
  /// dT = 0 (planned T = nominal T) and the given alpha. Used by OC-FB on the real plant.
  /// With the kRiccati convention and alpha = 0 it is exactly "nominal inputs + feedback on
  /// dx", whether or not the gradient L_u + F_u^T p has vanished.
  OnlineController& ConvergedPolicy(double alpha = 1.0);

  /// The law of ConvergedPolicy(alpha) as K(t) and u_ff(t) per mode, in physical time
  /// (ModeFeedbackLaw). Allocates; call between trials. Throws before Initialize.
  std::vector<ModeFeedbackLaw> FeedbackLaw(double alpha = 1.0) const;

  LearnerStatus status() const { return status_; }
  /// The status in words a user can act on, with the figures of the test that decided it (the
  /// predicted decrease of the full step against the current cost, alpha against alpha_min,
  /// the trial budget: "stopped: max_trials = N reached; ..." once trials() reaches it).
  /// Formats on demand (allocates); not for a real-time loop.
  std::string StopReason() const;
  /// Initialize has run (NextTrial and CompleteTrial may be called).
  bool initialized() const { return initialized_; }
  bool converged() const { return status_ == LearnerStatus::kConverged; }
  double alpha() const { return alpha_; }
  /// sigma (curvature_scale_min): the next trial steps alpha / sigma along the model.
  double curvature_scale() const { return curvature_scale_; }
  int iteration() const { return iteration_; }
  int trials() const { return trials_; }
  /// Restarts so far (LearnerSettings::restart_on_failure).
  int restarts() const { return restarts_; }
  /// The next trial re-measures the nominal (LearnerSettings::remeasure_nominal).
  bool remeasuring() const { return remeasure_pending_; }
  /// Re-measurements of the current nominal that I^i averages (0: I^i is the accepted trial's).
  int nominal_samples() const { return nominal_samples_; }
  /// sigma of noise_margin: sqrt of the mean of (s - s_prev)^2 / 2 over the re-measurements s,
  /// s_prev the nominal's previous sample (its accepted trial's cost, or the last
  /// re-measurement); 0 before the first.
  double cost_noise() const;
  /// dI_start of LearnerSettings::start_correction for a trial that started at x0 (0 when x0
  /// has another size than the nominal's start). Call after the trial's cost reference is set.
  double StartShift(const ConstVectorRef& x0) const;
  const Trajectory& nominal() const { return nominal_; }
  double nominal_cost() const { return nominal_cost_; }
  const BackwardPass& backward_pass() const { return pass_; }
  /// Integration steps of every backward pass since construction (BackwardPass::total_substeps;
  /// a resize by Solve starts the count again).
  long integration_steps() const { return pass_.total_substeps(); }
  const SwitchingTimeStep& switching_step() const { return switching_step_; }
  const std::vector<double>& step_history() const { return step_history_; }
  const LearnerSettings& settings() const { return settings_; }
  /// First-order optimality of the current nominal, and at the initial nominal.
  const Optimality& optimality() const { return optimality_; }
  const Optimality& initial_optimality() const { return initial_optimality_; }
  /// The Levenberg-Marquardt regularization mu of the current backward pass.
  double regularization() const { return mu_; }

 private:
  // Makes `direction` the nominal with cost `cost` and runs (30) on it, raising mu until the
  // pass succeeds. Returns false (nominal unchanged) when it never does.
  bool AcceptNominal(const Trajectory& direction, double cost);
  // (30) on nominal_ with the current mu, raising it on failure.
  bool RunPass();
  // The law that produced the nominal: the accepted trial's controller, or (none accepted yet)
  // the nominal's inputs with the pass's feedback (TrialDriver runs u^0 instead, which
  // produced it).
  OnlineController& NominalLaw();
  // r with the learner's state after the trial: iteration, status, optimality.
  TrialResult Reported(TrialResult r) const;
  // restart_on_failure: alpha <- restart_alpha (or alpha_initial) around the same nominal.
  void RestartLineSearch(TrialResult* r);
  // The alpha a restarted line search (and Restore) starts at: restart_alpha, else alpha_initial.
  double RestartAlpha() const;
  // alpha < alpha_min: restart (online), raise mu and search again (failure_raises), or
  // terminate.
  void LineSearchExhausted(TrialResult* r);
  // remeasure_nominal: I^i <- the mean of the nominal's re-measurements, with `cost` added.
  void AddNominalSample(double cost);
  // The status after a new nominal: converged when the optimality (and step) tests hold.
  void UpdateConvergence();
  // The Newton decrement -dI_pred(1) of the current pass (the full step's predicted gain) and,
  // in *bound, what convergence allows: convergence_tolerance |I^i| plus the gain's rounding.
  double PredictedGain(double* bound) const;
  // The trial `measured` (run with controllers_[active_]) becomes the nominal with cost `cost`:
  // itself, or its re-run on direction_plant when one is given (mRL).
  bool AdoptTrial(const Trajectory& measured, Plant* direction_plant, double cost);
  // int |u_a(tau) - u_b(tau)|^2 dtau on a's grid, b interpolated in tau (trapezoid).
  static double InputDistance(const Trajectory& a, const Trajectory& b);
  // du_prev(s) = u_new(tau_s) - u_old(tau_s) at the samples of new (m x samples).
  static void InputDifference(const Trajectory& new_nominal, const Trajectory& old_nominal,
                              Matrix* du);

  const Problem* problem_;
  LearnerSettings settings_;
  BackwardPass pass_;
  OnlineController controllers_[2];  // [active_] is handed out; [accepted_] produced the nominal
  int active_ = 0;
  int accepted_ = -1;                // -1: no trial accepted yet
  bool trial_pending_ = false;
  bool initialized_ = false;
  Trajectory nominal_;       // x^i, u^i, T^i (direction trajectory)
  Trajectory previous_nominal_;
  double nominal_cost_ = 0;  // I^i (cost plant)
  double nominal_own_cost_ = 0;  // the nominal's EvaluateCost when it was adopted
  double alpha_ = 1;
  int iteration_ = 0;
  int trials_ = 0;
  int restarts_ = 0;
  int failure_raises_ = 0;          // failure_raises used since the last accepted trial
  double curvature_scale_ = 1;      // sigma: the next trial's step is alpha / sigma
  bool remeasure_pending_ = false;  // remeasure_nominal: the next trial re-runs the nominal's law
  bool remeasure_trial_ = false;    // the pending trial is such a re-measurement
  int nominal_samples_ = 0;         // re-measurements of the nominal in nominal_cost_
  double nominal_sample_sum_ = 0;
  double last_sample_ = 0;          // the nominal's last sample (accepted cost or re-measurement)
  double noise_sum_ = 0;            // sum of (s - s_prev)^2 / 2 over the re-measurements
  int noise_count_ = 0;
  bool in_solve_ = false;  // inside Solve: restart_on_failure does not apply
  LearnerStatus status_ = LearnerStatus::kRunning;
  SwitchingTimeStep switching_step_;
  std::vector<double> step_history_;  // step of each accepted trial
  Matrix du_prev_;                    // m x samples
  double mu_ = 0;                     // Levenberg-Marquardt regularization of (30), (33)
  double luu_scale_ = 0;              // max |diag L_uu| seen, for the first raise of mu
  Optimality optimality_, initial_optimality_;
  double initial_cost_ = 0;           // I^0, the cost of the nominal Initialize was given
  const OnlineController* initial_law_ = nullptr;  // SetInitialLaw
};

}  // namespace ddoc

#endif  // DDOC_LEARNER_H_
