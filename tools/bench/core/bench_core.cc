// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// bench_core: the online step (33)-(34) and the backward pass (30).
#include <memory>
#include <random>

#include <benchmark/benchmark.h>

#include "ddoc/backward_pass.h"
#include "ddoc/learner.h"
#include "ddoc/online_controller.h"
#include "ddoc/plant.h"

namespace ddoc {
namespace {

constexpr int kModes = 2;

// xdot = A_k x + B_k u, identity-like reset, quadratic costs; hand-written derivatives.
class LinearSystem : public SwitchedSystem {
 public:
  LinearSystem(int n, int m, std::mt19937* rng)
      : SwitchedSystem({n, n}, m), A_(n, n), B_(n, m) {
    std::normal_distribution<double> nd(0.0, 1.0 / std::sqrt(n));
    for (int i = 0; i < n * n; ++i) A_.data()[i] = nd(*rng);
    for (int i = 0; i < n * m; ++i) B_.data()[i] = nd(*rng);
  }

 protected:
  void DoFlow(int, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef xdot) const override {
    xdot.noalias() = A_ * x;
    xdot.noalias() += B_ * u;
  }
  void DoFlowDerivatives(int, const ConstVectorRef&, const ConstVectorRef&, MatrixRef fx,
                         MatrixRef fu) const override {
    fx = A_;
    fu = B_;
  }
  void DoReset(int, const ConstVectorRef& x, VectorRef x_next) const override { x_next = x; }
  void DoResetDerivative(int, const ConstVectorRef&, MatrixRef gx) const override {
    gx.setIdentity();
  }

 private:
  Matrix A_, B_;
};

class QuadCost : public SwitchedCost {
 protected:
  double DoRunning(int, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    return 0.5 * x.squaredNorm() + 0.05 * u.squaredNorm();
  }
  void DoRunningDerivatives(int, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    lx = x;
    lu = 0.1 * u;
    lxx.setIdentity();
    luu.setIdentity();
    luu *= 0.1;
    lux.setZero();
  }
  double DoSwitching(int, const ConstVectorRef& x) const override { return x.squaredNorm(); }
  void DoSwitchingDerivatives(int, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    phix = 2 * x;
    phixx.setIdentity();
    phixx *= 2;
  }
};

struct Setup {
  std::mt19937 rng{42};
  std::unique_ptr<LinearSystem> sys;
  QuadCost cost;
  Problem problem;
  Trajectory nominal;

  Setup(int n, int m, int samples) {
    sys = std::make_unique<LinearSystem>(n, m, &rng);
    problem.system = sys.get();
    problem.cost = &cost;
    problem.bounds.u_min = Vector::Constant(m, -0.3);
    problem.bounds.u_max = Vector::Constant(m, 0.3);
    problem.bounds.duration_min = Vector::Constant(kModes, 0.01);
    problem.bounds.duration_max = Vector::Constant(kModes, 100.0);
    problem.surface_weights = Vector::Zero(kModes);
    // A synthetic nominal: samples/2 samples per mode, random smooth-ish states and inputs.
    std::normal_distribution<double> nd;
    nominal.modes.resize(kModes);
    const int per_mode = samples / kModes;
    const double dt = 1e-3;
    for (int k = 0; k < kModes; ++k) {
      ModeTrajectory& mode = nominal.modes[k];
      const double start = k * (per_mode - 1) * dt;
      mode.t = Vector::LinSpaced(per_mode, start, start + (per_mode - 1) * dt);
      mode.x.resize(n, per_mode);
      mode.u.resize(m, per_mode);
      for (int i = 0; i < mode.x.size(); ++i) mode.x.data()[i] = 0.5 * nd(rng);
      for (int i = 0; i < mode.u.size(); ++i) mode.u.data()[i] = 0.1 * nd(rng);
    }
    nominal.T = Vector(kModes);
    for (int k = 0; k < kModes; ++k) nominal.T(k) = nominal.modes[k].t(per_mode - 1);
    nominal.x0 = nominal.modes[0].x.col(0);
  }
};

// Args: m, n + K.
void BM_OnlineStep(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0));
  const int n = static_cast<int>(state.range(1)) - kModes;
  Setup s(n, m, 600);
  BackwardPass pass;
  pass.Allocate(s.problem, 600);
  pass.Run(s.nominal);
  OnlineController ctrl;
  ctrl.Allocate(s.problem, 600);
  const Vector dT = Vector::Constant(kModes, 0.001);
  ctrl.Load(s.nominal, pass, 0.5, dT);
  Vector x(n), u(m);
  std::normal_distribution<double> nd;
  const int steps = 299;
  int i = 0;
  for (auto _ : state) {
    const int k = (i / steps) % kModes;
    const int j = i % steps;
    x = s.nominal.modes[k].x.col(j);
    x(j % n) += 0.5;  // a measured deviation
    ctrl.Step(k, (j + 0.5) * 1e-3, x, u);
    benchmark::DoNotOptimize(u.data());
    ++i;
  }
  state.counters["qp_failures"] = ctrl.qp_failures();
}
BENCHMARK(BM_OnlineStep)
    ->ArgNames({"m", "nK"})
    ->ArgsProduct({{4, 8, 20}, {16, 32}})
    ->Unit(benchmark::kMicrosecond);

