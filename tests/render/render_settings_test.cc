// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// RenderSettings::Validate and the create-time checks: bad input is rejected with a
// message naming the field, before any simulation or rendering.
#include "ddoc/render/render_settings.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include "ddoc/render/frame_recorder.h"
#include "ddoc/render/offscreen_renderer.h"
#include "render_test_util.h"

namespace ddoc {
namespace {

namespace fs = std::filesystem;
using testing::RenderTest;

class RenderSettingsTest : public RenderTest {
 protected:
  RenderSettings Valid() const {
    RenderSettings s;
    s.dir = (dir_ / "frames").string();
    return s;
  }
  // Validate must fail, and the message must contain `needle`.
  void ExpectInvalid(const RenderSettings& s, const std::string& needle) {
    std::string error;
    EXPECT_FALSE(s.Validate(&error)) << "accepted: " << needle;
    EXPECT_NE(error.find(needle), std::string::npos) << "message: " << error;
  }
};

TEST_F(RenderSettingsTest, DefaultsAreValidAndCreateNestedDirectory) {
  RenderSettings s = Valid();
  s.dir = (dir_ / "a" / "b" / "c").string();
  std::string error;
  ASSERT_TRUE(s.Validate(&error)) << error;
  EXPECT_TRUE(fs::is_directory(s.dir));
  EXPECT_EQ(s.width, 640);
  EXPECT_EQ(s.height, 480);
  EXPECT_EQ(s.fps, 60);
  // The writability probe leaves nothing behind.
  EXPECT_TRUE(fs::is_empty(s.dir));
}

TEST_F(RenderSettingsTest, RejectsZeroOrNegativeSize) {
  for (int bad : {0, -1, -640}) {
    RenderSettings s = Valid();
    s.width = bad;
    ExpectInvalid(s, "width must be in [1, 8192] pixels, got " + std::to_string(bad));
    s = Valid();
    s.height = bad;
    ExpectInvalid(s, "height must be in [1, 8192] pixels, got " + std::to_string(bad));
  }
  RenderSettings s = Valid();
  s.width = RenderSettings::kMaxImageSize + 1;
  ExpectInvalid(s, "width");
}

TEST_F(RenderSettingsTest, RejectsZeroNegativeNonFiniteOrTooLargeFps) {
  for (double bad : {0.0, -1.0, -60.0, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    RenderSettings s = Valid();
    s.fps = bad;
    ExpectInvalid(s, "fps must be > 0 and finite");
  }
  // 1e9 fps wrote 500 000 copies of each 0.5 ms step's frame until the disk was full.
  RenderSettings s = Valid();
  s.fps = 1e9;
  ExpectInvalid(s, "fps must be at most 1000 (more frames than physics steps only repeat them, "
                   "one file each), got 1e+09");
  s.fps = RenderSettings::kMaxFps;
  std::string error;
  EXPECT_TRUE(s.Validate(&error)) << error;
}

TEST_F(RenderSettingsTest, RejectsBadCameraAndQualityFields) {
  RenderSettings s = Valid();
  s.camera_distance = 0;
  ExpectInvalid(s, "camera_distance");
  s = Valid();
  s.multisamples = -1;
  ExpectInvalid(s, "multisamples");
  s = Valid();
  s.grid_spacing = -0.5;
  ExpectInvalid(s, "grid_spacing");
  s = Valid();
  s.lookat_z = std::numeric_limits<double>::quiet_NaN();
  ExpectInvalid(s, "finite");
}

TEST_F(RenderSettingsTest, RejectsEmptyDirectory) {
  RenderSettings s = Valid();
  s.dir = "";
  ExpectInvalid(s, "output directory is empty");
}

TEST_F(RenderSettingsTest, RejectsDirectoryUnderARegularFile) {
  fs::create_directories(dir_);
  const fs::path file = dir_ / "not_a_dir";
  std::ofstream(file) << "x";
  RenderSettings s = Valid();
  s.dir = (file / "frames").string();
  ExpectInvalid(s, "cannot create output directory '" + s.dir + "'");
  // The path itself being a regular file is also an error.
  s.dir = file.string();
  ExpectInvalid(s, "exists but is not a directory");
}

TEST_F(RenderSettingsTest, RejectsReadOnlyDirectory) {
  // Root writes into a 0555 directory, and the suite runs as root on our machines and in CI; the
  // read-only directory is then /proc/self, a directory in which no process, root included, can
  // create a file or a subdirectory.
  const bool root = ::geteuid() == 0;
  fs::path ro = dir_ / "ro";
  if (root) {
    ro = "/proc/self";
    ASSERT_TRUE(fs::is_directory(ro)) << "no /proc: no read-only directory to test as root";
  } else {
    fs::create_directories(ro);
    ::chmod(ro.c_str(), 0555);
  }
  RenderSettings s = Valid();
  s.dir = ro.string();
  ExpectInvalid(s, "is not writable");
  s.dir = (ro / "sub").string();
  ExpectInvalid(s, "cannot create output directory");
  if (!root) ::chmod(ro.c_str(), 0755);
}

TEST_F(RenderSettingsTest, RecorderCreateFailsBeforeRenderingOnBadSettings) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  RenderSettings s = Valid();
  s.fps = 0;
  std::string error;
  EXPECT_EQ(FrameRecorder::Create(m.get(), s, &error), nullptr);
  EXPECT_NE(error.find("fps"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(s.dir)) << "no directory may be created for invalid settings";

  s = Valid();
  s.height = -3;
  EXPECT_EQ(OffscreenRenderer::Create(m.get(), s, &error), nullptr);
  EXPECT_NE(error.find("height"), std::string::npos) << error;
}

TEST_F(RenderSettingsTest, UnknownTrackBodyIsNamed) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  RenderSettings s = Valid();
  s.track_body = "pelvis";
  std::string error;
  EXPECT_EQ(OffscreenRenderer::Create(m.get(), s, &error), nullptr);
  EXPECT_NE(error.find("track_body 'pelvis' is not a body"), std::string::npos) << error;
  EXPECT_NE(error.find("torso"), std::string::npos) << "should list the bodies: " << error;
}

TEST_F(RenderSettingsTest, NullModelIsRejected) {
  std::string error;
  EXPECT_EQ(OffscreenRenderer::Create(nullptr, Valid(), &error), nullptr);
  EXPECT_NE(error.find("model is null"), std::string::npos) << error;
}

}  // namespace
}  // namespace ddoc
