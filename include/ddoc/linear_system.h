// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A linear switched system given by matrices.
#ifndef DDOC_LINEAR_SYSTEM_H_
#define DDOC_LINEAR_SYSTEM_H_

#include <vector>

#include "ddoc/switched_system.h"

namespace ddoc {

/// xdot = A_k x + B_k u in mode k and x+ = E_k x at its end: K matrices A_k (n_k x n_k), K
/// matrices B_k (n_k x m, m >= 0 the same in every mode), K - 1 resets E_k (n_{k+1} x n_k), or
/// K with E_{K-1} (n_0 x n_{K-1}) as the cycle reset. No switching surfaces.
class LinearSystem : public SwitchedSystem {
 public:
  /// Throws InvalidArgument naming the matrix whose size is wrong or that has a non-finite entry.
  LinearSystem(std::vector<Matrix> A, std::vector<Matrix> B, std::vector<Matrix> E);

  const Matrix& A(int k) const { return A_[static_cast<size_t>(k)]; }
  const Matrix& B(int k) const { return B_[static_cast<size_t>(k)]; }
  const Matrix& E(int k) const { return E_[static_cast<size_t>(k)]; }

 protected:
  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override;
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override;
  void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const override;
  void DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const override;

 private:
  std::vector<Matrix> A_, B_, E_;
};

}  // namespace ddoc

#endif  // DDOC_LINEAR_SYSTEM_H_
