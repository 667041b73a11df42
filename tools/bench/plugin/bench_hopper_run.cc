// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The controller plugin over a 100-hop Algorithm 1 run of the default scenario (10 kg drag-free
// model, 8 kg MuJoCo robot with drag, 0.5 m/s):
//   BM_ComputeAndOffline    the longest HopperController::Compute call (target <= 50 us at the
//                           0.5 ms step), in wall time and in the thread's CPU time (wall time
//                           includes preemption by other processes), and the offline part's
//                           time per hop (RunOffline, host mode): median, p99, the longest, the
//                           first (the Initialize hop) and the longest after it (issue 46)
//   BM_RunVersusBarePhysics the run's wall time against bare MuJoCo stepping of the same robot
//                           for the same simulated time, both in one iteration, as a ratio
//                           (target <= 1.2); /0 the host runs the offline part between steps,
//                           /1 the controller's worker thread does; the mj_step calls alone
//                           (Compute inside) against bare's, summed and the longest, and the
//                           offline parts summed against bare stepping (issue 46's <= 1.1x,
//                           <= 1.5x and <= 0.2x)
//   BM_ControllerCreate     nominal gait + OC-FB solve on the model (once per run)
//
//   bench_hopper_run --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "ddoc/mujoco/hopper_sim.h"
#include "hopper_controller.h"

namespace {

using ddoc::plugin::HopperController;
using Clock = std::chrono::steady_clock;

constexpr int kHops = 100;
constexpr double kMaxSeconds = 80.0;  // upper bound of simulated time per run
// The default scenario's robot.
const std::string kRobot = std::string(DDOC_SOURCE_DIR) + "/models/hopper_m8.xml";

struct Robot {
  ddoc::MjModelPtr model = ddoc::LoadMjcf(kRobot);
  ddoc::MjDataPtr data{mj_makeData(model.get())};
};

std::unique_ptr<HopperController> MakeController(const mjModel* m, bool worker_thread,
                                                 const std::string& law_cache = "") {
  ddoc::plugin::ControllerConfig config;  // the default scenario: inexact 10 kg drag-free model
  config.gait.forward_speed = 0.5;
  config.offline_thread = worker_thread;
  config.law_cache = law_cache;
  std::string error;
  auto c = HopperController::Create(m, config, &error);
  if (!c) throw std::runtime_error(error);
  return c;
}

// CPU time of the calling thread, us: unlike wall time it does not count the time the thread
// was preempted (on a shared machine the scheduler's 4 ms tick shows up in single calls).
double ThreadCpuUs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e6 * static_cast<double>(ts.tv_sec) + 1e-3 * static_cast<double>(ts.tv_nsec);
}

// Per-call timing of Compute through mjcb_control: wall and thread CPU time.
HopperController* g_timed = nullptr;
std::vector<double>* g_compute_us = nullptr;
std::vector<double>* g_compute_cpu_us = nullptr;
void TimedCallback(const mjModel* m, mjData* d) {
  const double c0 = ThreadCpuUs();
  const Clock::time_point t0 = Clock::now();
  g_timed->Compute(m, d);
  const Clock::time_point t1 = Clock::now();
  g_compute_cpu_us->push_back(ThreadCpuUs() - c0);
  g_compute_us->push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
}

// The same per-call timing around a trivial callback (the VSA spring law with a constant input,
// as in RunBare) over the same number of bare steps: the machine's noise floor of the maxima.
const HopperController* g_trivial = nullptr;
ddoc::VsaState g_trivial_vsa;
void TimedTrivialCallback(const mjModel* m, mjData* d) {
  const double c0 = ThreadCpuUs();
  const Clock::time_point t0 = Clock::now();
  ddoc::WriteActuation(g_trivial->mapping(), m, d, g_trivial_vsa, g_trivial->gait().u0.data());
  const Clock::time_point t1 = Clock::now();
  g_compute_cpu_us->push_back(ThreadCpuUs() - c0);
  g_compute_us->push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
}

// Wall time of the mj_step calls of a run (the control callback inside them): their sum and
// the longest, s.
struct StepTimes {
  double sum = 0.0, max = 0.0;
  void Add(double s) {
    sum += s;
    max = std::max(max, s);
  }
};

