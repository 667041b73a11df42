// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A sampled trajectory of one trial (measured on a plant or predicted by a model).
#ifndef DDOC_TRAJECTORY_H_
#define DDOC_TRAJECTORY_H_

#include <vector>

#include "ddoc/switched_system.h"

namespace ddoc {

/// Samples of one mode k on [T_{k-1}, T_k].
///
/// A mode of zero duration (T_k = T_{k-1}, allowed when Bounds::duration_min(k) = 0) has its
/// samples at that one instant (a model plant records two: the entry state and, unchanged, the
/// pre-switch state); Tau spreads them evenly over [k, k+1].
/// Sample 0 is at t = T_{k-1} and holds the post-reset state x^+(T_{k-1}) (x0 for k = 0);
/// the last sample is at t = T_k and holds the PRE-switch state x^-(T_k). Times are absolute
/// from the start of the trial (t = 0) and non-decreasing, at least 2 samples per mode.
/// Column j of `u` is the input applied from sample j on (zero-order hold); the last column
/// repeats the input in effect at the switch.
struct ModeTrajectory {
  Vector t;  ///< N_k sample times
  Matrix x;  ///< n_k x N_k states
  Matrix u;  ///< m x N_k applied inputs

  int num_samples() const { return static_cast<int>(t.size()); }
};

/// One trial: K modes, the measured switching instants and the initial state.
struct Trajectory {
  std::vector<ModeTrajectory> modes;  ///< K modes
  Vector T;                           ///< K switching instants; T(k) = modes[k].t(last), T(K-1) = end
  Vector x0;                          ///< n_0 initial state (= modes[0].x.col(0))

  int num_modes() const { return static_cast<int>(modes.size()); }
  /// Total number of samples over all modes.
  int total_samples() const;
  /// Start time of mode k: 0 for k = 0, else T(k-1).
  double ModeStart(int k) const { return k == 0 ? 0.0 : T(k - 1); }
  /// Normalized time (12) of sample j of mode k: tau = k + (t - T_{k-1}) / (T_k - T_{k-1});
  /// k + j / (N_k - 1) for a mode of zero duration.
  double Tau(int k, int j) const;

  /// Structural checks; throws InvalidArgument naming the offending mode/sample/quantity:
  /// K == 0, fewer than 2 samples, size mismatches between t/x/u, non-finite or decreasing
  /// times, first sample of mode 0 not at t = 0, mode k not starting at T(k-1), last sample not
  /// at T(k), negative durations (zero is legal), non-finite states or inputs, x0 != first state.
  void Validate() const;
  /// Validate() plus dimensions against a system: K, n_k, m.
  void Validate(const SwitchedSystem& system) const;
};

/// Records a trajectory sample by sample, e.g. from inside a simulator callback.
/// Reserve() once; then BeginMode/AddSample/EndMode do not allocate as long as the
/// reserved number of samples per mode is not exceeded (beyond it, storage doubles).
class TrajectoryRecorder {
 public:
  /// Sizes the buffers: K modes with state dims n_k, input dim m, max samples per mode.
  void Reserve(const std::vector<int>& state_dims, int input_dim, int max_samples_per_mode);
  void Reserve(const SwitchedSystem& system, int max_samples_per_mode);
  /// Clears all recorded samples (keeps capacity).
  void Clear();
  /// Starts recording mode k (modes must be recorded in order 0..K-1).
  void BeginMode(int k);
  /// Appends (t, x, u) to the current mode.
  void AddSample(double t, const ConstVectorRef& x, const ConstVectorRef& u);
  /// Ends the current mode; its last sample becomes T_k.
  void EndMode();
  /// Number of modes completed so far.
  int completed_modes() const { return completed_; }
  /// Copies the recorded modes into `out` (allocates). Throws if not all K modes are complete.
  void Finish(Trajectory* out) const;

 private:
  struct Buffer {
    std::vector<double> t;  // capacity max samples
    Matrix x;               // n_k x capacity
    Matrix u;               // m x capacity
    int count = 0;
  };
  std::vector<Buffer> buffers_;  // K
  int current_ = -1;
  int completed_ = 0;
};

}  // namespace ddoc

#endif  // DDOC_TRAJECTORY_H_