// Args: m, n + K, blend (0: Load alone, the bare baseline; 1: Load then BlendStateFeedback with
// another loaded law, what a trial costs with LearnerSettings::blend_feedback; 2: the same with
// the feed-forward, LearnerSettings::blend_feedforward). 600 samples.
void BM_LoadTrialLaw(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0));
  const int n = static_cast<int>(state.range(1)) - kModes;
  const bool blend = state.range(2) != 0, feedforward = state.range(2) == 2;
  Setup s(n, m, 600);
  BackwardPass pass;
  pass.Allocate(s.problem, 600);
  pass.Run(s.nominal);
  OnlineController ctrl, nominal_law;
  ctrl.Allocate(s.problem, 600);
  nominal_law.Allocate(s.problem, 600);
  const Vector dT = Vector::Constant(kModes, 0.001);
  nominal_law.Load(s.nominal, pass, 0.0, Vector::Zero(kModes));
  for (auto _ : state) {
    ctrl.Load(s.nominal, pass, 0.25, dT);
    if (blend) ctrl.BlendStateFeedback(nominal_law, 0.5, feedforward);
    benchmark::DoNotOptimize(&ctrl);
  }
}
BENCHMARK(BM_LoadTrialLaw)
    ->ArgNames({"m", "nK", "blend"})
    ->ArgsProduct({{4, 8}, {16, 32}, {0, 1, 2}})
    ->Unit(benchmark::kMicrosecond);

// Args: n + K, samples, integrator (0 RK4, 1 midpoint), preset (0 the paper's backward pass:
// kLyapunov with the previous-du term off, no time curvature; 1 the default: box-aware kRiccati
// with time curvature).
void BM_BackwardPass(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)) - kModes;
  const int samples = static_cast<int>(state.range(1));
  Setup s(n, 4, samples);
  BackwardPassSettings settings =
      state.range(3) == 0 ? LearnerSettings::Paper().backward : LearnerSettings{}.backward;
  settings.use_previous_du = false;
  settings.integrator =
      state.range(2) == 0 ? BackwardIntegrator::kRk4 : BackwardIntegrator::kMidpoint;
  BackwardPass pass;
  pass.Allocate(s.problem, samples, settings);
  for (auto _ : state) {
    pass.Run(s.nominal);
    benchmark::DoNotOptimize(pass.p(0, 0).data());
  }
  state.counters["us_per_sample"] =
      benchmark::Counter(samples, benchmark::Counter::kIsIterationInvariantRate |
                                      benchmark::Counter::kInvert);
}
BENCHMARK(BM_BackwardPass)
    ->ArgNames({"nK", "samples", "midpoint", "preset"})
    ->ArgsProduct({{16, 32, 64}, {500, 1000, 2000}, {0}, {0}})
    ->Args({16, 1000, 1, 0})
    ->Args({16, 1000, 0, 1})->Args({16, 1000, 1, 1})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace ddoc

BENCHMARK_MAIN();
