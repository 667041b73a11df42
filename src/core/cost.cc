// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/cost.h"

namespace ddoc {

CostBreakdown EvaluateCost(const Problem& problem, const Trajectory& trajectory) {
  problem.Validate();
  trajectory.Validate(*problem.system);
  const SwitchedSystem& sys = *problem.system;
  const SwitchedCost& cost = *problem.cost;
  const int K = sys.num_modes();
  CostBreakdown out;
  out.running = Vector::Zero(K);
  out.switching = Vector::Zero(K);
  out.surface = Vector::Zero(K);
  for (int k = 0; k < K; ++k) {
    const ModeTrajectory& mode = trajectory.modes[k];
    const int N = mode.num_samples();
    // Trapezoidal rule on the samples.
    double prev = cost.Running(k, mode.x.col(0), mode.u.col(0));
    double running = 0;
    for (int j = 1; j < N; ++j) {
      const double cur = cost.Running(k, mode.x.col(j), mode.u.col(j));
      running += 0.5 * (mode.t(j) - mode.t(j - 1)) * (prev + cur);
      prev = cur;
    }
    out.running(k) = running;
    out.switching(k) = cost.Switching(k, mode.x.col(N - 1));
    if (problem.surface_weights(k) > 0) {
      Vector h(sys.surface_dim(k));
      sys.Surface(k, mode.x.col(N - 1), h);
      out.surface(k) = problem.surface_weights(k) * h.squaredNorm();
    }
  }
  out.total = out.running.sum() + out.switching.sum() + out.surface.sum();
  return out;
}

}  // namespace ddoc
