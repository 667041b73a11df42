// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-render-frame: renders one frame of an MJCF model into a PNG, headless (OSMesa).
//
//   ddoc-render-frame --model models/hopper.xml --out tools/assets/hopper_frame.png
//                     [--width 640] [--height 480] [--time 0] [--body torso]
//                     [--distance 3] [--elevation -12] [--text "Algorithm 1"]
//
// The state shown is the model's initial state (qpos0, or keyframe 0 when the model has
// one) after --time seconds of passive simulation (zero controls).
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "ddoc/render/frame_recorder.h"
#include "ddoc/render/offscreen_renderer.h"
#include "ddoc/render/png.h"

namespace {

int Usage(const char* error) {
  if (error) std::cerr << "ddoc-render-frame: " << error << "\n";
  std::cerr << "usage: ddoc-render-frame --model FILE.xml --out FILE.png [--width W] "
               "[--height H] [--time T] [--body NAME] [--distance D] [--elevation DEG] "
               "[--text METHOD]\n";
  return 2;
}

bool ParseDouble(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end && *end == '\0' && !text.empty();
}

}  // namespace

int main(int argc, char** argv) {
  std::string model_path, out_path, text;
  double time = 0;
  ddoc::RenderSettings settings;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") return Usage(nullptr), 0;
    if (i + 1 >= argc) return Usage(("missing value after " + flag).c_str());
    const std::string value = argv[++i];
    double number = 0;
    const bool numeric = ParseDouble(value, &number);
    if (flag == "--model") {
      model_path = value;
    } else if (flag == "--out") {
      out_path = value;
    } else if (flag == "--body") {
      settings.track_body = value;
    } else if (flag == "--text") {
      text = value;
    } else if (!numeric) {
      return Usage((flag + " needs a number, got '" + value + "'").c_str());
    } else if (flag == "--width") {
      settings.width = static_cast<int>(number);
    } else if (flag == "--height") {
      settings.height = static_cast<int>(number);
    } else if (flag == "--time") {
      time = number;
    } else if (flag == "--distance") {
      settings.camera_distance = number;
    } else if (flag == "--elevation") {
      settings.camera_elevation = number;
    } else {
      return Usage(("unknown option " + flag).c_str());
    }
  }
  if (model_path.empty() || out_path.empty()) return Usage("--model and --out are required");

  char load_error[1000] = "";
  std::unique_ptr<mjModel, void (*)(mjModel*)> m(
      mj_loadXML(model_path.c_str(), nullptr, load_error, sizeof(load_error)), mj_deleteModel);
  if (!m) {
    std::cerr << "ddoc-render-frame: cannot load " << model_path << ": " << load_error << "\n";
    return 1;
  }
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m.get()), mj_deleteData);
  if (m->nkey > 0) mj_resetDataKeyframe(m.get(), d.get(), 0);
  mj_forward(m.get(), d.get());
  while (d->time < time) mj_step(m.get(), d.get());

  std::string error;
  auto renderer = ddoc::OffscreenRenderer::Create(m.get(), settings, &error);
  if (!renderer) {
    std::cerr << "ddoc-render-frame: " << error << "\n";
    return 1;
  }
  ddoc::Overlay overlay;
  overlay.method = text;
  std::string labels, values;
  ddoc::FormatOverlay(overlay, m.get(), d.get(), renderer->track_body_id(), &labels, &values);
  std::vector<unsigned char> rgb;
  renderer->Render(m.get(), d.get(), text.empty() ? "" : labels, text.empty() ? "" : values,
                   &rgb);
  if (!ddoc::WritePng(out_path, rgb, renderer->width(), renderer->height(), &error,
                      ddoc::PngCompression::kSmall)) {
    std::cerr << "ddoc-render-frame: " << error << "\n";
    return 1;
  }
  std::printf("wrote %s (%dx%d, t = %.3f s, %s)\n", out_path.c_str(), renderer->width(),
              renderer->height(), d->time, renderer->gl_renderer().c_str());
  return 0;
}
