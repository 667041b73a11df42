// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/switched_system.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace ddoc {
namespace {

// Throws InvalidArgument "<where>(k=<k>): <what> has size <actual>, expected <expected>".
template <class V>
void CheckSize(const char* where, int k, const char* what, const V& v, Eigen::Index expected) {
  if (v.size() != expected) {
    std::ostringstream os;
    os << where << "(k=" << k << "): " << what << " has size " << v.size() << ", expected "
       << expected;
    throw InvalidArgument(os.str());
  }
}

template <class M>
void CheckShape(const char* where, int k, const char* what, const M& m, Eigen::Index rows,
                Eigen::Index cols) {
  if (m.rows() != rows || m.cols() != cols) {
    std::ostringstream os;
    os << where << "(k=" << k << "): " << what << " is " << m.rows() << "x" << m.cols()
       << ", expected " << rows << "x" << cols;
    throw InvalidArgument(os.str());
  }
}

template <class V>
void CheckFinite(const char* where, int k, const char* what, const V& v) {
  if (!v.allFinite()) {
    std::ostringstream os;
    os << where << "(k=" << k << "): " << what << " has a non-finite entry";
    for (Eigen::Index i = 0; i < v.size(); ++i) {
      if (!std::isfinite(v.data()[i])) {
        os << " at index " << i << " (" << v.data()[i] << ")";
        break;
      }
    }
    throw InvalidArgument(os.str());
  }
}

// Throws InvalidArgument "<where>(k=<k>): <what> has a non-finite entry at point j, index i".
void CheckFinitePoints(const char* where, int k, const char* what, const ConstMatrixRef& X) {
  if (X.allFinite()) return;
  for (Eigen::Index j = 0; j < X.cols(); ++j) {
    for (Eigen::Index i = 0; i < X.rows(); ++i) {
      if (!std::isfinite(X(i, j))) {
        std::ostringstream os;
        os << where << "(k=" << k << "): " << what << " has a non-finite entry at point " << j
           << ", index " << i << " (" << X(i, j) << ")";
        throw InvalidArgument(os.str());
      }
    }
  }
}

// The checks of a batch call on N = X.cols() points: X n x N, U m x N, both finite.
void CheckPoints(const char* where, int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                 Eigen::Index n, Eigen::Index m) {
  CheckShape(where, k, "X", X, n, X.cols());
  CheckShape(where, k, "U", U, m, X.cols());
  CheckFinitePoints(where, k, "X", X);
  CheckFinitePoints(where, k, "U", U);
}

}  // namespace

SwitchedSystem::SwitchedSystem(std::vector<int> state_dims, int input_dim,
                               std::vector<int> surface_dims, bool has_cycle_reset)
    : state_dims_(std::move(state_dims)),
      surface_dims_(std::move(surface_dims)),
      input_dim_(input_dim),
      has_cycle_reset_(has_cycle_reset) {
  if (state_dims_.empty()) {
    throw InvalidArgument("SwitchedSystem: empty mode sequence (K = 0), expected K >= 1 modes");
  }
  for (size_t k = 0; k < state_dims_.size(); ++k) {
    if (state_dims_[k] <= 0) {
      std::ostringstream os;
      os << "SwitchedSystem: state dimension n_" << k << " = " << state_dims_[k]
         << ", expected > 0";
      throw InvalidArgument(os.str());
    }
  }
  if (input_dim_ < 0) {
    std::ostringstream os;
    os << "SwitchedSystem: input dimension m = " << input_dim_ << ", expected >= 0";
    throw InvalidArgument(os.str());
  }
  if (surface_dims_.empty()) surface_dims_.assign(state_dims_.size(), 0);
  if (surface_dims_.size() != state_dims_.size()) {
    std::ostringstream os;
    os << "SwitchedSystem: surface_dims has " << surface_dims_.size() << " entries, expected K = "
       << state_dims_.size();
    throw InvalidArgument(os.str());
  }
  for (size_t k = 0; k < surface_dims_.size(); ++k) {
    if (surface_dims_[k] < 0) {
      std::ostringstream os;
      os << "SwitchedSystem: surface dimension s_" << k << " = " << surface_dims_[k]
         << ", expected >= 0";
      throw InvalidArgument(os.str());
    }
  }
}

int SwitchedSystem::state_dim(int k) const {
  if (k < 0 || k >= num_modes()) {
    std::ostringstream os;
    os << "SwitchedSystem::state_dim: mode k = " << k << " out of range [0, " << num_modes() << ")";
    throw InvalidArgument(os.str());
  }
  return state_dims_[k];
}

int SwitchedSystem::surface_dim(int k) const {
  if (k < 0 || k >= num_modes()) {
    std::ostringstream os;
    os << "SwitchedSystem::surface_dim: mode k = " << k << " out of range [0, " << num_modes()
       << ")";
    throw InvalidArgument(os.str());
  }
  return surface_dims_[k];
}

