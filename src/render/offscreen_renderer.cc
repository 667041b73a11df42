// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/render/offscreen_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <GL/osmesa.h>

#include "render_internal.h"

namespace ddoc {

namespace {

// Extra scene capacity beyond the model's geoms: MuJoCo's decor (contact points, frames,
// labels when enabled) plus our grid lines.
constexpr int kExtraSceneGeoms = 1000;
// Grid lines never number more than this (the rest of the extra capacity stays for decor).
constexpr int kMaxGridLines = 400;
// Grid line width (m) and height above the floor plane (m, avoids z-fighting).
constexpr double kGridLineWidth = 0.012;
constexpr double kGridLineLift = 0.0015;
// Cells per side of the finite stand-in for an infinite plane (see Create).
constexpr double kInfinitePlaneCells = 48;

// mju_error() calls exit() unless mju_user_error is set. While a ScopedErrorThrow lives,
// MuJoCo errors become C++ exceptions, so that Create() can fail cleanly instead of ending
// the process. (libmujoco is built with unwind tables on x86-64, as GCC does by default.)
// mju_user_error is global: do not create renderers from two threads at once.
[[noreturn]] void ThrowMujocoError(const char* msg) {
  throw std::runtime_error(std::string("MuJoCo error: ") + msg);
}
class ScopedErrorThrow {
 public:
  ScopedErrorThrow() : previous_(mju_user_error) { mju_user_error = ThrowMujocoError; }
  ~ScopedErrorThrow() { mju_user_error = previous_; }

 private:
  void (*previous_)(const char*);
};

std::string BodyList(const mjModel* m) {
  std::ostringstream out;
  for (int b = 0; b < m->nbody; ++b) {
    const char* name = mj_id2name(m, mjOBJ_BODY, b);
    out << (b ? ", " : "") << (name && *name ? name : "(unnamed)");
  }
  return out.str();
}

bool Fail(std::string* error, const std::string& message) {
  if (error) *error = "render: " + message;
  return false;
}

}  // namespace

struct OffscreenRenderer::GlState {
  OSMesaContext context = nullptr;
  // OSMesa's default framebuffer, width x height RGBA. MuJoCo draws into its own offscreen
  // framebuffer object (mjFB_OFFSCREEN); this one only has to exist to make the context
  // current.
  std::vector<unsigned char> window;
  int width = 0;
  int height = 0;
  ~GlState() {
    if (context) OSMesaDestroyContext(context);
  }
};

std::unique_ptr<OffscreenRenderer> OffscreenRenderer::Create(const mjModel* m,
                                                             const RenderSettings& settings,
                                                             std::string* error) {
  if (!m) {
    Fail(error, "model is null");
    return nullptr;
  }
  if (!ValidateRenderGeometry(settings, error)) return nullptr;

  std::unique_ptr<OffscreenRenderer> r(new OffscreenRenderer());
  r->settings_ = settings;
  r->width_ = settings.width;
  r->height_ = settings.height;

  // The tracked body.
  if (!settings.track_body.empty()) {
    r->track_body_id_ = mj_name2id(m, mjOBJ_BODY, settings.track_body.c_str());
    if (r->track_body_id_ < 0) {
      Fail(error, "track_body '" + settings.track_body + "' is not a body of the model " +
                      "(bodies: " + BodyList(m) + ")");
      return nullptr;
    }
  }

  // OSMesa context: RGBA, 24-bit depth, 8-bit stencil, 8-bit accumulation (as in
  // MuJoCo's sample/record.cc). Linking libOSMesa puts OSMesaGetProcAddress into the
  // global symbol scope, which is where MuJoCo's glad loader looks first (see header).
  r->gl_ = std::make_unique<GlState>();
  r->gl_->context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 8, nullptr);
  if (!r->gl_->context) {
    Fail(error, "OSMesaCreateContextExt failed (is libOSMesa's software rasterizer usable?)");
    return nullptr;
  }
  r->gl_->width = settings.width;
  r->gl_->height = settings.height;
  r->gl_->window.assign(4 * static_cast<size_t>(settings.width) * settings.height, 0);
  if (!OSMesaMakeCurrent(r->gl_->context, r->gl_->window.data(), GL_UNSIGNED_BYTE,
                         settings.width, settings.height)) {
    Fail(error, "OSMesaMakeCurrent failed for a " + std::to_string(settings.width) + "x" +
                    std::to_string(settings.height) + " buffer");
    return nullptr;
  }
  const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  if (!version || !renderer) {
    Fail(error, "OpenGL context is not usable (glGetString returned null)");
    return nullptr;
  }
  r->gl_renderer_ = renderer;
  GLint max_renderbuffer = 0;
  glGetIntegerv(0x84E8 /* GL_MAX_RENDERBUFFER_SIZE */, &max_renderbuffer);
  if (max_renderbuffer > 0 &&
      (settings.width > max_renderbuffer || settings.height > max_renderbuffer)) {
    Fail(error, "image " + std::to_string(settings.width) + "x" +
                    std::to_string(settings.height) + " exceeds GL_MAX_RENDERBUFFER_SIZE " +
                    std::to_string(max_renderbuffer) + " of " + r->gl_renderer_);
    return nullptr;
  }

