// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A pre-check of an MJCF file (and the files it <include>s) before MuJoCo compiles it, so that
// errors name the file, the line and the element: MuJoCo 2.2 reports a non-positive mass only as
// "mass and inertia of moving bodies must be larger than mjMINVAL", without saying where.
#ifndef DDOC_SRC_MUJOCO_MJCF_PRECHECK_H_
#define DDOC_SRC_MUJOCO_MJCF_PRECHECK_H_

#include <string>

namespace ddoc {

/// Throws HopperSimError for: a missing/unreadable file, malformed XML (file, line, parser
/// message), an <inertial> with mass <= 0 or a diaginertia/fullinertia diagonal entry <= 0
/// (file, line, body name).
void PrecheckMjcf(const std::string& path);

}  // namespace ddoc

#endif  // DDOC_SRC_MUJOCO_MJCF_PRECHECK_H_