int SwitchedSystem::max_state_dim() const {
  return *std::max_element(state_dims_.begin(), state_dims_.end());
}

void SwitchedSystem::Flow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                          VectorRef xdot) const {
  const int n = state_dim(k);
  CheckSize("Flow", k, "x", x, n);
  CheckSize("Flow", k, "u", u, input_dim_);
  CheckSize("Flow", k, "xdot", xdot, n);
  CheckFinite("Flow", k, "x", x);
  CheckFinite("Flow", k, "u", u);
  DoFlow(k, x, u, xdot);
}

void SwitchedSystem::FlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                     MatrixRef fx, MatrixRef fu) const {
  const int n = state_dim(k);
  CheckSize("FlowDerivatives", k, "x", x, n);
  CheckSize("FlowDerivatives", k, "u", u, input_dim_);
  CheckShape("FlowDerivatives", k, "fx", fx, n, n);
  CheckShape("FlowDerivatives", k, "fu", fu, n, input_dim_);
  CheckFinite("FlowDerivatives", k, "x", x);
  CheckFinite("FlowDerivatives", k, "u", u);
  DoFlowDerivatives(k, x, u, fx, fu);
}

void SwitchedSystem::FlowBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                               MatrixRef F) const {
  const int n = state_dim(k);
  CheckPoints("FlowBatch", k, X, U, n, input_dim_);
  CheckShape("FlowBatch", k, "F", F, n, X.cols());
  DoFlowBatch(k, X, U, F);
}

void SwitchedSystem::FlowDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                          MatrixRef FX, MatrixRef FU) const {
  const int n = state_dim(k);
  CheckPoints("FlowDerivativesBatch", k, X, U, n, input_dim_);
  CheckShape("FlowDerivativesBatch", k, "FX", FX, n, n * X.cols());
  CheckShape("FlowDerivativesBatch", k, "FU", FU, n, input_dim_ * X.cols());
  DoFlowDerivativesBatch(k, X, U, FX, FU);
}

void SwitchedSystem::DoFlowBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                 MatrixRef F) const {
  for (Eigen::Index j = 0; j < X.cols(); ++j) DoFlow(k, X.col(j), U.col(j), F.col(j));
}

void SwitchedSystem::DoFlowDerivativesBatch(int k, const ConstMatrixRef& X,
                                            const ConstMatrixRef& U, MatrixRef FX,
                                            MatrixRef FU) const {
  const Eigen::Index n = X.rows(), m = U.rows();
  for (Eigen::Index j = 0; j < X.cols(); ++j) {
    DoFlowDerivatives(k, X.col(j), U.col(j), FX.middleCols(j * n, n), FU.middleCols(j * m, m));
  }
}

void SwitchedSystem::Reset(int k, const ConstVectorRef& x, VectorRef x_next) const {
  const int n = state_dim(k);
  const int kn = (k + 1) % num_modes();
  if (k == num_modes() - 1 && !has_cycle_reset_) {
    throw InvalidArgument("Reset(k=" + std::to_string(k) +
                          "): the last mode has no cycle reset (has_cycle_reset() == false)");
  }
  CheckSize("Reset", k, "x", x, n);
  CheckSize("Reset", k, "x_next", x_next, state_dims_[kn]);
  CheckFinite("Reset", k, "x", x);
  DoReset(k, x, x_next);
}

void SwitchedSystem::ResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const {
  const int n = state_dim(k);
  const int kn = (k + 1) % num_modes();
  if (k == num_modes() - 1 && !has_cycle_reset_) {
    throw InvalidArgument("ResetDerivative(k=" + std::to_string(k) +
                          "): the last mode has no cycle reset (has_cycle_reset() == false)");
  }
  CheckSize("ResetDerivative", k, "x", x, n);
  CheckShape("ResetDerivative", k, "gx", gx, state_dims_[kn], n);
  CheckFinite("ResetDerivative", k, "x", x);
  DoResetDerivative(k, x, gx);
}

void SwitchedSystem::Surface(int k, const ConstVectorRef& x, VectorRef h) const {
  const int n = state_dim(k);
  const int s = surface_dims_[k];
  if (s == 0) {
    throw InvalidArgument("Surface(k=" + std::to_string(k) + "): mode has no switching surface (s_k = 0)");
  }
  CheckSize("Surface", k, "x", x, n);
  CheckSize("Surface", k, "h", h, s);
  CheckFinite("Surface", k, "x", x);
  DoSurface(k, x, h);
}

void SwitchedSystem::SurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const {
  const int n = state_dim(k);
  const int s = surface_dims_[k];
  if (s == 0) {
    throw InvalidArgument("SurfaceDerivative(k=" + std::to_string(k) +
                          "): mode has no switching surface (s_k = 0)");
  }
  CheckSize("SurfaceDerivative", k, "x", x, n);
  CheckShape("SurfaceDerivative", k, "hx", hx, s, n);
  CheckFinite("SurfaceDerivative", k, "x", x);
  DoSurfaceDerivative(k, x, hx);
}

