// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Fuzz target: the parsers of flag values (ParsePush: --push TIME,FORCE,DURATION of every
// executable; ParseMethod: --method; ParseNumberList: ddoc-drop's --state/--input lists). The
// input is split at the first two NUL bytes into a push, a method and a list. Every value must
// parse or throw ScenarioError; a parsed push must satisfy what ValidateScenario demands.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t a = input.find('\0');
  const size_t b = a == std::string::npos ? a : input.find('\0', a + 1);
  const std::string push = input.substr(0, a);
  const std::string method = a == std::string::npos ? "" : input.substr(a + 1, b - a - 1);
  const std::string list = b == std::string::npos ? "" : input.substr(b + 1);
  try {
    const ddoc::Push p = ddoc::app::ParsePush(push);
    if (!(p.time >= 0.0 && std::isfinite(p.time) && p.duration > 0.0 &&
          std::isfinite(p.duration) && std::isfinite(p.force))) {
      std::abort();  // ParsePush accepted a push that no run can use
    }
  } catch (const ddoc::app::ScenarioError&) {
  }
  try {
    (void)ddoc::app::ParseMethod(method);
  } catch (const ddoc::app::ScenarioError&) {
  }
  try {
    for (double v : ddoc::app::ParseNumberList(list, 4, "--input")) {
      if (!std::isfinite(v)) std::abort();  // a non-finite number passed
    }
  } catch (const ddoc::app::ScenarioError&) {
  }
  return 0;
}
