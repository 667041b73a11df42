// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A policy maps (mode, time in mode, measured state) to an input, one step at a time.
#ifndef DDOC_POLICY_H_
#define DDOC_POLICY_H_

#include <functional>

#include "ddoc/trajectory.h"

namespace ddoc {

/// Something a Plant executes during one trial. Implementations: OnlineController (33)-(34),
/// OpenLoopPolicy (replay of inputs in normalized time), FunctionPolicy.
///
/// Time mapping used by all ddoc policies: with the planned durations D_k of the trial, the
/// normalized time is tau = k + clamp(t_since_mode_start / D_k, 0, 1). A mode that lasts longer
/// than planned stays at tau = k + 1 (the end of the mode's nominal); a mode that ends early
/// simply never reaches k + 1: the next mode starts at tau = k + 1 when the plant reports the
/// switch (the mode index follows the measured event, not the plan).
class Policy {
 public:
  virtual ~Policy() = default;
  /// Called by the plant at the start of every trial (resets per-trial state).
  virtual void BeginTrial() {}
  /// The planned duration D_k = T_k - T_{k-1} of mode k (time-based switching uses it).
  virtual double PlannedDuration(int k) const = 0;
  /// u = policy(k, t since the start of mode k, measured x). u has size m, x size n_k.
  virtual void Step(int k, double t_since_mode_start, const ConstVectorRef& x, VectorRef u) = 0;
};

/// Replays the inputs of a trajectory in normalized time (12): u(tau) interpolated linearly
/// between the samples, with planned durations from the trajectory (or given T). Allocation-free
/// Step. This is the "u^0, T^0" initial policy of Algorithm 1 and a pure feed-forward policy.
class OpenLoopPolicy : public Policy {
 public:
  /// Plays `trajectory`'s inputs with its own switching instants.
  explicit OpenLoopPolicy(const Trajectory& trajectory);
  /// Plays `trajectory`'s inputs with planned switching instants T (size K, increasing).
  OpenLoopPolicy(const Trajectory& trajectory, const ConstVectorRef& T_planned);
  void BeginTrial() override;
  double PlannedDuration(int k) const override { return durations_(k); }
  void Step(int k, double t_since_mode_start, const ConstVectorRef& x, VectorRef u) override;

 private:
  Trajectory nominal_;
  Vector durations_;         // K planned durations
  std::vector<Vector> tau_;  // per mode: tau of the samples
  std::vector<int> cursor_;  // per mode: last interval used
};

/// A policy given by a function of normalized time: u = fn(k, tau, x), with planned durations.
/// Handy for initial guesses (constant or smooth inputs) and tests.
class FunctionPolicy : public Policy {
 public:
  using Function =
      std::function<void(int k, double tau, const ConstVectorRef& x, VectorRef u)>;
  FunctionPolicy(const ConstVectorRef& planned_durations, Function fn);
  double PlannedDuration(int k) const override { return durations_(k); }
  void Step(int k, double t_since_mode_start, const ConstVectorRef& x, VectorRef u) override;

 private:
  Vector durations_;
  Function fn_;
};

/// tau = k + clamp(t / D, 0, 1) (D > 0; tau = k for D = 0), the time mapping shared by all ddoc
/// policies.
double NormalizedTime(int k, double t_since_mode_start, double planned_duration);

}  // namespace ddoc

#endif  // DDOC_POLICY_H_
