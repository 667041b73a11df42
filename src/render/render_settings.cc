// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/render/render_settings.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <system_error>

#include <unistd.h>

#include "render_internal.h"

namespace ddoc {
namespace {

namespace fs = std::filesystem;

bool Fail(std::string* error, const std::string& message) {
  if (error) *error = "render: " + message;
  return false;
}

// Checks the numeric fields; shared by Validate() and ValidateRenderGeometry().
bool CheckNumbers(const RenderSettings& s, std::string* error) {
  std::ostringstream msg;
  if (s.width <= 0 || s.width > RenderSettings::kMaxImageSize) {
    msg << "width must be in [1, " << RenderSettings::kMaxImageSize << "] pixels, got "
        << s.width;
  } else if (s.height <= 0 || s.height > RenderSettings::kMaxImageSize) {
    msg << "height must be in [1, " << RenderSettings::kMaxImageSize << "] pixels, got "
        << s.height;
  } else if (!(s.fps > 0) || !std::isfinite(s.fps)) {
    msg << "fps must be > 0 and finite, got " << s.fps;
  } else if (s.fps > RenderSettings::kMaxFps) {
    msg << "fps must be at most " << RenderSettings::kMaxFps
        << " (more frames than physics steps only repeat them, one file each), got " << s.fps;
  } else if (!(s.camera_distance > 0) || !std::isfinite(s.camera_distance)) {
    msg << "camera_distance must be > 0 and finite, got " << s.camera_distance;
  } else if (!std::isfinite(s.camera_azimuth) || !std::isfinite(s.camera_elevation) ||
             !std::isfinite(s.lookat_x) || !std::isfinite(s.lookat_y) ||
             !std::isfinite(s.lookat_z)) {
    msg << "camera angles and look-at coordinates must be finite";
  } else if (s.multisamples < 0 || s.multisamples > 16) {
    msg << "multisamples must be in [0, 16], got " << s.multisamples;
  } else if (!(s.grid_spacing >= 0) || !std::isfinite(s.grid_spacing)) {
    msg << "grid_spacing must be >= 0 m (0 = no grid lines), got " << s.grid_spacing;
  } else {
    return true;
  }
  return Fail(error, msg.str());
}

}  // namespace

bool ValidateRenderGeometry(const RenderSettings& s, std::string* error) {
  return CheckNumbers(s, error);
}

namespace {

// Creates `dir` (and parents) when missing and checks that a file can be created in it.
bool PrepareDirectory(const std::string& dir, std::string* error) {
  // create_directories reports, e.g., a regular file in the way as "Not a directory".
  const fs::path path(dir);
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    fs::create_directories(path, ec);
    if (ec) {
      return Fail(error, "cannot create output directory '" + dir + "': " + ec.message());
    }
  }
  if (!fs::is_directory(path, ec)) {
    return Fail(error, "output directory '" + dir + "' exists but is not a directory");
  }

  // Writable? Create and remove a probe file: this also catches read-only file systems,
  // which access(W_OK) does not.
  const fs::path probe = path / (".ddoc_write_probe_" + std::to_string(::getpid()));
  std::FILE* f = std::fopen(probe.c_str(), "wb");
  if (!f) {
    return Fail(error, "output directory '" + dir + "' is not writable: " +
                           std::strerror(errno));
  }
  std::fclose(f);
  fs::remove(probe, ec);
  return true;
}

}  // namespace

bool RenderSettings::Validate(std::string* error) const {
  if (!CheckNumbers(*this, error)) return false;
  if (dir.empty() && video.empty()) return Fail(error, "output directory is empty");
  if (!dir.empty() && !PrepareDirectory(dir, error)) return false;
  if (video.empty()) return true;
  std::error_code ec;
  if (fs::is_directory(video, ec)) {
    return Fail(error, "video file '" + video + "' is a directory");
  }
  const fs::path parent = fs::path(video).parent_path();
  return PrepareDirectory(parent.empty() ? std::string(".") : parent.string(), error);
}

}  // namespace ddoc
