// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// AssembleVideo: an MP4 from recorded frames when ffmpeg is installed; a clear message
// when it is not, when there are no frames, or when fps is bad.
#include "ddoc/render/video.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <sys/stat.h>

#include "ddoc/render/frame_recorder.h"
#include "render_test_util.h"

namespace ddoc {
namespace {

namespace fs = std::filesystem;
using testing::RenderTest;

// Sets PATH for the lifetime of the object.
class ScopedPath {
 public:
  explicit ScopedPath(const std::string& value) {
    const char* old = std::getenv("PATH");
    had_ = old != nullptr;
    if (had_) old_ = old;
    setenv("PATH", value.c_str(), 1);
  }
  ~ScopedPath() {
    if (had_) {
      setenv("PATH", old_.c_str(), 1);
    } else {
      unsetenv("PATH");
    }
  }

 private:
  bool had_ = false;
  std::string old_;
};

class VideoTest : public RenderTest {
 protected:
  // Records 0.25 s at 20 fps (6 frames, 95 x 71: odd sizes, which AssembleVideo pads to even for
  // yuv420p) of the pushed test model to `s`'s destinations (dir, video); the recorder is
  // finished. The test has failed when it returns null.
  std::unique_ptr<FrameRecorder> Record(RenderSettings s) {
    model_ = testing::LoadModel(testing::TestModelXml(true));
    auto d = testing::MakeData(model_.get());
    s.width = 95;
    s.height = 71;
    s.fps = 20;
    std::string error;
    auto rec = FrameRecorder::Create(model_.get(), s, &error);
    EXPECT_NE(rec, nullptr) << error;
    if (rec == nullptr) return nullptr;
    rec->MaybeCapture(model_.get(), d.get(), Overlay());
    while (d->time < 0.25 - 1e-9) {
      d->ctrl[0] = 1;
      mj_step(model_.get(), d.get());
      rec->MaybeCapture(model_.get(), d.get(), Overlay());
    }
    const bool finished = rec->Finish(&error);
    EXPECT_TRUE(finished) << error;
    return finished ? std::move(rec) : nullptr;
  }
  // Records the 6 frames into dir_/frames.
  void RecordFrames() {
    RenderSettings s;
    s.dir = (dir_ / "frames").string();
    const auto rec = Record(s);
    ASSERT_NE(rec, nullptr);
    ASSERT_EQ(rec->frame_count(), 6);
  }

