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
  /// by Validate() when missing. Empty: no PNG files (then `video` is required).
  std::string dir;
  /// MP4 file the frames are streamed into through ffmpeg (VideoStream), no PNG needed; its
  /// directory is created by Validate() when missing. Empty (default): no video.
  std::string video;
  /// Image width in pixels, > 0 (at most kMaxImageSize).
  int width = 640;
  /// Image height in pixels, > 0 (at most kMaxImageSize).
  int height = 480;
  /// Frames per second of simulated time, in (0, kMaxFps].
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
  /// Keep MuJoCo's own 200 x 200 tessellation of infinite planes; false (default): a 48 x 48
  /// grid of the same extent (same texture, coarser lighting; cost in docs/rendering.md).
  bool fine_infinite_planes = false;
  /// Shadow pass; default false (its cost on llvmpipe: docs/rendering.md).
  bool shadows = false;
  /// Mirror reflections on materials with reflectance > 0; default false (docs/rendering.md).
  bool reflection = false;
  /// Multisample anti-aliasing samples of the offscreen buffer, in [0, 16]; default 0 (off).
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
  /// Largest accepted fps: beyond one frame per physics step frames only repeat, one file each.
  static constexpr double kMaxFps = 1000;

  /// Checks every field and prepares the output directories: creates `dir` and the
  /// directory of `video` (and parents) when missing and checks that a file can be created
  /// in them. Call it before the simulation starts. Returns false and sets *error (if non-null) to a message naming
  /// the field, the expected range and the actual value, e.g.
  /// "render: width must be in [1, 8192] pixels, got -5" or
  /// "render: cannot create output directory 'f/frames': Not a directory" (f is a file).
  bool Validate(std::string* error) const;
};

}  // namespace ddoc

#endif  // DDOC_RENDER_RENDER_SETTINGS_H_
