// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/sample_layout.h"

#include <sstream>
#include <string>

namespace ddoc {

void SampleLayout::Allocate(const SwitchedSystem& system, int max_samples, const char* who) {
  if (max_samples < 2) {
    throw InvalidArgument(std::string(who) + ": max_samples = " + std::to_string(max_samples) +
                          ", expected >= 2");
  }
  const int K = system.num_modes();
  dims_.resize(K);
  for (int k = 0; k < K; ++k) dims_[k] = system.state_dim(k);
  counts_.assign(K, 0);
  offsets_.assign(K, 0);
  m_ = system.input_dim();
  total_ = 0;
  max_samples_ = max_samples;
}

int SampleLayout::Assign(const Trajectory& trajectory, const char* who) {
  const int K = num_modes();
  if (trajectory.num_modes() != K) {
    throw InvalidArgument(std::string(who) + ": trajectory has " +
                          std::to_string(trajectory.num_modes()) + " modes, expected K = " +
                          std::to_string(K));
  }
  for (int k = 0; k < K; ++k) {
    const ModeTrajectory& mode = trajectory.modes[k];
    const int N = mode.num_samples();
    if (N < 2 || mode.x.rows() != dims_[k] || mode.x.cols() != N || mode.u.rows() != m_ ||
        mode.u.cols() != N) {
      std::ostringstream os;
      os << who << ": mode " << k << " has " << N << " samples, x " << mode.x.rows() << "x"
         << mode.x.cols() << ", u " << mode.u.rows() << "x" << mode.u.cols()
         << "; expected >= 2 samples, x n_k = " << dims_[k] << " rows, u m = " << m_ << " rows";
      throw InvalidArgument(os.str());
    }
    counts_[k] = N;
  }
  return Commit("trajectory", who);
}

int SampleLayout::CheckCounts(const std::vector<int>& counts, const char* who) const {
  const int K = num_modes();
  if (static_cast<int>(counts.size()) != K) {
    throw InvalidArgument(std::string(who) + ": samples has " + std::to_string(counts.size()) +
                          " entries, expected K = " + std::to_string(K));
  }
  long total = 0;
  for (int k = 0; k < K; ++k) {
    if (counts[k] < 2) {
      throw InvalidArgument(std::string(who) + ": samples[" + std::to_string(k) + "] = " +
                            std::to_string(counts[k]) + ", expected >= 2");
    }
    total += counts[k];
  }
  if (total > max_samples_) {
    throw InvalidArgument(std::string(who) + ": " + std::to_string(total) +
                          " samples, more than max_samples = " + std::to_string(max_samples_) +
                          " (the size allocated; for a Learner LearnerSettings.max_samples: "
                          "raise it to at least " + std::to_string(total) + ")");
  }
  return static_cast<int>(total);
}

int SampleLayout::AssignCounts(const std::vector<int>& counts, const char* who) {
  CheckCounts(counts, who);
  for (int k = 0; k < num_modes(); ++k) counts_[k] = counts[k];
  return Commit("law", who);
}

int SampleLayout::Commit(const char* what, const char* who) {
  int total = 0;
  for (int k = 0; k < num_modes(); ++k) {
    offsets_[k] = total;
    total += counts_[k];
  }
  if (total > max_samples_) {
    throw InvalidArgument(std::string(who) + ": " + what + " has " + std::to_string(total) +
                          " samples, more than max_samples = " + std::to_string(max_samples_) +
                          " (the size allocated; for a Learner LearnerSettings.max_samples: "
                          "raise it to at least " + std::to_string(total) + ")");
  }
  total_ = total;
  return total;
}

}  // namespace ddoc
