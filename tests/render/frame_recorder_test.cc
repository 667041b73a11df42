// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// FrameRecorder: the number of files matches duration * fps (see the frame clock in
// frame_recorder.h), numbering continues across trials, stale frames are cleared,
// asynchronous and synchronous writing give identical files, and write errors surface.
#include "ddoc/render/frame_recorder.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "ddoc/render/png.h"
#include "render_test_util.h"

namespace ddoc {
namespace {

namespace fs = std::filesystem;
using testing::CountFrames;
using testing::RenderTest;

class FrameRecorderTest : public RenderTest {
 protected:
  RenderSettings Small(double fps) const {
    RenderSettings s;
    s.dir = (dir_ / "frames").string();
    s.width = 96;
    s.height = 72;
    s.fps = fps;
    s.multisamples = 0;
    return s;
  }
  // Steps the test model for `duration` seconds of simulated time with a sideways push,
  // calling MaybeCapture before the first step and after every step. Returns the number
  // of calls that wrote a frame.
  static int Run(const mjModel* m, mjData* d, FrameRecorder* rec, double duration) {
    int captured = 0;
    Overlay overlay;
    overlay.method = "test";
    captured += rec->MaybeCapture(m, d, overlay);
    const int steps = static_cast<int>(std::lround(duration / m->opt.timestep));
    for (int i = 0; i < steps; ++i) {
      d->ctrl[0] = 0.5;
      mj_step(m, d);
      captured += rec->MaybeCapture(m, d, overlay);
    }
    return captured;
  }
  static std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
};

// N = floor(T fps + fps dt / 2) + 1, computed independently of the recorder's loop.
int64_t ExpectedFrames(double duration, double fps, double timestep) {
  return static_cast<int64_t>(std::floor(duration * fps + 0.5 * fps * timestep)) + 1;
}

TEST_F(FrameRecorderTest, FileCountMatchesDurationTimesFps) {
  struct Case {
    double duration, fps, timestep;
  };
  for (const Case& c : {Case{0.5, 60, 0.002}, Case{1.0, 30, 0.001}, Case{0.37, 24, 0.002},
                        Case{0.2, 100, 0.025} /* timestep > 1/fps: repeated frames */}) {
    SCOPED_TRACE("T=" + std::to_string(c.duration) + " fps=" + std::to_string(c.fps) +
                 " dt=" + std::to_string(c.timestep));
    fs::remove_all(dir_);
    auto m = testing::LoadModel(testing::TestModelXml(true));
    m->opt.timestep = c.timestep;
    auto d = testing::MakeData(m.get());
    std::string error;
    auto rec = FrameRecorder::Create(m.get(), Small(c.fps), &error);
    ASSERT_NE(rec, nullptr) << error;
    Run(m.get(), d.get(), rec.get(), c.duration);
    ASSERT_TRUE(rec->Finish(&error)) << error;
    const int64_t expected = ExpectedFrames(c.duration, c.fps, c.timestep);
    EXPECT_EQ(rec->frame_count(), expected);
    EXPECT_EQ(CountFrames(dir_ / "frames"), expected);
    // Files are numbered without gaps from 0.
    EXPECT_TRUE(fs::exists(rec->FramePath(0)));
    EXPECT_TRUE(fs::exists(rec->FramePath(expected - 1)));
    EXPECT_FALSE(fs::exists(rec->FramePath(expected)));
  }
  // The common case stated in the issue: 0.5 s at 60 fps with a 2 ms step = 31 frames.
  EXPECT_EQ(ExpectedFrames(0.5, 60, 0.002), 31);
}

TEST_F(FrameRecorderTest, FramesArePngsOfTheRequestedSize) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  std::string error;
  auto rec = FrameRecorder::Create(m.get(), Small(60), &error);
  ASSERT_NE(rec, nullptr) << error;
  Run(m.get(), d.get(), rec.get(), 0.05);
  ASSERT_TRUE(rec->Finish(&error)) << error;
  std::vector<unsigned char> rgb;
  int w = 0, h = 0;
  ASSERT_TRUE(ReadPng(rec->FramePath(1), &rgb, &w, &h, &error)) << error;
  EXPECT_EQ(w, 96);
  EXPECT_EQ(h, 72);
}

// The first frame of a recording shows the state as it is, even when no mj_step or mj_forward
// has computed its poses (ddoc-hopper's frame 0 after the controller placed the robot): the same
// image as after mj_forward. It showed the sky only, with the speed "+0.000".
TEST_F(FrameRecorderTest, FirstFrameOfAStateNoStepHasSeenShowsIt) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  std::string error;
  std::vector<std::vector<unsigned char>> images;
  for (const bool forward : {false, true}) {
    auto d = testing::MakeData(m.get());
    d->qpos[0] = 0.3;  // x
    d->qpos[2] = 0.4;  // pitch
    d->qvel[0] = 0.7;  // the overlay's speed
    if (forward) mj_forward(m.get(), d.get());
    RenderSettings settings = Small(60);
    settings.dir = (dir_ / (forward ? "forward" : "placed")).string();
    settings.async_write = false;
    auto rec = FrameRecorder::Create(m.get(), settings, &error);
    ASSERT_NE(rec, nullptr) << error;
    ASSERT_TRUE(rec->MaybeCapture(m.get(), d.get(), Overlay()));
    std::vector<unsigned char> rgb;
    int w = 0, h = 0;
    ASSERT_TRUE(ReadPng(rec->FramePath(0), &rgb, &w, &h, &error)) << error;
    images.push_back(rgb);
  }
  EXPECT_TRUE(images[0] == images[1]) << "frame 0 differs from the same state after mj_forward";
}

