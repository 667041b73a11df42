// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Horizontal pushes on the hopper's body (Section V-D, disturbance rejection).
#ifndef DDOC_HOPPER_PUSH_H_
#define DDOC_HOPPER_PUSH_H_

#include <vector>

namespace ddoc {

/// A horizontal push on the body's COM: `force` during [time, time + duration). The field order
/// is the order of every command line's `--push TIME,FORCE,DURATION` and of the scenario's
/// <push time force duration>.
struct Push {
  double time = 0.0;      ///< start, simulated s
  double force = 0.0;     ///< horizontal force, N; + is forward (+x). Paper: -20 and +25
  double duration = 0.1;  ///< s, > 0
};

/// The sum of the forces of the pushes active at time t (time <= t < time + duration), N.
double PushForce(const std::vector<Push>& pushes, double t);

}  // namespace ddoc

#endif  // DDOC_HOPPER_PUSH_H_
