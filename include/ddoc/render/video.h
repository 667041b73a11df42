// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Assembling recorded frames into an MP4 with the ffmpeg command-line tool.
#ifndef DDOC_RENDER_VIDEO_H_
#define DDOC_RENDER_VIDEO_H_

#include <memory>
#include <string>
#include <vector>

namespace ddoc {

/// Full path of an executable called `name` in the directories of `path_list` (a PATH-style
/// ':'-separated list), or "" when there is none.
std::string FindExecutable(const std::string& name, const std::string& path_list);

/// Assembles frames_dir/frame_%06d.png (as written by FrameRecorder) into mp4_path at fps
/// frames per second with the `ffmpeg` command found on $PATH:
///   ffmpeg -y -loglevel error -framerate FPS -i DIR/frame_%06d.png
///          -vf pad=ceil(iw/2)*2:ceil(ih/2)*2 -c:v libx264 -pix_fmt yuv420p MP4
/// (the pad filter makes odd sizes even, as yuv420p needs). If that ffmpeg has no libx264,
/// it retries with -c:v mpeg4 -q:v 3. ffmpeg runs as a child process (fork/execv, no
/// shell), so paths need no quoting.
///
/// Returns true on success, with *message (if non-null) saying which encoder wrote what.
/// Returns false with a clear *message when ffmpeg is not installed ("ffmpeg is not
/// installed (no 'ffmpeg' on PATH); the frames are in DIR; install it (apt-get install
/// ffmpeg) and run: <command>"), when fps is not > 0, when frames_dir has no
/// frame_000000.png, or when ffmpeg fails (its exit status and last error lines).
bool AssembleVideo(const std::string& frames_dir, double fps, const std::string& mp4_path,
                   std::string* message);

/// Streams RGB frames into an MP4 through a pipe to the `ffmpeg` found on $PATH, without image
/// files on disk (ddoc-hopper --video):
///   ffmpeg -y -loglevel error -f rawvideo -pix_fmt rgb24 -s WxH -framerate FPS -i -
///          -vf pad=ceil(iw/2)*2:ceil(ih/2)*2 -c:v libx264 -preset veryfast -pix_fmt yuv420p MP4
/// (-c:v mpeg4 -q:v 3 when that ffmpeg has no libx264, found by `ffmpeg -h encoder=libx264`).
/// ffmpeg runs as a child process (fork/execv, no shell); its messages go to an unlinked
/// temporary file and appear in the error of WriteFrame or Finish. SIGPIPE is ignored once a stream starts (a
/// dead ffmpeg makes WriteFrame fail instead of killing the process).
class VideoStream {
 public:
  /// Starts ffmpeg. Null and *error (if non-null) when width, height or fps is not positive and
  /// finite, when ffmpeg is not installed ("video: ffmpeg is not installed (no 'ffmpeg' on PATH),
  /// so MP4 cannot be written; install it (e.g. apt-get install ffmpeg) or use --render DIR for
  /// PNG frames") or when it cannot be started.
  static std::unique_ptr<VideoStream> Start(const std::string& mp4_path, int width, int height,
                                            double fps, std::string* error);
  /// Kills and reaps ffmpeg when Finish was not called (the MP4 is then incomplete).
  ~VideoStream();
  VideoStream(const VideoStream&) = delete;
  VideoStream& operator=(const VideoStream&) = delete;

  /// Writes one frame (rgb: 3 * width * height bytes, top row first); blocks while ffmpeg is
  /// busy. False and *error (naming the file and ffmpeg's last lines) when ffmpeg has gone.
  bool WriteFrame(const std::vector<unsigned char>& rgb, std::string* error);
  /// Closes the pipe and waits for ffmpeg. True with *message "video: wrote MP4 (N frames,
  /// libx264, yuv420p, FPS fps)"; false with ffmpeg's exit status and last lines.
  bool Finish(std::string* message);

  const std::string& path() const { return path_; }
  long frames() const { return frames_; }  ///< frames written so far

 private:
  VideoStream() = default;
  std::string FfmpegOutput() const;  // the last lines of ffmpeg's messages

  std::string path_, encoder_;
  int log_fd_ = -1;  // ffmpeg's stdout and stderr: an unlinked temporary file
  int width_ = 0, height_ = 0;
  double fps_ = 0;
  int fd_ = -1;     // write end of ffmpeg's stdin
  int pid_ = -1;    // ffmpeg, -1 once reaped
  long frames_ = 0;
};

}  // namespace ddoc

#endif  // DDOC_RENDER_VIDEO_H_
