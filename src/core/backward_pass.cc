// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/backward_pass.h"

#include <cmath>
#include <sstream>

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
#include <immintrin.h>
#endif

namespace ddoc {
namespace {

// Small dense product Y = X A (all column-major, leading dimensions ldx, lda, ldy), the hot
// spot of the backward pass (one per RK4 stage). Eigen's general product packs both operands
// and blocks for caches, which costs more than the arithmetic at the sizes here (n + K ~ 16-64,
// everything in L1/L2); this register-blocked kernel needs no packing. It uses Eigen's SIMD
// packets, so it is as wide as the build (SSE2 by default, AVX/AVX-512 with -march=native).
// Each entry is the sum over l = 0..depth-1 in order, as in Eigen's product.
using Packet = Eigen::internal::packet_traits<double>::type;
constexpr int kPacket = Eigen::internal::packet_traits<double>::size;
// Above this many rows Eigen's cache-blocked product is used instead.
constexpr int kSmallProductMaxRows = 96;

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
// differ from the SSE2 kernel only by the rounding of the fused multiply-add.
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
      for (int c = 0; c < NC; ++c) acc[c] += X[l * ldx + i] * A[c * lda + l];
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

bool HasAvx2Fma() {
#if defined(__AVX2__) && defined(__FMA__)
  return true;
#else
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
#endif
}
#endif

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

// The fused pass of one integrator stage over P, X, acc (nz x nz, leading dimension ld):
//   v = k_s = (Y + Y^T) + Q, then by kind
//   kFirst:        acc = v,           X = P + a v
//   kMiddle:       acc = acc + 2 v,   X = P + a v
//   kLastRk4:      P = P + h/6 (acc + v)
//   kLastMidpoint: P = P + h v
enum class StageKind { kFirst, kMiddle, kLastRk4, kLastMidpoint };

struct StagePass {
  const double* Y;  // nz x nz, leading dimension ld: X_s(:, 0:n) A_s
  const double* Q;  // nz x nz, leading dimension ldq: L_zz at the stage
  double* P;        // nz x nz, leading dimension ld
  double* X;        // nz x nz, leading dimension ld: next stage point
  double* acc;      // nz x nz, leading dimension ld
  int ld, ldq;
  double a, h;
};

// Rows [r0, r1) x columns [c0, c1), scalar.
template <StageKind kKind>
void StagePassScalar(const StagePass& s, int r0, int r1, int c0, int c1) {
  const double w = s.h / 6.0;
  const double a = s.a;
  const double h = s.h;
  const int ld = s.ld;
  for (int col = c0; col < c1; ++col) {
    const double* Yc = s.Y + col * ld;
    const double* Yr = s.Y + col;  // row `col` of Y, stride ld
    const double* Qc = s.Q + col * s.ldq;
    double* Pc = s.P + col * ld;
    double* Xc = s.X + col * ld;
    double* Ac = s.acc + col * ld;
    for (int r = r0; r < r1; ++r) {
      const double v = (Yc[r] + Yr[r * ld]) + Qc[r];
      if (kKind == StageKind::kFirst) {
        Ac[r] = v;
        Xc[r] = Pc[r] + a * v;
      } else if (kKind == StageKind::kMiddle) {
        Ac[r] = Ac[r] + 2.0 * v;
        Xc[r] = Pc[r] + a * v;
      } else if (kKind == StageKind::kLastRk4) {
        Pc[r] += w * (Ac[r] + v);
      } else {
        Pc[r] += h * v;
      }
    }
  }
}

#ifdef DDOC_BACKWARD_PASS_AVX2_DISPATCH
// 4 x 4 tiles with in-register transposes of the mirrored tile of Y (the compiler may fuse
// the multiply-adds, so results can differ from StagePassScalar's by rounding).
template <StageKind kKind>
__attribute__((target("avx2,fma"))) void StagePassAvx2(const StagePass& s, int nz) {
  const int nz4 = nz & ~3;
  const __m256d a = _mm256_set1_pd(s.a);
  const __m256d two = _mm256_set1_pd(2.0);
  const __m256d w = _mm256_set1_pd(s.h / 6.0);
  const __m256d h = _mm256_set1_pd(s.h);
  // Locals, so that the stores below need not be assumed to modify `s`.
  const int ld = s.ld;
  const int ldq = s.ldq;
  const double* const Y = s.Y;
  const double* const Q = s.Q;
  double* const P = s.P;
  double* const X = s.X;
  double* const acc = s.acc;
  for (int cb = 0; cb < nz4; cb += 4) {
    for (int rb = 0; rb < nz4; rb += 4) {
      // t_i = Y(cb:cb+4, rb+i); tt_c = Y(cb+c, rb:rb+4) = Y^T(rb:rb+4, cb+c).
      const __m256d t0 = _mm256_loadu_pd(Y + (rb + 0) * ld + cb);
      const __m256d t1 = _mm256_loadu_pd(Y + (rb + 1) * ld + cb);
      const __m256d t2 = _mm256_loadu_pd(Y + (rb + 2) * ld + cb);
      const __m256d t3 = _mm256_loadu_pd(Y + (rb + 3) * ld + cb);
      const __m256d u0 = _mm256_unpacklo_pd(t0, t1);
      const __m256d u1 = _mm256_unpackhi_pd(t0, t1);
      const __m256d u2 = _mm256_unpacklo_pd(t2, t3);
      const __m256d u3 = _mm256_unpackhi_pd(t2, t3);
      __m256d tt[4];
      tt[0] = _mm256_permute2f128_pd(u0, u2, 0x20);
      tt[1] = _mm256_permute2f128_pd(u1, u3, 0x20);
      tt[2] = _mm256_permute2f128_pd(u0, u2, 0x31);
      tt[3] = _mm256_permute2f128_pd(u1, u3, 0x31);
      for (int c = 0; c < 4; ++c) {
        const int col = cb + c;
        const __m256d y = _mm256_loadu_pd(Y + col * ld + rb);
        const __m256d q = _mm256_loadu_pd(Q + col * ldq + rb);
        const __m256d v = _mm256_add_pd(_mm256_add_pd(y, tt[c]), q);
        double* Pc = P + col * ld + rb;
        double* Xc = X + col * ld + rb;
        double* Ac = acc + col * ld + rb;
        if (kKind == StageKind::kFirst) {
          _mm256_storeu_pd(Ac, v);
          _mm256_storeu_pd(Xc, _mm256_add_pd(_mm256_loadu_pd(Pc), _mm256_mul_pd(a, v)));
        } else if (kKind == StageKind::kMiddle) {
          _mm256_storeu_pd(Ac, _mm256_add_pd(_mm256_loadu_pd(Ac), _mm256_mul_pd(two, v)));
          _mm256_storeu_pd(Xc, _mm256_add_pd(_mm256_loadu_pd(Pc), _mm256_mul_pd(a, v)));
        } else if (kKind == StageKind::kLastRk4) {
          const __m256d sum = _mm256_add_pd(_mm256_loadu_pd(Ac), v);
          _mm256_storeu_pd(Pc, _mm256_add_pd(_mm256_loadu_pd(Pc), _mm256_mul_pd(w, sum)));
        } else {
          _mm256_storeu_pd(Pc, _mm256_add_pd(_mm256_loadu_pd(Pc), _mm256_mul_pd(h, v)));
        }
      }
    }
  }
  // Clear the upper halves before returning to SSE code (the compiler does not always insert
  // this; dirty upper halves slow down all later SSE instructions on some CPUs).
  _mm256_zeroupper();
}
#endif

template <StageKind kKind>
void RunStagePass(const StagePass& s, int nz) {
#ifdef DDOC_BACKWARD_PASS_AVX2_DISPATCH
  if (HasAvx2Fma()) {
    StagePassAvx2<kKind>(s, nz);
    // The rim (rows or columns beyond the last multiple of 4).
    const int nz4 = nz & ~3;
    StagePassScalar<kKind>(s, nz4, nz, 0, nz);
    StagePassScalar<kKind>(s, 0, nz4, nz4, nz);
    return;
  }
#endif
  StagePassScalar<kKind>(s, 0, nz, 0, nz);
}

}  // namespace

void RegularizationDiagonal(RegularizationScaling scaling, double reg, const ConstMatrixRef& luu,
                            const ConstVectorRef& inv_range_sq, VectorRef mu) {
  const int m = static_cast<int>(luu.rows());
  if (luu.cols() != m || inv_range_sq.size() != m || mu.size() != m) {
    throw InvalidArgument("RegularizationDiagonal: L_uu is " + std::to_string(luu.rows()) + "x" +
                          std::to_string(luu.cols()) + ", inv_range_sq has " +
                          std::to_string(inv_range_sq.size()) + " and mu " +
                          std::to_string(mu.size()) + " entries (expected m x m, m, m)");
  }
  if (scaling == RegularizationScaling::kPerInput) {
    mu = reg * (luu.diagonal().cwiseAbs() + inv_range_sq);
  } else {
    mu.setConstant(reg * (1.0 + luu.diagonal().cwiseAbs().maxCoeff()));
  }
}

Vector InverseSquaredInputRanges(const Bounds& bounds) {
  if (bounds.u_min.size() != bounds.u_max.size()) {
    throw InvalidArgument("InverseSquaredInputRanges: u_min has " +
                          std::to_string(bounds.u_min.size()) + " entries, u_max " +
                          std::to_string(bounds.u_max.size()));
  }
  Vector out(bounds.u_min.size());
  for (int i = 0; i < out.size(); ++i) {
    const double s = bounds.u_max(i) - bounds.u_min(i);
    out(i) = (std::isfinite(s) && s > 0) ? 1.0 / (s * s) : 1.0;
  }
  return out;
}

void BackwardPass::Coefficients::Allocate(int nz_max, int m) {
  A.setZero(nz_max, nz_max);
  Q.setZero(nz_max, nz_max);
  Lz.setZero(nz_max);
  B.setZero(nz_max, m);
  Lzu.setZero(nz_max, m);
  Luz.setZero(m, nz_max);
  Lu.setZero(m);
  Luu.setZero(m, m);
  du.setZero(m);
  LuuInv.setZero(m, m);
}

void BackwardPass::Allocate(const Problem& problem, int max_samples,
                            const BackwardPassSettings& settings) {
  problem.Validate();
  if (max_samples < 2) {
    throw InvalidArgument("BackwardPass::Allocate: max_samples = " + std::to_string(max_samples) +
                          ", expected >= 2");
  }
  problem_ = &problem;
  settings_ = settings;
  if (!(settings.riccati_regularization >= 0)) {
    throw InvalidArgument("BackwardPassSettings: riccati_regularization = " +
                          std::to_string(settings.riccati_regularization) + ", expected >= 0");
  }
  if (!(settings.cyclic_value >= 0.0 && settings.cyclic_value <= 1.0)) {
    throw InvalidArgument("BackwardPassSettings: cyclic_value = " +
                          std::to_string(settings.cyclic_value) + ", expected in [0, 1]");
  }
  normalization_ = std::make_unique<TimeNormalization>(problem);
  const SwitchedSystem& sys = *problem.system;
  K_ = sys.num_modes();
  m_ = sys.input_dim();
  n_max_ = sys.max_state_dim();
  nz_max_ = n_max_ + K_;
  max_samples_ = max_samples;
  dims_.resize(K_);
  for (int k = 0; k < K_; ++k) dims_[k] = sys.state_dim(k);
  counts_.assign(K_, 0);
  offsets_.assign(K_, 0);
  tau_.setZero(max_samples);
  P_store_.setZero(nz_max_ * nz_max_, max_samples);
  p_store_.setZero(nz_max_, max_samples);
  gain_store_.setZero(m_ * nz_max_, max_samples);
  ff_store_.setZero(m_, max_samples);
  luu_store_.setZero(m_ * m_, max_samples);
  for (auto& c : coef_) c.Allocate(nz_max_, m_);
  inv_range_sq_ = InverseSquaredInputRanges(problem.bounds);
  mu_.setZero(m_);
  z_.setZero(nz_max_);
  phiz_.setZero(nz_max_);
  phizz_.setZero(nz_max_, nz_max_);
  Gz_.setZero(nz_max_, nz_max_);
  event_f_.setZero(n_max_);
  event_hx_.setZero(n_max_);
  event_Pi_.setZero(n_max_, n_max_);
  event_tmp_.setZero(nz_max_, nz_max_);
  cyclic_P0_.setZero(n_max_, n_max_);
  cyclic_G_.setZero(n_max_, n_max_);
  cyclic_tmp_.setZero(n_max_, n_max_);
  cyclic_valid_ = false;
  tmp_.setZero(nz_max_, nz_max_);
  P_.setZero(nz_max_, nz_max_);
  p_.setZero(nz_max_);
  Ps_.setZero(nz_max_, nz_max_);
  ps_.setZero(nz_max_);
  for (int i = 0; i < 4; ++i) {
    kP_[i].setZero(nz_max_, nz_max_);
    kp_[i].setZero(nz_max_);
  }
  PA_.setZero(nz_max_, nz_max_);
  Bdu_.setZero(n_max_);
  Bt_.setZero(m_, n_max_);
  M_.setZero(nz_max_, m_);
  W_.setZero(nz_max_, m_);
  r_.setZero(m_);
  llt_ = Eigen::LLT<Matrix>(m_);
  valid_ = false;
}

Eigen::Map<const Matrix> BackwardPass::P(int k, int j) const {
  const int nz = augmented_dim(k);
  return Eigen::Map<const Matrix>(P_store_.col(index(k, j)).data(), nz, nz);
}
Eigen::Map<const Vector> BackwardPass::p(int k, int j) const {
  return Eigen::Map<const Vector>(p_store_.col(index(k, j)).data(), augmented_dim(k));
}
Eigen::Map<const Matrix> BackwardPass::Gain(int k, int j) const {
  return Eigen::Map<const Matrix>(gain_store_.col(index(k, j)).data(), m_, augmented_dim(k));
}
Eigen::Map<const Vector> BackwardPass::Feedforward(int k, int j) const {
  return Eigen::Map<const Vector>(ff_store_.col(index(k, j)).data(), m_);
}
Eigen::Map<const Matrix> BackwardPass::Luu(int k, int j) const {
  return Eigen::Map<const Matrix>(luu_store_.col(index(k, j)).data(), m_, m_);
}
Eigen::Map<const Vector> BackwardPass::p2_initial() const {
  return Eigen::Map<const Vector>(p_store_.col(0).data() + dims_[0], K_);
}
Matrix BackwardPass::P22_initial() const { return P(0, 0).bottomRightCorner(K_, K_); }

void BackwardPass::Evaluate(int k, const Trajectory& nominal, int j, const Matrix* du_prev,
                            Coefficients* c) {
  const int n = dims_[k];
  const int nz = n + K_;
  auto z = z_.head(nz);
  z.head(n) = nominal.modes[k].x.col(j);
  z.tail(K_) = nominal.T;
  const auto u = nominal.modes[k].u.col(j);
  normalization_->FlowDerivatives(k, z, u, c->A.topLeftCorner(nz, nz), c->B.topRows(nz));
  normalization_->RunningDerivatives(k, z, u, c->Lz.head(nz), c->Lu, c->Q.topLeftCorner(nz, nz),
                                     c->Luu, c->Luz.leftCols(nz));
  // L_zu is only read by the du_prev term and the Riccati variants.
  if (settings_.use_previous_du || riccati()) c->Lzu.topRows(nz) = c->Luz.leftCols(nz).transpose();
  if (settings_.use_previous_du && du_prev != nullptr) {
    c->du = du_prev->col(index(k, j));
  } else {
    c->du.setZero();
  }
  if (riccati()) Invert(c);
}

void BackwardPass::Invert(Coefficients* c) {
  // (L_uu + mu I)^{-1} without allocation (LLT preallocated for m x m).
  c->LuuInv = c->Luu;
  RegularizationDiagonal(settings_.regularization_scaling, settings_.riccati_regularization,
                         c->Luu, inv_range_sq_, mu_);
  c->LuuInv.diagonal() += mu_;
  llt_.compute(c->LuuInv);
  if (llt_.info() != Eigen::Success) {
    throw InvalidArgument(
        "BackwardPass (Riccati variant): L_uu + mu I is not positive definite; raise "
        "riccati_regularization");
  }
  c->LuuInv.setIdentity();
  llt_.solveInPlace(c->LuuInv);
}

void BackwardPass::Interpolate(int n, int nz, const Coefficients& a, const Coefficients& b,
                               Coefficients* c) {
  c->A.topLeftCorner(n, nz) = 0.5 * (a.A.topLeftCorner(n, nz) + b.A.topLeftCorner(n, nz));
  c->Q.topLeftCorner(nz, nz) = 0.5 * (a.Q.topLeftCorner(nz, nz) + b.Q.topLeftCorner(nz, nz));
  c->Lz.head(nz) = 0.5 * (a.Lz.head(nz) + b.Lz.head(nz));
  if (settings_.use_previous_du || riccati()) {
    c->B.topRows(n) = 0.5 * (a.B.topRows(n) + b.B.topRows(n));
    c->Lzu.topRows(nz) = 0.5 * (a.Lzu.topRows(nz) + b.Lzu.topRows(nz));
    c->du = 0.5 * (a.du + b.du);
  }
  if (riccati()) {
    c->Lu = 0.5 * (a.Lu + b.Lu);
    c->Luu = 0.5 * (a.Luu + b.Luu);
    Invert(c);
  }
}

void BackwardPass::Derivative(int n, int nz, const Coefficients& c, const ConstMatrixRef& P,
                              const ConstVectorRef& p, MatrixRef dP, VectorRef dp) {
  // F_z has zero bottom rows, so P F_z = P(:, 0:n) F_z(0:n, :).
  auto PA = PA_.topLeftCorner(nz, nz);
  PA.noalias() = P.leftCols(n) * c.A.topLeftCorner(n, nz);
  dP = PA + PA.transpose() + c.Q.topLeftCorner(nz, nz);
  dp = c.Lz.head(nz);
  dp.noalias() += c.A.topLeftCorner(n, nz).transpose() * p.head(n);
  if (riccati()) {
    // - (P F_u + L_zu) H^{-1} (F_u^T P + L_uz) [and - (P F_u + L_zu) H^{-1} (L_u + F_u^T p)].
    auto M = M_.topRows(nz);
    M = c.Lzu.topRows(nz);
    M.noalias() += P.leftCols(n) * c.B.topRows(n);
    auto W = W_.topRows(nz);
    W.noalias() = M * c.LuuInv;
    dP.noalias() -= W * M.transpose();
    if (equation_ == BackwardEquation::kRiccati) {
      r_ = c.Lu;
      r_.noalias() += c.B.topRows(n).transpose() * p.head(n);
      dp.noalias() -= W * r_;
      return;
    }
  }
  if (settings_.use_previous_du) {
    auto Bdu = Bdu_.head(n);
    Bdu.noalias() = c.B.topRows(n) * c.du;
    dp.noalias() += P.leftCols(n) * Bdu;
    dp.noalias() += c.Lzu.topRows(nz) * c.du;
  }
}

void BackwardPass::Step(int n, int nz, double h, const Coefficients& hi, const Coefficients& lo,
                        MatrixRef P, VectorRef p) {
  Coefficients& mid = coef_[2];
  Interpolate(n, nz, hi, lo, &mid);
  auto Ps = Ps_.topLeftCorner(nz, nz);
  auto ps = ps_.head(nz);
  auto k1P = kP_[0].topLeftCorner(nz, nz);
  auto k2P = kP_[1].topLeftCorner(nz, nz);
  auto k3P = kP_[2].topLeftCorner(nz, nz);
  auto k4P = kP_[3].topLeftCorner(nz, nz);
  auto k1p = kp_[0].head(nz);
  auto k2p = kp_[1].head(nz);
  auto k3p = kp_[2].head(nz);
  auto k4p = kp_[3].head(nz);
  if (settings_.integrator == BackwardIntegrator::kMidpoint) {
    Derivative(n, nz, hi, P, p, k1P, k1p);
    Ps = P + (0.5 * h) * k1P;
    ps = p + (0.5 * h) * k1p;
    Derivative(n, nz, mid, Ps, ps, k2P, k2p);
    P += h * k2P;
    p += h * k2p;
    return;
  }
  Derivative(n, nz, hi, P, p, k1P, k1p);
  Ps = P + (0.5 * h) * k1P;
  ps = p + (0.5 * h) * k1p;
  Derivative(n, nz, mid, Ps, ps, k2P, k2p);
  Ps = P + (0.5 * h) * k2P;
  ps = p + (0.5 * h) * k2p;
  Derivative(n, nz, mid, Ps, ps, k3P, k3p);
  Ps = P + h * k3P;
  ps = p + h * k3p;
  Derivative(n, nz, lo, Ps, ps, k4P, k4p);
  P += (h / 6.0) * (k1P + 2.0 * k2P + 2.0 * k3P + k4P);
  p += (h / 6.0) * (k1p + 2.0 * k2p + 2.0 * k3p + k4p);
}

void BackwardPass::LyapunovDp(int n, int nz, const Coefficients& c, const ConstMatrixRef& X,
                              const ConstVectorRef& x, VectorRef dp) {
  dp = c.Lz.head(nz);
  // Coefficient-wise (nz dot products of length n): cheaper than Eigen's GEMV at these sizes.
  dp.noalias() += c.A.topLeftCorner(n, nz).transpose().lazyProduct(x.head(n));
  if (settings_.use_previous_du) {
    auto Bdu = Bdu_.head(n);
    Bdu.noalias() = c.B.topRows(n) * c.du;
    dp.noalias() += X.leftCols(n) * Bdu;
    dp.noalias() += c.Lzu.topRows(nz) * c.du;
  }
}

void BackwardPass::LyapunovStep(int n, int nz, double h, const Coefficients& hi,
                                const Coefficients& lo) {
  // Stage s of RK4 (hi, mid, mid, lo) or the midpoint rule (hi, mid) evaluates
  //   k_s = X_s A_s + (X_s A_s)^T + Q_s   (A_s = top n rows of F_z, so X_s A_s = X_s(:, 0:n) A_s)
  // at X_1 = P, X_2 = P + h/2 k_1, X_3 = P + h/2 k_2, X_4 = P + h k_3 (midpoint: X_2, then
  // P += h k_2) and P += h/6 (k_1 + 2 k_2 + 2 k_3 + k_4), in the operation order of Step.
  // One pass per stage forms k_s from the product Y = X_s(:, 0:n) A_s, accumulates it and
  // writes the next X; k_s is never stored.
  Coefficients& mid = coef_[2];
  Interpolate(n, nz, hi, lo, &mid);
  const bool rk4 = settings_.integrator == BackwardIntegrator::kRk4;
  const int stages = rk4 ? 4 : 2;
  const Coefficients* coef[4] = {&hi, &mid, &mid, &lo};
  const int ld = nz_max_;
  double* P = P_.data();      // nz x nz (leading dimension ld): P, updated at the last stage
  double* X = Ps_.data();     // nz x nz: X_s for s >= 2
  double* Y = PA_.data();     // nz x nz: X_s(:, 0:n) A_s
  double* acc = kP_[0].data();  // nz x nz: k_1 + 2 k_2 + 2 k_3 (RK4)
  auto p = p_.head(nz);
  auto ps = ps_.head(nz);
  for (int s = 0; s < stages; ++s) {
    const Coefficients& c = *coef[s];
    const double* Xs = s == 0 ? P : X;
    if (nz <= kSmallProductMaxRows) {
      SmallProduct(nz, nz, n, Xs, ld, c.A.data(), static_cast<int>(c.A.rows()), Y, ld);
    } else if (s == 0) {
      PA_.topLeftCorner(nz, nz).noalias() = P_.topLeftCorner(nz, n) * c.A.topLeftCorner(n, nz);
    } else {
      PA_.topLeftCorner(nz, nz).noalias() = Ps_.topLeftCorner(nz, n) * c.A.topLeftCorner(n, nz);
    }
    // p: the same stages with dp/ds = A^T p + L_z (+ du_prev term).
    auto dp = kp_[s].head(nz);
    if (s == 0) {
      LyapunovDp(n, nz, c, P_.topLeftCorner(nz, nz), p, dp);
    } else {
      LyapunovDp(n, nz, c, Ps_.topLeftCorner(nz, nz), ps, dp);
    }
    const bool last = s == stages - 1;
    // Weight of k_s in the next stage point: h/2, h/2, h (RK4) or h/2 (midpoint).
    const double a = (rk4 && s == 2) ? h : 0.5 * h;
    const StagePass pass{Y, c.Q.data(), P, X, acc, ld, static_cast<int>(c.Q.rows()), a, h};
    if (!last) {
      if (s == 0) {
        RunStagePass<StageKind::kFirst>(pass, nz);
      } else {
        RunStagePass<StageKind::kMiddle>(pass, nz);
      }
    } else if (rk4) {
      RunStagePass<StageKind::kLastRk4>(pass, nz);
    } else {
      RunStagePass<StageKind::kLastMidpoint>(pass, nz);
    }
    if (!last) {
      ps = p + a * dp;
    } else if (rk4) {
      p += (h / 6.0) * (kp_[0].head(nz) + 2.0 * kp_[1].head(nz) + 2.0 * kp_[2].head(nz) + dp);
    } else {
      p += h * dp;
    }
  }
}

void BackwardPass::StoreOutputs(int k, int j, const Coefficients& c) {
  const int n = dims_[k];
  const int nz = n + K_;
  const int s = index(k, j);
  Eigen::Map<Matrix> Pout(P_store_.col(s).data(), nz, nz);
  Eigen::Map<Vector> pout(p_store_.col(s).data(), nz);
  Pout = P_.topLeftCorner(nz, nz);
  pout = p_.head(nz);
  Eigen::Map<Matrix> gain(gain_store_.col(s).data(), m_, nz);
  // gain = F_u^T P + L_uz = (F_u(0:n, :)^T) P(0:n, :) + L_uz, with the small-product kernel.
  auto Bt = Bt_.leftCols(n);
  Bt = c.B.topRows(n).transpose();
  SmallProduct(m_, nz, n, Bt.data(), m_, P_.data(), nz_max_, gain.data(), m_);
  gain += c.Luz.leftCols(nz);
  auto ff = ff_store_.col(s);
  ff = c.Lu;
  ff.noalias() += c.B.topRows(n).transpose() * p_.head(n);
  Eigen::Map<Matrix>(luu_store_.col(s).data(), m_, m_) = c.Luu;
}

void BackwardPass::Run(const Trajectory& nominal, const Matrix* du_prev) {
  if (problem_ == nullptr) throw InvalidArgument("BackwardPass::Run: call Allocate first");
  valid_ = false;
  equation_ = settings_.equation;
  if (settings_.riccati && equation_ == BackwardEquation::kLyapunov) {
    equation_ = BackwardEquation::kRiccatiFeedback;
  }
  // Allocation-free structural checks (the full validation is the caller's job).
  if (nominal.num_modes() != K_ || nominal.T.size() != K_) {
    throw InvalidArgument("BackwardPass::Run: trajectory has " +
                          std::to_string(nominal.num_modes()) + " modes and T of size " +
                          std::to_string(nominal.T.size()) + ", expected K = " +
                          std::to_string(K_));
  }
  int total = 0;
  for (int k = 0; k < K_; ++k) {
    const ModeTrajectory& mode = nominal.modes[k];
    const int N = mode.num_samples();
    if (N < 2 || mode.x.rows() != dims_[k] || mode.x.cols() != N || mode.u.rows() != m_ ||
        mode.u.cols() != N) {
      std::ostringstream os;
      os << "BackwardPass::Run: mode " << k << " has " << N << " samples, x " << mode.x.rows()
         << "x" << mode.x.cols() << ", u " << mode.u.rows() << "x" << mode.u.cols()
         << "; expected >= 2 samples, x n_k = " << dims_[k] << " rows, u m = " << m_ << " rows";
      throw InvalidArgument(os.str());
    }
    offsets_[k] = total;
    counts_[k] = N;
    total += N;
  }
  if (total > max_samples_) {
    throw InvalidArgument("BackwardPass::Run: trajectory has " + std::to_string(total) +
                          " samples, more than max_samples = " + std::to_string(max_samples_));
  }
  if (settings_.use_previous_du && du_prev != nullptr &&
      (du_prev->rows() != m_ || du_prev->cols() != total)) {
    throw InvalidArgument("BackwardPass::Run: du_prev is " + std::to_string(du_prev->rows()) +
                          "x" + std::to_string(du_prev->cols()) + ", expected m x samples = " +
                          std::to_string(m_) + "x" + std::to_string(total));
  }
  for (int k = 0; k < K_; ++k) {
    for (int j = 0; j < counts_[k]; ++j) tau_(offsets_[k] + j) = nominal.Tau(k, j);
  }

  // Pi of terminal_event depends only on the nominal's last sample: once per Run, not per sweep.
  terminal_projected_ = settings_.terminal_event && EventProjection(K_ - 1, nominal);
  const bool cyclic = settings_.cyclic_value > 0 && riccati() &&
                      problem_->system->has_cycle_reset();
  if (!cyclic) {
    Sweep(nominal, du_prev, false);
    sweeps_ = 1;
    valid_ = true;
    return;
  }
  const int n0 = dims_[0];
  const int nK = dims_[K_ - 1];
  {
    const ModeTrajectory& last = nominal.modes[K_ - 1];
    problem_->system->ResetDerivative(K_ - 1, last.x.col(last.num_samples() - 1),
                                      cyclic_G_.topLeftCorner(n0, nK));
    if (terminal_projected_) {
      auto tmp = cyclic_tmp_.topLeftCorner(n0, nK);
      tmp.noalias() = cyclic_G_.topLeftCorner(n0, nK) * event_Pi_.topLeftCorner(nK, nK);
      cyclic_G_.topLeftCorner(n0, nK) = tmp;
    }
  }
  if (!cyclic_valid_) cyclic_P0_.topLeftCorner(n0, n0).setZero();
  sweeps_ = 0;
  for (int sweep = 0; sweep < std::max(1, settings_.cyclic_max_sweeps); ++sweep) {
    Sweep(nominal, du_prev, true);
    ++sweeps_;
    Eigen::Map<const Matrix> P0(P_store_.col(index(0, 0)).data(), n0 + K_, n0 + K_);
    const double change = (P0.topLeftCorner(n0, n0) - cyclic_P0_.topLeftCorner(n0, n0)).norm();
    const double size = P0.topLeftCorner(n0, n0).norm();
    cyclic_P0_.topLeftCorner(n0, n0) = P0.topLeftCorner(n0, n0);
    if (!std::isfinite(size)) break;
    if (change <= settings_.cyclic_tolerance * std::max(size, 1e-12)) break;
  }
  cyclic_valid_ = cyclic_P0_.topLeftCorner(n0, n0).allFinite();
  valid_ = true;
}

void BackwardPass::Sweep(const Trajectory& nominal, const Matrix* du_prev, bool cyclic) {
  Coefficients* hi = &coef_[0];
  Coefficients* lo = &coef_[1];
  for (int k = K_ - 1; k >= 0; --k) {
    const int n = dims_[k];
    const int nz = n + K_;
    const int N = counts_[k];
    // Terminal condition (k = K-1) or jump condition at tau = k+1 (pre-switch sample).
    auto z = z_.head(nz);
    z.head(n) = nominal.modes[k].x.col(N - 1);
    z.tail(K_) = nominal.T;
    auto phiz = phiz_.head(nz);
    auto phizz = phizz_.topLeftCorner(nz, nz);
    normalization_->SwitchingDerivatives(k, z, phiz, phizz);
    // terminal_event: the horizon ends at the plant's event t_e. A deviation dx at the
    // planned end moves the event by dt_e = -gamma_x dx / (gamma_x f); to first order the
    // cost changes by Phi_x (dx + f dt_e) + l dt_e, so
    //   p_x(K) = Pi^T Phi_x - (l / gamma_x f) gamma_x,   P_xx(K) = Pi^T Phi_xx Pi.
    if (k == K_ - 1 && terminal_projected_) {
      auto Pi = event_Pi_.topLeftCorner(n, n);
      auto tmp = event_tmp_.topLeftCorner(n, n);
      tmp.noalias() = phizz.topLeftCorner(n, n) * Pi;
      phizz.topLeftCorner(n, n).noalias() = Pi.transpose() * tmp;
      auto v = event_f_.head(n);  // f is no longer needed: scratch for Pi^T Phi_x
      v.noalias() = Pi.transpose() * phiz.head(n);
      phiz.head(n) = v - event_cost_rate_ * event_hx_.head(n);
    }
    if (settings_.psd_switching_hessians) {
      const Matrix sym = 0.5 * (phizz + phizz.transpose());
      Eigen::SelfAdjointEigenSolver<Matrix> eig(sym);
      phizz = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() *
              eig.eigenvectors().transpose();
    }
    if (k == K_ - 1) {
      P_.topLeftCorner(nz, nz) = phizz;
      p_.head(nz) = phiz;
      if (cyclic) {  // + gamma_c G^T P_0 G: the value of the next cycle
        const int n0 = dims_[0];
        auto G = cyclic_G_.topLeftCorner(n0, n);
        auto tmp = cyclic_tmp_.topLeftCorner(n0, n);
        tmp.noalias() = cyclic_P0_.topLeftCorner(n0, n0) * G;
        P_.topLeftCorner(n, n).noalias() += settings_.cyclic_value * (G.transpose() * tmp);
      }
    } else {
      const int nzn = dims_[k + 1] + K_;
      auto Gz = Gz_.topLeftCorner(nzn, nz);
      normalization_->ResetDerivative(k, z, Gz);
      Eigen::Map<const Matrix> Pplus(P_store_.col(index(k + 1, 0)).data(), nzn, nzn);
      Eigen::Map<const Vector> pplus(p_store_.col(index(k + 1, 0)).data(), nzn);
      auto tmp = tmp_.topLeftCorner(nzn, nz);
      tmp.noalias() = Pplus * Gz;
      P_.topLeftCorner(nz, nz) = phizz;
      P_.topLeftCorner(nz, nz).noalias() += Gz.transpose() * tmp;
      p_.head(nz) = phiz;
      p_.head(nz).noalias() += Gz.transpose() * pplus;
    }
    Evaluate(k, nominal, N - 1, du_prev, hi);
    StoreOutputs(k, N - 1, *hi);
    // Backward integration inside mode k.
    for (int j = N - 2; j >= 0; --j) {
      Evaluate(k, nominal, j, du_prev, lo);
      const double h = tau_(offsets_[k] + j + 1) - tau_(offsets_[k] + j);
      if (h > 0) {
        if (riccati()) {
          Step(n, nz, h, *hi, *lo, P_.topLeftCorner(nz, nz), p_.head(nz));
        } else {
          LyapunovStep(n, nz, h, *hi, *lo);
        }
      }
      StoreOutputs(k, j, *lo);
      std::swap(hi, lo);
    }
  }
}

bool BackwardPass::EventProjection(int k, const Trajectory& nominal) {
  const SwitchedSystem& sys = *problem_->system;
  const int n = dims_[k];
  const ModeTrajectory& mode = nominal.modes[k];
  const int last = mode.num_samples() - 1;
  auto hx = event_hx_.head(n);
  if (!sys.GuardGradient(k, mode.x.col(last), mode.u.col(last), hx)) return false;
  auto f = event_f_.head(n);
  sys.Flow(k, mode.x.col(last), mode.u.col(last), f);
  const double rate = hx.dot(f);  // d gamma / dt at the switch
  if (!(std::abs(rate) > 1e-9 * (hx.norm() * f.norm() + 1e-300))) return false;
  event_cost_rate_ = problem_->cost->Running(k, mode.x.col(last), mode.u.col(last)) / rate;
  auto Pi = event_Pi_.topLeftCorner(n, n);
  Pi.setIdentity();
  for (int j = 0; j < n; ++j) Pi.col(j) -= f * (hx(j) / rate);
  return true;
}

}  // namespace ddoc
