// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/hopper_learning.h"

#include <cmath>
#include <memory>

#include "ddoc/policy.h"

namespace ddoc {

LearnerSettings HopperLearnerSettings() {
  // The default preset (kRiccati, alpha on the feed-forward only, Armijo on the predicted
  // decrease with the trust ratio kRatio), then:
  LearnerSettings s;
  s.interpolate_backtracking = false;
  s.step_convergence = true;
  s.gamma = 0.5;
  s.regularization_min = 0.01;
  s.backward.integrator = BackwardIntegrator::kRk4;
  s.backward.psd_switching_hessians = true;
  s.backward.box_aware = false;
  s.backward.time_curvature = false;
  s.backward.cyclic_value = 0.99;
  s.backward.terminal_event = true;
  s.alpha_initial = 0.5;
  s.start_correction = false;
  s.restart_on_failure = true;
  s.restart_alpha = 1e-3;
  s.blend_feedback = true;
  return s;
}

LearnerSettings HopperModelSolveSettings() {
  LearnerSettings s = HopperLearnerSettings();
  s.alpha_initial = 0.1;
  s.blend_feedback = false;  // every trial starts from the same state: nothing to blend for
  s.acceptance = Acceptance::kSufficientDecrease;  // (36) as printed, alpha / gamma after an
  s.c = 1e-7;                                      // accepted trial (docs/hopper.md)
  s.alpha_after_accept = AlphaAfterAccept::kGrow;
  s.failure_raises = 0;  // a u^0 nearer the model's optimum is less robust (docs/hopper.md)
  return s;
}

LearnerSettings HopperPaperLearnerSettings() {
  LearnerSettings s = LearnerSettings::Paper();
  s.c = 1e-7;
  s.alpha_initial = 0.1;
  s.regularization_min = 0.01;
  s.backward.integrator = BackwardIntegrator::kRk4;
  s.backward.psd_switching_hessians = true;
  return s;
}

TrialDriverSettings HopperTrialSettings(Preset preset) {
  TrialDriverSettings s;
  s.method = Method::kAlg1;
  s.warmup_trials = 1;
  if (preset == Preset::kPaper) {
    s.learner = HopperPaperLearnerSettings();  // no harm guard: Algorithm 1 as printed
    return s;
  }
  s.learner = HopperLearnerSettings();
  // The harm guard's median watch (docs/engine.md, "Never keeping harm"): accepted laws are kept
  // on their own trial; a kept law whose last 8 judged costs have a median above 1.5 x the mean
  // of the law it replaced (or u^0's) lets that law run 3 times, and is abandoned when their
  // median beats the window's and the kept law's record (docs/experiments.md, "The median watch
  // becomes the default"); ControllerConfig::watch_max_mass suspends it on heavier robots.
  s.guard.verify_trials = 3;
  s.guard.watch_trials = 8;
  s.guard.verify_accepted = false;
  s.guard.watch_ratio = 1.5;
  return s;
}

Problem HopperProblem(const HopperModel& model, const HopperCost& cost,
                      const HopperModeDurations& d) {
  Problem p;
  p.system = &model;
  p.cost = &cost;
  p.bounds.u_min = hopper::InputLowerBound();
  p.bounds.u_max = hopper::InputUpperBound();
  p.bounds.duration_min = Eigen::Vector2d(d.flight_min, d.stance_min);
  p.bounds.duration_max = Eigen::Vector2d(d.flight_max, d.stance_max);
  p.surface_weights = Eigen::Vector2d(cost.weights().surface_weight, 0.0);
  p.Validate();
  return p;
}

void HopperPredictionPlant::Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) {
  x0_ = x0;
  if (x0_.size() == hopper::kFlightDim) x0_(hopper::kRd) = 0.0;
  model_->Run(x0_, policy, out);
}

TrialDriver::CostReference HopperCostReference(HopperCost* cost, const Vector& anchor,
                                               double anchor_weight, double filter,
                                               double overspeed_latch,
                                               std::shared_ptr<bool> latched) {
  if (!(anchor_weight >= 0.0 && anchor_weight <= 1.0)) {
    throw InvalidArgument("HopperCostReference: anchor_weight = " + std::to_string(anchor_weight) +
                          ", expected in [0, 1]");
  }
  if (!(filter > 0.0 && filter <= 1.0)) {
    throw InvalidArgument("HopperCostReference: filter = " + std::to_string(filter) +
                          ", expected in (0, 1]");
  }
  if (!(overspeed_latch >= 0.0) || !std::isfinite(overspeed_latch)) {
    throw InvalidArgument("HopperCostReference: overspeed_latch = " +
                          std::to_string(overspeed_latch) + ", expected finite and >= 0");
  }
  // The filtered start state s, from the anchor: s <- s + filter (x(0) - s) at each learner call.
  const bool moves = HopperReferenceMoves(anchor, anchor_weight, filter);
  const bool latches = moves && overspeed_latch > 0.0;
  auto own = std::make_shared<Vector>(anchor);
  if (latched == nullptr) latched = std::make_shared<bool>(false);
  *latched = false;
  return [cost, anchor, anchor_weight, filter, moves, latches, overspeed_latch, own, latched](
             const Trajectory& trial, bool for_learner) {
    if (!for_learner || anchor.size() == 0) {
      cost->SetReference(trial.x0);
      return;
    }
    const bool finite = trial.x0.size() == anchor.size() && trial.x0.allFinite();
    // Once a learner's hop starts faster than the gait by more than the latch, the gait's state
    // is the reference from that hop on (docs/experiments.md, issue 45's overspeed latch).
    if (latches && !*latched && finite &&
        trial.x0(hopper::kXd) - anchor(hopper::kXd) > overspeed_latch) {
      *latched = true;
    }
    if (anchor_weight == 1.0 || *latched) {
      cost->SetReference(anchor);
      return;
    }
    if (moves && finite) *own += filter * (trial.x0 - *own);
    const Vector& start = moves ? *own : trial.x0;
    cost->SetReference(anchor_weight * anchor + (1.0 - anchor_weight) * start);
  };
}

bool HopperReferenceMoves(const Vector& anchor, double anchor_weight, double filter) {
  return anchor.size() > 0 && anchor_weight < 1.0 && filter < 1.0;
}

SolveResult SolveFromGait(Learner& learner, Plant& model_plant, HopperCost* cost,
                          const NominalGait& gait) {
  cost->SetReference(gait.x0);
  const Eigen::Vector2d durations(gait.T0(0), gait.T0(1) - gait.T0(0));
  const Eigen::Vector4d u0 = gait.u0;
  FunctionPolicy initial(durations,
                         [u0](int, double, const ConstVectorRef&, VectorRef u) { u = u0; });
  return learner.Solve(model_plant, model_plant, gait.x0, initial);
}

}  // namespace ddoc
