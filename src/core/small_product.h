// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The small dense product of the backward pass's hot loop (not part of the public API).
#ifndef DDOC_SRC_CORE_SMALL_PRODUCT_H_
#define DDOC_SRC_CORE_SMALL_PRODUCT_H_

namespace ddoc {
namespace internal {

/// Y (rows x cols) = X (rows x depth) * A (depth x cols), all column-major with leading
/// dimensions ldx, lda, ldy. A register-blocked kernel without packing (Eigen's general product
/// packs both operands, which costs more than the arithmetic at the sizes of the backward pass,
/// n + K ~ 16-64). AVX2/FMA is selected at run time where the CPU has it (results differ from
/// the SSE2 path only by the rounding of the fused multiply-add); the compile definition
/// DDOC_BACKWARD_PASS_NO_DISPATCH forces the portable path. Each entry is the sum over
/// l = 0..depth-1 in order.
void SmallProduct(int rows, int cols, int depth, const double* X, int ldx, const double* A,
                  int lda, double* Y, int ldy);

}  // namespace internal
}  // namespace ddoc

#endif  // DDOC_SRC_CORE_SMALL_PRODUCT_H_
