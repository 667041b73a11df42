// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Where the tools' MuJoCo warnings go. MuJoCo's default handler prints to stdout and appends to
// MUJOCO_LOG.TXT in the working directory, a file nobody asked for; the tools print them on
// stderr, named, beside their own messages.
#ifndef DDOC_SRC_APP_MUJOCO_WARNINGS_H_
#define DDOC_SRC_APP_MUJOCO_WARNINGS_H_

#include <mujoco/mujoco.h>

#include <atomic>
#include <cstdio>

namespace ddoc::app {

namespace mujoco_warnings {
inline const char* tool = "ddoc";
inline std::atomic<int> count{0};
constexpr int kMaxPrinted = 20;  ///< a warning repeated every step would flood the terminal

inline void Print(const char* message) {
  const int n = count++;
  if (n < kMaxPrinted) {
    std::fprintf(stderr, "%s: MuJoCo warning: %s\n", tool, message);
  } else if (n == kMaxPrinted) {
    std::fprintf(stderr, "%s: more MuJoCo warnings follow; not printed\n", tool);
  }
}
}  // namespace mujoco_warnings

/// Sends MuJoCo's warnings to stderr as "<tool>: MuJoCo warning: <text>" (the first 20).
inline void RouteMujocoWarnings(const char* tool) {
  mujoco_warnings::tool = tool;
  mju_user_warning = mujoco_warnings::Print;
}

}  // namespace ddoc::app

#endif  // DDOC_SRC_APP_MUJOCO_WARNINGS_H_
