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
    // Trapezoidal rule on each sample interval with the input held there (zero-order hold):
    // int_{t_j}^{t_{j+1}} l dt ~ (t_{j+1} - t_j) (l(x_j, u_j) + l(x_{j+1}, u_j)) / 2.
    double running = 0;
    if (cost.prefers_batch() && N > 1) {
      // One RunningBatch call for the mode: the left ends (x_j, u_j) then the right ends
      // (x_{j+1}, u_j), summed in the per-point loop's order.
      const int I = N - 1;
      Matrix X(mode.x.rows(), 2 * I), U(mode.u.rows(), 2 * I);
      X << mode.x.leftCols(I), mode.x.rightCols(I);
      U << mode.u.leftCols(I), mode.u.leftCols(I);
      Vector l(2 * I);
      cost.RunningBatch(k, X, U, l);
      for (int j = 0; j < I; ++j) running += 0.5 * (mode.t(j + 1) - mode.t(j)) * (l(j) + l(I + j));
    } else {
      for (int j = 0; j + 1 < N; ++j) {
        const auto u = mode.u.col(j);
        running += 0.5 * (mode.t(j + 1) - mode.t(j)) *
                   (cost.Running(k, mode.x.col(j), u) + cost.Running(k, mode.x.col(j + 1), u));
      }
    }
    out.running(k) = running;
    out.switching(k) = cost.Switching(k, mode.x.col(N - 1));
    if (problem.SurfaceWeight(k) > 0) {
      Vector h(sys.surface_dim(k));
      sys.Surface(k, mode.x.col(N - 1), h);
      out.surface(k) = problem.SurfaceWeight(k) * h.squaredNorm();
    }
  }
  out.total = out.running.sum() + out.switching.sum() + out.surface.sum();
  return out;
}

}  // namespace ddoc
