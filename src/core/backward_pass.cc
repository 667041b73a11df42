// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/backward_pass.h"

#include <sstream>

namespace ddoc {

void BackwardPass::Coefficients::Allocate(int n_max, int nz_max, int m) {
  A.setZero(n_max, nz_max);
  Q.setZero(nz_max, nz_max);
  Lz.setZero(nz_max);
  B.setZero(n_max, m);
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
  for (auto& c : coef_) c.Allocate(n_max_, nz_max_, m_);
  z_.setZero(nz_max_);
  phiz_.setZero(nz_max_);
  phizz_.setZero(nz_max_, nz_max_);
  Gz_.setZero(nz_max_, nz_max_);
  tmp_.setZero(nz_max_, nz_max_);
  Fz_.setZero(nz_max_, nz_max_);
  Fu_.setZero(nz_max_, m_);
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
  auto Fz = Fz_.topLeftCorner(nz, nz);
  auto Fu = Fu_.topRows(nz);
  normalization_->FlowDerivatives(k, z, u, Fz, Fu);
  c->A.topLeftCorner(n, nz) = Fz.topRows(n);
  c->B.topRows(n) = Fu.topRows(n);
  normalization_->RunningDerivatives(k, z, u, c->Lz.head(nz), c->Lu, c->Q.topLeftCorner(nz, nz),
                                     c->Luu, c->Luz.leftCols(nz));
  c->Lzu.topRows(nz) = c->Luz.leftCols(nz).transpose();
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
  const double mu =
      settings_.riccati_regularization * (1.0 + c->Luu.diagonal().cwiseAbs().maxCoeff());
  c->LuuInv.diagonal().array() += mu;
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

void BackwardPass::StoreOutputs(int k, int j, const Coefficients& c) {
  const int n = dims_[k];
  const int nz = n + K_;
  const int s = index(k, j);
  Eigen::Map<Matrix> Pout(P_store_.col(s).data(), nz, nz);
  Eigen::Map<Vector> pout(p_store_.col(s).data(), nz);
  Pout = P_.topLeftCorner(nz, nz);
  pout = p_.head(nz);
  Eigen::Map<Matrix> gain(gain_store_.col(s).data(), m_, nz);
  gain = c.Luz.leftCols(nz);
  gain.noalias() += c.B.topRows(n).transpose() * P_.topLeftCorner(n, nz);
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
    if (settings_.psd_switching_hessians) {
      const Matrix sym = 0.5 * (phizz + phizz.transpose());
      Eigen::SelfAdjointEigenSolver<Matrix> eig(sym);
      phizz = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() *
              eig.eigenvectors().transpose();
    }
    if (k == K_ - 1) {
      P_.topLeftCorner(nz, nz) = phizz;
      p_.head(nz) = phiz;
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
      if (h > 0) Step(n, nz, h, *hi, *lo, P_.topLeftCorner(nz, nz), p_.head(nz));
      StoreOutputs(k, j, *lo);
      std::swap(hi, lo);
    }
  }
  valid_ = true;
}

}  // namespace ddoc