  // MuJoCo sizes its offscreen buffer from m->vis.global.offwidth/offheight and
  // m->vis.quality.offsamples. m is const and owned by the caller, so pass a SHALLOW copy
  // with those three fields changed: mjr_makeContext only reads the model (textures,
  // meshes, visual settings) through the copied pointers and keeps none of them.
  mjModel sized = *m;
  sized.vis.global.offwidth = settings.width;
  sized.vis.global.offheight = settings.height;
  sized.vis.quality.offsamples = settings.multisamples;
  // Infinite planes: mjr_makeContext tessellates each into a fixed 200 x 200 grid of quads
  // (mjMAXPLANEGRID) spanning ~2.1 zfar, which llvmpipe transforms and lights per vertex in
  // every frame (measured: ~5 ms of a 9 ms 640x480 hopper frame). Hand it a finite plane of
  // the same extent with kInfinitePlaneCells cells per side instead. Texture coordinates of
  // planes come from glTexGen on object coordinates and the scene geom keeps size 0, so the
  // texture is unchanged; only per-vertex lighting gets coarser.
  std::vector<mjtNum> plane_sizes(m->geom_size, m->geom_size + 3 * m->ngeom);  // 3 * ngeom
  const mjtNum half_extent = 1.05 * m->vis.map.zfar * m->stat.extent;
  for (int g = 0; g < m->ngeom; ++g) {
    if (settings.fine_infinite_planes || m->geom_type[g] != mjGEOM_PLANE) continue;
    for (int k = 0; k < 2; ++k) {
      if (plane_sizes[3 * g + k] > 0) continue;
      plane_sizes[3 * g + k] = half_extent;
      plane_sizes[3 * g + 2] =
          std::max(plane_sizes[3 * g + 2], half_extent / kInfinitePlaneCells);
    }
  }
  sized.geom_size = plane_sizes.data();

  mjv_defaultScene(&r->scene_);
  mjr_defaultContext(&r->context_);
  try {
    ScopedErrorThrow throw_on_error;
    mjv_makeScene(m, &r->scene_, m->ngeom + kExtraSceneGeoms);
    r->scene_made_ = true;
    // Font: 100 % up to 600 pixels of height (the overlay table then covers ~1/4 of a
    // 640x480 frame), 150 % up to 1000, 200 % beyond.
    const int font_scale = settings.height <= 600    ? mjFONTSCALE_100
                           : settings.height <= 1000 ? mjFONTSCALE_150
                                                     : mjFONTSCALE_200;
    mjr_makeContext(&sized, &r->context_, font_scale);
    r->context_made_ = true;
    mjr_setBuffer(mjFB_OFFSCREEN, &r->context_);
  } catch (const std::exception& e) {
    Fail(error, std::string("cannot create MuJoCo's GL context: ") + e.what());
    return nullptr;  // the destructor frees what was made
  }
  if (r->context_.currentBuffer != mjFB_OFFSCREEN || r->context_.offWidth != settings.width ||
      r->context_.offHeight != settings.height) {
    Fail(error, "MuJoCo's offscreen buffer is " + std::to_string(r->context_.offWidth) + "x" +
                    std::to_string(r->context_.offHeight) + ", expected " +
                    std::to_string(settings.width) + "x" + std::to_string(settings.height));
    return nullptr;
  }

  // Scene and camera.
  r->scene_.flags[mjRND_SHADOW] = settings.shadows ? 1 : 0;
  r->scene_.flags[mjRND_REFLECTION] = settings.reflection ? 1 : 0;
  mjv_defaultOption(&r->option_);
  mjv_defaultFreeCamera(m, &r->camera_);
  r->camera_.type = mjCAMERA_FREE;
  r->camera_.distance = settings.camera_distance;
  r->camera_.azimuth = settings.camera_azimuth;
  r->camera_.elevation = settings.camera_elevation;
  r->camera_.lookat[0] = settings.lookat_x;
  r->camera_.lookat[1] = settings.lookat_y;
  r->camera_.lookat[2] = settings.lookat_z;

