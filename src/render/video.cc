// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/render/video.h"

#include <cerrno>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace ddoc {
namespace {

namespace fs = std::filesystem;

std::string FormatFps(double fps) {
  std::ostringstream out;
  out.precision(10);
  out << fps;
  return out.str();
}

std::vector<std::string> FfmpegArgs(const std::string& ffmpeg, const std::string& frames_dir,
                                    double fps, const std::string& mp4_path, bool x264) {
  std::vector<std::string> args = {ffmpeg,      "-y",
                                   "-loglevel", "error",
                                   "-framerate", FormatFps(fps),
                                   "-i",        (fs::path(frames_dir) / "frame_%06d.png").string(),
                                   "-vf",       "pad=ceil(iw/2)*2:ceil(ih/2)*2"};
  if (x264) {
    args.insert(args.end(), {"-c:v", "libx264", "-pix_fmt", "yuv420p"});
  } else {
    args.insert(args.end(), {"-c:v", "mpeg4", "-q:v", "3", "-pix_fmt", "yuv420p"});
  }
  args.push_back(mp4_path);
  return args;
}

std::string Join(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) {
    if (!out.empty()) out += ' ';
    const bool quote = a.find_first_of(" ()*'\"$") != std::string::npos;
    out += quote ? "'" + a + "'" : a;
  }
  return out;
}

// Runs args[0] with args (no shell); stderr and stdout are captured into *output.
// In a forked child: stdin from in_fd (unless -1), stdout and stderr into out_fd, both ends of
// `pipe_fds` closed, then argv. Only async-signal-safe calls between fork and exec (the PNG writer
// thread may run).
[[noreturn]] void ExecChild(const std::vector<char*>& argv, int in_fd, int out_fd,
                            const int pipe_fds[2]) {
  if (in_fd >= 0) dup2(in_fd, STDIN_FILENO);
  dup2(out_fd, STDOUT_FILENO);
  dup2(out_fd, STDERR_FILENO);
  close(pipe_fds[0]);
  close(pipe_fds[1]);
  execv(argv[0], argv.data());
  static const char kExecFailed[] = "execv failed\n";
  (void)!write(STDERR_FILENO, kExecFailed, sizeof(kExecFailed) - 1);
  _exit(127);
}

// Returns the exit status, or -1 when the process could not be started.
int Run(const std::vector<std::string>& args, std::string* output) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) {
    *output = std::string("pipe: ") + std::strerror(errno);
    return -1;
  }
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    *output = std::string("fork: ") + std::strerror(errno);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    return -1;
  }
  if (pid == 0) {
    // Child: stdin from /dev/null (ffmpeg reads keys from stdin), stdout+stderr to pipe.
    const int null_fd = open("/dev/null", O_RDONLY);
    if (null_fd >= 0) dup2(null_fd, STDIN_FILENO);
    ExecChild(argv, -1, pipe_fds[1], pipe_fds);
  }
  close(pipe_fds[1]);
  output->clear();
  char buffer[4096];
  ssize_t n;
  while ((n = read(pipe_fds[0], buffer, sizeof(buffer))) != 0) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    output->append(buffer, static_cast<size_t>(n));
  }
  close(pipe_fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// The last few lines of ffmpeg's output, for error messages.
std::string Tail(const std::string& text, int lines) {
  size_t pos = text.size();
  while (pos > 0 && (text[pos - 1] == '\n' || text[pos - 1] == '\r')) --pos;
  const size_t end = pos;
  for (int i = 0; i < lines && pos > 0; ++i) {
    pos = text.rfind('\n', pos - 1);
    if (pos == std::string::npos) {
      pos = 0;
      break;
    }
  }
  return text.substr(pos == 0 ? 0 : pos + 1, end - (pos == 0 ? 0 : pos + 1));
}

}  // namespace

std::string FindExecutable(const std::string& name, const std::string& path_list) {
  size_t start = 0;
  while (start <= path_list.size()) {
    size_t end = path_list.find(':', start);
    if (end == std::string::npos) end = path_list.size();
    const std::string dir = path_list.substr(start, end - start);
    const std::string candidate = (dir.empty() ? std::string(".") : dir) + "/" + name;
    struct stat st;
    if (stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        access(candidate.c_str(), X_OK) == 0) {
      return candidate;
    }
    start = end + 1;
  }
  return "";
}

