// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The online control update (33)-(34), one time step at a time.
#ifndef DDOC_ONLINE_CONTROLLER_H_
#define DDOC_ONLINE_CONTROLLER_H_

#include <cstdint>
#include <vector>

#include <Eigen/Cholesky>

#include "ddoc/backward_pass.h"
#include "ddoc/box_qp.h"
#include "ddoc/policy.h"
#include "ddoc/problem.h"
#include "ddoc/sample_layout.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// Settings of OnlineController.
struct OnlineControllerSettings {
  /// Interpolate nominal and gains linearly in tau between samples (true, default) or hold the
  /// sample at or before tau (false).
  bool interpolate = true;
  /// Warm-start the box QP with the previous step's du (default true).
  bool warm_start = true;
  /// Per-component feedback scale, an experiment (NOT the paper; empty = all ones, as printed,
  /// the default): one vector per mode k with that mode's state dimension; component i of dx is
  /// multiplied by state_feedback_scale[k](i) before the gain of (34). Finite and >= 0.
  std::vector<Vector> state_feedback_scale;
  BoxQPSettings qp;  ///< settings of the m-dimensional box QP
};

/// A loaded OnlineController's law as plain arrays: everything Step reads besides the settings.
/// A host can keep it and load it later without re-solving (ExportLaw, ImportLaw); the engine
/// itself does no I/O. S = sum of samples[k]; sample s of mode k is column offset_k + j.
struct OnlineControllerLaw {
  double alpha = 0.0;            ///< alpha of (34)
  double feedback_factor = 1.0;  ///< alpha (kLyapunov) or 1 (kRiccati)
  Vector dT;                     ///< K: dT_alpha
  Vector nominal_T;              ///< K: T^i; the planned T^{i+1} = T^i + dT
  std::vector<int> samples;      ///< K: N_k, each >= 2
  Vector tau;                    ///< S: normalized time, in [k, k+1] and nondecreasing in mode k
  Matrix x;                      ///< n_max x S: nominal states (rows past n_k unused)
  Matrix u;                      ///< m x S: nominal inputs
  Matrix Kx;                     ///< m n_max x S: state gains, column-major m x n_k (rest unused)
  Matrix c;                      ///< m x S: constant part of b (dT and alpha folded in)
  Matrix huu;                    ///< m^2 x S: H = L_uu + mu I
};

/// The control law of trial i+1, built from nominal trial i (Algorithm 1, online part):
///
///   du = argmin_{du in U - u^i(tau)} 1/2 du^T H du + du^T b                          (33)
///   b  = alpha [(L_uz + F_u^T P) [dx; dT_alpha] + L_u + F_u^T p]     (kLyapunov, the paper)
///   b  = (L_uz + F_u^T P) [dx; dT_alpha] + alpha (L_u + F_u^T p)     (kRiccati, DDP)   (34)
///   u  = clamp(u^i(tau) + du, u_min, u_max)                                           (35)
///
/// with dx = x_measured - x^i(tau) the measured deviation from the nominal state at the same
/// normalized time and H = L_uu + mu I. The gains, H and the convention for alpha come from the
/// BackwardPass (each equation's convention makes the step a descent direction); the dT part is
/// folded into the constant at Load, so a Step costs O(n m + m^3).
///
/// Time mapping (see Policy): tau = k + clamp(t_since_mode_start / D_k^{i+1}, 0, 1) with the
/// planned durations of T^{i+1} = T^i + dT_alpha. A mode lasting longer than planned keeps the
/// gains and nominal of its last sample (tau = k+1); the next mode starts when the plant reports
/// the (measured) switch.
///
/// Robustness: a non-finite x or t gives u = clamp(u^i(tau)) (du = 0) and increments
/// nonfinite_count(); the output is never NaN. Wrong sizes or k throw InvalidArgument.
///
/// Lifecycle: Allocate (sizes), Load (between trials, no allocation), BeginTrial, Step (no
/// allocation).
class OnlineController : public Policy {
 public:
  OnlineController() = default;

