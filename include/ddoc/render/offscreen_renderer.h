// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Headless rendering of a MuJoCo 2.2 model with MuJoCo's own renderer (mjv_/mjr_) into
// an OSMesa (software OpenGL) context: no X, no GLFW, no GPU.
//
// How the GL functions get resolved: Debian's libmujoco 2.2.2 does not link libGL. Its
// glad loader (mjGladLoadGL, run once by the first mjr_makeContext) looks, in the global
// symbol scope of the process (dlopen(NULL)), for eglGetProcAddress, then
// OSMesaGetProcAddress, then glXGetProcAddressARB, and falls back to walking the loaded
// DSOs (dl_iterate_phdr) for libGL/libGLX/libEGL/libOSMesa. ddoc_render links libOSMesa,
// so OSMesaGetProcAddress is found in the global scope and every gl* entry point comes
// from OSMesa. Keep libEGL out of processes that render: it would be picked first.
#ifndef DDOC_RENDER_OFFSCREEN_RENDERER_H_
#define DDOC_RENDER_OFFSCREEN_RENDERER_H_

#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "ddoc/render/render_settings.h"

namespace ddoc {

/// Renders mjData states of one mjModel into RGB images.
///
/// Rendering only reads the simulation: mjv_updateScene copies poses out of mjData
/// (xpos, xmat, geom_xpos, ...) and uses mjData's scratch stack, but never writes
/// qpos, qvel, act, time, ctrl or any other state (tested bit-for-bit in
/// tests/render/render_determinism_test.cc).
///
/// Each renderer owns its OSMesa context and makes it current on the calling thread in
/// Render(); do not use one renderer from two threads at once.
class OffscreenRenderer {
 public:
  /// Creates the OSMesa context, MuJoCo's scene and GL context, and an offscreen buffer of
  /// settings.width x settings.height. Returns null and sets *error (if non-null) when the
  /// settings are invalid (RenderSettings::Validate, except that `dir` is not needed and
  /// not touched here), when settings.track_body is not a body of m, or when OSMesa /
  /// OpenGL cannot be set up; never returns half an object. m must outlive the renderer.
  static std::unique_ptr<OffscreenRenderer> Create(const mjModel* m,
                                                   const RenderSettings& settings,
                                                   std::string* error);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  /// Renders the state in d (poses as computed by the last mj_step/mj_forward) and reads
  /// the image back. m must be the model given to Create (its GL resources were made
  /// from it). overlay_left and overlay_right are the two columns of the text table
  /// that mjr_overlay draws in the top-left corner (lines separated by '\n'; e.g. labels
  /// left, values right); empty strings draw nothing.
  /// rgb: resized to 3 * width * height, row-major, TOP row first (OpenGL's bottom-up
  /// rows are flipped), 8-bit R, G, B per pixel.
  void Render(const mjModel* m, mjData* d, const std::string& overlay_left,
              const std::string& overlay_right, std::vector<unsigned char>* rgb);

  /// Projects world point p (3) with the camera of the last Render() into image pixel
  /// coordinates: *col in [0, width) from the left, *row in [0, height) from the TOP.
  /// Returns false when p is behind the camera. Pinhole model of mjr_render:
  /// with v = p - cam.pos, z = v.forward, x = v.(forward x up), y = v.up,
  ///   col = width * (0.5 + (near x / z - center) / (2 hw)),  hw = aspect (top-bottom)/2,
  ///   row = height * (1 - (near y / z - bottom) / (top - bottom)).
  bool ProjectToPixel(const double p[3], double* col, double* row) const;

  int width() const { return width_; }
  int height() const { return height_; }
  /// Id of the tracked body in the model, or -1 when the camera does not track a body.
  int track_body_id() const { return track_body_id_; }
  /// True when the renderer draws its own grid lines because the floor has no texture.
  bool draws_grid_lines() const { return grid_plane_geom_ >= 0; }
  /// The GL_RENDERER string of the context (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
  const std::string& gl_renderer() const { return gl_renderer_; }

 private:
  struct GlState;  // OSMesa context and its (unused, 1x1) default framebuffer
  OffscreenRenderer() = default;
  void MakeCurrent();
  void AddGridLines(const mjModel* m);
  void AddSunLight();

  RenderSettings settings_;
  std::unique_ptr<GlState> gl_;
  int width_ = 0;
  int height_ = 0;
  int track_body_id_ = -1;
  int grid_plane_geom_ = -1;  // untextured horizontal plane that gets grid lines, or -1
  bool scene_made_ = false;
  bool context_made_ = false;
  mjvScene scene_;
  mjvOption option_;
  mjvCamera camera_;
  mjrContext context_;
  std::vector<unsigned char> flipped_;  // 3 * width * height, bottom row first (GL order)
  std::string gl_renderer_;
};

}  // namespace ddoc

#endif  // DDOC_RENDER_OFFSCREEN_RENDERER_H_
