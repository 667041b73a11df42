// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// bench_render: throughput of headless rendering (OSMesa / llvmpipe) at 640x480 and the
// cost of recording frames during a simulation.
//
//   bench_render [--model=FILE.xml|embedded] [google benchmark flags, e.g.
//                --benchmark_repetitions=5 --benchmark_report_aggregates_only=true]
//
// The model defaults to models/hopper.xml of the source tree when it exists, else to a small
// embedded capsule model. Benchmarks:
//   BM_RenderReadPixels  mjv_updateScene + mjr_render + overlay + mjr_readPixels + row flip
//                        of the model's keyframe pose; items/s = frames per second (the
//                        issue's target: >= 60). CPU time is of the whole process (llvmpipe
//                        rasterizes on worker threads).
//   BM_EncodePng         lodepng encoding of one rendered 640x480 frame, items/s = frames/s.
//   BM_RecordFrame       FrameRecorder end to end per frame (render + encode + write to
//                        /tmp), sync and async (encode on a second thread).
//   BM_SimulateOneSecond 1 s of simulated time, passive (zero controls: the hopper falls),
//                        without frames (arg 0) and recording 60 fps (arg 1); the counter
//                        `slowdown` of arg 1 is measured in the same iteration against a
//                        plain run. (For the full CLI with the controller, time
//                        ddoc-hopper with and without --render.)
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#include "ddoc/render/frame_recorder.h"
#include "ddoc/render/offscreen_renderer.h"
#include "ddoc/render/png.h"

namespace {

using Clock = std::chrono::steady_clock;

const char kFallbackModel[] = R"(<mujoco model="bench">
  <option timestep="0.001"/>
  <asset>
    <texture name="grid" type="2d" builtin="checker" rgb1=".25 .3 .35" rgb2=".4 .45 .5"
             width="256" height="256" mark="edge" markrgb=".9 .9 .9"/>
    <material name="grid" texture="grid" texrepeat="2 2" texuniform="true"/>
  </asset>
  <worldbody>
    <light pos="0 -1 4" dir="0 .25 -1"/>
    <geom name="floor" type="plane" size="0 0 1" material="grid"/>
    <body name="torso" pos="0 0 0.5">
      <joint type="slide" axis="1 0 0"/>
      <joint type="slide" axis="0 0 1"/>
      <joint type="hinge" axis="0 1 0"/>
      <geom type="capsule" size=".08 .2" rgba="1 0 0 1"/>
    </body>
  </worldbody>
</mujoco>)";

std::string g_model_path;  // --model, or the default

struct Sim {
  mjModel* m = nullptr;
  mjData* d = nullptr;
  Sim() {
    char error[1000] = "";
    if (!g_model_path.empty()) {
      m = mj_loadXML(g_model_path.c_str(), nullptr, error, sizeof(error));
    } else {
      const std::string path = std::filesystem::temp_directory_path() /
                               ("ddoc_bench_model_" + std::to_string(::getpid()) + ".xml");
      std::FILE* f = std::fopen(path.c_str(), "w");
      std::fputs(kFallbackModel, f);
      std::fclose(f);
      m = mj_loadXML(path.c_str(), nullptr, error, sizeof(error));
      std::filesystem::remove(path);
    }
    if (!m) {
      std::fprintf(stderr, "bench_render: cannot load model: %s\n", error);
      std::exit(1);
    }
    d = mj_makeData(m);
    Reset();
  }
  ~Sim() {
    mj_deleteData(d);
    mj_deleteModel(m);
  }
  void Reset() {
    mj_resetData(m, d);
    if (m->nkey > 0) mj_resetDataKeyframe(m, d, 0);
    mj_forward(m, d);
  }
};

ddoc::RenderSettings Settings(const std::string& dir) {
  ddoc::RenderSettings s;
  s.dir = dir;  // 640x480, 60 fps, all defaults
  return s;
}

std::string TempDir(const char* name) {
  return (std::filesystem::temp_directory_path() /
          (std::string("ddoc_bench_render_") + name + "_" + std::to_string(::getpid())))
      .string();
}

// A 640x480 renderer for sim, or nullptr after marking the benchmark skipped with the reason.
std::unique_ptr<ddoc::OffscreenRenderer> CreateOrSkip(const Sim& sim, benchmark::State& state) {
  std::string error;
  auto renderer = ddoc::OffscreenRenderer::Create(sim.m, Settings(""), &error);
  if (!renderer) state.SkipWithError(error.c_str());
  return renderer;
}