  /// Sizes every buffer for up to max_samples nominal samples (allocates). The problem must
  /// outlive this object.
  void Allocate(const Problem& problem, int max_samples,
                const OnlineControllerSettings& settings = {});
  /// Loads the control law: nominal trajectory i, its backward pass, alpha and dT_alpha
  /// (T^{i+1} = nominal.T + dT). Does not allocate.
  void Load(const Trajectory& nominal, const BackwardPass& pass, double alpha,
            const ConstVectorRef& dT);
  bool loaded() const { return loaded_; }
  /// The loaded law as plain arrays (allocates). Throws InvalidArgument when nothing is loaded.
  OnlineControllerLaw ExportLaw() const;
  /// Loads a law exported by ExportLaw of a controller allocated for the same problem: a
  /// controller so loaded steps bitwise like the exporting one (with the same settings). Checks
  /// every size and value and throws InvalidArgument naming the first bad field, before anything
  /// changes. Does not allocate.
  void ImportLaw(const OnlineControllerLaw& law);

  void BeginTrial() override;
  double PlannedDuration(int k) const override { return planned_durations_(k); }
  /// One control step (33)-(35). Allocation-free.
  void Step(int k, double t_since_mode_start, const ConstVectorRef& x_measured,
            VectorRef u_out) override;

  double alpha() const { return alpha_; }
  /// The factor of the state feedback in b: alpha (kLyapunov) or 1 (kRiccati).
  double feedback_factor() const { return feedback_factor_; }
  const Vector& dT() const { return dT_; }                    ///< K
  const Vector& planned_T() const { return planned_T_; }      ///< K: T^{i+1}
  const Vector& nominal_T() const { return nominal_T_; }      ///< K: T^i
  /// int |du|^2 dtau accumulated over this trial's Step calls (left Riemann sum in tau; the
  /// interval after the last Step of a mode is not included). The Learner's (36) uses the
  /// measured inputs instead.
  double du_squared_integral() const { return du_integral_; }
  /// Steps with a non-finite state or time since BeginTrial.
  int nonfinite_count() const { return nonfinite_count_; }
  /// Box QPs that did not report kConverged since BeginTrial.
  int qp_failures() const { return qp_failures_; }
  /// The last du (m) and tau.
  const Vector& last_du() const { return du_; }
  double last_tau() const { return last_tau_; }
  const OnlineControllerSettings& settings() const { return settings_; }
  /// Replaces OnlineControllerSettings::state_feedback_scale (validated like Allocate: one
  /// vector per mode of that mode's state size, entries finite and >= 0; empty = as printed).
  /// Allocates; call between trials.
  void SetStateFeedbackScale(const std::vector<Vector>& scale);
  /// Blends the loaded law's state feedback with that of `law` (loaded for the same problem):
  /// G <- w G + (1 - w) H H_law^{-1} G_law, G the effective gain (feedback factor x K_x), with
  /// `law` read where the nominal was at each sample: at the time since the mode's start at
  /// which the nominal passed it (the nominal's durations; `law`'s planned durations). The
  /// feed-forward and the dT part stay. w in [0, 1]; w = 0 gives `law`'s feedback
  /// -H_law^{-1} G_law dx inside this law's box QP; a sample where H_law is not positive
  /// definite keeps this law's gain. With `feedforward` the unconstrained step also moves by
  /// (1 - w) e, e = `law`'s unconstrained command at the nominal's state minus the nominal's
  /// input (c <- c - (1 - w) H e): at w = 0 this law's answer from any state is `law`'s own
  /// unconstrained command plus this law's step, and (with the same H) `law`'s clamped command
  /// when the step is 0. Bad input throws before anything changes. No allocation.
  /// docs/engine.md, "The trial's feedback".
  void BlendStateFeedback(const OnlineController& law, double w, bool feedforward = false);

