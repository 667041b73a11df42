// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/render/frame_recorder.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <stdexcept>
#include <system_error>

#include "ddoc/render/png.h"
#include "ddoc/render/video.h"
#include "png_writer.h"

namespace ddoc {
namespace {

namespace fs = std::filesystem;

std::string FormatNumber(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

// Deletes dir/frame_NNNNNN.png (exactly six digits); returns how many, or -1 on error.
int RemoveStaleFrames(const std::string& dir, std::string* error) {
  static const std::regex kFrameName("frame_[0-9]{6}\\.png");
  int removed = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || !std::regex_match(name, kFrameName)) continue;
    if (!fs::remove(entry.path(), ec)) {
      if (error) {
        *error = "render: cannot remove stale frame '" + entry.path().string() +
                 "': " + ec.message();
      }
      return -1;
    }
    ++removed;
  }
  if (ec) {
    if (error) *error = "render: cannot list output directory '" + dir + "': " + ec.message();
    return -1;
  }
  return removed;
}

}  // namespace

void FormatOverlay(const Overlay& overlay, const mjModel* m, const mjData* d, int track_body_id,
                   std::string* labels, std::string* values) {
  labels->clear();
  values->clear();
  auto line = [&](const char* label, const std::string& value) {
    if (!labels->empty()) {
      *labels += '\n';
      *values += '\n';
    }
    *labels += label;
    *values += value;
  };
  line("Method", overlay.method.empty() ? "-" : overlay.method);
  if (overlay.iteration >= 0) line("Iteration", std::to_string(overlay.iteration));
  line("Hop", overlay.hop >= 0 ? std::to_string(overlay.hop) : "-");
  const double time = std::isnan(overlay.time) ? d->time : overlay.time;
  line("Time", FormatNumber("%.3f s", time));
  line("Last cost",
       std::isnan(overlay.last_cost) ? "-" : FormatNumber("%.5g", overlay.last_cost));
  double speed = overlay.forward_speed;
  if (std::isnan(speed) && track_body_id >= 0) {
    // 6D velocity [angular; linear] of the body origin in the world frame (from cvel,
    // which mj_step/mj_forward computed; reads d only).
    mjtNum velocity[6];
    mj_objectVelocity(m, d, mjOBJ_BODY, track_body_id, velocity, 0);
    speed = velocity[3];
  }
  line("Speed", std::isnan(speed) ? "-" : FormatNumber("%+.3f m/s", speed));
}

std::unique_ptr<FrameRecorder> FrameRecorder::Create(const mjModel* m,
                                                     const RenderSettings& settings,
                                                     std::string* error) {
  if (!settings.Validate(error)) return nullptr;
  std::unique_ptr<FrameRecorder> recorder(new FrameRecorder());
  recorder->settings_ = settings;
  recorder->renderer_ = OffscreenRenderer::Create(m, settings, error);
  if (!recorder->renderer_) return nullptr;
  if (!settings.dir.empty()) {
    recorder->stale_removed_ = RemoveStaleFrames(settings.dir, error);
    if (recorder->stale_removed_ < 0) return nullptr;
  }
  if (!settings.video.empty()) {
    recorder->video_ = VideoStream::Start(settings.video, settings.width, settings.height,
                                          settings.fps, error);
    if (!recorder->video_) return nullptr;
  }
  if (settings.async_write && !settings.dir.empty()) {
    recorder->writer_ = std::make_unique<PngWriterQueue>(settings.width, settings.height);
  }
  return recorder;
}

FrameRecorder::~FrameRecorder() = default;  // ~PngWriterQueue drains and joins

std::string FrameRecorder::FramePath(int64_t j) const {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%06lld.png", static_cast<long long>(j));
  return (fs::path(settings_.dir) / name).string();
}

bool FrameRecorder::MaybeCapture(const mjModel* m, mjData* d, const Overlay& overlay) {
  // A new trial (simulated time went back), or the first call: the current state becomes
  // the next frame, numbering continues.
  const bool segment_start = last_time_ < 0 || d->time < last_time_;
  if (segment_start) {
    offset_ = static_cast<double>(next_frame_) / settings_.fps - d->time;
  }
  last_time_ = d->time;

  // Frames due: t_j = j / fps <= r + timestep / 2 with r = d->time + offset.
  const double r = d->time + offset_;
  const double tolerance = 0.5 * m->opt.timestep;
  std::vector<std::string>& paths = paths_;
  paths.clear();
  int due = 0;
  while (static_cast<double>(next_frame_) / settings_.fps <= r + tolerance) {
    if (!settings_.dir.empty()) paths.push_back(FramePath(next_frame_));
    ++next_frame_;
    ++due;
  }
  if (due == 0) return false;

  // The start of a recording (or of a trial after a reset) is usually a state no mj_step or
  // mj_forward has seen: its poses and velocities (xpos, geom_xpos, cam_xpos, cvel, ...) are
  // those of the previous state, or zeros after mj_resetData. Compute them from qpos and qvel
  // (positions, com, cameras and lights, com velocities: no control callback, no state change).
  if (segment_start) {
    mj_kinematics(m, d);
    mj_comPos(m, d);
    mj_camlight(m, d);
    mj_comVel(m, d);
  }

  FormatOverlay(overlay, m, d, renderer_->track_body_id(), &labels_, &values_);
  renderer_->Render(m, d, labels_, values_, &rgb_);

  std::string message;
  for (int i = 0; video_ && i < due; ++i) {
    if (!video_->WriteFrame(rgb_, &message)) throw std::runtime_error("render: " + message);
  }
  if (paths.empty()) return true;
  if (writer_) {
    if (!writer_->Push(rgb_, paths, &message)) throw std::runtime_error("render: " + message);
    return true;
  }
  std::vector<unsigned char> png;
  if (!EncodePng(rgb_, settings_.width, settings_.height, &png, &message)) {
    throw std::runtime_error("render: " + message);
  }
  for (const std::string& path : paths) {
    if (!WriteFileBytes(path, png, &message)) throw std::runtime_error("render: " + message);
  }
  return true;
}

bool FrameRecorder::Finish(std::string* error) {
  std::string message;
  if (writer_ && !writer_->Flush(&message)) {
    if (error) *error = "render: " + message;
    return false;
  }
  if (video_) {
    const bool ok = video_->Finish(&video_message_);
    video_.reset();
    if (!ok) {
      if (error) *error = "render: " + video_message_;
      return false;
    }
  }
  return true;
}

}  // namespace ddoc
