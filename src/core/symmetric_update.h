// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The symmetric right-hand side of the backward pass's P equation, fused with the integrator's
// stage updates (the backward pass's hot loop; not part of the public API).
#ifndef DDOC_SRC_CORE_SYMMETRIC_UPDATE_H_
#define DDOC_SRC_CORE_SYMMETRIC_UPDATE_H_

namespace ddoc {
namespace internal {

/// dP = Y + Y^T + q L - R (nz x nz, column-major): Y the "half" P F_z that the product gives,
/// q L the running cost's l_xx scaled by the mode's duration on the top-left n x n block, R the
/// Riccati term M H^-1 M^T (may be null). Only the upper triangle (r <= c) of L and R is read,
/// so every dP(r, c) = dP(c, r) comes from one expression, ((Y(r, c) + Y(c, r)) + q L(r, c)) -
/// R(r, c), whether it is formed with packets or scalars.
struct SymmetricTerms {
  int nz = 0, n = 0;
  double* Y = nullptr;
  int ldy = 0;
  const double* L = nullptr;
  int ldl = 0;
  double q = 0.0;
  const double* R = nullptr;
  int ldr = 0;
};

/// What is done with dP (a the step factor; P may be asymmetric at the rounding level after a
/// jump, so each triangle of P keeps its own entries except with kStep):
///   kStage      out = P + a dP                       (both triangles)
///   kStep       P(r, c) = P(c, r) = P(r, c) + a dP   (P becomes exactly symmetric)
///   kRk4Stage   out = P + a dP, and dP's upper triangle into Y's (the stage's derivative)
///   kRk4Final   P += a (((d0 + 2 d1) + 2 d2) + dP)   (d0..d2 the upper triangles kRk4Stage
///               left in its Y, leading dimension ldd)
enum class SymmetricUpdate { kStage, kStep, kRk4Stage, kRk4Final };

void SymmetricStage(const SymmetricTerms& t, SymmetricUpdate kind, double* P, int ldp, double* out,
                    int ldo, double a, const double* d0 = nullptr, const double* d1 = nullptr,
                    const double* d2 = nullptr, int ldd = 0);

}  // namespace internal
}  // namespace ddoc

#endif  // DDOC_SRC_CORE_SYMMETRIC_UPDATE_H_
