// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Local stability of a periodic motion from measured (or simulated) returns to a section.
//
// A periodic gait under a fixed control law is a fixed point x* of its return map P (takeoff to
// takeoff for the hopper): x_{k+1} = P(x_k). Near x*, x_{k+1} - x* ~ A (x_k - x*); the gait is
// locally stable when every eigenvalue of A lies inside the unit circle, and an eigenvalue near
// -1 is a period-2 (hop-to-hop alternating) mode. FitReturnMap estimates A by least squares from
// pairs (x_k, x_{k+1}) such as the hops of perturbed runs, which averages out the noise of
// event detection on a fixed-step simulator. MuJoCo-free; the hopper tool is ddoc-return-map.
#ifndef DDOC_RETURN_MAP_H_
#define DDOC_RETURN_MAP_H_

#include <Eigen/Core>

#include <complex>

#include "ddoc/switched_system.h"

namespace ddoc {

/// The fitted linear return map and its spectrum.
struct ReturnMapFit {
  Matrix A;                        ///< n x n: x_{k+1} - x* ~ A (x_k - x*), in the caller's units
  Eigen::VectorXcd eigenvalues;    ///< n, sorted by modulus, largest first
  Eigen::MatrixXcd eigenvectors;   ///< n x n, column j belongs to eigenvalue j; in scaled units
                                   ///< (divided by `scale`), unit norm
  /// RMS of the fit residual in scaled units, over all samples and components.
  double residual_rms = 0.0;
  /// RMS of the scaled deviations x_{k+1} - x* (what the fit explains).
  double target_rms = 0.0;
  int samples = 0;
  /// Largest eigenvalue modulus (the spectral radius of A).
  double spectral_radius() const { return eigenvalues.size() ? std::abs(eigenvalues(0)) : 0.0; }
};

/// Least-squares fit of A from sample pairs: column j of `from` is x_k, column j of `to` is
/// x_{k+1}. `fixed_point` is x*. Each component i is divided by scale(i) > 0 before the fit (a
/// diagonal similarity: the eigenvalues do not depend on it, the conditioning does), so pass the
/// typical size of a deviation of each component. Throws InvalidArgument, naming the argument,
/// on mismatched sizes, fewer samples than the dimension, a non-positive or non-finite scale,
/// non-finite samples, or samples whose deviations do not span every direction (rank < n).
ReturnMapFit FitReturnMap(const Matrix& from, const Matrix& to, const Vector& fixed_point,
                          const Vector& scale);

}  // namespace ddoc

#endif  // DDOC_RETURN_MAP_H_
