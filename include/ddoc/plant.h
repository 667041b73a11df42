// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Plants run one trial of a policy and return the measured trajectory.
#ifndef DDOC_PLANT_H_
#define DDOC_PLANT_H_

#include <functional>

#include "ddoc/policy.h"
#include "ddoc/problem.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// Something that executes a policy for one trial (all K modes) from an initial state and
/// reports what happened: the sampled states, the applied inputs and the measured switching
/// instants (Algorithm 1: "Measure x^{i+1}, T^{i+1}"). A ModelPlant integrates a model; the
/// MuJoCo harness implements a real-robot stand-in.
class Plant {
 public:
  virtual ~Plant() = default;
  /// Runs one trial from x0 (size n_0) with `policy`; fills `out` (times start at t = 0).
  virtual void Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) = 0;
};

/// Settings of ModelPlant.
struct ModelPlantSettings {
  double dt = 1e-3;               ///< RK4 step and control period (s); policy is held over a step
  double event_tolerance = 1e-9;  ///< bisection stops when the event bracket is shorter (s)
  int max_bisections = 60;        ///< cap on bisection steps per event
  /// true: every mode ends at its planned duration (time-based), ignoring surfaces/guards.
  bool time_based_only = false;
};

/// Integrates a SwitchedSystem with classical RK4 at a fixed step, zero-order-hold inputs from
/// the policy (called once per step, at its start), and event detection:
///
/// - mode k ends at the first t with t - T_{k-1} >= duration_min(k) where the guard is <= 0;
///   a crossing from > 0 to <= 0 inside a step is located by bisection (re-integrating the
///   step with RK4) to event_tolerance; if the guard is already <= 0 when duration_min(k) is
///   reached, the mode ends there;
/// - the default guard is h_k(x)[0] when s_k > 0, else time-based: the mode ends after the
///   policy's PlannedDuration(k) (clamped into [duration_min, duration_max]);
/// - every mode ends at duration_max(k) at the latest.
///
/// Steps are shortened to land exactly on duration_min, duration_max and planned switching
/// times, so the measured cost is a smooth function of the planned T.
class ModelPlant : public Plant {
 public:
  /// Guard of mode k: the mode ends when it crosses from > 0 to <= 0.
  using Guard = std::function<double(int k, const ConstVectorRef& x, const ConstVectorRef& u)>;

  /// `system` may differ from the problem's model (a "true" plant); bounds give the duration
  /// limits. `system` must outlive the plant.
  ModelPlant(const SwitchedSystem& system, const Bounds& bounds,
             const ModelPlantSettings& settings = {});
  /// Uses problem.system and problem.bounds.
  explicit ModelPlant(const Problem& problem, const ModelPlantSettings& settings = {});

  /// Replaces the guard (nullptr restores the default).
  void set_guard(Guard guard) { guard_ = std::move(guard); }
  ModelPlantSettings& settings() { return settings_; }

  void Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) override;

 private:
  void Rk4(int k, const Vector& x, const Vector& u, double h, Vector* out);
  // Guard value, or +1 when the mode is time-based.
  double GuardValue(int k, const Vector& x, const Vector& u);
  bool TimeBased(int k) const;

  const SwitchedSystem* system_;
  Bounds bounds_;
  ModelPlantSettings settings_;
  Guard guard_;
  TrajectoryRecorder recorder_;
  Vector k1_, k2_, k3_, k4_, tmp_, h_;  // workspace (n_max, s_max)
};

}  // namespace ddoc

#endif  // DDOC_PLANT_H_
