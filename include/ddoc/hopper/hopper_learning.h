// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Learning on the hopper: the settings, the problem, mRL's prediction plant, the cost reference
// and the initial law u^0 that the controller plugin and ddoc-hop-experiment share.
#ifndef DDOC_HOPPER_HOPPER_LEARNING_H_
#define DDOC_HOPPER_HOPPER_LEARNING_H_

#include <memory>

#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/nominal_gait.h"
#include "ddoc/learner.h"
#include "ddoc/plant.h"
#include "ddoc/problem.h"
#include "ddoc/trial_driver.h"

namespace ddoc {

/// Algorithm 1 on the hopper, the default: the engine's LearnerSettings{} with these overrides
/// (why, with the measurements, in docs/hopper.md "Learner settings" and docs/robustness_map.md):
/// the preset's Armijo test on the predicted decrease (c = 1e-4) and trust ratio (kRatio) with
/// alpha_initial = 0.5, gamma = 0.5, plain backtracking and the paper's step test; the line
/// search restarts at alpha = 1e-3 instead of terminating (restart_on_failure, restart_alpha);
/// no start correction;
/// regularization_min = 0.01; RK4 pass with PSD switching Hessians, box_aware = false,
/// time_curvature = false, the periodic value cyclic_value = 0.99 and the terminal condition
/// through the takeoff event (terminal_event); a trial's feedback blends from the nominal law's
/// to the pass's (blend_feedback).
LearnerSettings HopperLearnerSettings();

/// The model solve of u^0 (SolveFromGait, every method's initial law and OC-FB's law):
/// HopperLearnerSettings() with alpha_initial = 0.1, blend_feedback = false and the paper's (36)
/// (c = 1e-7, kGrow).
LearnerSettings HopperModelSolveSettings();

/// The `paper` preset on the hopper: LearnerSettings::Paper() with the hopper's scales
/// (c = 1e-7, alpha_initial = 0.1, regularization_min = 0.01) and the RK4 pass with PSD
/// switching Hessians; with ControllerConfig::anchor_reference = false it is Algorithm 1 as
/// printed.
LearnerSettings HopperPaperLearnerSettings();

/// The trial driver on the hopper: Algorithm 1 with one "Initialize" hop of u^0 (as printed),
/// learner = HopperLearnerSettings() (kDefault) or HopperPaperLearnerSettings() (kPaper); the
/// harm guard's median watch with kDefault (verify_trials 3, watch_trials 8, verify_accepted
/// false, watch_ratio 1.5; docs/engine.md, "Never keeping harm"), off with kPaper.
TrialDriverSettings HopperTrialSettings(Preset preset = Preset::kDefault);

/// Duration bounds of the hopper's modes (Bounds::duration_min/max), s.
struct HopperModeDurations {
  double flight_min = 0.05;  ///< s
  double flight_max = 1.5;   ///< s
  double stance_min = 0.05;  ///< s
  double stance_max = 1.0;   ///< s
};

/// The problem of Section V on the analytic hopper: `model`, `cost` (42), the input bounds of
/// Table I, the mode durations, and I4 through Problem::surface_weights = (w, 0). Both must
/// outlive the problem. Throws InvalidArgument (Problem::Validate) on reversed durations.
Problem HopperProblem(const HopperModel& model, const HopperCost& cost,
                      const HopperModeDurations& durations = {});

/// mRL's prediction plant on the hopper: `model` run from the measured start state with the
/// flight leg-length rate rd set to 0 first. The model's massless leg has rd = 0 after takeoff and
/// rdd = 0 in flight; MuJoCo's measured rd in flight is the oscillation of the 2 g foot on the
/// leg spring (about 1 m/s at takeoff), which the model would read as a leg that keeps extending.
class HopperPredictionPlant : public Plant {
 public:
  /// `model` must outlive this plant.
  explicit HopperPredictionPlant(Plant* model) : model_(model) {}
  void Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) override;

 private:
  Plant* model_;
  Vector x0_;  // n_0: the projected start state
};

/// TrialDriver::CostReference for the hopper: before a trial's cost is evaluated, I1's x_ref is
/// set to the trial's own start x(0) (the paper's (42)), or, for the costs the learner sees and
/// when `anchor` is not empty, to `anchor` (e.g. the model gait's takeoff state, so that I1 also
/// pulls the robot back to the gait; NOT the paper), or with `anchor_weight` w < 1 to w anchor +
/// (1 - w) x(0). With `filter` b < 1 (and w < 1) x(0) is replaced by s, the robot's own start
/// state filtered over the learner's trials: s <- s + b (x(0) - s) at each call with for_learner,
/// s = anchor at first; the reference then moves between trials (LearnerSettings::
/// reference_shift). With that moving reference and `overspeed_latch` d > 0, the first learner
/// call whose x(0) has xd above anchor's by more than d (m/s) latches: anchor is the reference
/// from that call on. Throws InvalidArgument for w outside [0, 1], b outside (0, 1] or d < 0 or
/// not finite. `latched`, if given, holds the latch's state (written by the reference's calls).
/// `cost` must outlive the driver.
TrialDriver::CostReference HopperCostReference(HopperCost* cost, const Vector& anchor = Vector(),
                                               double anchor_weight = 1.0, double filter = 1.0,
                                               double overspeed_latch = 0.0,
                                               std::shared_ptr<bool> latched = nullptr);

/// Whether HopperCostReference(cost, anchor, anchor_weight, filter) moves the learner's reference
/// between trials (the filtered own state: anchor given, w < 1, b < 1); a learner given that
/// reference needs LearnerSettings::reference_shift.
bool HopperReferenceMoves(const Vector& anchor, double anchor_weight, double filter);

/// u^0, T^0 of every method (Section V-C): Algorithm 1 run to convergence on the model itself
/// (`model_plant` as both plants) from the gait's constant input u0 and durations T0; the OC-FB
/// law is then learner.ConvergedPolicy(alpha). Sets the cost reference to the gait's x0 first.
SolveResult SolveFromGait(Learner& learner, Plant& model_plant, HopperCost* cost,
                          const NominalGait& gait);

}  // namespace ddoc

#endif  // DDOC_HOPPER_HOPPER_LEARNING_H_
