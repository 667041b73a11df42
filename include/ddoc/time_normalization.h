// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Time normalization (12)-(17): the free-switching-time problem (9)-(10) as a fixed-time
// problem in tau in [0, K] with the augmented state z = [x; T].
#ifndef DDOC_TIME_NORMALIZATION_H_
#define DDOC_TIME_NORMALIZATION_H_

#include "ddoc/problem.h"

namespace ddoc {

/// The normalized model of one problem (zero-based modes, T_{-1} = 0, D_k = T_k - T_{k-1}):
///
///   tau = k + (t - T_{k-1}) / D_k,  tau in [k, k+1]                                 (12)
///   z = [x; T] in R^{n_k + K}                                                        (13)
///   F_k(z, u) = [D_k f_k(x, u); 0]                                                   (14)
///   G_k(z)    = [g_k(x); T]                    (R^{n_k+K} -> R^{n_{k+1}+K})          (15)
///   Phi_k(z)  = phi_k(x) + w_k ||h_k(x)||^2    (8), (16)
///   L_k(z, u) = D_k l_k(x, u)                                                        (17)
///
/// The T-dependence enters only through D_k: dF/dT_k = [f; 0], dF/dT_{k-1} = [-f; 0] (k > 0),
/// and the same for L. F has no second derivative in T alone, so L_TT = 0.
///
/// Phi_zz uses the Gauss-Newton Hessian 2 w h_x^T h_x of the surface penalty (the system API
/// has no h_xx); it is exact for affine h_k.
///
/// All methods are allocation-free after construction (buffers sized for n_max).
/// The output arguments must have the documented sizes (checked, InvalidArgument).
class TimeNormalization {
 public:
  /// Validates the problem. The problem must outlive this object.
  explicit TimeNormalization(const Problem& problem);

  /// n_k + K, the augmented state dimension of mode k.
  int augmented_dim(int k) const;
  /// D_k = T_k - T_{k-1} from z (T_{-1} = 0).
  double Duration(int k, const ConstVectorRef& z) const;

  /// F = F_k(z, u), size n_k + K.
  void Flow(int k, const ConstVectorRef& z, const ConstVectorRef& u, VectorRef F);
  /// Fz (n_k+K)^2 and Fu (n_k+K) x m.
  void FlowDerivatives(int k, const ConstVectorRef& z, const ConstVectorRef& u, MatrixRef Fz,
                       MatrixRef Fu);
  /// L_k(z, u).
  double Running(int k, const ConstVectorRef& z, const ConstVectorRef& u);
  /// Lz (n_k+K), Lu (m), Lzz (n_k+K)^2, Luu (m x m), Luz (m x (n_k+K)).
  void RunningDerivatives(int k, const ConstVectorRef& z, const ConstVectorRef& u, VectorRef Lz,
                          VectorRef Lu, MatrixRef Lzz, MatrixRef Luu, MatrixRef Luz);
  /// z_next = G_k(z), size n_{k+1} + K (k < K-1, or the cycle reset for k = K-1).
  void Reset(int k, const ConstVectorRef& z, VectorRef z_next);
  /// Gz = dG_k/dz = blockdiag(g_x, I_K), (n_{k+1}+K) x (n_k+K).
  void ResetDerivative(int k, const ConstVectorRef& z, MatrixRef Gz);
  /// Phi_k(z) = phi_k(x) + w_k ||h_k(x)||^2.
  double Switching(int k, const ConstVectorRef& z);
  /// Phiz (n_k+K) and Phizz (n_k+K)^2 (Gauss-Newton in the surface penalty).
  void SwitchingDerivatives(int k, const ConstVectorRef& z, VectorRef Phiz, MatrixRef Phizz);

 private:
  void CheckZ(const char* where, int k, const ConstVectorRef& z) const;

  const Problem* problem_;
  int K_ = 0;
  int m_ = 0;
  // Workspace, sized for n_max; used through top-left blocks.
  Vector f_;    // n_max
  Matrix fx_;   // n_max x n_max
  Matrix fu_;   // n_max x m
  Vector lx_;   // n_max
  Vector lu_;   // m
  Matrix lxx_;  // n_max x n_max
  Matrix luu_;  // m x m
  Matrix lux_;  // m x n_max
  Matrix gx_;   // n_max x n_max
  Vector h_;    // s_max
  Matrix hx_;   // s_max x n_max
};

}  // namespace ddoc

#endif  // DDOC_TIME_NORMALIZATION_H_
