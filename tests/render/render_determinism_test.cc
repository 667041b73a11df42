// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Rendering must not change the simulation: the same run with and without a recorder
// (and with a render after EVERY step) gives bit-identical states.
#include <cstdint>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "ddoc/render/frame_recorder.h"
#include "ddoc/render/offscreen_renderer.h"
#include "render_test_util.h"

namespace ddoc {
namespace {

using testing::RenderTest;

enum class Mode { kNone, kRecorder, kRenderEveryStep };

// FNV-1a over raw bytes.
uint64_t Hash(const void* data, size_t bytes, uint64_t h) {
  const unsigned char* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

struct Trace {
  std::vector<uint64_t> step_hashes;  // hash of (time, qpos, qvel, act, qacc_warmstart, ...)
  std::vector<mjtNum> final_state;    // time, qpos (nq), qvel (nv)
};

class RenderDeterminismTest : public RenderTest {
 protected:
  // A falling, bouncing, pushed capsule (contacts, friction, a hinge): 1 s at 2 ms.
  Trace Simulate(Mode mode) {
    auto m = testing::LoadModel(testing::TestModelXml(true));
    auto d = testing::MakeData(m.get());
    d->qpos[1] = 0.4;   // start 0.4 m above the initial height: falls onto the floor
    d->qvel[2] = 3.0;   // spinning about y
    std::unique_ptr<FrameRecorder> recorder;
    std::unique_ptr<OffscreenRenderer> renderer;
    std::vector<unsigned char> rgb;
    RenderSettings s;
    s.dir = (dir_ / "frames").string();
    s.width = 96;
    s.height = 72;
    std::string error;
    if (mode == Mode::kRecorder) {
      recorder = FrameRecorder::Create(m.get(), s, &error);
      EXPECT_NE(recorder, nullptr) << error;
    } else if (mode == Mode::kRenderEveryStep) {
      renderer = OffscreenRenderer::Create(m.get(), s, &error);
      EXPECT_NE(renderer, nullptr) << error;
    }
    Trace trace;
    Overlay overlay;
    overlay.method = "test";
    mj_forward(m.get(), d.get());
    for (int i = 0; i < 500; ++i) {
      if (recorder) recorder->MaybeCapture(m.get(), d.get(), overlay);
      if (renderer) renderer->Render(m.get(), d.get(), "a", "b", &rgb);
      d->ctrl[0] = 0.8 * std::sin(4.0 * d->time);
      mj_step(m.get(), d.get());
      uint64_t h = 1469598103934665603ull;
      h = Hash(&d->time, sizeof(mjtNum), h);
      h = Hash(d->qpos, sizeof(mjtNum) * m->nq, h);
      h = Hash(d->qvel, sizeof(mjtNum) * m->nv, h);
      h = Hash(d->act, sizeof(mjtNum) * m->na, h);
      h = Hash(d->qacc_warmstart, sizeof(mjtNum) * m->nv, h);
      h = Hash(d->qfrc_applied, sizeof(mjtNum) * m->nv, h);
      h = Hash(d->xfrc_applied, sizeof(mjtNum) * 6 * m->nbody, h);
      h = Hash(&d->ncon, sizeof(int), h);
      trace.step_hashes.push_back(h);
    }
    if (recorder) {
      recorder->MaybeCapture(m.get(), d.get(), overlay);  // the state after the last step
      EXPECT_TRUE(recorder->Finish(&error)) << error;
      EXPECT_EQ(recorder->frame_count(), 61);  // floor(1.0 * 60) + 1
    }
    trace.final_state.push_back(d->time);
    trace.final_state.insert(trace.final_state.end(), d->qpos, d->qpos + m->nq);
    trace.final_state.insert(trace.final_state.end(), d->qvel, d->qvel + m->nv);
    return trace;
  }
};

TEST_F(RenderDeterminismTest, RenderingDoesNotChangeTheSimulation) {
  const Trace plain = Simulate(Mode::kNone);
  const Trace recorded = Simulate(Mode::kRecorder);
  const Trace every_step = Simulate(Mode::kRenderEveryStep);
  // The run is not trivial: the body moved and had contacts.
  ASSERT_GT(std::abs(plain.final_state[1]), 0.01);
  ASSERT_EQ(plain.step_hashes.size(), 500u);
  // Bit-identical, step by step.
  for (size_t i = 0; i < plain.step_hashes.size(); ++i) {
    ASSERT_EQ(plain.step_hashes[i], recorded.step_hashes[i]) << "step " << i;
    ASSERT_EQ(plain.step_hashes[i], every_step.step_hashes[i]) << "step " << i;
  }
  ASSERT_EQ(plain.final_state.size(), recorded.final_state.size());
  EXPECT_EQ(0, std::memcmp(plain.final_state.data(), recorded.final_state.data(),
                           plain.final_state.size() * sizeof(mjtNum)));
  EXPECT_EQ(0, std::memcmp(plain.final_state.data(), every_step.final_state.data(),
                           plain.final_state.size() * sizeof(mjtNum)));
}

}  // namespace
}  // namespace ddoc
