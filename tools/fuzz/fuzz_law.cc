// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Fuzz target: the law cache's file parser (ParseInitialLaw, plugin/law_cache.h) and the checks
// of OnlineController::ImportLaw. The input is a law file without its checksum (which the target
// appends, so that the fuzzer reaches past it) for the key "fuzz key". A parsed law must have
// consistent sizes; a law ImportLaw accepts, on a two-mode problem (one state, one input), must
// give finite inputs inside the bounds at any state. ParseInitialLaw must not throw, ImportLaw
// only InvalidArgument.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "ddoc/linear_system.h"
#include "ddoc/online_controller.h"
#include "ddoc/quadratic_cost.h"
#include "law_cache.h"

namespace {

struct TwoModes {
  ddoc::LinearSystem system{{ddoc::Matrix::Constant(1, 1, -1.0), ddoc::Matrix::Zero(1, 1)},
                            {ddoc::Matrix::Ones(1, 1), ddoc::Matrix::Ones(1, 1)},
                            {ddoc::Matrix::Ones(1, 1), ddoc::Matrix::Ones(1, 1)}};
  ddoc::QuadraticTrackingCost cost{{ddoc::Matrix::Ones(1, 1), ddoc::Matrix::Ones(1, 1)},
                                   {ddoc::Vector::Zero(1), ddoc::Vector::Zero(1)},
                                   {ddoc::Matrix::Ones(1, 1), ddoc::Matrix::Ones(1, 1)},
                                   {0.0, 0.0},
                                   {ddoc::Matrix::Ones(1, 1), ddoc::Matrix::Ones(1, 1)},
                                   {ddoc::Vector::Zero(1), ddoc::Vector::Zero(1)}};
  ddoc::Problem problem;
  TwoModes() {
    problem.system = &system;
    problem.cost = &cost;
    problem.bounds.u_min = ddoc::Vector::Constant(1, -2.0);
    problem.bounds.u_max = ddoc::Vector::Constant(1, 3.0);
    problem.bounds.duration_min = ddoc::Vector::Constant(2, 0.01);
    problem.bounds.duration_max = ddoc::Vector::Constant(2, 10.0);
    problem.surface_weights = ddoc::Vector::Zero(2);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using ddoc::plugin::StoredInitialLaw;
  static const TwoModes modes;
  std::string file(reinterpret_cast<const char*>(data), size);
  const std::uint64_t sum = ddoc::plugin::LawFileChecksum(file.data(), file.size());
  file.append(reinterpret_cast<const char*>(&sum), sizeof(sum));
  StoredInitialLaw stored;
  std::string why;
  if (!ddoc::plugin::ParseInitialLaw(file, "fuzz key", &stored, &why)) {
    if (why.empty()) std::abort();  // a rejection must say why
    return 0;
  }
  const ddoc::OnlineControllerLaw& law = stored.law;
  long samples = 0;
  for (int n : law.samples) samples += n;
  const auto S = static_cast<Eigen::Index>(samples);
  if (law.tau.size() != S || law.u.cols() != S || law.x.cols() != S || law.Kx.cols() != S ||
      law.c.cols() != S || law.huu.cols() != S ||
      law.Kx.rows() != law.u.rows() * law.x.rows() ||
      law.huu.rows() != law.u.rows() * law.u.rows() || !std::isfinite(stored.model_cost) ||
      stored.cyclic_value.rows() != stored.cyclic_value.cols() ||
      stored.cyclic_value.rows() > law.x.rows() || !stored.cyclic_value.allFinite()) {
    std::abort();  // the parser accepted inconsistent sizes
  }
  ddoc::OnlineController controller;
  controller.Allocate(modes.problem, 4096);
  try {
    controller.ImportLaw(law);
  } catch (const ddoc::InvalidArgument&) {
    return 0;
  }
  ddoc::Vector u(1), x(1);
  for (int k = 0; k < 2; ++k) {
    for (double t : {0.0, 0.003, 0.05, 1.0}) {
      for (double xv : {-1e3, 0.0, 0.5}) {
        x(0) = xv;
        controller.Step(k, t, x, u);
        if (!(u(0) >= -2.0 && u(0) <= 3.0)) std::abort();  // NaN or out of the box
      }
    }
  }
  return 0;
}