bool AssembleVideo(const std::string& frames_dir, double fps, const std::string& mp4_path,
                   std::string* message) {
  std::string scratch;
  std::string& msg = message ? *message : scratch;
  if (!(fps > 0) || !std::isfinite(fps)) {
    msg = "video: fps must be > 0 and finite, got " + FormatFps(fps);
    return false;
  }
  const fs::path first = fs::path(frames_dir) / "frame_000000.png";
  std::error_code ec;
  if (!fs::is_regular_file(first, ec)) {
    msg = "video: no frames to assemble: '" + first.string() + "' does not exist";
    return false;
  }
  const char* path_env = std::getenv("PATH");
  const std::string ffmpeg = FindExecutable("ffmpeg", path_env ? path_env : "");
  if (ffmpeg.empty()) {
    msg = "video: ffmpeg is not installed (no 'ffmpeg' on PATH), so " + mp4_path +
          " was not written; the frames are in " + frames_dir +
          ". Install ffmpeg (e.g. apt-get install ffmpeg) and run: " +
          Join(FfmpegArgs("ffmpeg", frames_dir, fps, mp4_path, true));
    return false;
  }

  std::string output;
  const std::vector<std::string> x264 = FfmpegArgs(ffmpeg, frames_dir, fps, mp4_path, true);
  int status = Run(x264, &output);
  if (status == 0) {
    msg = "video: wrote " + mp4_path + " (libx264, yuv420p, " + FormatFps(fps) + " fps)";
    return true;
  }
  // Some ffmpeg builds lack libx264: fall back to the built-in MPEG-4 part 2 encoder.
  const std::string x264_output = output;
  const std::vector<std::string> mpeg4 = FfmpegArgs(ffmpeg, frames_dir, fps, mp4_path, false);
  status = Run(mpeg4, &output);
  if (status == 0) {
    msg = "video: wrote " + mp4_path + " (mpeg4, yuv420p, " + FormatFps(fps) +
          " fps; libx264 failed: " + Tail(x264_output, 1) + ")";
    return true;
  }
  msg = "video: ffmpeg failed with status " + std::to_string(status) + ": " + Tail(output, 3) +
        " (command: " + Join(mpeg4) + "; with libx264: " + Tail(x264_output, 2) + ")";
  return false;
}

namespace {

// True when `ffmpeg` has the libx264 encoder.
bool HasX264(const std::string& ffmpeg) {
  std::string output;
  const int status = Run({ffmpeg, "-hide_banner", "-h", "encoder=libx264"}, &output);
  return status == 0 && output.find("Encoder libx264") != std::string::npos;
}

}  // namespace

