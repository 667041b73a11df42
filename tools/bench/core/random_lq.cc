// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Random switched linear-quadratic problems, none of them in the suite: K = 2-3 modes, n = 2-3
// states, m = 1-2 unbounded inputs, identity resets, a fixed final time of 2 s, durations >= 10 ms.
// Each is solved by the default preset from equal durations and u^0 = 0, and compared with
//   - its global optimum: the closed-form optimal cost (LqOptimalCost) on a grid of the free
//     instants (steps of 25 ms, plus the instants that put a duration on its 10 ms bound), then
//     Newton from the best point (LqReference);
//   - the first-order conditions at the engine's instants: the independent switching gradient
//     (LqSwitchingGradient) in durations, zero where a duration is free and pointing out of the
//     box where it sits on its bound.
//
//   random_lq [--problems 100] [--seed 1] [--max-trials 100] [--verbose]
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <CLI/CLI.hpp>

#include "ddoc/ddoc.h"
#include "standard_problems.h"
#include "standard_references.h"

namespace ddoc {
namespace {

using testing::LinearQuadraticData;

constexpr double kFinalTime = 2.0;
constexpr double kMinDuration = 0.01;  // the duration bound StandardProblemFromLq poses

LinearQuadraticData RandomProblem(std::mt19937* rng) {
  std::normal_distribution<double> normal;
  std::uniform_int_distribution<int> modes(2, 3), states(2, 3), inputs(1, 2);
  LinearQuadraticData d;
  const int K = modes(*rng), n = states(*rng), m = inputs(*rng);
  auto random = [&](int rows, int cols, double scale) {
    Matrix M(rows, cols);
    for (int i = 0; i < rows * cols; ++i) M.data()[i] = scale * normal(*rng);
    return M;
  };
  for (int k = 0; k < K; ++k) {
    d.A.push_back(random(n, n, 0.8));
    d.B.push_back(random(n, m, 1.0));
    const Matrix M = random(n, n, 1.0);
    d.Q.push_back(0.5 * M * M.transpose() / n);
    d.r.push_back(random(n, 1, 1.0));
    const Matrix N = random(m, m, 1.0);
    d.R.push_back(0.3 * N * N.transpose() + 0.2 * Matrix::Identity(m, m));
    d.rho.push_back(0.2 * std::abs(normal(*rng)));
    d.S.push_back(k == K - 1 ? Matrix(Matrix::Identity(n, n)) : Matrix(Matrix::Zero(n, n)));
    d.s.push_back(random(n, 1, 1.0));
    if (k + 1 < K) d.E.push_back(Matrix::Identity(n, n));
  }
  d.u_min = Vector::Constant(m, -std::numeric_limits<double>::infinity());
  d.u_max = -d.u_min;
  d.x0 = random(n, 1, 1.0);
  d.final_time = kFinalTime;
  return d;
}

// The global optimum over the free instants: the best grid point, then Newton from it.
testing::ReferenceOptimum GlobalOptimum(const LinearQuadraticData& d) {
  const int K = d.num_modes(), G = 80;
  // Instants on a grid of kFinalTime / G, plus those that put a duration on its bound.
  std::vector<double> grid = {kMinDuration};
  for (int i = 1; i < G; ++i) grid.push_back(kFinalTime * i / G);
  grid.push_back(kFinalTime - kMinDuration);
  double best = std::numeric_limits<double>::infinity();
  Vector best_T(K), T(K);
  T(K - 1) = kFinalTime;
  auto consider = [&]() {
    for (int k = 0; k < K; ++k) {
      if (T(k) - (k == 0 ? 0.0 : T(k - 1)) < kMinDuration - 1e-12) return;
    }
    const double cost = testing::LqOptimalCost(d, T);
    if (cost < best) {
      best = cost;
      best_T = T;
    }
  };
  for (const double t0 : grid) {
    T(0) = t0;
    if (K == 2) {
      consider();
      continue;
    }
    for (const double t1 : grid) {
      T(1) = t1;
      consider();
    }
    T(1) = t0 + kMinDuration;  // the middle mode on its bound
    consider();
  }
  return testing::LqReference(d, best_T, kMinDuration);
}

// The largest violation of the first-order conditions in durations (dJ/dD_k = sum_{j >= k}
// dJ/dT_j over the free instants, D_{K-1} taking up the rest): |dJ/dD| on a free duration, the
// part pointing into the box on one at its bound.
double KktViolation(const LinearQuadraticData& d, const Vector& T) {
  const int K = d.num_modes();
  const Vector g = testing::LqSwitchingGradient(d, T);  // dJ/dT_k, k < K - 1
  double worst = 0;
  for (int k = 0; k + 1 < K; ++k) {
    // Lengthening D_k by e with the others fixed moves T_k..T_{K-2} by e and shortens D_{K-1}.
    double dD = 0;
    for (int j = k; j + 1 < K; ++j) dD += g(j);
    const double D = T(k) - (k == 0 ? 0.0 : T(k - 1));
    const double last = T(K - 1) - T(K - 2);
    const bool at_min = D <= kMinDuration + 1e-6, last_at_min = last <= kMinDuration + 1e-6;
    double v = std::abs(dD);
    if (at_min) v = std::max(0.0, -dD);        // may only grow: needs dJ/dD >= 0
    if (last_at_min) v = std::max(0.0, dD);    // may only shrink: needs dJ/dD <= 0
    if (at_min && last_at_min) v = 0;
    worst = std::max(worst, v);
  }
  return worst;
}

int Main(int argc, char** argv) {
  CLI::App app("Random switched LQ problems against their global optimum");
  int problems = 100, seed = 1, max_trials = 100;
  bool verbose = false;
  app.add_option("--problems", problems, "number of problems")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "random seed");
  app.add_option("--max-trials", max_trials, "trial budget per run")->check(CLI::PositiveNumber);
  app.add_flag("--verbose", verbose, "every problem that misses the global optimum");
  CLI11_PARSE(app, argc, argv);
  std::mt19937 rng(static_cast<unsigned>(seed));
  int converged = 0, global = 0, stationary = 0, most_trials = 0;
  double worst_ratio = 1;
  for (int p = 0; p < problems; ++p) {
    const LinearQuadraticData d = RandomProblem(&rng);
    const int K = d.num_modes();
    const testing::ReferenceOptimum ref = GlobalOptimum(d);
    // The suite's posing: durations in [10 ms, 2 s], the final time fixed, u^0 = 0.
    const std::unique_ptr<testing::StandardProblem> sp = testing::StandardProblemFromLq(d);
    sp->problem.Validate();
    sp->initial_durations = Vector::Constant(K, kFinalTime / K);
    FunctionPolicy initial = sp->InitialPolicy();
    LearnerSettings settings;
    settings.max_trials = max_trials;
    const SolveResult r = testing::SolveOnModel(*sp, initial, settings);
    const bool ok = r.status == LearnerStatus::kConverged;
    const bool at_global = ok && std::abs(r.cost - ref.cost) <= 1e-3 * std::abs(ref.cost) &&
                           (r.T - ref.T).cwiseAbs().maxCoeff() <= 1e-3;
    // First order at the engine's instants, relative to the gradient's size at the start.
    const double scale = 1.0 + KktViolation(d, Vector::LinSpaced(K, kFinalTime / K, kFinalTime));
    const double violation = KktViolation(d, r.T);
    const bool kkt = violation <= 1e-3 * scale;
    converged += ok;
    global += at_global;
    stationary += ok && kkt;
    most_trials = std::max(most_trials, r.trials);
    if (ok && !at_global) worst_ratio = std::max(worst_ratio, r.cost / ref.cost);
    if (verbose && !at_global) {
      std::fprintf(stderr, "problem %d (K %d, n %d, m %d): %s, %d trials, cost %.4f x I*, T (",
                   p, K, d.state_dim(0), d.input_dim(), LearnerStatusName(r.status), r.trials,
                   r.cost / ref.cost);
      for (int k = 0; k < K; ++k) std::fprintf(stderr, "%s%.3f", k ? ", " : "", r.T(k));
      std::fprintf(stderr, ") s, first-order violation %.1e\n", violation);
    }
  }
  std::printf("| problems | converged | first-order point | at the global optimum | the others: "
              "cost / I* up to | trials (max) |\n|---:|---:|---:|---:|---:|---:|\n");
  std::printf("| %d | %d | %d | %d | %.3f | %d |\n", problems, converged, stationary, global,
              worst_ratio, most_trials);
  return 0;
}

}  // namespace
}  // namespace ddoc

int main(int argc, char** argv) { return ddoc::Main(argc, argv); }