  std::unique_ptr<mjModel, void (*)(mjModel*)> model_{nullptr, mj_deleteModel};  // outlives rec
};

TEST_F(VideoTest, FindExecutableSearchesThePathList) {
  fs::create_directories(dir_ / "bin");
  const fs::path tool = dir_ / "bin" / "mytool";
  std::ofstream(tool) << "#!/bin/sh\n";
  EXPECT_EQ(FindExecutable("mytool", "/nonexistent:" + (dir_ / "bin").string()), "");  // not +x
  ::chmod(tool.c_str(), 0755);
  EXPECT_EQ(FindExecutable("mytool", "/nonexistent:" + (dir_ / "bin").string()), tool.string());
  EXPECT_EQ(FindExecutable("mytool", "/nonexistent"), "");
  EXPECT_EQ(FindExecutable("mytool", ""), "");
}

TEST_F(VideoTest, SaysClearlyWhenFfmpegIsNotInstalled) {
  RecordFrames();
  const std::string mp4 = (dir_ / "out.mp4").string();
  std::string message;
  {
    ScopedPath no_ffmpeg((dir_ / "empty_bin").string());
    EXPECT_FALSE(AssembleVideo((dir_ / "frames").string(), 20, mp4, &message));
  }
  EXPECT_NE(message.find("ffmpeg is not installed"), std::string::npos) << message;
  EXPECT_NE(message.find((dir_ / "frames").string()), std::string::npos)
      << "should say where the frames are: " << message;
  EXPECT_FALSE(fs::exists(mp4));
}

TEST_F(VideoTest, RejectsMissingFramesAndBadFps) {
  std::string message;
  EXPECT_FALSE(AssembleVideo((dir_ / "nothing").string(), 60, (dir_ / "a.mp4").string(),
                             &message));
  EXPECT_NE(message.find("no frames to assemble"), std::string::npos) << message;
  EXPECT_FALSE(AssembleVideo((dir_ / "nothing").string(), 0, (dir_ / "a.mp4").string(),
                             &message));
  EXPECT_NE(message.find("fps must be > 0"), std::string::npos) << message;
}

TEST_F(VideoTest, AssemblesAnMp4WhenFfmpegIsInstalled) {
  const char* path = std::getenv("PATH");
  if (FindExecutable("ffmpeg", path ? path : "").empty()) {
    GTEST_SKIP() << "ffmpeg is not installed";
  }
  RecordFrames();
  const fs::path mp4 = dir_ / "video dir" / "out.mp4";  // a space: no shell quoting issues
  fs::create_directories(mp4.parent_path());
  std::string message;
  ASSERT_TRUE(AssembleVideo((dir_ / "frames").string(), 20, mp4.string(), &message)) << message;
  EXPECT_NE(message.find("wrote"), std::string::npos) << message;
  ASSERT_TRUE(fs::exists(mp4));
  EXPECT_GT(fs::file_size(mp4), 500u);
  // An MP4 file has an 'ftyp' box right after the first 4-byte size field.
  std::ifstream in(mp4, std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  EXPECT_EQ(std::string(head + 4, 4), "ftyp");
}

// A recording with settings.video and no dir streams the frames through ffmpeg: the MP4 has one
// frame per 1/fps of simulated time and no PNG file is written.
TEST_F(VideoTest, StreamsFramesIntoAnMp4WithoutPngFiles) {
  const char* path = std::getenv("PATH");
  if (FindExecutable("ffmpeg", path ? path : "").empty()) {
    GTEST_SKIP() << "ffmpeg is not installed";
  }
  RenderSettings s;
  s.video = (dir_ / "videos" / "run.mp4").string();  // its directory is created
  const auto rec = Record(s);
  ASSERT_NE(rec, nullptr);
  EXPECT_NE(rec->video_message().find("wrote " + s.video + " (6 frames"), std::string::npos)
      << rec->video_message();
  ASSERT_TRUE(fs::exists(s.video));
  std::ifstream in(s.video, std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  EXPECT_EQ(std::string(head + 4, 4), "ftyp");
  for (const auto& e : fs::recursive_directory_iterator(dir_)) {
    EXPECT_NE(e.path().extension(), ".png") << e.path();
  }
}

TEST_F(VideoTest, AStreamSaysClearlyWhenFfmpegIsNotInstalledOrAFrameIsWrong) {
  std::string error;
  {
    ScopedPath empty((dir_ / "no-such-dir").string());
    EXPECT_EQ(VideoStream::Start((dir_ / "a.mp4").string(), 96, 72, 20, &error), nullptr);
    EXPECT_NE(error.find("ffmpeg is not installed"), std::string::npos) << error;
  }
  EXPECT_EQ(VideoStream::Start((dir_ / "a.mp4").string(), 96, 72, 0, &error), nullptr);
  EXPECT_NE(error.find("fps must be > 0"), std::string::npos) << error;
  const char* path = std::getenv("PATH");
  if (FindExecutable("ffmpeg", path ? path : "").empty()) return;
  fs::create_directories(dir_);
  auto v = VideoStream::Start((dir_ / "a.mp4").string(), 96, 72, 20, &error);
  ASSERT_NE(v, nullptr) << error;
  EXPECT_FALSE(v->WriteFrame(std::vector<unsigned char>(10), &error));
  EXPECT_NE(error.find("expected 20736"), std::string::npos) << error;
}

}  // namespace
}  // namespace ddoc
