// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Wall time of a headless Algorithm 1 run of the MuJoCo hopper (controller plugin attached through
// mjcb_control, learning every hop) against bare MuJoCo stepping of the same simulated duration,
// both in this process. Target of issue 4: the run costs at most 3x the bare physics.
//
//   bench_hopper_run --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <string>

#include "ddoc/mujoco/hopper_sim.h"
#include "hopper_controller.h"

namespace {

using ddoc::plugin::HopperController;

constexpr int kHops = 100;
constexpr double kMaxSeconds = 80.0;  // upper bound of simulated time per run
const std::string kRobot = std::string(DDOC_SOURCE_DIR) + "/models/hopper_m8.xml";  // the default scenario's robot

struct Robot {
  ddoc::MjModelPtr model = ddoc::LoadMjcf(kRobot);
  ddoc::MjDataPtr data{mj_makeData(model.get())};
};

std::unique_ptr<HopperController> MakeController(const mjModel* m) {
  ddoc::plugin::ControllerConfig config;  // inexact model: 10 kg, no drag (default scenario)
  config.gait.forward_speed = 0.5;
  std::string error;
  auto c = HopperController::Create(m, config, &error);
  if (!c) throw std::runtime_error(error);
  return c;
}

// Steps until kHops hops (or kMaxSeconds, or the controller fails); returns simulated seconds.
double RunLearning(Robot& r, HopperController& c) {
  c.Reset(r.model.get(), r.data.get());
  ddoc::plugin::Attach(&c);
  const ddoc::HopperMapping& map = c.mapping();
  while (c.hop() < kHops && r.data->time < kMaxSeconds && !c.failed()) {
    ddoc::ApplyDragAndPush(map, r.model.get(), r.data.get(), 0.0);
    mj_step(r.model.get(), r.data.get());
  }
  ddoc::plugin::Detach();
  return r.data->time;
}

// Bare physics for `seconds`: same robot and start, the VSA spring law with a constant input
// written into ctrl each step (no learning, no controller).
void RunBare(Robot& r, const HopperController& c, double seconds) {
  mj_resetData(r.model.get(), r.data.get());
  ddoc::VsaState vsa;
  const ddoc::HopperMapping& map = c.mapping();
  ddoc::WriteFlightState(map, c.gait().x0.data(), r.data.get(), &vsa);
  const Eigen::Vector4d u = c.gait().u0;
  while (r.data->time < seconds) {
    ddoc::WriteActuation(map, r.model.get(), r.data.get(), vsa, u.data());
    ddoc::ApplyDragAndPush(map, r.model.get(), r.data.get(), 0.0);
    mj_step(r.model.get(), r.data.get());
  }
}

void BM_Alg1HopperRun(benchmark::State& state) {
  Robot r;
  auto c = MakeController(r.model.get());
  double sim = 0;
  for (auto _ : state) sim = RunLearning(r, *c);
  state.counters["hops"] = c->hop();
  state.counters["sim_s"] = sim;
  state.counters["fell_or_failed"] = c->hop() < kHops ? 1 : 0;
}
BENCHMARK(BM_Alg1HopperRun)->Unit(benchmark::kMillisecond)->Iterations(1);

// Both in one iteration, so the ratio comes from one moment of a noisy machine.
void BM_Alg1VersusBarePhysics(benchmark::State& state) {
  Robot r;
  auto c = MakeController(r.model.get());
  double ratio = 0, run_s = 0, bare_s = 0, sim = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    sim = RunLearning(r, *c);
    auto t1 = std::chrono::steady_clock::now();
    RunBare(r, *c, sim);
    auto t2 = std::chrono::steady_clock::now();
    run_s = std::chrono::duration<double>(t1 - t0).count();
    bare_s = std::chrono::duration<double>(t2 - t1).count();
    ratio = run_s / bare_s;
  }
  state.counters["ratio"] = ratio;
  state.counters["run_ms"] = 1e3 * run_s;
  state.counters["bare_ms"] = 1e3 * bare_s;
  state.counters["sim_s"] = sim;
  state.counters["hops"] = c->hop();
}
BENCHMARK(BM_Alg1VersusBarePhysics)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_ControllerCreate(benchmark::State& state) {
  Robot r;
  for (auto _ : state) benchmark::DoNotOptimize(MakeController(r.model.get()));
}
BENCHMARK(BM_ControllerCreate)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
