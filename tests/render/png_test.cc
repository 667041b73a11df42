// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// PNG encoding: lossless round trip for both compression settings, clear errors.
#include "ddoc/render/png.h"

#include <cstdint>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "render_test_util.h"

namespace ddoc {
namespace {

using testing::RenderTest;

class PngTest : public RenderTest {};

// A test image with flat areas, gradients and fixed-seed noise, 3 * w * h bytes.
std::vector<unsigned char> TestImage(int w, int h) {
  std::mt19937 rng(7);
  std::vector<unsigned char> rgb(3 * static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      unsigned char* p = &rgb[3 * (static_cast<size_t>(y) * w + x)];
      p[0] = static_cast<unsigned char>(x < w / 2 ? 200 : x);
      p[1] = static_cast<unsigned char>(y);
      p[2] = static_cast<unsigned char>(y > h / 2 ? rng() : 40);
    }
  }
  return rgb;
}

TEST_F(PngTest, RoundTripIsLosslessForBothCompressions) {
  const int w = 67, h = 45;  // odd sizes
  const std::vector<unsigned char> rgb = TestImage(w, h);
  std::filesystem::create_directories(dir_);
  for (PngCompression c : {PngCompression::kFast, PngCompression::kSmall}) {
    const std::string path = (dir_ / "x.png").string();
    std::string error;
    ASSERT_TRUE(WritePng(path, rgb, w, h, &error, c)) << error;
    std::vector<unsigned char> back;
    int bw = 0, bh = 0;
    ASSERT_TRUE(ReadPng(path, &back, &bw, &bh, &error)) << error;
    EXPECT_EQ(bw, w);
    EXPECT_EQ(bh, h);
    EXPECT_EQ(back, rgb);
  }
}

TEST_F(PngTest, SmallIsNotLargerThanFast) {
  const std::vector<unsigned char> rgb = TestImage(200, 150);
  std::vector<unsigned char> fast, small;
  std::string error;
  ASSERT_TRUE(EncodePng(rgb, 200, 150, &fast, &error, PngCompression::kFast)) << error;
  ASSERT_TRUE(EncodePng(rgb, 200, 150, &small, &error, PngCompression::kSmall)) << error;
  EXPECT_LE(small.size(), fast.size());
}

TEST_F(PngTest, SizeMismatchAndUnwritablePathAreReported) {
  std::vector<unsigned char> png;
  std::string error;
  EXPECT_FALSE(EncodePng(std::vector<unsigned char>(10), 4, 4, &png, &error));
  EXPECT_NE(error.find("rgb has 10 bytes, expected 3 * 4 * 4"), std::string::npos) << error;
  const std::string path = (dir_ / "missing" / "f.png").string();
  EXPECT_FALSE(WritePng(path, TestImage(4, 4), 4, 4, &error));
  EXPECT_NE(error.find("cannot write '" + path + "'"), std::string::npos) << error;
  EXPECT_FALSE(ReadPng(path, &png, nullptr, nullptr, &error));
  EXPECT_NE(error.find("cannot read PNG"), std::string::npos) << error;
}

}  // namespace
}  // namespace ddoc