void BM_RenderReadPixels(benchmark::State& state) {
  Sim sim;
  auto renderer = CreateOrSkip(sim, state);
  if (!renderer) return;
  std::vector<unsigned char> rgb;
  ddoc::Overlay overlay;
  overlay.method = "Algorithm 1";
  std::string labels, values;
  for (auto _ : state) {
    // The keyframe pose every time (a passive hopper would fall through the floor and
    // leave the view, which makes frames cheaper than in a real run).
    sim.d->time += sim.m->opt.timestep;
    ddoc::FormatOverlay(overlay, sim.m, sim.d, renderer->track_body_id(), &labels, &values);
    renderer->Render(sim.m, sim.d, labels, values, &rgb);
    benchmark::DoNotOptimize(rgb.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(renderer->gl_renderer());
}
BENCHMARK(BM_RenderReadPixels)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()  // llvmpipe renders on worker threads
    ->UseRealTime();

void BM_EncodePng(benchmark::State& state) {
  Sim sim;
  std::string error;
  auto renderer = CreateOrSkip(sim, state);
  if (!renderer) return;
  std::vector<unsigned char> rgb, png;
  renderer->Render(sim.m, sim.d, "Method", "Algorithm 1", &rgb);
  for (auto _ : state) {
    ddoc::EncodePng(rgb, 640, 480, &png, &error);
    benchmark::DoNotOptimize(png.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["png_kB"] = png.size() / 1000.0;
}
BENCHMARK(BM_EncodePng)->Unit(benchmark::kMillisecond)->UseRealTime();

// arg 0: synchronous writes; arg 1: asynchronous (default of RenderSettings).
void BM_RecordFrame(benchmark::State& state) {
  Sim sim;
  const std::string dir = TempDir("record");
  ddoc::RenderSettings s = Settings(dir);
  s.async_write = state.range(0) != 0;
  s.fps = 1.0 / sim.m->opt.timestep;  // one frame per step
  std::string error;
  auto recorder = ddoc::FrameRecorder::Create(sim.m, s, &error);
  if (!recorder) {
    state.SkipWithError(error.c_str());
    return;
  }
  ddoc::Overlay overlay;
  overlay.method = "Algorithm 1";
  for (auto _ : state) {
    sim.d->time += sim.m->opt.timestep;  // one frame due per call; keyframe pose (see above)
    recorder->MaybeCapture(sim.m, sim.d, overlay);
  }
  recorder->Finish(&error);  // inside the timing would be fairer; it is at most 8 frames
  state.SetItemsProcessed(state.iterations());
  recorder.reset();
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_RecordFrame)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();

// Seconds of wall time to simulate 1 s, optionally recording at 60 fps (incl. Finish()).
double SimulateOneSecond(Sim* sim, ddoc::FrameRecorder* recorder) {
  sim->Reset();
  const auto start = Clock::now();
  const double t_end = sim->d->time + 1.0 - 0.5 * sim->m->opt.timestep;
  ddoc::Overlay overlay;
  overlay.method = "Algorithm 1";
  if (recorder) recorder->MaybeCapture(sim->m, sim->d, overlay);
  while (sim->d->time < t_end) {
    mj_step(sim->m, sim->d);
    if (recorder) recorder->MaybeCapture(sim->m, sim->d, overlay);
  }
  if (recorder) {
    std::string error;
    recorder->Finish(&error);
  }
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void BM_SimulateOneSecond(benchmark::State& state) {
  Sim sim;
  const bool record = state.range(0) != 0;
  const std::string dir = TempDir("simulate");
  std::unique_ptr<ddoc::FrameRecorder> recorder;
  if (record) {
    std::string error;
    recorder = ddoc::FrameRecorder::Create(sim.m, Settings(dir), &error);
    if (!recorder) {
      state.SkipWithError(error.c_str());
      return;
    }
  }
  double plain_total = 0, with_total = 0;
  for (auto _ : state) {
    const double t = SimulateOneSecond(&sim, recorder.get());
    state.SetIterationTime(t);
    if (record) {
      // The reference run, in the same iteration, untimed by the framework.
      state.PauseTiming();
      plain_total += SimulateOneSecond(&sim, nullptr);
      with_total += t;
      state.ResumeTiming();
    }
  }
  if (record) {
    state.counters["slowdown"] = with_total / plain_total;
    state.counters["frames"] = static_cast<double>(recorder->frame_count()) / state.iterations();
  }
  state.counters["steps"] = 1.0 / sim.m->opt.timestep;
  recorder.reset();
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_SimulateOneSecond)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseManualTime();

}  // namespace

int main(int argc, char** argv) {
  // Our own flag with CLI11; the rest goes to Google Benchmark.
  CLI::App cli{"bench_render: the OSMesa renderer's frame rate and a recording simulation's "
               "slowdown. Other flags (--benchmark_*) go to Google Benchmark."};
  cli.allow_extras();
  cli.add_option("--model", g_model_path,
                 "MJCF to render (default models/hopper.xml; 'embedded': a capsule)");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e);
  }
  if (g_model_path == "embedded") {
    g_model_path.clear();
  } else if (g_model_path.empty()) {
    const std::string hopper = std::string(DDOC_SOURCE_DIR) + "/models/hopper.xml";
    if (std::filesystem::exists(hopper)) g_model_path = hopper;
  }
  std::printf("bench_render: model %s\n",
              g_model_path.empty() ? "(embedded capsule)" : g_model_path.c_str());
  std::vector<std::string> extras = cli.remaining();
  std::vector<char*> rest{argv[0]};
  for (std::string& e : extras) rest.push_back(e.data());
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