// Steps until kHops hops (or kMaxSeconds, or a failure) with the offline part run by the host
// between steps (or by the worker thread). Returns simulated seconds. With `offline_ms`, the
// time of every RunOffline call is recorded; with `steps`, the time of every mj_step.
double RunHops(Robot& r, HopperController& c, std::vector<double>* offline_ms,
               StepTimes* steps = nullptr) {
  c.Reset(r.model.get(), r.data.get());
  const ddoc::HopperMapping& map = c.mapping();
  while (c.hop() < kHops && r.data->time < kMaxSeconds && !c.failed()) {
    ddoc::ApplyDragAndPush(map, r.model.get(), r.data.get(), 0.0);
    const Clock::time_point s0 = Clock::now();
    mj_step(r.model.get(), r.data.get());
    if (steps) steps->Add(std::chrono::duration<double>(Clock::now() - s0).count());
    if (!c.offline_pending()) continue;
    const Clock::time_point t0 = Clock::now();
    c.RunOffline();
    if (offline_ms) {
      offline_ms->push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
  }
  c.FinishOffline();
  return r.data->time;
}

// Bare physics for `seconds`: same robot and start, the VSA spring law with a constant input
// written into ctrl each step (no learning, no controller); with `steps`, the time of every
// mj_step.
void RunBare(Robot& r, const HopperController& c, double seconds, StepTimes* steps = nullptr) {
  mj_resetData(r.model.get(), r.data.get());
  ddoc::VsaState vsa;
  const ddoc::HopperMapping& map = c.mapping();
  ddoc::WriteFlightState(map, c.gait().x0.data(), r.data.get(), &vsa);
  const Eigen::Vector4d u = c.gait().u0;
  while (r.data->time < seconds) {
    ddoc::WriteActuation(map, r.model.get(), r.data.get(), vsa, u.data());
    ddoc::ApplyDragAndPush(map, r.model.get(), r.data.get(), 0.0);
    const Clock::time_point s0 = Clock::now();
    mj_step(r.model.get(), r.data.get());
    if (steps) steps->Add(std::chrono::duration<double>(Clock::now() - s0).count());
  }
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * static_cast<double>(v.size() - 1))];
}

void BM_ComputeAndOffline(benchmark::State& state) {
  Robot r;
  auto c = MakeController(r.model.get(), false);
  std::vector<double> compute_us, compute_cpu_us, offline_ms;
  compute_us.reserve(200000);
  compute_cpu_us.reserve(200000);
  offline_ms.reserve(kHops);
  double sim = 0;
  for (auto _ : state) {
    compute_us.clear();
    compute_cpu_us.clear();
    offline_ms.clear();
    g_timed = c.get();
    g_compute_us = &compute_us;
    g_compute_cpu_us = &compute_cpu_us;
    mjcb_control = TimedCallback;
    sim = RunHops(r, *c, &offline_ms);
    mjcb_control = nullptr;
  }
  // Noise floor: the trivial callback over the same number of bare steps.
  std::vector<double> trivial_us, trivial_cpu_us;
  trivial_us.reserve(compute_us.size());
  trivial_cpu_us.reserve(compute_us.size());
  g_compute_us = &trivial_us;
  g_compute_cpu_us = &trivial_cpu_us;
  g_trivial = c.get();
  ddoc::WriteFlightState(c->mapping(), c->gait().x0.data(), r.data.get(), &g_trivial_vsa);
  mjcb_control = TimedTrivialCallback;
  mj_resetData(r.model.get(), r.data.get());
  ddoc::WriteFlightState(c->mapping(), c->gait().x0.data(), r.data.get(), &g_trivial_vsa);
  while (trivial_us.size() < compute_us.size()) {
    ddoc::ApplyDragAndPush(c->mapping(), r.model.get(), r.data.get(), 0.0);
    mj_step(r.model.get(), r.data.get());
  }
  mjcb_control = nullptr;
  state.counters["trivial_max_us"] = Quantile(trivial_us, 1.0);
  state.counters["trivial_cpu_max_us"] = Quantile(trivial_cpu_us, 1.0);
  state.counters["compute_max_us"] = Quantile(compute_us, 1.0);
  state.counters["compute_p999_us"] = Quantile(compute_us, 0.999);
  state.counters["compute_median_us"] = Quantile(compute_us, 0.5);
  state.counters["compute_cpu_max_us"] = Quantile(compute_cpu_us, 1.0);
  state.counters["offline_max_ms"] = Quantile(offline_ms, 1.0);
  state.counters["offline_median_ms"] = Quantile(offline_ms, 0.5);
  state.counters["offline_p99_ms"] = Quantile(offline_ms, 0.99);
  // The Initialize hop's call (the first) and the slowest call after it.
  state.counters["offline_first_ms"] = offline_ms.empty() ? 0.0 : offline_ms.front();
  state.counters["offline_later_max_ms"] =
      offline_ms.size() < 2 ? 0.0 : *std::max_element(offline_ms.begin() + 1, offline_ms.end());
  state.counters["calls"] = static_cast<double>(compute_us.size());
  state.counters["hops"] = c->hop();
  state.counters["sim_s"] = sim;
}
BENCHMARK(BM_ComputeAndOffline)->Unit(benchmark::kMillisecond)->Iterations(1);

