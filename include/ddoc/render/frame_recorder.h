// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Writes rendered frames of a running MuJoCo simulation as numbered PNG files at a fixed
// rate of simulated time.
#ifndef DDOC_RENDER_FRAME_RECORDER_H_
#define DDOC_RENDER_FRAME_RECORDER_H_

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "ddoc/render/offscreen_renderer.h"
#include "ddoc/render/render_settings.h"

namespace ddoc {

class PngWriterQueue;  // background PNG encoder (src/render/png_writer.h)
class VideoStream;     // ffmpeg through a pipe (ddoc/render/video.h)

/// The text drawn in the top-left corner of every frame, as a label/value table.
/// A field at its "unset" value is shown as "-".
struct Overlay {
  /// Method name, e.g. "Algorithm 1", "mRL", "OC-FB". Empty: "-".
  std::string method;
  /// Learning iteration (trial) index; negative: the line is left out.
  int iteration = -1;
  /// Hop index within the trial; negative: "-".
  int hop = -1;
  /// Time in s to show; NaN: the simulated time d->time.
  double time = std::numeric_limits<double>::quiet_NaN();
  /// Cost of the last completed hop/trial; NaN: "-".
  double last_cost = std::numeric_limits<double>::quiet_NaN();
  /// Forward speed in m/s; NaN: world x velocity of the tracked body's origin
  /// (mj_objectVelocity), or "-" when no body is tracked.
  double forward_speed = std::numeric_limits<double>::quiet_NaN();
};

/// Formats an Overlay as the two columns (labels, values) passed to
/// OffscreenRenderer::Render. d supplies the defaults for unset time and speed.
void FormatOverlay(const Overlay& overlay, const mjModel* m, const mjData* d, int track_body_id,
                   std::string* labels, std::string* values);

/// Owns an OffscreenRenderer and writes settings.dir/frame_000000.png, frame_000001.png, ...
/// and/or streams the same frames into the MP4 settings.video (VideoStream, no files between).
/// Only the frames due are rendered (one render per call, whatever the number due).
///
/// Frame clock. Frame j is due at recording time t_j = j / fps. The recording time is
/// r = d->time + offset. MaybeCapture() is meant to be called once after every mj_step
/// (and once before the first one); it writes frame j for every due t_j with
/// t_j <= r + timestep / 2 (the half-step tolerance absorbs rounding in d->time, so a
/// frame lands on the nearest step), all showing the current state. So with timestep <=
/// 1 / fps, a run of duration T yields exactly
///     N = floor(T * fps + fps * timestep / 2) + 1  (= floor(T * fps) + 1 unless T * fps is
///                                                    within half a step of an integer)
/// frames, one per 1/fps of simulated time, the first showing t = 0; a larger timestep
/// repeats frames so that the video still plays in simulated time.
///
/// Several trials in one recording. When d->time goes backwards (a reset for the next
/// trial), offset is chosen so that the new trial's first state falls due at once as the
/// next frame: numbering continues and each trial contributes floor(T_i fps) + 1 frames.
///
/// The first frame of a recording or of a trial shows the state as it is: MaybeCapture computes
/// its poses and velocities from qpos and qvel (mj_kinematics, mj_comPos, mj_camlight,
/// mj_comVel), so no mj_forward is needed after a reset (it would run the control callback).
///
/// Files. Create() deletes stale frame_NNNNNN.png files (exactly 6 digits) left in dir
/// by an earlier run, so that a video assembled from dir never mixes two runs; other
/// files are left alone. Writing happens on a background thread when
/// settings.async_write (the default); Finish() waits for it.
class FrameRecorder {
 public:
  /// Validates settings (RenderSettings::Validate: creates dir), clears stale frames and
  /// creates the renderer. Returns null and sets *error (if non-null) on any failure.
  static std::unique_ptr<FrameRecorder> Create(const mjModel* m, const RenderSettings& settings,
                                               std::string* error);
  /// Waits for pending writes (errors at this point are lost: call Finish() to see them).
  ~FrameRecorder();
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  /// Renders and writes the frames that are due at the current state (see the class
  /// comment). Returns true when at least one frame was written (or queued), false when
  /// none was due. Throws std::runtime_error naming the file when a PNG cannot be
  /// encoded or written (with async writing, the error surfaces at the next call or in
  /// Finish()). Does not modify the simulation state.
  bool MaybeCapture(const mjModel* m, mjData* d, const Overlay& overlay);

  /// Waits until every queued frame is on disk and, with a video, closes the stream and waits
  /// for ffmpeg (video_message() says what it wrote). Returns false and sets *error (if
  /// non-null) when a write or the video failed. Further MaybeCapture calls are allowed
  /// afterwards for PNG files only (the video is complete).
  bool Finish(std::string* error);
  /// After Finish: "video: wrote PATH (N frames, ...)" or why the video failed; "" without one.
  const std::string& video_message() const { return video_message_; }

  /// Number of frame files written or queued so far (= index of the next frame).
  int64_t frame_count() const { return next_frame_; }
  /// Path of frame j: dir/frame_%06d.png.
  std::string FramePath(int64_t j) const;
  /// Number of stale frame files Create() deleted.
  int stale_frames_removed() const { return stale_removed_; }
  OffscreenRenderer& renderer() { return *renderer_; }

 private:
  FrameRecorder() = default;

  RenderSettings settings_;
  std::unique_ptr<OffscreenRenderer> renderer_;
  std::unique_ptr<PngWriterQueue> writer_;
  std::unique_ptr<VideoStream> video_;
  std::string video_message_;
  int64_t next_frame_ = 0;
  double offset_ = 0;      // recording time minus simulated time, s
  double last_time_ = -1;  // d->time at the previous call (detects resets), s
  int stale_removed_ = 0;
  std::string labels_, values_;    // overlay columns, reused
  std::vector<unsigned char> rgb_;  // 3 * width * height, top row first
  std::vector<std::string> paths_;  // files due at the current call
};

}  // namespace ddoc

#endif  // DDOC_RENDER_FRAME_RECORDER_H_
