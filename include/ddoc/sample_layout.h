// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Where the samples of a trajectory sit in per-sample buffers (BackwardPass, OnlineController).
#ifndef DDOC_SAMPLE_LAYOUT_H_
#define DDOC_SAMPLE_LAYOUT_H_

#include <vector>

#include "ddoc/switched_system.h"
#include "ddoc/trajectory.h"

namespace ddoc {

/// The global sample index of a trajectory, mode-major: the N_0 samples of mode 0 first, then
/// the N_1 samples of mode 1, ...; sample j of mode k has index(k, j) = offset(k) + j. Buffers
/// with one column per sample (sized max_samples at Allocate) are addressed with it.
///
/// Lifecycle: Allocate once (sizes), Assign per trajectory (no allocation).
class SampleLayout {
 public:
  /// Sizes the layout for the modes of `system` and at most max_samples samples in total
  /// (allocates). Throws InvalidArgument naming `who` when max_samples < 2.
  void Allocate(const SwitchedSystem& system, int max_samples, const char* who);

  /// Takes the sample counts of `trajectory`. Checks, naming `who` in the message: K modes,
  /// every mode with N_k >= 2 samples, x of n_k x N_k, u of m x N_k, at most max_samples samples
  /// in total. Allocation-free. Returns the total number of samples.
  int Assign(const Trajectory& trajectory, const char* who);

  /// The total of the sample counts N_k, checked without changing the layout: K of them, each
  /// >= 2, at most max_samples in all; else throws InvalidArgument naming `who` and the count.
  int CheckCounts(const std::vector<int>& counts, const char* who) const;
  /// Takes the sample counts N_k directly (checked as CheckCounts). Allocation-free. Returns the
  /// total.
  int AssignCounts(const std::vector<int>& counts, const char* who);

  int num_modes() const { return static_cast<int>(dims_.size()); }  ///< K
  int input_dim() const { return m_; }                               ///< m
  int max_samples() const { return max_samples_; }
  int total() const { return total_; }                   ///< samples of the last Assign
  int dim(int k) const { return dims_[k]; }              ///< n_k
  int count(int k) const { return counts_[k]; }          ///< N_k of the last Assign
  int offset(int k) const { return offsets_[k]; }        ///< index of sample 0 of mode k
  int index(int k, int j) const { return offsets_[k] + j; }

 private:
  std::vector<int> dims_;     // K: n_k
  std::vector<int> counts_;   // K: N_k of the last Assign
  std::vector<int> offsets_;  // K: first global index of mode k
  int m_ = 0;
  int total_ = 0;
  int max_samples_ = 0;

  // counts_ holds the new N_k: sets the offsets and the total, or throws naming `who` when the
  // total exceeds max_samples.
  int Commit(const char* what, const char* who);
};

}  // namespace ddoc

#endif  // DDOC_SAMPLE_LAYOUT_H_
