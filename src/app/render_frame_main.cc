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
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "ddoc/render/frame_recorder.h"
#include "ddoc/render/offscreen_renderer.h"
#include "ddoc/render/png.h"

int main(int argc, char** argv) {
  std::string model_path, out_path, text;
  double time = 0;
  ddoc::RenderSettings settings;
  CLI::App cli{"ddoc-render-frame: one headless (OSMesa) frame of an MJCF model into a PNG"};
  cli.add_option("--model", model_path, "MJCF file")->required();
  cli.add_option("--out", out_path, "PNG file")->required();
  cli.add_option("--width", settings.width, "pixels (default 640)");
  cli.add_option("--height", settings.height, "pixels (default 480)");
  cli.add_option("--time", time, "seconds of passive simulation first (default 0)");
  cli.add_option("--body", settings.track_body, "body the camera tracks");
  cli.add_option("--distance", settings.camera_distance, "camera distance, m");
  cli.add_option("--elevation", settings.camera_elevation, "camera elevation, deg");
  cli.add_option("--text", text, "method name of the overlay (none: no overlay)");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }

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