bool SwitchedSystem::GuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                   VectorRef hx) const {
  const int n = state_dim(k);
  CheckSize("GuardGradient", k, "x", x, n);
  CheckSize("GuardGradient", k, "u", u, input_dim_);
  CheckSize("GuardGradient", k, "hx", hx, n);
  CheckFinite("GuardGradient", k, "x", x);
  CheckFinite("GuardGradient", k, "u", u);
  return DoGuardGradient(k, x, u, hx);
}

bool SwitchedSystem::DoGuardGradient(int, const ConstVectorRef&, const ConstVectorRef&,
                                     VectorRef) const {
  return false;
}

void SwitchedSystem::DoSurface(int k, const ConstVectorRef&, VectorRef) const {
  throw InvalidArgument("Surface(k=" + std::to_string(k) +
                        "): s_k > 0 but the system does not implement DoSurface");
}

void SwitchedSystem::DoSurfaceDerivative(int k, const ConstVectorRef&, MatrixRef) const {
  throw InvalidArgument("SurfaceDerivative(k=" + std::to_string(k) +
                        "): s_k > 0 but the system does not implement DoSurfaceDerivative");
}

// ----------------------------------------------------------------------------- SwitchedCost

double SwitchedCost::Running(int k, const ConstVectorRef& x, const ConstVectorRef& u) const {
  CheckFinite("Running", k, "x", x);
  CheckFinite("Running", k, "u", u);
  return DoRunning(k, x, u);
}

void SwitchedCost::RunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                      VectorRef lx, VectorRef lu, MatrixRef lxx, MatrixRef luu,
                                      MatrixRef lux) const {
  const Eigen::Index n = x.size(), m = u.size();
  CheckSize("RunningDerivatives", k, "lx", lx, n);
  CheckSize("RunningDerivatives", k, "lu", lu, m);
  CheckShape("RunningDerivatives", k, "lxx", lxx, n, n);
  CheckShape("RunningDerivatives", k, "luu", luu, m, m);
  CheckShape("RunningDerivatives", k, "lux", lux, m, n);
  CheckFinite("RunningDerivatives", k, "x", x);
  CheckFinite("RunningDerivatives", k, "u", u);
  DoRunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
}

double SwitchedCost::Switching(int k, const ConstVectorRef& x) const {
  CheckFinite("Switching", k, "x", x);
  return DoSwitching(k, x);
}

void SwitchedCost::SwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                                        MatrixRef phixx) const {
  const Eigen::Index n = x.size();
  CheckSize("SwitchingDerivatives", k, "phix", phix, n);
  CheckShape("SwitchingDerivatives", k, "phixx", phixx, n, n);
  CheckFinite("SwitchingDerivatives", k, "x", x);
  DoSwitchingDerivatives(k, x, phix, phixx);
}

void SwitchedCost::RunningBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                VectorRef l) const {
  CheckPoints("RunningBatch", k, X, U, X.rows(), U.rows());
  CheckSize("RunningBatch", k, "l", l, X.cols());
  DoRunningBatch(k, X, U, l);
}

void SwitchedCost::RunningDerivativesBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                           MatrixRef LX, MatrixRef LU, MatrixRef LXX,
                                           MatrixRef LUU, MatrixRef LUX) const {
  const Eigen::Index n = X.rows(), m = U.rows(), N = X.cols();
  CheckPoints("RunningDerivativesBatch", k, X, U, n, m);
  CheckShape("RunningDerivativesBatch", k, "LX", LX, n, N);
  CheckShape("RunningDerivativesBatch", k, "LU", LU, m, N);
  CheckShape("RunningDerivativesBatch", k, "LXX", LXX, n, n * N);
  CheckShape("RunningDerivativesBatch", k, "LUU", LUU, m, m * N);
  CheckShape("RunningDerivativesBatch", k, "LUX", LUX, m, n * N);
  DoRunningDerivativesBatch(k, X, U, LX, LU, LXX, LUU, LUX);
}

void SwitchedCost::DoRunningBatch(int k, const ConstMatrixRef& X, const ConstMatrixRef& U,
                                  VectorRef l) const {
  for (Eigen::Index j = 0; j < X.cols(); ++j) l(j) = DoRunning(k, X.col(j), U.col(j));
}

void SwitchedCost::DoRunningDerivativesBatch(int k, const ConstMatrixRef& X,
                                             const ConstMatrixRef& U, MatrixRef LX, MatrixRef LU,
                                             MatrixRef LXX, MatrixRef LUU, MatrixRef LUX) const {
  const Eigen::Index n = X.rows(), m = U.rows();
  for (Eigen::Index j = 0; j < X.cols(); ++j) {
    DoRunningDerivatives(k, X.col(j), U.col(j), LX.col(j), LU.col(j), LXX.middleCols(j * n, n),
                         LUU.middleCols(j * m, m), LUX.middleCols(j * n, n));
  }
}

}  // namespace ddoc
