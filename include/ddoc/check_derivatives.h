// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A finite-difference checker for user models.
#ifndef DDOC_CHECK_DERIVATIVES_H_
#define DDOC_CHECK_DERIVATIVES_H_

#include <functional>
#include <string>
#include <vector>

#include "ddoc/switched_system.h"

namespace ddoc {

/// Central-difference Jacobian of fn: R^n -> R^r at x, the one finite-difference Jacobian of
/// ddoc (CheckDerivatives, the tests, the nominal gait search and the return-map tools use it):
///   J(:, i) = (fn(x + h_i e_i) - fn(x - h_i e_i)) / (2 h_i),  h_i = step * max(1, |x_i|).
/// 2n evaluations of fn (one more when n = 0, to size J). Throws InvalidArgument when step is
/// not finite and > 0 or when fn returns vectors of different sizes.
Matrix CentralDifferenceJacobian(const std::function<Vector(const Vector&)>& fn,
                                 const ConstVectorRef& x, double step = 1e-6);

/// The points at which CentralDifferenceJacobian evaluates fn, for each column z of Z (n x N)
/// at once: columns 2 (j n + i) and 2 (j n + i) + 1 are Z.col(j) + h_i e_i and Z.col(j) - h_i e_i,
/// h_i = step * max(1, |Z(i, j)|) (n x 2nN). With CentralDifferenceQuotients, the Jacobians of
/// a function evaluated at all the points in one call (a batch of Python points). Throws
/// InvalidArgument when step is not finite and > 0.
Matrix CentralDifferencePoints(const ConstMatrixRef& Z, double step = 1e-6);

/// The Jacobians from the values V (r x 2nN) of fn at CentralDifferencePoints(Z, step): J (r x
/// nN), columns j n .. j n + n - 1 the Jacobian at Z.col(j), bitwise CentralDifferenceJacobian's
/// for the same values. Throws InvalidArgument when V has the wrong number of columns.
Matrix CentralDifferenceQuotients(const ConstMatrixRef& Z, const ConstMatrixRef& V,
                                  double step = 1e-6);

/// max_ij |a - b| / max(1, max_ij |b|): the relative error CheckDerivatives reports (b is the
/// reference, e.g. the central differences). Throws InvalidArgument when the sizes differ.
double RelativeError(const ConstMatrixRef& a, const ConstMatrixRef& b);

/// max_ij |a_ij - b_ij| / (abs_tol + rel_tol |b_ij|): each entry against a tolerance of its own
/// (b the reference); <= 1 when every entry is within it. Unlike RelativeError, a small entry
/// beside a large one is held to its own size. Throws InvalidArgument when the sizes differ or a
/// tolerance is negative or both are 0.
double EntryError(const ConstMatrixRef& a, const ConstMatrixRef& b, double abs_tol, double rel_tol);

/// One checked derivative.
struct DerivativeError {
  std::string name;          ///< "fx", "fu", "gx", "hx", "lx", "lu", "lxx", "luu", "lux", "phix", "phixx"
  double max_abs_error = 0;  ///< max_ij |analytic - central difference|
  double max_rel_error = 0;  ///< max_abs_error / max(1, max_ij |central difference|)
  double entry_error = 0;    ///< EntryError with DerivativeCheckSettings' abs/rel tolerances
};

/// All checked derivatives of one mode at one point.
struct DerivativeCheckReport {
  std::vector<DerivativeError> entries;
  /// The entry called `name`, or nullptr.
  const DerivativeError* Find(const std::string& name) const;
  /// Largest max_rel_error over all entries.
  double max_rel_error() const;
  /// True when every entry has max_rel_error <= tolerance.
  bool Passed(double tolerance) const { return max_rel_error() <= tolerance; }
  /// Largest entry_error over all entries.
  double max_entry_error() const;
  /// True when every matrix entry is within its own tolerance (max_entry_error() <= 1).
  bool PassedPerEntry() const { return max_entry_error() <= 1.0; }
};

/// Settings of CheckDerivatives.
struct DerivativeCheckSettings {
  double step = 1e-6;  ///< central difference step, scaled by max(1, |x_i|)
  double abs_tolerance = 1e-6;  ///< per-entry check: absolute part (the differences' rounding)
  double rel_tolerance = 1e-6;  ///< per-entry check: part relative to the entry
};

/// Compares the analytic derivatives of `system` (f_x, f_u; g_x when mode k has a reset;
/// h_x when s_k > 0) and, if `cost` is non-null, of the costs (l_x, l_u, l_xx, l_uu, l_ux,
/// phi_x, phi_xx) with central differences at (x, u) in mode k. First derivatives are
/// differenced from values, second derivatives from the analytic first derivatives.
DerivativeCheckReport CheckDerivatives(const SwitchedSystem& system, const SwitchedCost* cost,
                                       int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                       const DerivativeCheckSettings& settings = {});

}  // namespace ddoc

#endif  // DDOC_CHECK_DERIVATIVES_H_
