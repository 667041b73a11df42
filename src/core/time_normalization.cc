// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/time_normalization.h"

#include <sstream>

namespace ddoc {
namespace {

template <class M>
void CheckShape(const char* where, int k, const char* what, const M& m, Eigen::Index rows,
                Eigen::Index cols) {
  if (m.rows() != rows || m.cols() != cols) {
    std::ostringstream os;
    os << "TimeNormalization::" << where << "(k=" << k << "): " << what << " is " << m.rows()
       << "x" << m.cols() << ", expected " << rows << "x" << cols;
    throw InvalidArgument(os.str());
  }
}

}  // namespace

TimeNormalization::TimeNormalization(const Problem& problem) : problem_(&problem) {
  problem.Validate();
  const SwitchedSystem& sys = *problem.system;
  K_ = sys.num_modes();
  m_ = sys.input_dim();
  const int n = sys.max_state_dim();
  int s_max = 0;
  for (int k = 0; k < K_; ++k) s_max = std::max(s_max, sys.surface_dim(k));
  f_.resize(n);
  fx_.resize(n, n);
  fu_.resize(n, m_);
  lx_.resize(n);
  lu_.resize(m_);
  lxx_.resize(n, n);
  luu_.resize(m_, m_);
  lux_.resize(m_, n);
  gx_.resize(n, n);
  h_.resize(std::max(s_max, 1));
  hx_.resize(std::max(s_max, 1), n);
}

int TimeNormalization::augmented_dim(int k) const {
  return problem_->system->state_dim(k) + K_;
}

void TimeNormalization::CheckZ(const char* where, int k, const ConstVectorRef& z) const {
  const int nz = augmented_dim(k);
  if (z.size() != nz) {
    std::ostringstream os;
    os << "TimeNormalization::" << where << "(k=" << k << "): z has size " << z.size()
       << ", expected n_k + K = " << nz;
    throw InvalidArgument(os.str());
  }
}

double TimeNormalization::Duration(int k, const ConstVectorRef& z) const {
  const int n = problem_->system->state_dim(k);
  const double start = k == 0 ? 0.0 : z(n + k - 1);
  return z(n + k) - start;
}

void TimeNormalization::Flow(int k, const ConstVectorRef& z, const ConstVectorRef& u,
                             VectorRef F) {
  CheckZ("Flow", k, z);
  const int n = problem_->system->state_dim(k);
  CheckShape("Flow", k, "F", F, n + K_, 1);
  auto f = f_.head(n);
  problem_->system->Flow(k, z.head(n), u, f);
  F.head(n) = Duration(k, z) * f;
  F.tail(K_).setZero();
}

void TimeNormalization::FlowDerivatives(int k, const ConstVectorRef& z, const ConstVectorRef& u,
                                        MatrixRef Fz, MatrixRef Fu) {
  CheckZ("FlowDerivatives", k, z);
  const int n = problem_->system->state_dim(k);
  const int nz = n + K_;
  CheckShape("FlowDerivatives", k, "Fz", Fz, nz, nz);
  CheckShape("FlowDerivatives", k, "Fu", Fu, nz, m_);
  auto f = f_.head(n);
  auto fx = fx_.topLeftCorner(n, n);
  auto fu = fu_.topRows(n);
  const SwitchedSystem& sys = *problem_->system;
  sys.Flow(k, z.head(n), u, f);
  sys.FlowDerivatives(k, z.head(n), u, fx, fu);
  const double D = Duration(k, z);
  Fz.setZero();
  Fz.topLeftCorner(n, n) = D * fx;
  Fz.col(n + k).head(n) = f;                 // dF/dT_k = [f; 0]
  if (k > 0) Fz.col(n + k - 1).head(n) = -f;  // dF/dT_{k-1} = [-f; 0]
  Fu.setZero();
  Fu.topRows(n) = D * fu;
}

double TimeNormalization::Running(int k, const ConstVectorRef& z, const ConstVectorRef& u) {
  CheckZ("Running", k, z);
  const int n = problem_->system->state_dim(k);
  return Duration(k, z) * problem_->cost->Running(k, z.head(n), u);
}

void TimeNormalization::RunningDerivatives(int k, const ConstVectorRef& z,
                                           const ConstVectorRef& u, VectorRef Lz, VectorRef Lu,
                                           MatrixRef Lzz, MatrixRef Luu, MatrixRef Luz) {
  CheckZ("RunningDerivatives", k, z);
  const int n = problem_->system->state_dim(k);
  const int nz = n + K_;
  CheckShape("RunningDerivatives", k, "Lz", Lz, nz, 1);
  CheckShape("RunningDerivatives", k, "Lu", Lu, m_, 1);
  CheckShape("RunningDerivatives", k, "Lzz", Lzz, nz, nz);
  CheckShape("RunningDerivatives", k, "Luu", Luu, m_, m_);
  CheckShape("RunningDerivatives", k, "Luz", Luz, m_, nz);
  const SwitchedCost& cost = *problem_->cost;
  auto lx = lx_.head(n);
  auto lxx = lxx_.topLeftCorner(n, n);
  auto lux = lux_.leftCols(n);
  const double l = cost.Running(k, z.head(n), u);
  cost.RunningDerivatives(k, z.head(n), u, lx, lu_, lxx, luu_, lux);
  const double D = Duration(k, z);
  Lz.head(n) = D * lx;
  Lz.tail(K_).setZero();
  Lz(n + k) = l;
  if (k > 0) Lz(n + k - 1) = -l;
  Lu = D * lu_;
  Lzz.setZero();
  Lzz.topLeftCorner(n, n) = D * lxx;
  Lzz.col(n + k).head(n) = lx;
  Lzz.row(n + k).head(n) = lx.transpose();
  if (k > 0) {
    Lzz.col(n + k - 1).head(n) = -lx;
    Lzz.row(n + k - 1).head(n) = -lx.transpose();
  }
  Luu = D * luu_;
  Luz.setZero();
  Luz.leftCols(n) = D * lux;
  Luz.col(n + k) = lu_;
  if (k > 0) Luz.col(n + k - 1) = -lu_;
}

void TimeNormalization::Reset(int k, const ConstVectorRef& z, VectorRef z_next) {
  CheckZ("Reset", k, z);
  const SwitchedSystem& sys = *problem_->system;
  const int n = sys.state_dim(k);
  const int nn = sys.state_dim((k + 1) % K_);
  CheckShape("Reset", k, "z_next", z_next, nn + K_, 1);
  sys.Reset(k, z.head(n), z_next.head(nn));
  z_next.tail(K_) = z.tail(K_);
}

void TimeNormalization::ResetDerivative(int k, const ConstVectorRef& z, MatrixRef Gz) {
  CheckZ("ResetDerivative", k, z);
  const SwitchedSystem& sys = *problem_->system;
  const int n = sys.state_dim(k);
  const int nn = sys.state_dim((k + 1) % K_);
  CheckShape("ResetDerivative", k, "Gz", Gz, nn + K_, n + K_);
  Gz.setZero();
  sys.ResetDerivative(k, z.head(n), Gz.topLeftCorner(nn, n));
  Gz.bottomRightCorner(K_, K_).setIdentity();
}

double TimeNormalization::Switching(int k, const ConstVectorRef& z) {
  CheckZ("Switching", k, z);
  const SwitchedSystem& sys = *problem_->system;
  const int n = sys.state_dim(k);
  double value = problem_->cost->Switching(k, z.head(n));
  const double w = problem_->SurfaceWeight(k);
  if (w > 0) {
    auto h = h_.head(sys.surface_dim(k));
    sys.Surface(k, z.head(n), h);
    value += w * h.squaredNorm();
  }
  return value;
}

void TimeNormalization::SwitchingDerivatives(int k, const ConstVectorRef& z, VectorRef Phiz,
                                             MatrixRef Phizz) {
  CheckZ("SwitchingDerivatives", k, z);
  const SwitchedSystem& sys = *problem_->system;
  const int n = sys.state_dim(k);
  const int nz = n + K_;
  CheckShape("SwitchingDerivatives", k, "Phiz", Phiz, nz, 1);
  CheckShape("SwitchingDerivatives", k, "Phizz", Phizz, nz, nz);
  Phiz.setZero();
  Phizz.setZero();
  problem_->cost->SwitchingDerivatives(k, z.head(n), Phiz.head(n), Phizz.topLeftCorner(n, n));
  const double w = problem_->SurfaceWeight(k);
  if (w > 0) {
    const int s = sys.surface_dim(k);
    auto h = h_.head(s);
    auto hx = hx_.topLeftCorner(s, n);
    sys.Surface(k, z.head(n), h);
    sys.SurfaceDerivative(k, z.head(n), hx);
    Phiz.head(n).noalias() += 2.0 * w * hx.transpose() * h;
    Phizz.topLeftCorner(n, n).noalias() += 2.0 * w * hx.transpose() * hx;  // Gauss-Newton
  }
}

}  // namespace ddoc