 private:
  // From the interval *j of mode k (in, out), finds j with tau_j <= tau <= tau_{j+1}; returns
  // the linear weight of sample j + 1, clamped to [0, 1].
  double Interval(int k, double tau, int* j) const;
  // Interval from Step's cursor; the weight follows settings().interpolate.
  double Locate(int k, double tau, int* j);
  // *H = (1 - a) H(s0) + a H(s1), the global samples' H = L_uu + mu I.
  void InterpolateHessian(int s0, int s1, double a, Matrix* H) const;
  void Accumulate(int k, double tau);
  // planned_T_ = nominal_T_ + dT_ and planned_durations_ from it.
  void PlanDurations();
  // Throws InvalidArgument naming `who` when a duration of T = nominal_T + dT is not > 0.
  void CheckPlannedDurations(const ConstVectorRef& nominal_T, const ConstVectorRef& dT,
                             const char* who) const;

  const Problem* problem_ = nullptr;
  OnlineControllerSettings settings_;
  int K_ = 0, m_ = 0, n_max_ = 0;
  bool loaded_ = false;
  SampleLayout layout_;          // n_k, N_k of the loaded nominal, mode-major sample indices
  std::vector<int> cursor_;      // K: last interval found by Step, per mode
  double alpha_ = 0;
  Vector dT_, planned_T_, nominal_T_, planned_durations_;  // K
  // Per sample (global index, mode-major).
  Vector tau_;  // S
  Matrix x_;    // n_max x S: nominal states
  Matrix u_;    // m x S: nominal inputs
  Matrix Kx_;   // m * n_max x S: state gain (L_uz + F_u^T P)(:, 0:n_k), column-major m x n_k
  Matrix c_;    // m x S: the constant part of b (dT and alpha folded in)
  Matrix huu_;  // m^2 x S: H = L_uu + mu I
  double feedback_factor_ = 1;  // alpha (kLyapunov) or 1 (kRiccati)
  // Step workspace.
  BoxQP qp_;
  Vector dx_;      // n_max
  Vector xnom_;    // n_max
  Vector unom_;    // m
  Vector b_;       // m
  Matrix H_;       // m x m
  Vector lo_, hi_; // m
  Vector du_;      // m
  // Content revision: a number no other state of any controller had, new at every change of the
  // law (Allocate, Load, ImportLaw, BlendStateFeedback); copies share it with their content.
  std::uint64_t revision_ = 0;
  static std::uint64_t NextRevision();
  // BlendStateFeedback's H_law^{-1} G_law of every sample (m * n_max x S, sized by the first
  // blend; blend_ok_ 0: no feedback to take), valid for the law of blend_law_revision_ at this
  // controller's tau_, nominal_T_ and counts as they were (the learner blends every trial of a
  // nominal with the same law).
  Matrix blend_g_;
  // With the feed-forward, the same samples' e (m x S): `law`'s unconstrained command at
  // x^i(tau) minus u^i(tau), computed only when a blend asks for it (blend_has_e_) and kept
  // under the same key, which does not see a change of x^i or u^i alone (the learner blends
  // after each Load of one nominal; a new nominal comes with a new law or new durations).
  Matrix blend_e_;
  bool blend_has_e_ = false;
  Vector blend_dx_;  // n_max: x^i(tau) - `law`'s state there
  std::vector<char> blend_ok_;
  std::uint64_t blend_law_revision_ = 0;
  Vector blend_tau_, blend_T_;
  std::vector<int> blend_counts_;
  Eigen::LLT<Matrix> llt_;  // m x m: BlendStateFeedback's factor of H_law
  // Per-trial bookkeeping.
  double du_integral_ = 0;
  double last_tau_ = 0;
  double last_du_sq_ = 0;
  int last_mode_ = -1;
  int nonfinite_count_ = 0;
  int qp_failures_ = 0;
};

}  // namespace ddoc

#endif  // DDOC_ONLINE_CONTROLLER_H_
