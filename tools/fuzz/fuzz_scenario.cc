// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Fuzz target: the scenario loader (LoadScenario: tinyxml2, the attribute table, ranges,
// ValidateScenario). Every input must load or throw ScenarioError; nothing else may escape.
// The input is written as scenarios/fuzz.xml of a copy of models/, so "../hopper.xml" resolves.
#include <cstddef>
#include <cstdint>

#include "fuzz_util.h"
#include "scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path =
      ddoc::fuzz::WriteInput(ddoc::fuzz::ModelsCopy("scenario") / "scenarios" / "fuzz.xml", data, size);
  try {
    (void)ddoc::app::LoadScenario(path);
  } catch (const ddoc::app::ScenarioError&) {
    // a named bad input: expected
  }
  return 0;
}
