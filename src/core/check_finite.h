// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Naming a non-finite entry of a matrix given by the user (not part of the public API).
#ifndef DDOC_SRC_CORE_CHECK_FINITE_H_
#define DDOC_SRC_CORE_CHECK_FINITE_H_

#include <cmath>
#include <string>

#include "ddoc/types.h"

namespace ddoc {
namespace internal {

/// Throws InvalidArgument "<what> has a non-finite entry at (i, j)" for the first such entry of M.
template <class M>
void CheckFiniteEntries(const M& m, const std::string& what) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (!std::isfinite(m(i, j))) {
        throw InvalidArgument(what + " has a non-finite entry at (" + std::to_string(i) + ", " +
                              std::to_string(j) + ")");
      }
    }
  }
}

}  // namespace internal
}  // namespace ddoc

#endif  // DDOC_SRC_CORE_CHECK_FINITE_H_
