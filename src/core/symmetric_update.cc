// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "symmetric_update.h"

#include <cstddef>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__)) && \
    !defined(DDOC_BACKWARD_PASS_NO_DISPATCH) && !defined(EIGEN_DONT_VECTORIZE)
#include <immintrin.h>
#define DDOC_SYMMETRIC_AVX2 1
#endif

#include "small_product.h"

namespace ddoc {
namespace internal {
namespace {

using Index = std::ptrdiff_t;

// Everything one update needs, with the leading dimensions as Index.
struct Args {
  int nz, n;
  double* Y;
  Index ldy;
  const double* L;
  Index ldl;
  double q;
  const double* R;
  Index ldr;
  double* P;
  Index ldp;
  double* out;
  Index ldo;
  double a;
  const double* d0;
  const double* d1;
  const double* d2;
  Index ldd;
};

inline double Value(const Args& s, int r, int c) {
  double d = s.Y[c * s.ldy + r] + s.Y[r * s.ldy + c];
  if (c < s.n) d += s.q * s.L[c * s.ldl + r];
  if (s.R != nullptr) d -= s.R[c * s.ldr + r];
  return d;
}

// Entry (r, c), r <= c, and its mirror (c, r), from the value d of dP(r, c). For kRk4Stage the
// caller stores d into Y(r, c) after every read of Y(r, c) is done.
template <SymmetricUpdate kKind>
inline void Apply(const Args& s, int r, int c, double d) {
  const Index rc = c * s.ldp + r, cr = r * s.ldp + c;
  if (kKind == SymmetricUpdate::kStage || kKind == SymmetricUpdate::kRk4Stage) {
    s.out[c * s.ldo + r] = s.P[rc] + s.a * d;
    s.out[r * s.ldo + c] = s.P[cr] + s.a * d;
  } else if (kKind == SymmetricUpdate::kStep) {
    const double v = s.P[rc] + s.a * d;
    s.P[rc] = v;
    s.P[cr] = v;
  } else {
    const Index i = c * s.ldd + r;
    const double t = s.a * (((s.d0[i] + 2.0 * s.d1[i]) + 2.0 * s.d2[i]) + d);
    s.P[rc] = s.P[rc] + t;
    if (r != c) s.P[cr] = s.P[cr] + t;
  }
}

template <SymmetricUpdate kKind>
inline void Scalar(const Args& s, int r, int c) {
  const double d = Value(s, r, c);
  Apply<kKind>(s, r, c, d);
  if (kKind == SymmetricUpdate::kRk4Stage) s.Y[c * s.ldy + r] = d;
}

#if defined(__SSE2__)
// The 2 x 2 block of rows r, r + 1 and columns c, c + 1 (r + 1 < c) and its mirror, in SSE2
// packets: the same additions and products per entry as Value and Apply.
template <SymmetricUpdate kKind>
inline void Block(const Args& s, int r, int c) {
  double* yc0 = s.Y + c * s.ldy + r;
  double* yc1 = yc0 + s.ldy;
  const __m128d b0 = _mm_loadu_pd(s.Y + r * s.ldy + c);        // Y(c, r), Y(c + 1, r)
  const __m128d b1 = _mm_loadu_pd(s.Y + (r + 1) * s.ldy + c);  // Y(c, r + 1), Y(c + 1, r + 1)
  __m128d d0 = _mm_add_pd(_mm_loadu_pd(yc0), _mm_unpacklo_pd(b0, b1));  // column c, rows r, r+1
  __m128d d1 = _mm_add_pd(_mm_loadu_pd(yc1), _mm_unpackhi_pd(b0, b1));  // column c + 1
  const __m128d q = _mm_set1_pd(s.q);
  if (c < s.n) d0 = _mm_add_pd(d0, _mm_mul_pd(q, _mm_loadu_pd(s.L + c * s.ldl + r)));
  if (c + 1 < s.n) d1 = _mm_add_pd(d1, _mm_mul_pd(q, _mm_loadu_pd(s.L + (c + 1) * s.ldl + r)));
  if (s.R != nullptr) {
    d0 = _mm_sub_pd(d0, _mm_loadu_pd(s.R + c * s.ldr + r));
    d1 = _mm_sub_pd(d1, _mm_loadu_pd(s.R + (c + 1) * s.ldr + r));
  }
  const __m128d a = _mm_set1_pd(s.a);
  double* pc0 = s.P + c * s.ldp + r;  // P(r.., c)
  double* pc1 = pc0 + s.ldp;
  double* pr0 = s.P + r * s.ldp + c;  // P(c.., r)
  double* pr1 = pr0 + s.ldp;
  if (kKind == SymmetricUpdate::kStage || kKind == SymmetricUpdate::kRk4Stage) {
    double* oc0 = s.out + c * s.ldo + r;
    double* or0 = s.out + r * s.ldo + c;
    _mm_storeu_pd(oc0, _mm_add_pd(_mm_loadu_pd(pc0), _mm_mul_pd(a, d0)));
    _mm_storeu_pd(oc0 + s.ldo, _mm_add_pd(_mm_loadu_pd(pc1), _mm_mul_pd(a, d1)));
    _mm_storeu_pd(or0, _mm_add_pd(_mm_loadu_pd(pr0), _mm_mul_pd(a, _mm_unpacklo_pd(d0, d1))));
    _mm_storeu_pd(or0 + s.ldo,
                  _mm_add_pd(_mm_loadu_pd(pr1), _mm_mul_pd(a, _mm_unpackhi_pd(d0, d1))));
    if (kKind == SymmetricUpdate::kRk4Stage) {
      _mm_storeu_pd(yc0, d0);
      _mm_storeu_pd(yc1, d1);
    }
  } else if (kKind == SymmetricUpdate::kStep) {
    const __m128d v0 = _mm_add_pd(_mm_loadu_pd(pc0), _mm_mul_pd(a, d0));
    const __m128d v1 = _mm_add_pd(_mm_loadu_pd(pc1), _mm_mul_pd(a, d1));
    _mm_storeu_pd(pc0, v0);
    _mm_storeu_pd(pc1, v1);
    _mm_storeu_pd(pr0, _mm_unpacklo_pd(v0, v1));
    _mm_storeu_pd(pr1, _mm_unpackhi_pd(v0, v1));
  } else {
    const __m128d two = _mm_set1_pd(2.0);
    auto sum = [&](Index i, __m128d d) {
      __m128d t = _mm_add_pd(_mm_loadu_pd(s.d0 + i), _mm_mul_pd(two, _mm_loadu_pd(s.d1 + i)));
      t = _mm_add_pd(t, _mm_mul_pd(two, _mm_loadu_pd(s.d2 + i)));
      return _mm_mul_pd(a, _mm_add_pd(t, d));
    };
    const __m128d t0 = sum(c * s.ldd + r, d0);
    const __m128d t1 = sum((c + 1) * s.ldd + r, d1);
    _mm_storeu_pd(pc0, _mm_add_pd(_mm_loadu_pd(pc0), t0));
    _mm_storeu_pd(pc1, _mm_add_pd(_mm_loadu_pd(pc1), t1));
    _mm_storeu_pd(pr0, _mm_add_pd(_mm_loadu_pd(pr0), _mm_unpacklo_pd(t0, t1)));
    _mm_storeu_pd(pr1, _mm_add_pd(_mm_loadu_pd(pr1), _mm_unpackhi_pd(t0, t1)));
  }
}
#endif

template <SymmetricUpdate kKind>
void Run(const Args& s) {
  const int nz = s.nz;
  int c = 0;
#if defined(__SSE2__)
  for (; c + 1 < nz; c += 2) {
    for (int r = 0; r + 1 < c; r += 2) Block<kKind>(s, r, c);
    // The diagonal block: (c, c), (c, c + 1) and (c + 1, c + 1), each value read before any
    // kRk4Stage store into Y.
    const double dcc = Value(s, c, c), dc1 = Value(s, c, c + 1), d11 = Value(s, c + 1, c + 1);
    Apply<kKind>(s, c, c, dcc);
    Apply<kKind>(s, c, c + 1, dc1);
    Apply<kKind>(s, c + 1, c + 1, d11);
    if (kKind == SymmetricUpdate::kRk4Stage) {
      s.Y[c * s.ldy + c] = dcc;
      s.Y[(c + 1) * s.ldy + c] = dc1;
      s.Y[(c + 1) * s.ldy + c + 1] = d11;
    }
  }
#endif
  for (; c < nz; ++c) {
    for (int r = 0; r <= c; ++r) Scalar<kKind>(s, r, c);
  }
}

#ifdef DDOC_SYMMETRIC_AVX2
#define DDOC_AVX2 __attribute__((target("avx2,fma")))

// Columns c0..c3 of a 4 x 4 block become its rows (the columns of its transpose).
DDOC_AVX2 inline void Transpose4(__m256d* c) {
  const __m256d t0 = _mm256_unpacklo_pd(c[0], c[1]), t1 = _mm256_unpackhi_pd(c[0], c[1]);
  const __m256d t2 = _mm256_unpacklo_pd(c[2], c[3]), t3 = _mm256_unpackhi_pd(c[2], c[3]);
  c[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
  c[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
  c[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
  c[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

// A diagonal block's columns with every entry below the diagonal replaced by its mirror above.
DDOC_AVX2 inline void MirrorUpper(__m256d* c) {
  __m256d t[4] = {c[0], c[1], c[2], c[3]};
  Transpose4(t);
  c[0] = _mm256_blend_pd(c[0], t[0], 0xE);
  c[1] = _mm256_blend_pd(c[1], t[1], 0xC);
  c[2] = _mm256_blend_pd(c[2], t[2], 0x8);
}

DDOC_AVX2 inline __m256d Load(const double* base, Index ld, int r, int c) {
  return _mm256_loadu_pd(base + c * ld + r);
}
DDOC_AVX2 inline void Store(double* base, Index ld, int r, int c, __m256d v) {
  _mm256_storeu_pd(base + c * ld + r, v);
}

// L's rows r..r+3 of column c < n; L has n rows, so in a diagonal block that crosses row n the
// rows from n on are not read (they are zero here, and MirrorUpper replaces them anyway).
DDOC_AVX2 inline __m256d LoadL(const Args& s, int r, int c) {
  if (r + 3 < s.n) return Load(s.L, s.ldl, r, c);
  const __m256i lanes = _mm256_set_epi64x(r + 3, r + 2, r + 1, r);
  const __m256i mask = _mm256_cmpgt_epi64(_mm256_set1_epi64x(s.n), lanes);
  return _mm256_maskload_pd(s.L + c * s.ldl + r, mask);
}

// dP's columns c..c+3 on rows r..r+3 (upper formula: Y(r, c) + Y(c, r) + q L(r, c) - R(r, c)),
// with yt the columns of the mirror block's transpose (Y(c + j, r..r+3)).
DDOC_AVX2 inline void BlockValue(const Args& s, int r, int c, const __m256d* yt, __m256d* d) {
  const __m256d q = _mm256_set1_pd(s.q);
  for (int j = 0; j < 4; ++j) {
    d[j] = _mm256_add_pd(Load(s.Y, s.ldy, r, c + j), yt[j]);
    if (c + j < s.n) d[j] = _mm256_fmadd_pd(q, LoadL(s, r, c + j), d[j]);
    if (s.R != nullptr) d[j] = _mm256_sub_pd(d[j], Load(s.R, s.ldr, r, c + j));
  }
}

// The 4 x 4 block of rows r..r+3 and columns c..c+3 (r + 3 < c) and its mirror.
template <SymmetricUpdate kKind>
DDOC_AVX2 inline void Block4(const Args& s, int r, int c) {
  __m256d yt[4], d[4];
  for (int i = 0; i < 4; ++i) yt[i] = Load(s.Y, s.ldy, c, r + i);
  Transpose4(yt);
  BlockValue(s, r, c, yt, d);
  const __m256d a = _mm256_set1_pd(s.a);
  if (kKind == SymmetricUpdate::kStage || kKind == SymmetricUpdate::kRk4Stage) {
    for (int j = 0; j < 4; ++j) {
      Store(s.out, s.ldo, r, c + j, _mm256_fmadd_pd(a, d[j], Load(s.P, s.ldp, r, c + j)));
    }
    __m256d dt[4] = {d[0], d[1], d[2], d[3]};
    Transpose4(dt);
    for (int i = 0; i < 4; ++i) {
      Store(s.out, s.ldo, c, r + i, _mm256_fmadd_pd(a, dt[i], Load(s.P, s.ldp, c, r + i)));
    }
    if (kKind == SymmetricUpdate::kRk4Stage) {
      for (int j = 0; j < 4; ++j) Store(s.Y, s.ldy, r, c + j, d[j]);
    }
  } else if (kKind == SymmetricUpdate::kStep) {
    __m256d v[4];
    for (int j = 0; j < 4; ++j) {
      v[j] = _mm256_fmadd_pd(a, d[j], Load(s.P, s.ldp, r, c + j));
      Store(s.P, s.ldp, r, c + j, v[j]);
    }
    Transpose4(v);
    for (int i = 0; i < 4; ++i) Store(s.P, s.ldp, c, r + i, v[i]);
  } else {
    const __m256d two = _mm256_set1_pd(2.0);
    __m256d t[4];
    for (int j = 0; j < 4; ++j) {
      __m256d u = _mm256_fmadd_pd(two, Load(s.d1, s.ldd, r, c + j), Load(s.d0, s.ldd, r, c + j));
      u = _mm256_fmadd_pd(two, Load(s.d2, s.ldd, r, c + j), u);
      t[j] = _mm256_mul_pd(a, _mm256_add_pd(u, d[j]));
      Store(s.P, s.ldp, r, c + j, _mm256_add_pd(Load(s.P, s.ldp, r, c + j), t[j]));
    }
    Transpose4(t);
    for (int i = 0; i < 4; ++i) {
      Store(s.P, s.ldp, c, r + i, _mm256_add_pd(Load(s.P, s.ldp, c, r + i), t[i]));
    }
  }
}

// The diagonal 4 x 4 block at (c, c): every entry from the upper formula, then the lower
// triangle mirrored from the upper one (as Value and Apply do entry by entry).
template <SymmetricUpdate kKind>
DDOC_AVX2 inline void Diagonal4(const Args& s, int c) {
  __m256d yt[4], d[4];
  for (int i = 0; i < 4; ++i) yt[i] = Load(s.Y, s.ldy, c, c + i);
  Transpose4(yt);
  BlockValue(s, c, c, yt, d);
  MirrorUpper(d);
  const __m256d a = _mm256_set1_pd(s.a);
  if (kKind == SymmetricUpdate::kStage || kKind == SymmetricUpdate::kRk4Stage) {
    for (int j = 0; j < 4; ++j) {
      Store(s.out, s.ldo, c, c + j, _mm256_fmadd_pd(a, d[j], Load(s.P, s.ldp, c, c + j)));
      if (kKind == SymmetricUpdate::kRk4Stage) Store(s.Y, s.ldy, c, c + j, d[j]);
    }
  } else if (kKind == SymmetricUpdate::kStep) {
    __m256d v[4];
    for (int j = 0; j < 4; ++j) v[j] = _mm256_fmadd_pd(a, d[j], Load(s.P, s.ldp, c, c + j));
    MirrorUpper(v);  // from P's upper triangle, as Apply's kStep
    for (int j = 0; j < 4; ++j) Store(s.P, s.ldp, c, c + j, v[j]);
  } else {
    const __m256d two = _mm256_set1_pd(2.0);
    __m256d d0[4], d1[4], d2[4];
    for (int j = 0; j < 4; ++j) {
      d0[j] = Load(s.d0, s.ldd, c, c + j);
      d1[j] = Load(s.d1, s.ldd, c, c + j);
      d2[j] = Load(s.d2, s.ldd, c, c + j);
    }
    MirrorUpper(d0);
    MirrorUpper(d1);
    MirrorUpper(d2);
    for (int j = 0; j < 4; ++j) {
      __m256d u = _mm256_fmadd_pd(two, d1[j], d0[j]);
      u = _mm256_fmadd_pd(two, d2[j], u);
      const __m256d t = _mm256_mul_pd(a, _mm256_add_pd(u, d[j]));
      Store(s.P, s.ldp, c, c + j, _mm256_add_pd(Load(s.P, s.ldp, c, c + j), t));
    }
  }
}

// Whole 4-column blocks in AVX2 (Value's and Apply's operations, with fused multiply-adds), then
// the remaining columns entry by entry.
template <SymmetricUpdate kKind>
DDOC_AVX2 void RunAvx2(const Args& s) {
  const int nz = s.nz;
  int c = 0;
  for (; c + 3 < nz; c += 4) {
    for (int r = 0; r + 3 < c; r += 4) Block4<kKind>(s, r, c);
    Diagonal4<kKind>(s, c);
  }
  for (; c < nz; ++c) {
    for (int r = 0; r <= c; ++r) Scalar<kKind>(s, r, c);
  }
  _mm256_zeroupper();
}
#endif

template <SymmetricUpdate kKind>
void Dispatch(const Args& s) {
#ifdef DDOC_SYMMETRIC_AVX2
  if (UseAvx2Kernels()) {
    RunAvx2<kKind>(s);
    return;
  }
#endif
  Run<kKind>(s);
}

}  // namespace

void SymmetricStage(const SymmetricTerms& t, SymmetricUpdate kind, double* P, int ldp, double* out,
                    int ldo, double a, const double* d0, const double* d1, const double* d2,
                    int ldd) {
  const Args s{t.nz, t.n, t.Y, t.ldy, t.L, t.ldl, t.q, t.R, t.ldr, P, ldp, out, ldo, a,
               d0, d1, d2, ldd};
  switch (kind) {
    case SymmetricUpdate::kStage:
      Dispatch<SymmetricUpdate::kStage>(s);
      break;
    case SymmetricUpdate::kStep:
      Dispatch<SymmetricUpdate::kStep>(s);
      break;
    case SymmetricUpdate::kRk4Stage:
      Dispatch<SymmetricUpdate::kRk4Stage>(s);
      break;
    case SymmetricUpdate::kRk4Final:
      Dispatch<SymmetricUpdate::kRk4Final>(s);
      break;
  }
}

}  // namespace internal
}  // namespace ddoc
