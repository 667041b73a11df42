// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/push.h"

namespace ddoc {

double PushForce(const std::vector<Push>& pushes, double t) {
  double f = 0.0;
  for (const Push& p : pushes) {
    if (t >= p.time && t < p.time + p.duration) f += p.force;
  }
  return f;
}

}  // namespace ddoc
