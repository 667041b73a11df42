// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// OffscreenRenderer: frames are not blank, show the body where the camera model projects
// it, change only around a moving body, follow the tracked body, and show grid lines on
// an untextured floor.
#include "ddoc/render/offscreen_renderer.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "render_test_util.h"

namespace ddoc {
namespace {

using testing::IsRed;
using testing::Pixel;
using testing::RenderTest;

constexpr int kWidth = 320;
constexpr int kHeight = 240;

class OffscreenRendererTest : public RenderTest {
 protected:
  std::unique_ptr<OffscreenRenderer> Make(const mjModel* m, const std::string& track) {
    RenderSettings s;
    s.width = kWidth;
    s.height = kHeight;
    s.track_body = track;
    std::string error;
    auto r = OffscreenRenderer::Create(m, s, &error);
    EXPECT_NE(r, nullptr) << error;
    return r;
  }
  // Places the torso at x (qpos of the x slide) and recomputes poses.
  static void SetX(const mjModel* m, mjData* d, double x) {
    d->qpos[0] = x;
    mj_forward(m, d);
  }
  // Image coordinates of the torso centre.
  static void TorsoPixel(const OffscreenRenderer& r, const mjData* d, double* col, double* row) {
    ASSERT_TRUE(r.ProjectToPixel(d->xpos + 3, col, row));  // body 1 = torso
  }
};

TEST_F(OffscreenRendererTest, FrameIsNotBlankAndShowsTheBodyWhereProjected) {
  for (bool textured : {true, false}) {
    SCOPED_TRACE(textured ? "textured floor" : "plain floor");
    auto m = testing::LoadModel(testing::TestModelXml(textured));
    auto d = testing::MakeData(m.get());
    SetX(m.get(), d.get(), 0.3);
    auto r = Make(m.get(), "");
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->draws_grid_lines(), !textured);

    std::vector<unsigned char> rgb;
    r->Render(m.get(), d.get(), "", "", &rgb);
    ASSERT_EQ(rgb.size(), 3u * kWidth * kHeight);

    // Not blank: the grey-level variance is large and there are many distinct colours.
    double mean = 0, var = 0;
    std::set<int> colours;
    for (size_t i = 0; i < rgb.size(); i += 3) {
      const double grey = (rgb[i] + rgb[i + 1] + rgb[i + 2]) / 3.0;
      mean += grey;
      var += grey * grey;
      colours.insert(rgb[i] << 16 | rgb[i + 1] << 8 | rgb[i + 2]);
    }
    const double n = kWidth * kHeight;
    mean /= n;
    var = var / n - mean * mean;
    EXPECT_GT(std::sqrt(var), 15.0) << "mean grey " << mean;
    EXPECT_GT(colours.size(), 100u);

    // The red capsule is where ProjectToPixel puts the body centre, and it is a localized
    // blob: some hundreds of red pixels, not the whole image.
    double col = 0, row = 0;
    TorsoPixel(*r, d.get(), &col, &row);
    ASSERT_GE(col, 0);
    ASSERT_LT(col, kWidth);
    ASSERT_GE(row, 0);
    ASSERT_LT(row, kHeight);
    EXPECT_TRUE(IsRed(Pixel(rgb, kWidth, static_cast<int>(col), static_cast<int>(row))))
        << "pixel at projected torso (" << col << ", " << row << ") is not red";
    int red = 0;
    for (size_t i = 0; i < rgb.size(); i += 3) red += IsRed(&rgb[i]);
    EXPECT_GT(red, 200);
    EXPECT_LT(red, n / 4);
  }
}

TEST_F(OffscreenRendererTest, FramesOfAMovingBodyDifferOnlyWhereTheBodyIs) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  auto r = Make(m.get(), "");  // fixed camera, so only the body moves in the image
  ASSERT_NE(r, nullptr);

  std::vector<unsigned char> before, after;
  double col0, row0, col1, row1;
  SetX(m.get(), d.get(), -0.3);
  r->Render(m.get(), d.get(), "", "", &before);
  TorsoPixel(*r, d.get(), &col0, &row0);
  SetX(m.get(), d.get(), 0.4);
  r->Render(m.get(), d.get(), "", "", &after);
  TorsoPixel(*r, d.get(), &col1, &row1);
  ASSERT_GT(col1 - col0, 20) << "the body should move right in the image";