std::unique_ptr<VideoStream> VideoStream::Start(const std::string& mp4_path, int width,
                                                int height, double fps, std::string* error) {
  std::string scratch;
  std::string& msg = error ? *error : scratch;
  if (width <= 0 || height <= 0 || !(fps > 0) || !std::isfinite(fps)) {
    msg = "video: width, height and fps must be > 0, got " + std::to_string(width) + " x " +
          std::to_string(height) + " at " + FormatFps(fps) + " fps";
    return nullptr;
  }
  const char* path_env = std::getenv("PATH");
  const std::string ffmpeg = FindExecutable("ffmpeg", path_env ? path_env : "");
  if (ffmpeg.empty()) {
    msg = "video: ffmpeg is not installed (no 'ffmpeg' on PATH), so " + mp4_path +
          " cannot be written; install it (e.g. apt-get install ffmpeg) or use --render DIR "
          "for PNG frames";
    return nullptr;
  }
  std::unique_ptr<VideoStream> v(new VideoStream());
  v->path_ = mp4_path;
  v->width_ = width;
  v->height_ = height;
  v->fps_ = fps;
  v->encoder_ = HasX264(ffmpeg) ? "libx264" : "mpeg4";
  std::vector<std::string> args = {ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo",
                                   "-pix_fmt", "rgb24", "-s",
                                   std::to_string(width) + "x" + std::to_string(height),
                                   "-framerate", FormatFps(fps), "-i", "-",
                                   "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"};
  if (v->encoder_ == "libx264") {
    args.insert(args.end(), {"-c:v", "libx264", "-preset", "veryfast", "-pix_fmt", "yuv420p"});
  } else {
    args.insert(args.end(), {"-c:v", "mpeg4", "-q:v", "3", "-pix_fmt", "yuv420p"});
  }
  args.push_back(mp4_path);
  char log_template[] = "/tmp/ddoc-ffmpeg-XXXXXX";
  const int log_fd = mkstemp(log_template);
  if (log_fd < 0) {
    msg = std::string("video: cannot create a temporary file for ffmpeg's messages: ") +
          std::strerror(errno);
    return nullptr;
  }
  unlink(log_template);  // read through the descriptor: nothing is left behind, whatever ends us
  v->log_fd_ = log_fd;
  fcntl(log_fd, F_SETFD, FD_CLOEXEC);  // the child gets it through dup2 only
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) {
    msg = std::string("video: pipe: ") + std::strerror(errno);
    return nullptr;
  }
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    msg = std::string("video: fork: ") + std::strerror(errno);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    return nullptr;
  }
  if (pid == 0) {
    // Child: stdin from the pipe, stdout and stderr into the log file. Its own process group,
    // so a Ctrl-C on the terminal reaches ddoc-hopper only, which then closes the stream.
    setpgid(0, 0);
    ExecChild(argv, pipe_fds[0], log_fd, pipe_fds);
  }
  close(pipe_fds[0]);
  fcntl(pipe_fds[1], F_SETFD, FD_CLOEXEC);
  std::signal(SIGPIPE, SIG_IGN);
  v->fd_ = pipe_fds[1];
  v->pid_ = pid;
  return v;
}

VideoStream::~VideoStream() {
  if (fd_ >= 0) close(fd_);
  if (pid_ > 0) {
    kill(pid_, SIGKILL);
    int status = 0;
    while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
  if (log_fd_ >= 0) close(log_fd_);
}

std::string VideoStream::FfmpegOutput() const {
  std::string text;
  char buffer[4096];
  off_t at = 0;
  ssize_t n;
  while (log_fd_ >= 0 && (n = pread(log_fd_, buffer, sizeof(buffer), at)) > 0) {
    text.append(buffer, static_cast<size_t>(n));
    at += n;
  }
  return Tail(text, 3);
}

bool VideoStream::WriteFrame(const std::vector<unsigned char>& rgb, std::string* error) {
  const size_t size = 3 * static_cast<size_t>(width_) * static_cast<size_t>(height_);
  if (fd_ < 0 || rgb.size() != size) {
    if (error) {
      *error = fd_ < 0 ? "video: " + path_ + " is closed"
                       : "video: a frame of " + std::to_string(rgb.size()) +
                             " bytes, expected " + std::to_string(size);
    }
    return false;
  }
  size_t done = 0;
  while (done < size) {
    const ssize_t n = write(fd_, rgb.data() + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (error) {
        *error = "video: ffmpeg stopped taking frames for " + path_ + " (" +
                 std::strerror(errno) + "): " + FfmpegOutput();
      }
      return false;
    }
    done += static_cast<size_t>(n);
  }
  ++frames_;
  return true;
}

bool VideoStream::Finish(std::string* message) {
  std::string scratch;
  std::string& msg = message ? *message : scratch;
  if (pid_ < 0) {
    msg = "video: " + path_ + " was already finished";
    return false;
  }
  close(fd_);
  fd_ = -1;
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  if (code != 0) {
    msg = "video: ffmpeg failed with status " + std::to_string(code) + " writing " + path_ +
          ": " + FfmpegOutput();
    return false;
  }
  if (frames_ == 0) {
    msg = "video: no frames were rendered, so " + path_ + " is empty";
    return false;
  }
  msg = "video: wrote " + path_ + " (" + std::to_string(frames_) + " frames, " + encoder_ +
        ", yuv420p, " + FormatFps(fps_) + " fps)";
  return true;
}

}  // namespace ddoc
