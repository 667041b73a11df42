// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Internal: a single background thread that encodes RGB frames as PNG and writes them.
#ifndef DDOC_SRC_RENDER_PNG_WRITER_H_
#define DDOC_SRC_RENDER_PNG_WRITER_H_

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace ddoc {

/// A bounded queue of frames, drained by one worker thread. Push() blocks while
/// kMaxPending frames wait, so memory stays bounded when the encoder is slower than the
/// renderer. Image buffers are recycled (no allocation per frame once warm).
class PngWriterQueue {
 public:
  static constexpr size_t kMaxPending = 8;

  PngWriterQueue(int width, int height);
  ~PngWriterQueue();  // drains the queue, then joins

  /// Queues rgb (3 * width * height, top row first) to be written to every path in paths
  /// (more than one when a long step makes several frames due at once). Returns false with
  /// the first write error seen so far, if any (the frame is then not queued).
  bool Push(const std::vector<unsigned char>& rgb, const std::vector<std::string>& paths,
            std::string* error);
  /// Blocks until the queue is empty and the worker idle. Returns false with the first
  /// error (which is then cleared).
  bool Flush(std::string* error);

 private:
  struct Job {
    std::vector<unsigned char> rgb;  // 3 * width * height
    std::vector<std::string> paths;
  };
  void Run();

  const int width_;
  const int height_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Job> pending_;
  std::vector<std::vector<unsigned char>> spare_;  // recycled rgb buffers
  bool busy_ = false;
  bool stop_ = false;
  std::string error_;  // first error since the last Flush
  std::thread worker_;
};

}  // namespace ddoc

#endif  // DDOC_SRC_RENDER_PNG_WRITER_H_