  // Bounding box of the changed pixels.
  int left = kWidth, right = -1, top = kHeight, bottom = -1, changed = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const unsigned char* a = Pixel(before, kWidth, x, y);
      const unsigned char* b = Pixel(after, kWidth, x, y);
      const int diff = std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]),
                                 std::abs(a[2] - b[2])});
      if (diff <= 24) continue;
      ++changed;
      left = std::min(left, x);
      right = std::max(right, x);
      top = std::min(top, y);
      bottom = std::max(bottom, y);
    }
  }
  ASSERT_GT(changed, 100);
  // It contains both projected body centres ...
  EXPECT_LE(left, col0);
  EXPECT_GE(right, col1);
  EXPECT_LE(top, std::min(row0, row1));
  EXPECT_GE(bottom, std::max(row0, row1));
  // ... and is localized around them: the capsule is 0.56 m tall and 0.16 m wide, the
  // camera 3 m away, so the box stays well inside a third of the image.
  const double box_area = double(right - left + 1) * (bottom - top + 1);
  EXPECT_LT(box_area, kWidth * kHeight / 3.0)
      << "box [" << left << ", " << right << "] x [" << top << ", " << bottom << "]";
  EXPECT_LT(right - left, kWidth / 2);
}

TEST_F(OffscreenRendererTest, CameraFollowsTheTrackedBodyHorizontally) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  auto r = Make(m.get(), "torso");
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->track_body_id(), 1);

  std::vector<unsigned char> near, far;
  double col0, row0, col1, row1;
  SetX(m.get(), d.get(), 0.0);
  r->Render(m.get(), d.get(), "", "", &near);
  TorsoPixel(*r, d.get(), &col0, &row0);
  SetX(m.get(), d.get(), 5.2);  // far outside the view of the x = 0 camera
  r->Render(m.get(), d.get(), "", "", &far);
  TorsoPixel(*r, d.get(), &col1, &row1);

  // The body stays at the horizontal image centre and is visible there ...
  EXPECT_NEAR(col0, kWidth / 2.0, 1.0);
  EXPECT_NEAR(col1, kWidth / 2.0, 1.0);
  EXPECT_NEAR(row0, row1, 1.0);
  EXPECT_TRUE(IsRed(Pixel(far, kWidth, static_cast<int>(col1), static_cast<int>(row1))));
  // ... while the floor moved under it (5.2 m is not a multiple of the checker period).
  int differing = 0;
  for (size_t i = 0; i < near.size(); ++i) differing += near[i] != far[i];
  EXPECT_GT(differing, 0);
}

TEST_F(OffscreenRendererTest, PlainFloorGetsGridLinesThatScrollWithTheCamera) {
  auto m = testing::LoadModel(testing::TestModelXml(false));
  auto d = testing::MakeData(m.get());
  RenderSettings s;
  s.width = kWidth;
  s.height = kHeight;
  s.track_body = "torso";
  std::string error;
  auto with_grid = OffscreenRenderer::Create(m.get(), s, &error);
  ASSERT_NE(with_grid, nullptr) << error;
  s.grid_spacing = 0;
  auto without_grid = OffscreenRenderer::Create(m.get(), s, &error);
  ASSERT_NE(without_grid, nullptr) << error;
  EXPECT_TRUE(with_grid->draws_grid_lines());
  EXPECT_FALSE(without_grid->draws_grid_lines());

  // Look at the bottom quarter of the image (floor only) and count pixels that differ.
  SetX(m.get(), d.get(), 0.0);
  std::vector<unsigned char> a, b, c;
  with_grid->Render(m.get(), d.get(), "", "", &a);
  without_grid->Render(m.get(), d.get(), "", "", &b);
  auto floor_diff = [](const std::vector<unsigned char>& p, const std::vector<unsigned char>& q) {
    int n = 0;
    for (int y = 3 * kHeight / 4; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const unsigned char* u = Pixel(p, kWidth, x, y);
        const unsigned char* v = Pixel(q, kWidth, x, y);
        n += std::abs(u[0] - v[0]) + std::abs(u[1] - v[1]) + std::abs(u[2] - v[2]) > 30;
      }
    }
    return n;
  };
  const int line_pixels = floor_diff(a, b);
  EXPECT_GT(line_pixels, 200) << "grid lines should be visible on the plain floor";
  EXPECT_LT(line_pixels, kWidth * kHeight / 8) << "lines, not a repaint of the floor";

  // Moving by a quarter of the grid spacing shifts the lines in the image.
  SetX(m.get(), d.get(), 0.125);
  with_grid->Render(m.get(), d.get(), "", "", &c);
  EXPECT_GT(floor_diff(a, c), 100);
}

