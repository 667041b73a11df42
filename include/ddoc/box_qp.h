// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A dense box-constrained QP solver (projected Newton), used for (31) and (33).
#ifndef DDOC_BOX_QP_H_
#define DDOC_BOX_QP_H_

#include <vector>

#include "ddoc/switched_system.h"

namespace ddoc {

/// Settings of BoxQP.
struct BoxQPSettings {
  int max_iterations = 50;         ///< Newton iterations (each: one Cholesky of the free block)
  /// Stop when ||x - clamp(x - s grad)||_inf <= tolerance (1 + ||s g||_inf) for s = 1 and for
  /// s = 1 / max H_ii. Default 1e-12.
  double tolerance = 1e-12;
  double armijo = 1e-4;            ///< sufficient decrease factor of the projected line search
  double backtrack = 0.5;          ///< step shrink factor of the projected line search
  int max_line_search_steps = 40;  ///< line search steps before giving up
  /// Largest distance to a bound at which a variable whose gradient points outward is held
  /// (Bertsekas' epsilon-active set, relative to 1 + |x_i|; the KKT residual if smaller).
  double active_set_margin = 1e-6;
};

enum class BoxQPStatus {
  kConverged = 0,          ///< projected-gradient test met: x satisfies the KKT conditions
  kMaxIterations,          ///< iteration limit; x is feasible and decreased the objective
  kNoProgress,             ///< neither the Newton nor the projected-gradient step decreased the
                           ///< objective (rounding level); x is feasible, kkt() says how far off
  kNotPositiveDefinite,    ///< the free block of H was not positive definite; x is feasible
};

/// min_x 1/2 x^T H x + g^T x  subject to  lo <= x <= hi, H symmetric positive definite.
/// Bounds may be infinite; lo == hi fixes a variable.
///
/// Projected Newton (Bertsekas 1982): at each iterate, the variables within epsilon of a bound
/// whose gradient pushes outward are held (epsilon = the KKT residual, capped), a Newton step on
/// the free variables (H_FF d_F = -grad_F) together with a scaled gradient step on the held ones
/// is searched along the projection onto the box with an Armijo test, and a projected
/// steepest-descent step is the fallback. It terminates in finitely many steps on strictly
/// convex QPs once the active set settles.
///
/// Allocation-free after construction/Allocate with the largest size (an own in-place
/// Cholesky on a preallocated buffer is used for the varying free block).
class BoxQP {
 public:
  explicit BoxQP(int max_size = 0, const BoxQPSettings& settings = {});
  /// Sizes the workspace for problems up to max_size variables (allocates).
  void Allocate(int max_size);
  int max_size() const { return max_size_; }
  BoxQPSettings& settings() { return settings_; }

  /// Solves the QP. `x` holds the warm start on entry (clamped into the box) and the solution
  /// on return. Sizes must agree and not exceed max_size; lo <= hi (InvalidArgument otherwise).
  BoxQPStatus Solve(const ConstMatrixRef& H, const ConstVectorRef& g, const ConstVectorRef& lo,
                    const ConstVectorRef& hi, VectorRef x);
  /// Newton iterations used by the last Solve.
  int iterations() const { return iterations_; }
  /// KKT residual ||x - clamp(x - (Hx + g))||_inf at the last iterate of the last Solve.
  double kkt() const { return kkt_; }

 private:
  double Objective(const ConstMatrixRef& H, const ConstVectorRef& g, const double* x, int n) const;
  // Cholesky of H over free_[0..nf) into chol_; false when H_FF is not positive definite.
  bool FactorFree(const ConstMatrixRef& H, int nf);
  // Armijo search along clamp(x + s direction_) from s = step; updates x on success.
  bool ProjectedSearch(const ConstMatrixRef& H, const ConstVectorRef& g, const ConstVectorRef& lo,
                       const ConstVectorRef& hi, double step, VectorRef x);

  BoxQPSettings settings_;
  int max_size_ = 0;
  int iterations_ = 0;
  double kkt_ = 0;
  Vector grad_;            // n: H x + g
  Vector direction_;       // n: Newton direction (0 on held variables)
  Vector trial_;           // n: projected trial point
  Vector rhs_;             // n_free
  Matrix chol_;            // max x max: Cholesky factor of H_FF (lower, top-left n_free block)
  std::vector<int> free_;  // n_free indices of the free variables
};

}  // namespace ddoc

#endif  // DDOC_BOX_QP_H_
