// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "small_product.h"

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#endif

#include <Eigen/Core>
#include <cmath>
#include <cstddef>

namespace ddoc {
namespace internal {
namespace {

// Small dense product Y = X A (all column-major, leading dimensions ldx, lda, ldy), the hot
// spot of the backward pass (one per RK4 stage). Eigen's general product packs both operands
// and blocks for caches, which costs more than the arithmetic at the sizes here (n + K ~ 16-64,
// everything in L1/L2); this register-blocked kernel needs no packing. It uses Eigen's SIMD
// packets, so it is as wide as the build (SSE2 by default, AVX/AVX-512 with -march=native).
// Each entry is the sum over l = 0..depth-1 in order, as in Eigen's product.
using Packet = Eigen::internal::packet_traits<double>::type;
constexpr int kPacket = Eigen::internal::packet_traits<double>::size;

// Rows [0, NP * kPacket) and columns [0, NC) of Y.
template <int NP, int NC>
inline void ProductTile(int depth, const double* X, int ldx, const double* A, int lda, double* Y,
                        int ldy) {
  using Eigen::internal::pmadd;
  using Eigen::internal::ploadu;
  using Eigen::internal::pset1;
  Packet acc[NP][NC];
  for (int p = 0; p < NP; ++p) {
    for (int c = 0; c < NC; ++c) acc[p][c] = pset1<Packet>(0.0);
  }
  for (int l = 0; l < depth; ++l) {
    Packet x[NP];
    for (int p = 0; p < NP; ++p) x[p] = ploadu<Packet>(X + l * ldx + p * kPacket);
    for (int c = 0; c < NC; ++c) {
      const Packet a = pset1<Packet>(A[c * lda + l]);
      for (int p = 0; p < NP; ++p) acc[p][c] = pmadd(x[p], a, acc[p][c]);
    }
  }
  for (int p = 0; p < NP; ++p) {
    for (int c = 0; c < NC; ++c) Eigen::internal::pstoreu(Y + c * ldy + p * kPacket, acc[p][c]);
  }
}

// Columns [0, NC) of Y, all `rows` rows.
template <int NC>
inline void ProductPanel(int rows, int depth, const double* X, int ldx, const double* A, int lda,
                         double* Y, int ldy) {
  int i = 0;
  for (; i + 2 * kPacket <= rows; i += 2 * kPacket) {
    ProductTile<2, NC>(depth, X + i, ldx, A, lda, Y + i, ldy);
  }
  for (; i + kPacket <= rows; i += kPacket) ProductTile<1, NC>(depth, X + i, ldx, A, lda, Y + i, ldy);
  for (; i < rows; ++i) {
    double acc[NC] = {};
    for (int l = 0; l < depth; ++l) {
      for (int c = 0; c < NC; ++c) acc[c] += X[l * ldx + i] * A[c * lda + l];
    }
    for (int c = 0; c < NC; ++c) Y[c * ldy + i] = acc[c];
  }
}

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && \
    !defined(DDOC_BACKWARD_PASS_NO_DISPATCH) && !defined(EIGEN_DONT_VECTORIZE)
// The default build targets SSE2 (2 doubles per instruction, no FMA). On CPUs with AVX2 and
// FMA the same kernel with 4-wide fused multiply-adds runs ~2.5x faster; it is selected at run
// time (no build flag needed), or always when the build targets AVX2 + FMA (-march=native,
// DDOC_NATIVE; measured faster here than Eigen's AVX-512 packets at these sizes). Results
// differ from the SSE2 kernel only by the rounding of the fused multiply-add, which every row
// takes on this path (the rows beyond whole packets through std::fma).
// -DDDOC_BACKWARD_PASS_NO_DISPATCH forces the portable path (used to test it on AVX2 machines).
#define DDOC_BACKWARD_PASS_AVX2_DISPATCH 1

template <int NP, int NC>
__attribute__((target("avx2,fma"))) inline void ProductTileAvx2(int depth, const double* X,
                                                                 int ldx, const double* A,
                                                                 int lda, double* Y, int ldy) {
  __m256d acc[NP][NC];
  for (int p = 0; p < NP; ++p) {
    for (int c = 0; c < NC; ++c) acc[p][c] = _mm256_setzero_pd();
  }
  for (int l = 0; l < depth; ++l) {
    __m256d x[NP];
    for (int p = 0; p < NP; ++p) x[p] = _mm256_loadu_pd(X + l * ldx + 4 * p);
    for (int c = 0; c < NC; ++c) {
      const __m256d a = _mm256_broadcast_sd(A + c * lda + l);
      for (int p = 0; p < NP; ++p) acc[p][c] = _mm256_fmadd_pd(x[p], a, acc[p][c]);
    }
  }
  for (int p = 0; p < NP; ++p) {
    for (int c = 0; c < NC; ++c) _mm256_storeu_pd(Y + c * ldy + 4 * p, acc[p][c]);
  }
}

template <int NC>
__attribute__((target("avx2,fma"))) inline void ProductPanelAvx2(int rows, int depth,
                                                                  const double* X, int ldx,
                                                                  const double* A, int lda,
                                                                  double* Y, int ldy) {
  int i = 0;
  for (; i + 8 <= rows; i += 8) ProductTileAvx2<2, NC>(depth, X + i, ldx, A, lda, Y + i, ldy);
  for (; i + 4 <= rows; i += 4) ProductTileAvx2<1, NC>(depth, X + i, ldx, A, lda, Y + i, ldy);
  for (; i < rows; ++i) {
    double acc[NC] = {};
    for (int l = 0; l < depth; ++l) {
      for (int c = 0; c < NC; ++c) acc[c] = std::fma(X[l * ldx + i], A[c * lda + l], acc[c]);
    }
    for (int c = 0; c < NC; ++c) Y[c * ldy + i] = acc[c];
  }
}

__attribute__((target("avx2,fma"))) void SmallProductAvx2(int rows, int cols, int depth,
                                                           const double* X, int ldx,
                                                           const double* A, int lda, double* Y,
                                                           int ldy) {
  int j = 0;
  for (; j + 4 <= cols; j += 4) {
    ProductPanelAvx2<4>(rows, depth, X, ldx, A + j * lda, lda, Y + j * ldy, ldy);
  }
  for (; j < cols; ++j) ProductPanelAvx2<1>(rows, depth, X, ldx, A + j * lda, lda, Y + j * ldy, ldy);
  _mm256_zeroupper();
}

__attribute__((target("avx2,fma"))) void SparseProductAvx2(int rows, const double* X, int ldx,
                                                            const double* A, int lda,
                                                            const ColumnPattern& pattern,
                                                            double* Y, int ldy) {
  const int rows4 = rows & ~3;  // SmallProductAvx2's packet rows (fused); the rest unfused
  for (int c = 0; c < pattern.cols; ++c) {
    const int* l_begin = pattern.rows.data() + pattern.start[c];
    const int* l_end = pattern.rows.data() + pattern.start[c + 1];
    const double* a = A + static_cast<ptrdiff_t>(c) * lda;
    double* y = Y + static_cast<ptrdiff_t>(c) * ldy;
    int i = 0;
    for (; i + 8 <= rows4; i += 8) {
      __m256d acc0 = _mm256_setzero_pd(), acc1 = _mm256_setzero_pd();
      for (const int* l = l_begin; l != l_end; ++l) {
        const __m256d al = _mm256_broadcast_sd(a + *l);
        const double* x = X + static_cast<ptrdiff_t>(*l) * ldx + i;
        acc0 = _mm256_fmadd_pd(_mm256_loadu_pd(x), al, acc0);
        acc1 = _mm256_fmadd_pd(_mm256_loadu_pd(x + 4), al, acc1);
      }
      _mm256_storeu_pd(y + i, acc0);
      _mm256_storeu_pd(y + i + 4, acc1);
    }
    for (; i < rows4; i += 4) {
      __m256d acc = _mm256_setzero_pd();
      for (const int* l = l_begin; l != l_end; ++l) {
        acc = _mm256_fmadd_pd(_mm256_loadu_pd(X + static_cast<ptrdiff_t>(*l) * ldx + i),
                              _mm256_broadcast_sd(a + *l), acc);
      }
      _mm256_storeu_pd(y + i, acc);
    }
    for (; i < rows; ++i) {
      double acc = 0.0;
      for (const int* l = l_begin; l != l_end; ++l) acc = std::fma(X[*l * ldx + i], a[*l], acc);
      y[i] = acc;
    }
  }
  _mm256_zeroupper();
}

bool HasAvx2Fma() {
#if defined(__AVX2__) && defined(__FMA__)
  return true;
#else
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
#endif
}
#endif

}  // namespace

// Y (rows x cols) = X (rows x depth) * A (depth x cols).
void SmallProduct(int rows, int cols, int depth, const double* X, int ldx, const double* A,
                  int lda, double* Y, int ldy) {
#ifdef DDOC_BACKWARD_PASS_AVX2_DISPATCH
  if (HasAvx2Fma()) {
    SmallProductAvx2(rows, cols, depth, X, ldx, A, lda, Y, ldy);
    return;
  }
#endif
  constexpr int kCols = 4;
  int j = 0;
  for (; j + kCols <= cols; j += kCols) {
    ProductPanel<kCols>(rows, depth, X, ldx, A + j * lda, lda, Y + j * ldy, ldy);
  }
  for (; j < cols; ++j) ProductPanel<1>(rows, depth, X, ldx, A + j * lda, lda, Y + j * ldy, ldy);
}

bool UseAvx2Kernels() {
#ifdef DDOC_BACKWARD_PASS_AVX2_DISPATCH
  return HasAvx2Fma();
#else
  return false;
#endif
}

void ColumnPattern::Allocate(int max_depth, int max_cols) {
  start.assign(static_cast<size_t>(max_cols) + 1, 0);
  rows.assign(static_cast<size_t>(max_depth) * static_cast<size_t>(max_cols), 0);
  cols = 0;
}

void ColumnPattern::Find(int num_depth, int num_cols, const double* A, int lda) {
  depth = num_depth;
  cols = num_cols;
  int k = 0;
  for (int c = 0; c < num_cols; ++c) {
    start[c] = k;
    const double* a = A + static_cast<ptrdiff_t>(c) * lda;
    for (int l = 0; l < num_depth; ++l) {
      if (a[l] != 0.0) rows[k++] = l;
    }
  }
  start[num_cols] = k;
}

void ColumnPattern::SetFull(int num_depth, int num_cols) {
  depth = num_depth;
  cols = num_cols;
  int k = 0;
  for (int c = 0; c < num_cols; ++c) {
    start[c] = k;
    for (int l = 0; l < num_depth; ++l) rows[k++] = l;
  }
  start[num_cols] = k;
}

void SparseProduct(int rows, const double* X, int ldx, const double* A, int lda,
                   const ColumnPattern& pattern, double* Y, int ldy) {
#ifdef DDOC_BACKWARD_PASS_AVX2_DISPATCH
  if (HasAvx2Fma()) {
    SparseProductAvx2(rows, X, ldx, A, lda, pattern, Y, ldy);
    return;
  }
#endif
  using Eigen::internal::pmadd;
  using Eigen::internal::ploadu;
  using Eigen::internal::pset1;
  // SmallProduct's portable path: Eigen packets for the rows in whole packets, then scalars.
  const int rows_p = rows - rows % kPacket;
  for (int c = 0; c < pattern.cols; ++c) {
    const int* l_begin = pattern.rows.data() + pattern.start[c];
    const int* l_end = pattern.rows.data() + pattern.start[c + 1];
    const double* a = A + static_cast<ptrdiff_t>(c) * lda;
    double* y = Y + static_cast<ptrdiff_t>(c) * ldy;
    int i = 0;
    for (; i < rows_p; i += kPacket) {
      Packet acc = pset1<Packet>(0.0);
      for (const int* l = l_begin; l != l_end; ++l) {
        acc = pmadd(ploadu<Packet>(X + static_cast<ptrdiff_t>(*l) * ldx + i), pset1<Packet>(a[*l]),
                    acc);
      }
      Eigen::internal::pstoreu(y + i, acc);
    }
    for (; i < rows; ++i) {
      double acc = 0.0;
      for (const int* l = l_begin; l != l_end; ++l) acc += X[*l * ldx + i] * a[*l];
      y[i] = acc;
    }
  }
}

void SparseTransposeTimes(const double* A, int lda, const ColumnPattern& pattern, int cols,
                          const double* x, double* y) {
  const int depth = pattern.depth;
  if (pattern.dense()) {  // Eigen's packet dot products
    for (int c = 0; c < cols; ++c) {
      y[c] = Eigen::Map<const Eigen::VectorXd>(A + static_cast<ptrdiff_t>(c) * lda, depth)
                 .dot(Eigen::Map<const Eigen::VectorXd>(x, depth));
    }
    return;
  }
  for (int c = 0; c < cols; ++c) {
    const double* a = A + static_cast<ptrdiff_t>(c) * lda;
    double acc = 0.0;
    for (int k = pattern.start[c]; k < pattern.start[c + 1]; ++k) {
      const int l = pattern.rows[k];
      acc += a[l] * x[l];
    }
    y[c] = acc;
  }
}

}  // namespace internal
}  // namespace ddoc
