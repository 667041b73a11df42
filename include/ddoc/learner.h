// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Algorithm 1: the iteration (backward pass, switching-time update, online control, measured
// cost, sufficient decrease (36), backtracking, convergence), batch or one trial at a time.
#ifndef DDOC_LEARNER_H_
#define DDOC_LEARNER_H_

#include <limits>
#include <vector>

#include "ddoc/backward_pass.h"
#include "ddoc/cost.h"
#include "ddoc/online_controller.h"
#include "ddoc/plant.h"
#include "ddoc/problem.h"
#include "ddoc/switching_time_update.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// Settings of Learner (Algorithm 1).
struct LearnerSettings {
  double c = 1e-4;              ///< sufficient-decrease constant c of (36), > 0
  double gamma = 0.5;           ///< backtracking factor: alpha <- gamma alpha, in (0, 1)
  double alpha_initial = 1.0;   ///< alpha at the start and after every accepted trial, in (0, 1]
  /// Algorithm 1 restarts every iteration at alpha = alpha_initial (true). false: after an
  /// accepted trial alpha <- min(alpha_initial, alpha / gamma), so a robot that needed a small
  /// alpha does not spend a run of rejected trials backtracking again every iteration.
  bool reset_alpha_on_accept = true;
  /// Option for robots whose trials start where the previous one ended (default false = (36)
  /// as printed). true: (36) compares the trial's cost with the nominal's cost predicted for the
  /// trial's own initial state, to second order from the backward pass at tau = 0,
  ///   I^i(x0^{i+1}) ~ I^i + p_1(0)^T dx0 + 1/2 dx0^T P_11(0) dx0,  dx0 = x0^{i+1} - x0^i,
  /// so that a trial is not rejected (or accepted) only because it started in a worse (or
  /// better) state. The cost must then not depend on x0 otherwise (e.g. no reference that moves
  /// with the start). Measured on the MuJoCo hopper (tools/hop_experiment, plugin): more trials
  /// pass (36) but the second-order prediction is too coarse for hop-to-hop deviations, so worse
  /// laws get accepted (exact 12 kg robot falls at hop 27); hence off by default.
  bool initial_state_correction = false;
  /// Non-monotone acceptance (NOT the paper; Grippo-Lampariello-Lucidi line search). 1 = (36)
  /// as printed. M > 1: (36) compares the trial's cost with the LARGEST of the costs of the last
  /// M accepted nominals, I^{i+1} - max_{j = 0..M-1} I^{i-j} <= -c (int |du|^2 + |dT|^2),
  /// (the backward pass still runs along the newest accepted trial), so that one accepted trial
  /// that happened to start in a good state does not block every later one. >= 1.
  /// Measured on the MuJoCo hopper (plugin, M = 3): no effect on the inexact 12 kg robot (no
  /// trial is ever accepted there, so the memory holds only I^0); mixed elsewhere (mRL exact
  /// 8 kg mean cost of the last 20 hops 0.995 vs 1.031, Algorithm 1 inexact 8 kg 1.135 vs 1.090).
  int nonmonotone_memory = 1;
  /// Re-baselining (NOT the paper) for robots whose trials start where the previous one ended.
  /// 0 = off. N > 0: after N consecutive rejected trials, the nominal's cost I^i is taken as no
  /// longer reproducible from the robot's current states, and Algorithm 1 restarts from the
  /// last (rejected) trial as if it were the initial one: it becomes the nominal x^i with its
  /// measured cost, (30) runs along it, the cost memory is cleared; alpha and the iteration
  /// count are kept. TrialResult::rebaselined reports it (accepted stays false).
  /// Measured on the MuJoCo hopper (plugin): worse. N = 3: Algorithm 1 inexact 8 kg robot falls
  /// at hop 20 (survives without), inexact 12 kg at hop 9 (14 without); N = 1, 2, 5: 6, 8, 10.
  int rebaseline_after = 0;
  double alpha_min = 1e-6;      ///< line search fails (terminated) when alpha drops below
  double epsilon = 1e-8;        ///< convergence: int |du|^2 dtau + |dT|^2 <= epsilon ...
  int delta_i = 2;              ///< ... for the last delta_i accepted iterations (Delta i)
  int max_trials = 500;         ///< batch Solve: maximum number of trials (plant runs)
  int max_samples = 20000;      ///< preallocation: most samples of one trajectory (all modes)
  BackwardPassSettings backward;         ///< (30)
  SwitchingTimeSettings switching;       ///< (31)
  OnlineControllerSettings controller;   ///< (33)-(34)

  /// The `paper` preset: Algorithm 1 as printed (Lyapunov-type (30) with the previous control
  /// variation driving p, alpha on all of (31) and (33), (36), the convergence test), with only
  /// the L_z erratum of (30) fixed. What the reproduction runs.
  static LearnerSettings Paper();
};

