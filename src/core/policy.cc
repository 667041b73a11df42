// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/policy.h"

#include <algorithm>
#include <cmath>

namespace ddoc {

double NormalizedTime(int k, double t_since_mode_start, double planned_duration) {
  double s = t_since_mode_start / planned_duration;
  if (!std::isfinite(s)) s = 0.0;
  return k + std::min(std::max(s, 0.0), 1.0);
}

OpenLoopPolicy::OpenLoopPolicy(const Trajectory& trajectory)
    : OpenLoopPolicy(trajectory, trajectory.T) {}

OpenLoopPolicy::OpenLoopPolicy(const Trajectory& trajectory, const ConstVectorRef& T_planned)
    : nominal_(trajectory) {
  nominal_.Validate();
  const int K = nominal_.num_modes();
  if (T_planned.size() != K) {
    throw InvalidArgument("OpenLoopPolicy: T_planned has size " +
                          std::to_string(T_planned.size()) + ", expected K = " +
                          std::to_string(K));
  }
  durations_.resize(K);
  tau_.resize(K);
  cursor_.assign(K, 0);
  for (int k = 0; k < K; ++k) {
    durations_(k) = T_planned(k) - (k == 0 ? 0.0 : T_planned(k - 1));
    // 0 is a vanished mode (Bounds::duration_min = 0): its inputs are those at tau = k.
    if (!(durations_(k) >= 0) || !std::isfinite(durations_(k))) {
      throw InvalidArgument("OpenLoopPolicy: planned duration of mode " + std::to_string(k) +
                            " is " + std::to_string(durations_(k)) + ", expected >= 0");
    }
    tau_[k].resize(nominal_.modes[k].num_samples());
    for (int j = 0; j < nominal_.modes[k].num_samples(); ++j) tau_[k](j) = nominal_.Tau(k, j);
  }
}

void OpenLoopPolicy::BeginTrial() { std::fill(cursor_.begin(), cursor_.end(), 0); }

void OpenLoopPolicy::Step(int k, double t_since_mode_start, const ConstVectorRef& /*x*/,
                          VectorRef u) {
  if (k < 0 || k >= nominal_.num_modes() || u.size() != nominal_.modes[0].u.rows()) {
    throw InvalidArgument("OpenLoopPolicy::Step: mode " + std::to_string(k) + " or u size " +
                          std::to_string(u.size()) + " invalid");
  }
  const double tau = NormalizedTime(k, t_since_mode_start, durations_(k));
  const Vector& taus = tau_[k];
  const int N = static_cast<int>(taus.size());
  int j = std::min(cursor_[k], N - 2);
  while (j > 0 && taus(j) > tau) --j;
  while (j < N - 2 && taus(j + 1) < tau) ++j;
  cursor_[k] = j;
  const double span = taus(j + 1) - taus(j);
  double w = span > 0 ? (tau - taus(j)) / span : 1.0;
  w = std::min(std::max(w, 0.0), 1.0);
  const Matrix& U = nominal_.modes[k].u;
  u = (1.0 - w) * U.col(j) + w * U.col(j + 1);
}

FunctionPolicy::FunctionPolicy(const ConstVectorRef& planned_durations, Function fn)
    : durations_(planned_durations), fn_(std::move(fn)) {
  for (int k = 0; k < durations_.size(); ++k) {
    if (!(durations_(k) >= 0) || !std::isfinite(durations_(k))) {  // 0: a vanished mode
      throw InvalidArgument("FunctionPolicy: planned duration of mode " + std::to_string(k) +
                            " is " + std::to_string(durations_(k)) + ", expected >= 0");
    }
  }
  if (!fn_) throw InvalidArgument("FunctionPolicy: empty function");
}

void FunctionPolicy::Step(int k, double t_since_mode_start, const ConstVectorRef& x, VectorRef u) {
  fn_(k, NormalizedTime(k, t_since_mode_start, durations_(k)), x, u);
}

}  // namespace ddoc