TEST_F(FrameRecorderTest, NumberingContinuesAcrossTrials) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  std::string error;
  auto rec = FrameRecorder::Create(m.get(), Small(50), &error);
  ASSERT_NE(rec, nullptr) << error;
  Run(m.get(), d.get(), rec.get(), 0.3);  // trial 1: 16 frames
  mj_resetData(m.get(), d.get());          // the time goes back to 0
  Run(m.get(), d.get(), rec.get(), 0.1);  // trial 2: 6 frames
  ASSERT_TRUE(rec->Finish(&error)) << error;
  const int64_t expected =
      ExpectedFrames(0.3, 50, m->opt.timestep) + ExpectedFrames(0.1, 50, m->opt.timestep);
  EXPECT_EQ(expected, 22);
  EXPECT_EQ(rec->frame_count(), expected);
  EXPECT_EQ(CountFrames(dir_ / "frames"), expected);
}

TEST_F(FrameRecorderTest, StaleFramesOfAnEarlierRunAreRemovedOthersKept) {
  fs::create_directories(dir_ / "frames");
  for (const char* name : {"frame_000000.png", "frame_000999.png", "frame_12.png", "notes.txt"}) {
    std::ofstream(dir_ / "frames" / name) << "old";
  }
  auto m = testing::LoadModel(testing::TestModelXml(true));
  std::string error;
  auto rec = FrameRecorder::Create(m.get(), Small(60), &error);
  ASSERT_NE(rec, nullptr) << error;
  EXPECT_EQ(rec->stale_frames_removed(), 2);
  EXPECT_FALSE(fs::exists(dir_ / "frames" / "frame_000999.png"));
  EXPECT_TRUE(fs::exists(dir_ / "frames" / "frame_12.png"));
  EXPECT_TRUE(fs::exists(dir_ / "frames" / "notes.txt"));
}

TEST_F(FrameRecorderTest, AsyncAndSyncWritingGiveIdenticalFiles) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  std::vector<std::string> files[2];
  for (int async = 0; async < 2; ++async) {
    auto d = testing::MakeData(m.get());
    RenderSettings s = Small(60);
    s.dir = (dir_ / (async ? "async" : "sync")).string();
    s.async_write = async;
    std::string error;
    auto rec = FrameRecorder::Create(m.get(), s, &error);
    ASSERT_NE(rec, nullptr) << error;
    Run(m.get(), d.get(), rec.get(), 0.2);
    ASSERT_TRUE(rec->Finish(&error)) << error;
    for (int64_t j = 0; j < rec->frame_count(); ++j) files[async].push_back(ReadBytes(rec->FramePath(j)));
  }
  ASSERT_EQ(files[0].size(), 13u);
  EXPECT_EQ(files[0], files[1]);
  EXPECT_NE(files[0].front(), files[0].back()) << "the pushed body moves between frames";
}

TEST_F(FrameRecorderTest, WriteErrorsSurface) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  for (bool async : {false, true}) {
    SCOPED_TRACE(async ? "async" : "sync");
    auto d = testing::MakeData(m.get());
    RenderSettings s = Small(60);
    s.async_write = async;
    std::string error;
    auto rec = FrameRecorder::Create(m.get(), s, &error);
    ASSERT_NE(rec, nullptr) << error;
    fs::remove_all(s.dir);  // the directory disappears after validation
    if (!async) {
      EXPECT_THROW(rec->MaybeCapture(m.get(), d.get(), Overlay()), std::runtime_error);
    } else {
      EXPECT_TRUE(rec->MaybeCapture(m.get(), d.get(), Overlay()));  // queued
      EXPECT_FALSE(rec->Finish(&error));
      EXPECT_NE(error.find("frame_000000.png"), std::string::npos) << error;
    }
  }
}

TEST_F(FrameRecorderTest, OverlayFormatsAllFieldsAndDefaults) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  d->qvel[0] = 0.75;
  d->time = 1.25;
  mj_forward(m.get(), d.get());
  std::string labels, values;
  Overlay o;
  FormatOverlay(o, m.get(), d.get(), /*track_body_id=*/1, &labels, &values);
  EXPECT_EQ(labels, "Method\nHop\nTime\nLast cost\nSpeed");
  EXPECT_EQ(values, "-\n-\n1.250 s\n-\n+0.750 m/s");  // speed from the tracked body
  o.method = "Algorithm 1";
  o.iteration = 4;
  o.hop = 7;
  o.time = 3.5;
  o.last_cost = 12.5;
  o.forward_speed = -0.25;
  FormatOverlay(o, m.get(), d.get(), -1, &labels, &values);
  EXPECT_EQ(labels, "Method\nIteration\nHop\nTime\nLast cost\nSpeed");
  EXPECT_EQ(values, "Algorithm 1\n4\n7\n3.500 s\n12.5\n-0.250 m/s");
}

}  // namespace
}  // namespace ddoc
