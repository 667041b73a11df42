// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Assembling recorded frames into an MP4 with the ffmpeg command-line tool.
#ifndef DDOC_RENDER_VIDEO_H_
#define DDOC_RENDER_VIDEO_H_

#include <string>

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

}  // namespace ddoc

#endif  // DDOC_RENDER_VIDEO_H_
