// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Settings of the headless (OSMesa) renderer and frame recorder. Plain struct,
// one commented default per field; parsing belongs to the CLI.
#ifndef DDOC_RENDER_RENDER_SETTINGS_H_
#define DDOC_RENDER_RENDER_SETTINGS_H_

#include <string>

namespace ddoc {

/// What to render and where to put the frames.
///
/// Frames are taken at a fixed rate of SIMULATED time: frame j shows the state at the
/// simulation step nearest to t = j / fps (see FrameRecorder). The camera is MuJoCo's
/// free camera looking at (x_b, lookat_y, lookat_z), where x_b is the world x of
/// `track_body`, so the camera follows the body horizontally at a fixed distance,
/// azimuth and elevation.
struct RenderSettings {
  /// Output directory for frame_000000.png, frame_000001.png, ...; created (with parents)
  /// by Validate() when missing. Required.
  std::string dir;
  /// Image width in pixels, > 0 (at most kMaxImageSize).
  int width = 640;
  /// Image height in pixels, > 0 (at most kMaxImageSize).
  int height = 480;
  /// Frames per second of simulated time, > 0 and finite.
  double fps = 60;
  /// Body whose world x the camera follows. Empty: the camera stays at lookat_x.
  std::string track_body = "torso";

  /// Look-at x in m, used only when track_body is empty.
  double lookat_x = 0;
  /// Look-at y in m (the hopper moves in the x-z plane, so y stays fixed).
  double lookat_y = 0;
  /// Look-at height z in m (fixed: the camera does not bob with the hops). With the
  /// default distance and elevation the view spans about z in [-0.6, 1.9] m at the body.
  double lookat_z = 0.6;
  /// Camera distance from the look-at point in m, > 0.
  double camera_distance = 3.0;
  /// Camera azimuth in degrees; 90 looks along +y, so world +x points right in the image.
  double camera_azimuth = 90;
  /// Camera elevation in degrees; negative looks down.
  double camera_elevation = -12;

  /// Adds a directional "sun" (from above, slightly from the camera side) to the model's
  /// lights, so that the floor stays evenly lit wherever the robot goes: a light fixed in
  /// the world (like the hopper MJCF's spotlight at x = 0) leaves the floor dark ~10 m away.
  bool sun_light = true;
  /// Keep MuJoCo's own tessellation of infinite planes (a 200 x 200 quad grid, lit per
  /// vertex). Off by default: the renderer substitutes a 48 x 48 grid of the same extent,
  /// which leaves the texture unchanged, coarsens only the lighting, and halves the time of
  /// a 640x480 hopper frame (measured: ~9 -> ~4-6 ms CPU).
  bool fine_infinite_planes = false;
  /// Shadow pass. Off by default: on llvmpipe it costs ~10 ms per 640x480 frame
  /// (measured: render 8 ms without, 18-20 ms with shadows).
  bool shadows = false;
  /// Mirror reflections on materials with reflectance > 0. Off by default: the hopper's
  /// floor has reflectance 0.1, and drawing the mirrored scene took a 640x480 hopper frame
  /// from 8.7 to 15.5 ms (measured, llvmpipe).
  bool reflection = false;
  /// Multisample anti-aliasing samples of MuJoCo's offscreen buffer (0 = off), in [0, 16].
  /// Off by default: with llvmpipe, 4 samples doubled the time of a 640x480 hopper frame
  /// (measured 11 -> 24 ms wall, 16 -> 40 ms CPU). Set 4 for smoother edges.
  int multisamples = 0;
  /// Spacing in m of grid lines drawn on the floor plane when the model's floor has no
  /// texture of its own (a textured floor, e.g. builtin="checker", is drawn as is).
  /// 0 disables the lines.
  double grid_spacing = 0.5;
  /// Encode and write PNG files on a background thread, so that PNG encoding (~5 ms per
  /// 640x480 frame) overlaps with simulation and rendering. Frames are identical either way.
  bool async_write = true;

  /// Largest accepted width or height in pixels.
  static constexpr int kMaxImageSize = 8192;

  /// Checks every field and prepares the output directory: creates `dir` (and parents)
  /// when missing and checks that a file can be created in it. Call it before the
  /// simulation starts. Returns false and sets *error (if non-null) to a message naming
  /// the field, the expected range and the actual value, e.g.
  /// "render: width must be in [1, 8192] pixels, got -5" or
  /// "render: cannot create output directory 'f/frames': Not a directory" (f is a file).
  bool Validate(std::string* error) const;
};

}  // namespace ddoc

#endif  // DDOC_RENDER_RENDER_SETTINGS_H_
