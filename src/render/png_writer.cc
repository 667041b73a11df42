// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "png_writer.h"

#include <utility>

#include "ddoc/render/png.h"

namespace ddoc {

PngWriterQueue::PngWriterQueue(int width, int height)
    : width_(width), height_(height), worker_([this] { Run(); }) {}

PngWriterQueue::~PngWriterQueue() {
  {
    std::unique_lock<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  worker_.join();
}

bool PngWriterQueue::Push(const std::vector<unsigned char>& rgb,
                          const std::vector<std::string>& paths, std::string* error) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!error_.empty()) {
    if (error) *error = error_;
    return false;
  }
  changed_.wait(lock, [this] { return pending_.size() < kMaxPending; });
  Job job;
  if (!spare_.empty()) {
    job.rgb = std::move(spare_.back());
    spare_.pop_back();
  }
  job.rgb.assign(rgb.begin(), rgb.end());
  job.paths = paths;
  pending_.push_back(std::move(job));
  changed_.notify_all();
  return true;
}

bool PngWriterQueue::Flush(std::string* error) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return pending_.empty() && !busy_; });
  if (!error_.empty()) {
    if (error) *error = error_;
    error_.clear();
    return false;
  }
  return true;
}

void PngWriterQueue::Run() {
  std::vector<unsigned char> png;  // encoded bytes, reused
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stop_ || !pending_.empty(); });
    if (pending_.empty()) return;  // stop_ and drained
    Job job = std::move(pending_.front());
    pending_.pop_front();
    busy_ = true;
    changed_.notify_all();  // room in the queue
    lock.unlock();

    std::string message;
    bool ok = EncodePng(job.rgb, width_, height_, &png, &message);
    for (size_t i = 0; ok && i < job.paths.size(); ++i) {
      ok = WriteFileBytes(job.paths[i], png, &message);
    }

    lock.lock();
    if (!ok && error_.empty()) error_ = message;
    spare_.push_back(std::move(job.rgb));
    busy_ = false;
    changed_.notify_all();
  }
}

}  // namespace ddoc