// Both in one iteration, so the ratio comes from one moment of a noisy machine. Also: the
// mj_step calls alone (the control callback inside them) against bare's, summed and the
// longest, and (host mode) the offline parts summed against bare stepping.
void BM_RunVersusBarePhysics(benchmark::State& state) {
  Robot r;
  auto c = MakeController(r.model.get(), state.range(0) == 1);
  double ratio = 0, run_s = 0, bare_s = 0, sim = 0, offline_s = 0;
  StepTimes run_steps, bare_steps;
  for (auto _ : state) {
    std::vector<double> offline_ms;
    run_steps = bare_steps = StepTimes();
    ddoc::plugin::Attach(c.get());
    const Clock::time_point t0 = Clock::now();
    sim = RunHops(r, *c, &offline_ms, &run_steps);
    const Clock::time_point t1 = Clock::now();
    ddoc::plugin::Detach();
    RunBare(r, *c, sim, &bare_steps);
    const Clock::time_point t2 = Clock::now();
    run_s = std::chrono::duration<double>(t1 - t0).count();
    bare_s = std::chrono::duration<double>(t2 - t1).count();
    ratio = run_s / bare_s;
    offline_s = 1e-3 * std::accumulate(offline_ms.begin(), offline_ms.end(), 0.0);
  }
  state.counters["ratio"] = ratio;
  state.counters["run_ms"] = 1e3 * run_s;
  state.counters["bare_ms"] = 1e3 * bare_s;
  state.counters["step_sum_ratio"] = run_steps.sum / bare_steps.sum;
  state.counters["step_max_us"] = 1e6 * run_steps.max;
  state.counters["bare_step_max_us"] = 1e6 * bare_steps.max;
  state.counters["step_max_ratio"] = run_steps.max / bare_steps.max;
  state.counters["offline_over_bare"] = offline_s / bare_s;  // host mode; 0 with the thread
  state.counters["sim_s"] = sim;
  state.counters["hops"] = c->hop();
}
BENCHMARK(BM_RunVersusBarePhysics)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_ControllerCreate(benchmark::State& state) {
  Robot r;
  for (auto _ : state) benchmark::DoNotOptimize(MakeController(r.model.get(), false));
}
BENCHMARK(BM_ControllerCreate)->Unit(benchmark::kMillisecond)->Iterations(3);

// Create with the law cache: the first Create solves and stores u^0 (store_ms), the timed ones
// load it; ratio = load / solve-and-store, measured in the same run.
void BM_ControllerCreateFromLawCache(benchmark::State& state) {
  Robot r;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "ddoc_bench_law_cache";
  std::filesystem::remove_all(dir);
  const auto t0 = std::chrono::steady_clock::now();
  auto first = MakeController(r.model.get(), false, dir.string());
  const double store_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (first->law_cache_status().rfind("stored ", 0) != 0) {
    state.SkipWithError(("not stored: " + first->law_cache_status()).c_str());
    return;
  }
  double load_s = 0;
  for (auto _ : state) {
    const auto t1 = std::chrono::steady_clock::now();
    auto c = MakeController(r.model.get(), false, dir.string());
    load_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    if (c->law_cache_status().rfind("loaded ", 0) != 0) state.SkipWithError("not loaded");
  }
  load_s /= static_cast<double>(state.iterations());
  state.counters["store_ms"] = 1e3 * store_s;
  state.counters["load_ms"] = 1e3 * load_s;
  state.counters["ratio"] = load_s / store_s;
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_ControllerCreateFromLawCache)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
