// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The small dense product of the backward pass's hot loop (not part of the public API).
#ifndef DDOC_SRC_CORE_SMALL_PRODUCT_H_
#define DDOC_SRC_CORE_SMALL_PRODUCT_H_

#include <vector>

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

/// True when the kernels here and in symmetric_update.cc take their AVX2 + FMA paths (the CPU
/// has them and the build allows the run-time dispatch).
bool UseAvx2Kernels();

/// The nonzero pattern of a small column-major matrix A (depth x cols): for each column c the
/// rows l with A(l, c) != 0, in increasing order. Find() is O(depth cols) and allocates nothing
/// once Allocate()d for the largest size.
struct ColumnPattern {
  std::vector<int> start;  // cols + 1: column c's rows are rows[start[c] .. start[c + 1])
  std::vector<int> rows;   // depth x cols at most
  int depth = 0, cols = 0;
  void Allocate(int max_depth, int max_cols);
  void Find(int depth, int cols, const double* A, int lda);
  /// Every entry of a depth x cols matrix, zero or not (a pattern that fits any such matrix).
  void SetFull(int depth, int cols);
  int nonzeros() const { return start[cols]; }
  bool dense() const { return 2 * nonzeros() > depth * cols; }
};

/// Y (rows x cols) = X (rows x depth) * A for A with the nonzero pattern `pattern` (Find() of
/// the same A): only the nonzero A(l, c) are multiplied. Each entry is the sum over the nonzero
/// l in increasing order with the rounding of SmallProduct (the same fused or separate
/// multiply-add per row), so the result is SmallProduct's bit for bit (a skipped term adds an
/// exact zero) but for the sign of a zero sum.
void SparseProduct(int rows, const double* X, int ldx, const double* A, int lda,
                   const ColumnPattern& pattern, double* Y, int ldy);

/// y (cols) = A(:, 0:cols)^T x for A with the nonzero pattern `pattern` (cols <= its columns):
/// y(c) is the sum over the nonzero A(l, c) x(l) in increasing l, or Eigen's dot product of the
/// whole column where more than half of A is nonzero.
void SparseTransposeTimes(const double* A, int lda, const ColumnPattern& pattern, int cols,
                          const double* x, double* y);

}  // namespace internal
}  // namespace ddoc

#endif  // DDOC_SRC_CORE_SMALL_PRODUCT_H_