TEST_F(OffscreenRendererTest, SunLightKeepsTheFloorLitFarFromTheModelsLight) {
  // The test model's only light is a spotlight above the origin.
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  auto floor_brightness = [&](bool sun, double x) {
    RenderSettings s;
    s.width = kWidth;
    s.height = kHeight;
    s.sun_light = sun;
    std::string error;
    auto r = OffscreenRenderer::Create(m.get(), s, &error);
    EXPECT_NE(r, nullptr) << error;
    SetX(m.get(), d.get(), x);
    std::vector<unsigned char> rgb;
    r->Render(m.get(), d.get(), "", "", &rgb);
    double sum = 0;  // mean grey level of the bottom quarter (floor only)
    for (int y = 3 * kHeight / 4; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const unsigned char* p = Pixel(rgb, kWidth, x, y);
        sum += (p[0] + p[1] + p[2]) / 3.0;
      }
    }
    return sum / (kWidth * kHeight / 4);
  };
  const double near_sun = floor_brightness(true, 0.0);
  const double far_sun = floor_brightness(true, 40.0);
  const double far_dark = floor_brightness(false, 40.0);
  EXPECT_GT(far_sun, far_dark + 20) << "the sun must light the floor 40 m from the spotlight";
  EXPECT_GT(far_sun, 0.5 * near_sun) << "near " << near_sun << ", far " << far_sun;
}

TEST_F(OffscreenRendererTest, CoarseInfinitePlaneKeepsTheFloorTexture) {
  // The finite stand-in for the infinite floor may change the lighting, not the texture:
  // the checker edges (strong horizontal gradients) must be at the same pixels.
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  SetX(m.get(), d.get(), 1.3);
  std::vector<unsigned char> images[2];
  for (int fine = 0; fine < 2; ++fine) {
    RenderSettings s;
    s.width = kWidth;
    s.height = kHeight;
    s.fine_infinite_planes = fine;
    std::string error;
    auto r = OffscreenRenderer::Create(m.get(), s, &error);
    ASSERT_NE(r, nullptr) << error;
    r->Render(m.get(), d.get(), "", "", &images[fine]);
  }
  auto grey = [&](const std::vector<unsigned char>& rgb, int x, int y) {
    const unsigned char* p = Pixel(rgb, kWidth, x, y);
    return (p[0] + p[1] + p[2]) / 3.0;
  };
  int edges = 0, matched = 0;
  for (int y = 3 * kHeight / 4; y < kHeight; ++y) {
    for (int x = 0; x + 1 < kWidth; ++x) {
      const double g_fine = grey(images[1], x + 1, y) - grey(images[1], x, y);
      const double g_coarse = grey(images[0], x + 1, y) - grey(images[0], x, y);
      if (std::abs(g_fine) < 12) continue;
      ++edges;
      matched += std::abs(g_coarse) > 4 && (g_coarse > 0) == (g_fine > 0);
    }
  }
  ASSERT_GT(edges, 100) << "the checker floor should have edges";
  EXPECT_GT(matched, 0.9 * edges) << matched << " of " << edges << " edges match";
}

TEST_F(OffscreenRendererTest, OverlayTextIsDrawnTopLeft) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  SetX(m.get(), d.get(), 0.0);
  auto r = Make(m.get(), "torso");
  ASSERT_NE(r, nullptr);
  std::vector<unsigned char> plain, text;
  r->Render(m.get(), d.get(), "", "", &plain);
  r->Render(m.get(), d.get(), "Method\nHop", "Algorithm 1\n3", &text);
  int top_left = 0, elsewhere = 0, max_x = 0, max_y = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const bool differs =
          std::memcmp(Pixel(plain, kWidth, x, y), Pixel(text, kWidth, x, y), 3) != 0;
      // The label/value table at mjFONTSCALE_100 is ~150 x 50 pixels here.
      (x < 0.7 * kWidth && y < 0.35 * kHeight ? top_left : elsewhere) += differs;
      if (differs) {
        max_x = std::max(max_x, x);
        max_y = std::max(max_y, y);
      }
    }
  }
  EXPECT_GT(top_left, 100);
  EXPECT_EQ(elsewhere, 0) << "changed pixels reach x = " << max_x << ", y = " << max_y;
}

TEST_F(OffscreenRendererTest, TwoRenderersInOneProcessAreIndependent) {
  auto m = testing::LoadModel(testing::TestModelXml(true));
  auto d = testing::MakeData(m.get());
  SetX(m.get(), d.get(), 0.2);
  auto r1 = Make(m.get(), "torso");
  std::vector<unsigned char> a, b, c;
  r1->Render(m.get(), d.get(), "", "", &a);
  {
    RenderSettings s;
    s.width = 100;
    s.height = 80;
    std::string error;
    auto r2 = OffscreenRenderer::Create(m.get(), s, &error);
    ASSERT_NE(r2, nullptr) << error;
    r2->Render(m.get(), d.get(), "", "", &b);
    EXPECT_EQ(b.size(), 3u * 100 * 80);
  }
  r1->Render(m.get(), d.get(), "", "", &c);
  EXPECT_EQ(a, c) << "rendering is deterministic and unaffected by another context";
}

}  // namespace
}  // namespace ddoc
