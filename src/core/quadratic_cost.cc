// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/quadratic_cost.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <utility>

#include "check_finite.h"

namespace ddoc {
namespace {

// 1/2 (a - c)' M (a - c) without temporaries (c empty: 0).
double HalfQuadraticForm(const Matrix& M, const ConstVectorRef& a, const Vector& c) {
  double v = 0;
  for (int j = 0; j < a.size(); ++j) {
    const double aj = a(j) - (c.size() > 0 ? c(j) : 0.0);
    for (int i = 0; i < a.size(); ++i) v += (a(i) - (c.size() > 0 ? c(i) : 0.0)) * M(i, j) * aj;
  }
  return 0.5 * v;
}

std::string Entry(const char* name, size_t k) {
  return std::string(name) + "[" + std::to_string(k) + "]";
}

void CheckSquare(const Matrix& M, Eigen::Index n, const std::string& name) {
  if (M.rows() != n || M.cols() != n) {
    throw InvalidArgument("QuadraticTrackingCost: " + name + " is " + std::to_string(M.rows()) +
                          " x " + std::to_string(M.cols()) + ", expected " + std::to_string(n) +
                          " x " + std::to_string(n));
  }
}

void CheckSize(const Vector& v, Eigen::Index n, const std::string& name) {
  if (v.size() != n) {
    throw InvalidArgument("QuadraticTrackingCost: " + name + " has size " +
                          std::to_string(v.size()) + ", expected " + std::to_string(n));
  }
}

// The form's value only sees the symmetric part; the derivatives Q x, Q are those of the form
// only for a symmetric Q. So the weights are kept as their symmetric parts, which must be
// positive semidefinite (else the problem has no minimum in the free directions).
Matrix SymmetricPsd(const Matrix& M, const std::string& name) {
  const Matrix sym = 0.5 * (M + M.transpose());
  if (sym.size() == 0) return sym;
  const double lowest = Eigen::SelfAdjointEigenSolver<Matrix>(sym, Eigen::EigenvaluesOnly)
                            .eigenvalues()
                            .minCoeff();
  const double scale = std::max(1.0, sym.cwiseAbs().maxCoeff());
  if (lowest < -1e-12 * scale) {
    std::ostringstream msg;
    msg << "QuadraticTrackingCost: " << name << " is not positive semidefinite (the smallest "
        << "eigenvalue of its symmetric part is " << lowest << ")";
    throw InvalidArgument(msg.str());
  }
  return sym;
}

}  // namespace

QuadraticTrackingCost::QuadraticTrackingCost(std::vector<Matrix> Q, std::vector<Vector> r,
                                             std::vector<Matrix> R, std::vector<double> rho,
                                             std::vector<Matrix> S, std::vector<Vector> s,
                                             std::vector<Matrix> N)
    : Q_(std::move(Q)), R_(std::move(R)), S_(std::move(S)), N_(std::move(N)), r_(std::move(r)),
      s_(std::move(s)), rho_(std::move(rho)) {
  const size_t K = Q_.size();
  if (K == 0 || r_.size() != K || R_.size() != K || rho_.size() != K || S_.size() != K ||
      s_.size() != K) {
    throw InvalidArgument("QuadraticTrackingCost: Q, r, R, rho, S, s have " +
                          std::to_string(Q_.size()) + ", " + std::to_string(r_.size()) + ", " +
                          std::to_string(R_.size()) + ", " + std::to_string(rho_.size()) + ", " +
                          std::to_string(S_.size()) + ", " + std::to_string(s_.size()) +
                          " entries, expected one per mode (K >= 1) in each");
  }
  if (!N_.empty() && N_.size() != K) {
    throw InvalidArgument("QuadraticTrackingCost: N has " + std::to_string(N_.size()) +
                          " entries, expected " + std::to_string(K) +
                          " (one per mode, as Q) or none (no cross term)");
  }
  for (size_t k = 0; k < K; ++k) {
    const Eigen::Index n = Q_[k].rows();
    CheckSquare(Q_[k], n, Entry("Q", k));
    CheckSize(r_[k], n, Entry("r", k));
    CheckSquare(R_[k], R_[0].rows(), Entry("R", k));
    CheckSquare(S_[k], n, Entry("S", k));
    CheckSize(s_[k], n, Entry("s", k));
    internal::CheckFiniteEntries(Q_[k], "QuadraticTrackingCost: " + Entry("Q", k));
    internal::CheckFiniteEntries(r_[k], "QuadraticTrackingCost: " + Entry("r", k));
    internal::CheckFiniteEntries(R_[k], "QuadraticTrackingCost: " + Entry("R", k));
    if (!std::isfinite(rho_[k])) {
      throw InvalidArgument("QuadraticTrackingCost: " + Entry("rho", k) + " is not finite");
    }
    internal::CheckFiniteEntries(S_[k], "QuadraticTrackingCost: " + Entry("S", k));
    internal::CheckFiniteEntries(s_[k], "QuadraticTrackingCost: " + Entry("s", k));
    Q_[k] = SymmetricPsd(Q_[k], Entry("Q", k));
    R_[k] = SymmetricPsd(R_[k], Entry("R", k));
    S_[k] = SymmetricPsd(S_[k], Entry("S", k));
    Qr_.push_back(Q_[k] * r_[k]);
    Ss_.push_back(S_[k] * s_[k]);
    if (!N_.empty()) {
      const Eigen::Index m = R_[k].rows();
      if (N_[k].rows() != m || N_[k].cols() != n) {
        throw InvalidArgument("QuadraticTrackingCost: " + Entry("N", k) + " is " +
                              std::to_string(N_[k].rows()) + " x " +
                              std::to_string(N_[k].cols()) + ", expected " + std::to_string(m) +
                              " x " + std::to_string(n) + " (m x n_k, as R[k] and Q[k])");
      }
      internal::CheckFiniteEntries(N_[k], "QuadraticTrackingCost: " + Entry("N", k));
      Matrix joint(n + m, n + m);
      joint << Q_[k], N_[k].transpose(), N_[k], R_[k];
      SymmetricPsd(joint, "[Q N'; N R][" + std::to_string(k) + "]");
      Nr_.push_back(N_[k] * r_[k]);
    }
  }
}

void QuadraticTrackingCost::Check(int k, const ConstVectorRef& x, const ConstVectorRef* u) const {
  if (k < 0 || k >= static_cast<int>(Q_.size())) {
    throw InvalidArgument("QuadraticTrackingCost: mode k=" + std::to_string(k) + ", but Q has " +
                          std::to_string(Q_.size()) + " entries (one per mode)");
  }
  const auto kk = static_cast<size_t>(k);
  if (x.size() != Q_[kk].rows() || (u != nullptr && u->size() != R_[kk].rows())) {
    throw InvalidArgument("QuadraticTrackingCost(k=" + std::to_string(k) + "): x has size " +
                          std::to_string(x.size()) + " and u size " +
                          std::to_string(u ? u->size() : 0) + ", Q[k] is " +
                          std::to_string(Q_[kk].rows()) + " x " + std::to_string(Q_[kk].rows()) +
                          " and R[k] " + std::to_string(R_[kk].rows()) + " x " +
                          std::to_string(R_[kk].rows()));
  }
}

double QuadraticTrackingCost::DoRunning(int k, const ConstVectorRef& x,
                                        const ConstVectorRef& u) const {
  Check(k, x, &u);
  double cross = 0;
  if (!N_.empty()) {
    for (int j = 0; j < x.size(); ++j) {
      const double dx = x(j) - r_[k](j);
      for (int i = 0; i < u.size(); ++i) cross += u(i) * N_[k](i, j) * dx;
    }
  }
  return HalfQuadraticForm(Q_[k], x, r_[k]) + HalfQuadraticForm(R_[k], u, Vector()) + cross +
         rho_[k];
}

void QuadraticTrackingCost::DoRunningDerivatives(int k, const ConstVectorRef& x,
                                                 const ConstVectorRef& u, VectorRef lx,
                                                 VectorRef lu, MatrixRef lxx, MatrixRef luu,
                                                 MatrixRef lux) const {
  Check(k, x, &u);
  lx.noalias() = Q_[k] * x;
  lx -= Qr_[k];
  if (u.size() > 0) lu.noalias() = R_[k] * u;
  lxx = Q_[k];
  luu = R_[k];
  if (N_.empty()) {
    lux.setZero();
  } else {
    // d/dx u' N (x - r) = N' u, d/du = N (x - r), d2/dudx = N.
    lx.noalias() += N_[k].transpose() * u;
    if (u.size() > 0) {
      lu.noalias() += N_[k] * x;
      lu -= Nr_[k];
    }
    lux = N_[k];
  }
}

double QuadraticTrackingCost::DoSwitching(int k, const ConstVectorRef& x) const {
  Check(k, x, nullptr);
  return HalfQuadraticForm(S_[k], x, s_[k]);
}

void QuadraticTrackingCost::DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                                                   MatrixRef phixx) const {
  Check(k, x, nullptr);
  phix.noalias() = S_[k] * x;
  phix -= Ss_[k];
  phixx = S_[k];
}

}  // namespace ddoc
