// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/linear_system.h"

#include <string>
#include <utility>

#include "check_finite.h"

namespace ddoc {
namespace {

std::string Shape(const Matrix& M) {
  return "(" + std::to_string(M.rows()) + ", " + std::to_string(M.cols()) + ")";
}

// The state sizes n_k of A, after checking the sizes of A, B and E.
std::vector<int> CheckedStateDims(const std::vector<Matrix>& A, const std::vector<Matrix>& B,
                                  const std::vector<Matrix>& E) {
  const size_t K = A.size();
  if (K == 0) throw InvalidArgument("LinearSystem: A has no modes");
  if (B.size() != K) {
    throw InvalidArgument("LinearSystem: " + std::to_string(B.size()) + " matrices B, expected " +
                          std::to_string(K) + " (one per mode)");
  }
  if (E.size() + 1 != K && E.size() != K) {
    throw InvalidArgument("LinearSystem: " + std::to_string(E.size()) + " matrices E, expected " +
                          std::to_string(K - 1) + " (resets) or " + std::to_string(K) +
                          " (with the cycle reset)");
  }
  std::vector<int> n;
  for (size_t k = 0; k < K; ++k) {
    const std::string i = "[" + std::to_string(k) + "]";
    if (A[k].rows() == 0 || A[k].rows() != A[k].cols()) {
      throw InvalidArgument("LinearSystem: A" + i + " is " + Shape(A[k]) +
                            ", expected square (n_k, n_k) with n_k > 0");
    }
    if (B[k].rows() != A[k].rows()) {
      // Name A[k] too: a wrong A[k] shows up as B[k]'s row count (issue 47).
      throw InvalidArgument("LinearSystem: A" + i + " and B" + i + " disagree on mode " +
                            std::to_string(k) + "'s state size: A" + i + " is " + Shape(A[k]) +
                            " and B" + i + " is " + Shape(B[k]) + ", expected (" +
                            std::to_string(A[k].rows()) + ", " + std::to_string(B[0].cols()) +
                            "); or A" + i + " should be (" + std::to_string(B[k].rows()) + ", " +
                            std::to_string(B[k].rows()) + ")");
    }
    if (B[k].cols() != B[0].cols()) {
      throw InvalidArgument("LinearSystem: B" + i + " is " + Shape(B[k]) + ", expected (" +
                            std::to_string(A[k].rows()) + ", " + std::to_string(B[0].cols()) +
                            ")");
    }
    internal::CheckFiniteEntries(A[k], "LinearSystem: A" + i);
    internal::CheckFiniteEntries(B[k], "LinearSystem: B" + i);
    n.push_back(static_cast<int>(A[k].rows()));
  }
  for (size_t k = 0; k < E.size(); ++k) {
    const Matrix& next = A[(k + 1) % K];
    if (E[k].rows() != next.rows() || E[k].cols() != A[k].rows()) {
      throw InvalidArgument("LinearSystem: E[" + std::to_string(k) + "] is " + Shape(E[k]) +
                            ", expected (" + std::to_string(next.rows()) + ", " +
                            std::to_string(A[k].rows()) + ")");
    }
    internal::CheckFiniteEntries(E[k], "LinearSystem: E[" + std::to_string(k) + "]");
  }
  return n;
}

}  // namespace

LinearSystem::LinearSystem(std::vector<Matrix> A, std::vector<Matrix> B, std::vector<Matrix> E)
    : SwitchedSystem(CheckedStateDims(A, B, E), B.empty() ? 0 : static_cast<int>(B[0].cols()), {},
                     E.size() == A.size()),
      A_(std::move(A)), B_(std::move(B)), E_(std::move(E)) {}

void LinearSystem::DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                          VectorRef xdot) const {
  xdot.noalias() = A(k) * x;
  if (u.size() > 0) xdot.noalias() += B(k) * u;
}

void LinearSystem::DoFlowDerivatives(int k, const ConstVectorRef&, const ConstVectorRef&,
                                     MatrixRef fx, MatrixRef fu) const {
  fx = A(k);
  fu = B(k);
}

void LinearSystem::DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const {
  x_next.noalias() = E(k) * x;  // SwitchedSystem::Reset rejects k = K-1 without a cycle reset
}

void LinearSystem::DoResetDerivative(int k, const ConstVectorRef&, MatrixRef gx) const {
  gx = E(k);
}

}  // namespace ddoc
