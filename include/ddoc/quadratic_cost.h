// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A quadratic tracking cost given by matrices.
#ifndef DDOC_QUADRATIC_COST_H_
#define DDOC_QUADRATIC_COST_H_

#include <vector>

#include "ddoc/switched_system.h"

namespace ddoc {

/// l_k = 1/2 (x - r_k)' Q_k (x - r_k) + 1/2 u' R_k u + u' N_k (x - r_k) + rho_k and
/// phi_k = 1/2 (x - s_k)' S_k (x - s_k), one entry per mode in every list: Q_k, S_k n_k x n_k,
/// r_k, s_k of size n_k, R_k m x m (0 x 0 without inputs), N_k m x n_k (the input-state cross
/// term of OCS2's and the continuous-time LQR's costs; an empty list: N = 0). Q, R and S are
/// kept as their symmetric parts (the forms' values; a nonsymmetric Q gave Q x as the gradient
/// before), which must be positive semidefinite, and with N so must [Q N'; N R]. Derivatives
/// are exact; evaluation allocates nothing.
class QuadraticTrackingCost : public SwitchedCost {
 public:
  /// Throws InvalidArgument naming the entry whose size is wrong, that has a non-finite entry,
  /// or whose symmetric part has a negative eigenvalue (below -1e-12 max(1, max |entry|)); with
  /// N, also when [Q_k N_k'; N_k R_k] has one.
  QuadraticTrackingCost(std::vector<Matrix> Q, std::vector<Vector> r, std::vector<Matrix> R,
                        std::vector<double> rho, std::vector<Matrix> S, std::vector<Vector> s,
                        std::vector<Matrix> N = {});

  /// Modes the cost was built for (the length of every list).
  int num_modes() const override { return static_cast<int>(Q_.size()); }
  /// R_k (symmetric part), m x m.
  const Matrix& R(int k) const { return R_[static_cast<size_t>(k)]; }

 protected:
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override;
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override;
  double DoSwitching(int k, const ConstVectorRef& x) const override;
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override;

 private:
  // The cost does not know the system: a mode or size it was not built for is an error.
  void Check(int k, const ConstVectorRef& x, const ConstVectorRef* u) const;

  std::vector<Matrix> Q_, R_, S_, N_;  // N_ empty: no cross term
  std::vector<Vector> r_, s_;
  std::vector<double> rho_;
  std::vector<Vector> Qr_, Ss_, Nr_;  // Q_k r_k, S_k s_k, N_k r_k
};

}  // namespace ddoc

#endif  // DDOC_QUADRATIC_COST_H_
