// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The backward pass (30) of the hopper's learner (HopperLearnerSettings(): kRiccati, RK4, the
// periodic value swept to a fixed point) on one hop of the analytic model under the nominal
// gait's constant u^0, sampled at the robot's 0.5 ms step (about 1000 samples, as a measured
// hop of the default scenario). The offline part of a hop that runs a pass is this pass plus
// the law's load (docs/benchmarks.md, "Where the offline part spends its time").
//   BM_HopperPass/cold:0  the cyclic value warm-started from the previous Run (an accepted
//                         trial's pass)
//   BM_HopperPass/cold:1  from P_0 = 0 (the Initialize hop's first pass)
// Counters: sweeps (per Run), us_per_interval (one sample interval of one sweep).
//
//   bench_hopper_pass --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   bench_hopper_pass --checksum [--dump F] [--compare F] [--min-substeps N]
//       a checksum of every output of one cold Run (a bitwise identity check of a change that
//       must not alter the pass); --dump writes the outputs to F, --compare prints their
//       largest difference from F's; --min-substeps N integrates with N sub-steps at least (a
//       reference solution)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "ddoc/backward_pass.h"
#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/hopper_learning.h"
#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/nominal_gait.h"
#include "ddoc/plant.h"
#include "ddoc/policy.h"

namespace ddoc {
namespace {

constexpr double kRobotStep = 5e-4;  // s: the MJCF robot's timestep, one sample per step

struct HopperPassSetup {
  HopperModel model{HopperParams()};
  HopperCost cost{model};
  Problem problem = HopperProblem(model, cost);
  Trajectory nominal;
  BackwardPassSettings settings = HopperLearnerSettings().backward;
  double regularization = HopperLearnerSettings().regularization_min;

  HopperPassSetup() {
    NominalGaitSettings gs;
    gs.forward_speed = 0.5;
    const NominalGait gait = FindNominalGait(HopperParams(), gs);
    cost.SetReference(gait.x0);
    ModelPlantSettings ps;
    ps.dt = kRobotStep;
    ModelPlant plant(problem, ps);
    const Eigen::Vector2d durations(gait.T0(0), gait.T0(1) - gait.T0(0));
    const Eigen::Vector4d u0 = gait.u0;
    FunctionPolicy policy(durations,
                          [u0](int, double, const ConstVectorRef&, VectorRef u) { u = u0; });
    plant.Run(gait.x0, policy, &nominal);
  }
  int samples() const { return nominal.modes[0].num_samples() + nominal.modes[1].num_samples(); }
};

HopperPassSetup& Setup() {
  static HopperPassSetup s;
  return s;
}

void BM_HopperPass(benchmark::State& state) {
  HopperPassSetup& s = Setup();
  const bool cold = state.range(0) != 0;
  BackwardPass pass;
  pass.Allocate(s.problem, s.samples(), s.settings);
  pass.Run(s.nominal, s.regularization);  // warms the cyclic value
  int sweeps = 0, runs = 0;
  for (auto _ : state) {
    if (cold) pass.ResetCyclicValue();
    pass.Run(s.nominal, s.regularization);
    benchmark::DoNotOptimize(pass.p(0, 0).data());
    sweeps += pass.sweeps();
    ++runs;
  }
  state.counters["sweeps"] = static_cast<double>(sweeps) / runs;
  state.counters["us_per_interval"] = benchmark::Counter(
      static_cast<double>(sweeps) / runs * (s.samples() - 2),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_HopperPass)->ArgName("cold")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// FNV-1a over the bytes of every output of one cold Run; with `dump`, the outputs also go into
// that file (raw doubles), and with `compare` their largest difference from such a file,
// relative to each output's largest magnitude, is printed.
int PrintChecksum(const char* dump, const char* compare, int min_substeps) {
  HopperPassSetup& s = Setup();
  BackwardPass pass;
  BackwardPassSettings settings = s.settings;
  settings.min_substeps = min_substeps;
  pass.Allocate(s.problem, s.samples(), settings);
  const auto start = std::chrono::steady_clock::now();
  if (!pass.Run(s.nominal, s.regularization)) {
    std::fprintf(stderr, "the pass failed\n");
    return 1;
  }
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::uint64_t h = 1469598103934665603ull;
  std::vector<double> all;
  auto add = [&h, &all](const double* v, Eigen::Index n) {
    all.insert(all.end(), v, v + n);
    const auto* b = reinterpret_cast<const unsigned char*>(v);
    for (Eigen::Index i = 0; i < n * static_cast<Eigen::Index>(sizeof(double)); ++i) {
      h = (h ^ b[i]) * 1099511628211ull;
    }
  };
  for (int k = 0; k < pass.num_modes(); ++k) {
    for (int j = 0; j < pass.num_samples(k); ++j) {
      add(pass.p(k, j).data(), pass.p(k, j).size());
      const Matrix g = pass.Gain(k, j);
      add(g.data(), g.size());
      add(pass.Feedforward(k, j).data(), pass.Feedforward(k, j).size());
      add(pass.Gradient(k, j).data(), pass.Gradient(k, j).size());
      add(pass.Step(k, j).data(), pass.Step(k, j).size());
    }
    for (int j : {0, pass.num_samples(k) - 1}) {
      const Matrix P = pass.P(k, j);
      add(P.data(), P.size());
    }
  }
  add(pass.gradient_T().data(), pass.gradient_T().size());
  std::printf("samples %d sweeps %d (%.1f ms) p2(0) %.17g %.17g checksum %016llx\n",
              s.samples(), pass.sweeps(), ms, pass.p2_initial()(0), pass.p2_initial()(1),
              static_cast<unsigned long long>(h));
  if (dump != nullptr) {
    std::FILE* f = std::fopen(dump, "wb");
    if (f == nullptr || std::fwrite(all.data(), sizeof(double), all.size(), f) != all.size()) {
      std::fprintf(stderr, "cannot write %s\n", dump);
      return 1;
    }
    std::fclose(f);
  }
  if (compare != nullptr) {
    std::vector<double> ref(all.size());
    std::FILE* f = std::fopen(compare, "rb");
    if (f == nullptr || std::fread(ref.data(), sizeof(double), ref.size(), f) != ref.size()) {
      std::fprintf(stderr, "cannot read %zu doubles from %s\n", ref.size(), compare);
      return 1;
    }
    std::fclose(f);
    double scale = 0.0, diff = 0.0;
    for (size_t i = 0; i < all.size(); ++i) {
      scale = std::max(scale, std::abs(ref[i]));
      diff = std::max(diff, std::abs(all[i] - ref[i]));
    }
    std::printf("largest difference %.3g (largest output %.3g, relative %.3g)\n", diff, scale,
                diff / scale);
  }
  return 0;
}

}  // namespace
}  // namespace ddoc

int main(int argc, char** argv) {
  const char* dump = nullptr;
  const char* compare = nullptr;
  bool checksum = false;
  int min_substeps = 1;
  for (int i = 1; i < argc; ++i) {
    checksum = checksum || std::strcmp(argv[i], "--checksum") == 0;
    if (std::strcmp(argv[i], "--dump") == 0 && i + 1 < argc) dump = argv[++i];
    if (std::strcmp(argv[i], "--compare") == 0 && i + 1 < argc) compare = argv[++i];
    if (std::strcmp(argv[i], "--min-substeps") == 0 && i + 1 < argc) {
      min_substeps = std::atoi(argv[++i]);
    }
  }
  if (checksum) return ddoc::PrintChecksum(dump, compare, min_substeps);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