  // Grid lines: only when the floor (a horizontal plane of the world body) has no texture.
  // A model whose floor has a texture (e.g. builtin="checker") shows its own grid.
  if (settings.grid_spacing > 0) {
    int plane = -1;
    bool textured = false;
    for (int g = 0; g < m->ngeom; ++g) {
      if (m->geom_type[g] != mjGEOM_PLANE || m->geom_bodyid[g] != 0) continue;
      // Normal = third column of R(geom_quat): horizontal planes have |n_z| ~ 1.
      mjtNum mat[9];
      mju_quat2Mat(mat, m->geom_quat + 4 * g);
      if (std::fabs(mat[8]) < 0.999) continue;
      const int mat_id = m->geom_matid[g];
      if (mat_id >= 0 && m->mat_texid[mat_id] >= 0) textured = true;
      if (plane < 0) plane = g;
    }
    if (plane >= 0 && !textured) r->grid_plane_geom_ = plane;
  }

  r->flipped_.resize(3 * static_cast<size_t>(settings.width) * settings.height);
  return r;
}

OffscreenRenderer::~OffscreenRenderer() {
  if (gl_ && gl_->context) MakeCurrent();
  if (context_made_) mjr_freeContext(&context_);
  if (scene_made_) mjv_freeScene(&scene_);
  gl_.reset();
}

void OffscreenRenderer::MakeCurrent() {
  if (OSMesaGetCurrentContext() != gl_->context) {
    OSMesaMakeCurrent(gl_->context, gl_->window.data(), GL_UNSIGNED_BYTE, gl_->width,
                      gl_->height);
  }
}

void OffscreenRenderer::AddGridLines(const mjModel* m) {
  const int g = grid_plane_geom_;
  const double spacing = settings_.grid_spacing;
  const double d = settings_.camera_distance;
  const double z = m->geom_pos[3 * g + 2] + kGridLineLift;
  // Extent: the plane's half sizes when finite (size 0 means infinite), else a window
  // around the look-at point that covers the view out to ~6 camera distances.
  const double cx = camera_.lookat[0], cy = camera_.lookat[1];
  double x0 = cx - 6 * d, x1 = cx + 6 * d, y0 = cy - 1.5 * d, y1 = cy + 6 * d;
  const double px = m->geom_pos[3 * g], py = m->geom_pos[3 * g + 1];
  if (m->geom_size[3 * g] > 0) {
    x0 = std::max(x0, px - m->geom_size[3 * g]);
    x1 = std::min(x1, px + m->geom_size[3 * g]);
  }
  if (m->geom_size[3 * g + 1] > 0) {
    y0 = std::max(y0, py - m->geom_size[3 * g + 1]);
    y1 = std::min(y1, py + m->geom_size[3 * g + 1]);
  }
  if (x1 <= x0 || y1 <= y0) return;

  // Line colour: darker than a light floor, lighter than a dark one.
  const float* floor_rgba = m->geom_rgba + 4 * g;
  const float luminance = 0.3f * floor_rgba[0] + 0.59f * floor_rgba[1] + 0.11f * floor_rgba[2];
  float rgba[4];
  for (int i = 0; i < 3; ++i) {
    rgba[i] = luminance > 0.5f ? 0.55f * floor_rgba[i] : std::min(1.0f, floor_rgba[i] + 0.35f);
  }
  rgba[3] = 1;

  const mjtNum identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  int budget = std::min(kMaxGridLines, scene_.maxgeom - scene_.ngeom);
  auto add_box = [&](double x, double y, double hx, double hy) {
    if (budget-- <= 0) return;
    mjvGeom* geom = scene_.geoms + scene_.ngeom++;
    const mjtNum size[3] = {hx, hy, 0.0005};
    const mjtNum pos[3] = {x, y, z};
    mjv_initGeom(geom, mjGEOM_BOX, size, pos, identity, rgba);
    geom->category = mjCAT_DECOR;
    geom->objtype = mjOBJ_UNKNOWN;
    geom->objid = -1;
  };
  // Lines of constant x (they show forward progress) ...
  for (double x = std::ceil(x0 / spacing) * spacing; x <= x1; x += spacing) {
    add_box(x, 0.5 * (y0 + y1), 0.5 * kGridLineWidth, 0.5 * (y1 - y0));
  }
  // ... and of constant y.
  for (double y = std::ceil(y0 / spacing) * spacing; y <= y1; y += spacing) {
    add_box(0.5 * (x0 + x1), y, 0.5 * (x1 - x0), 0.5 * kGridLineWidth);
  }
}

