// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The stiffness dynamics of the two variable-stiffness actuators (paper Section V-A):
//
//   kdd + 2 beta kd + beta^2 k = beta^2 k0,
//
// a critically damped second-order servo per stiffness. In the MuJoCo harness these states
// live BESIDE the simulation (not as MuJoCo activations): they are advanced once per step by
// the exact zero-order-hold solution below, with k0 held over the step.
#ifndef DDOC_HOPPER_VSA_H_
#define DDOC_HOPPER_VSA_H_

namespace ddoc {

/// Default stiffness bandwidth beta in rad/s (not given in the paper; 20-25 rad/s is typical of
/// VSA servo models). The MJCF may override it with <numeric name="vsa_beta">.
constexpr double kDefaultVsaBeta = 20.0;

/// The two stiffness states and their rates.
struct VsaState {
  double k_hip = 0.0;   ///< hip stiffness k_1, N m / rad
  double k_leg = 0.0;   ///< leg stiffness k_2, N / m
  double kd_hip = 0.0;  ///< d k_hip / dt
  double kd_leg = 0.0;  ///< d k_leg / dt
};

/// Exact zero-order-hold step of kdd + 2 beta kd + beta^2 k = beta^2 k0 over dt >= 0.
/// With e = k - k0:  e(t)  = exp(-beta t) [(1 + beta t) e0 + t ed0],
///                   ed(t) = exp(-beta t) [-beta^2 t e0 + (1 - beta t) ed0].
void AdvanceStiffness(double beta, double dt, double k0, double* k, double* kd);

/// The pair of VSA stiffness servos of the hopper.
class Vsa {
 public:
  /// beta > 0 (rad/s); throws ddoc::InvalidArgument otherwise.
  explicit Vsa(double beta = kDefaultVsaBeta, const VsaState& state = VsaState());

  /// Advances both stiffnesses by dt with the commanded (k0_hip, k0_leg) held constant.
  void Advance(double dt, double k0_hip, double k0_leg);
  /// Resets the states, e.g. to k = k0, kd = 0 at the start of a trial.
  void Reset(const VsaState& state) { state_ = state; }

  const VsaState& state() const { return state_; }
  double beta() const { return beta_; }

 private:
  double beta_;     // rad/s
  VsaState state_;  // k_hip, k_leg and rates
};

}  // namespace ddoc

#endif  // DDOC_HOPPER_VSA_H_