enum class LearnerStatus {
  kRunning = 0,      ///< learning continues
  kConverged,        ///< the convergence test of Algorithm 1 holds
  kLineSearchFailed, ///< alpha < alpha_min: terminated with the previous control law
  kMaxTrials,        ///< batch Solve hit max_trials
};

/// What happened in one trial.
struct TrialResult {
  bool accepted = false;    ///< (36) held; the trial became the new nominal
  double cost = 0;          ///< measured cost I^{i+1} of the trial (inf for an aborted trial)
  double nominal_cost = 0;  ///< cost I^i of the nominal it was compared with
  double decrease = 0;      ///< I^{i+1} - I^i (I^i corrected to x0^{i+1}, see settings)
  double expected_nominal_cost = 0;  ///< I^i, or its prediction at x0^{i+1} (correction on)
  bool rebaselined = false; ///< rejected, but became the nominal (settings.rebaseline_after)
  double step = 0;          ///< int |du|^2 dtau + |dT|^2 (measured dT, du vs. nominal inputs)
  double alpha = 0;         ///< alpha used for this trial
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
  std::vector<double> cost_history;  ///< cost of the nominal after each accepted trial (incl. 0)
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
/// Rejected trials: a trial on a robot has happened even when (36) fails. The nominal stays the
/// last ACCEPTED trajectory (with its cost I^i), alpha <- gamma alpha, and the next trial is
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
  /// direction trajectory (nullptr: the same). Computes I^0 and runs (30).
  void Initialize(const Trajectory& measured, const Trajectory* direction = nullptr);

  /// The control law for the next trial: (31) with the current alpha, then Load (33)-(34).
  /// The returned controller stays valid until the next NextTrial/CompleteTrial.
  OnlineController& NextTrial();

  /// Ends the trial run with NextTrial(): measured cost, (36), backtracking or acceptance.
  /// On acceptance the new nominal is `measured`, or, when direction_plant is given (mRL), the
  /// same policy re-run on direction_plant from measured.x0. Then (30) runs for the next trial.
  TrialResult CompleteTrial(const Trajectory& measured, Plant* direction_plant = nullptr);

  /// A trial that could not be measured (robot fell, NaN): counts as rejected.
  TrialResult AbortTrial();

  /// Re-runs the backward pass (30) along the current nominal, keeping its measured cost I^i.
  /// For costs whose parameters changed since the nominal was accepted, e.g. a terminal cost
  /// that refers to the next trial's measured initial state (the hopper's I1 with x(0) = the
  /// next hop's takeoff state). The next NextTrial() uses the new pass. Call it between
  /// CompleteTrial (or Initialize) and NextTrial.
  void RecomputeDirection();

  /// Batch Algorithm 1 / mRL / OC-FB from a fixed initial state: runs `initial_policy` on both
  /// plants, then trials until convergence, line-search failure or max_trials. Pass the same
  /// object twice for Algorithm 1 (real, real) and OC-FB (model, model); (model, real) is mRL.
  SolveResult Solve(Plant& direction_plant, Plant& cost_plant, const ConstVectorRef& x0,
                    Policy& initial_policy);

  /// The converged feed-forward + feedback law: (33)-(34) around the current nominal with
  /// dT = 0 (planned T = nominal T) and the given alpha. Used by OC-FB on the real plant.
  /// With settings.controller.alpha_scales_feedback = false and alpha = 0 it is exactly
  /// "nominal inputs + feedback on dx", whether or not the gradient L_u + F_u^T p has vanished.
  OnlineController& ConvergedPolicy(double alpha = 1.0);

  LearnerStatus status() const { return status_; }
  bool converged() const { return status_ == LearnerStatus::kConverged; }
  double alpha() const { return alpha_; }
  int iteration() const { return iteration_; }
  int trials() const { return trials_; }
  const Trajectory& nominal() const { return nominal_; }
  double nominal_cost() const { return nominal_cost_; }
  const BackwardPass& backward_pass() const { return pass_; }
  const SwitchingTimeStep& switching_step() const { return switching_step_; }
  const std::vector<double>& step_history() const { return step_history_; }
  const LearnerSettings& settings() const { return settings_; }

 private:
  void AcceptNominal(const Trajectory& direction, double cost);
  // The trial `measured` (run with controllers_[active_]) becomes the nominal with cost `cost`:
  // itself, or its re-run on direction_plant when one is given (mRL).
  void AdoptTrial(const Trajectory& measured, Plant* direction_plant, double cost);
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
  double alpha_ = 1;
  int iteration_ = 0;
  int trials_ = 0;
  LearnerStatus status_ = LearnerStatus::kRunning;
  SwitchingTimeStep switching_step_;
  std::vector<double> step_history_;  // step of each accepted trial
  std::vector<double> cost_memory_;   // costs of the last nonmonotone_memory nominals
  int rejections_ = 0;                // consecutive rejected trials
  Matrix du_prev_;                    // m x samples
};

}  // namespace ddoc

#endif  // DDOC_LEARNER_H_
