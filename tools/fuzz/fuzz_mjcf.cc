// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Fuzz target: the MJCF pre-check and the robot loader (HopperSim: LoadMjcf = PrecheckMjcf +
// mj_loadXML, then HopperMapping::Build; HopperParamsFromModel as ddoc-hopper loads a model), and
// on success the HopperSim steps 20 times with constant inputs. Every input must load or
// throw HopperSimError (an InvalidArgument); nothing else may escape. The input is written as
// fuzz.xml in a copy of models/, so <include file="hopper_common.xml"/> resolves.
#include <cstddef>
#include <cstdint>

#include <mujoco/mujoco.h>

#include "ddoc/mujoco/hopper_sim.h"
#include "fuzz_util.h"

// MuJoCo warns about many malformed inputs (a NaN in the XML, ...): expected here. Its default
// handler would print each and append it to MUJOCO_LOG.TXT in the working directory.
extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  mju_user_warning = [](const char*) {};
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path =
      ddoc::fuzz::WriteInput(ddoc::fuzz::ModelsCopy("mjcf") / "fuzz.xml", data, size);
  try {
    ddoc::HopperSim sim(path);  // LoadMjcf, HopperMapping::Build
    (void)ddoc::HopperParamsFromModel(sim.model(), path);
    for (int i = 0; i < 20; ++i) sim.Step(Eigen::Vector4d(0.0, 0.0, 50.0, 2000.0));
  } catch (const ddoc::InvalidArgument&) {
    // a named bad input: expected
  }
  return 0;
}