void OffscreenRenderer::AddSunLight() {
  // Directional light: direction (0, 0.35, -1)/|.| points down and away from a camera at
  // azimuth 90 deg; no attenuation, no shadow. Moderate intensity, so that the model's own
  // lights still show where they shine.
  mjvLight& light = scene_.lights[scene_.nlight++];
  std::memset(&light, 0, sizeof(light));
  const float norm = std::sqrt(0.35f * 0.35f + 1.0f);
  light.pos[2] = 10;
  light.dir[1] = 0.35f / norm;
  light.dir[2] = -1.0f / norm;
  light.attenuation[0] = 1;
  light.cutoff = 180;
  light.directional = 1;
  light.castshadow = 0;
  for (int i = 0; i < 3; ++i) {
    light.ambient[i] = 0.1f;
    light.diffuse[i] = 0.35f;
    light.specular[i] = 0.1f;
  }
}

void OffscreenRenderer::Render(const mjModel* m, mjData* d, const std::string& overlay_left,
                               const std::string& overlay_right,
                               std::vector<unsigned char>* rgb) {
  MakeCurrent();

  // Follow the tracked body horizontally; y, z, distance and angles stay fixed.
  if (track_body_id_ >= 0) camera_.lookat[0] = d->xpos[3 * track_body_id_];

  // Abstract scene from the poses in d (reads mjData; uses only its scratch stack).
  // mjv_updateScene adds the geoms BEFORE it updates the scene camera, and it tessellates
  // planes around the camera position it finds in the scene, i.e. the previous frame's
  // (measured: the first frame differed from later renders of the same state by +-3
  // levels over the floor). Updating the camera first makes each image a function of the
  // current state only.
  mjv_updateCamera(m, d, &camera_, &scene_);
  mjv_updateScene(m, d, &option_, nullptr, &camera_, mjCAT_ALL, &scene_);
  if (grid_plane_geom_ >= 0) AddGridLines(m);
  if (settings_.sun_light && scene_.nlight < mjMAXLIGHT) AddSunLight();

  const mjrRect viewport = {0, 0, width_, height_};
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  mjr_render(viewport, &scene_, &context_);
  if (!overlay_left.empty() || !overlay_right.empty()) {
    mjr_overlay(mjFONT_NORMAL, mjGRID_TOPLEFT, viewport, overlay_left.c_str(),
                overlay_right.c_str(), &context_);
  }
  mjr_readPixels(flipped_.data(), nullptr, viewport, &context_);

  // OpenGL returns the bottom row first; images are stored top row first.
  const size_t row_bytes = 3 * static_cast<size_t>(width_);
  rgb->resize(row_bytes * height_);
  for (int row = 0; row < height_; ++row) {
    std::memcpy(rgb->data() + row * row_bytes, flipped_.data() + (height_ - 1 - row) * row_bytes,
                row_bytes);
  }
}

bool OffscreenRenderer::ProjectToPixel(const double p[3], double* col, double* row) const {
  const mjvGLCamera cam = mjv_averageCamera(scene_.camera, scene_.camera + 1);
  double v[3], right[3];
  for (int i = 0; i < 3; ++i) v[i] = p[i] - cam.pos[i];
  // right = forward x up
  right[0] = cam.forward[1] * cam.up[2] - cam.forward[2] * cam.up[1];
  right[1] = cam.forward[2] * cam.up[0] - cam.forward[0] * cam.up[2];
  right[2] = cam.forward[0] * cam.up[1] - cam.forward[1] * cam.up[0];
  const double z = v[0] * cam.forward[0] + v[1] * cam.forward[1] + v[2] * cam.forward[2];
  if (z <= 0) return false;
  const double x = v[0] * right[0] + v[1] * right[1] + v[2] * right[2];
  const double y = v[0] * cam.up[0] + v[1] * cam.up[1] + v[2] * cam.up[2];
  const double height = cam.frustum_top - cam.frustum_bottom;
  const double half_width = 0.5 * static_cast<double>(width_) / height_ * height;
  const double xn = cam.frustum_near * x / z, yn = cam.frustum_near * y / z;
  *col = width_ * (0.5 + (xn - cam.frustum_center) / (2 * half_width));
  *row = height_ * (1.0 - (yn - cam.frustum_bottom) / height);
  return true;
}

}  // namespace ddoc
