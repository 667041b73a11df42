// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Template definitions of HopperModel's right-hand sides and resets (private to src/hopper), plus
// small fixed-size AutoDiff helpers. Included by hopper_model.cc and hopper_cost.cc only.
#ifndef DDOC_SRC_HOPPER_HOPPER_MODEL_IMPL_H_
#define DDOC_SRC_HOPPER_HOPPER_MODEL_IMPL_H_

#include <cmath>

#include <unsupported/Eigen/AutoDiff>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc {

template <typename T>
void HopperModel::FlightRhs(const Eigen::Matrix<T, 14, 1>& x, const Eigen::Matrix<T, 4, 1>& u,
                            Eigen::Matrix<T, 14, 1>* xdot) const {
  using namespace hopper;  // NOLINT
  using std::abs;
  const HopperParams& p = params_;
  T tau = u(kTau0) - x(kKhip) * (x(kPhi) - x(kTheta));
  if (p.b_hip != 0.0) tau -= p.b_hip * (x(kPhid) - x(kThetad));  // hip damper (0: the paper)
  const double b = p.beta;
  // Positions and stiffnesses integrate their rates.
  for (int i = 0; i < 7; ++i) (*xdot)(i) = x(7 + i);
  (*xdot)(kXd) = -(p.c_d / p.M) * x(kXd) * abs(x(kXd));
  (*xdot)(kYd) = -p.g - (p.c_d / p.M) * x(kYd) * abs(x(kYd));
  (*xdot)(kThetad) = -tau / p.J_leg;
  (*xdot)(kPhid) = tau / p.J_body;
  (*xdot)(kRd) = T(0.0) * x(kRd);
  (*xdot)(kKhipd) = b * b * (u(kK0hip) - x(kKhip)) - 2.0 * b * x(kKhipd);
  (*xdot)(kKlegd) = b * b * (u(kK0leg) - x(kKleg)) - 2.0 * b * x(kKlegd);
}

template <typename T>
void HopperModel::StanceRhs(const Eigen::Matrix<T, 10, 1>& x, const Eigen::Matrix<T, 4, 1>& u,
                            Eigen::Matrix<T, 10, 1>* xdot) const {
  using namespace hopper;  // NOLINT
  using std::cos;
  using std::sin;
  const HopperParams& p = params_;
  const T& th = x(kSTheta);
  const T& r = x(kSR);
  const T& thd = x(kSThetad);
  const T& rd = x(kSRd);
  T tau = u(kTau0) - x(kSKhip) * (x(kSPhi) - th);
  if (p.b_hip != 0.0) tau -= p.b_hip * (x(kSPhid) - thd);  // hip damper (0: the paper)
  T force = u(kF0) - x(kSKleg) * (r - p.r0);
  if (p.b_leg != 0.0) force -= p.b_leg * rd;  // leg damper (0: the paper)
  const double b = p.beta;
  for (int i = 0; i < 5; ++i) (*xdot)(i) = x(5 + i);
  (*xdot)(kSThetad) = (p.M * (r * p.g * sin(th) - 2.0 * r * rd * thd) - tau) /
                      (p.J_leg + p.M * r * r);
  (*xdot)(kSPhid) = tau / p.J_body;
  (*xdot)(kSRd) = r * thd * thd - p.g * cos(th) + force / p.M;
  (*xdot)(kSKhipd) = b * b * (u(kK0hip) - x(kSKhip)) - 2.0 * b * x(kSKhipd);
  (*xdot)(kSKlegd) = b * b * (u(kK0leg) - x(kSKleg)) - 2.0 * b * x(kSKlegd);
}

template <typename T>
void HopperModel::TouchdownReset(const Eigen::Matrix<T, 14, 1>& x,
                                 Eigen::Matrix<T, 10, 1>* xs) const {
  using namespace hopper;  // NOLINT
  using std::cos;
  using std::sin;
  const HopperParams& p = params_;
  const T& th = x(kTheta);
  const T c = cos(th);
  const T s = sin(th);
  const T v = x(kXd) * c + x(kYd) * s + x(kR) * x(kThetad);  // foot velocity normal to the leg
  T thd_plus;
  if (p.impact == ImpactModel::kMasslessLeg) {
    // Angular momentum about the foot is conserved: thd+ = thd - M r v / (J_leg + M r^2).
    thd_plus = x(kThetad) - p.M * x(kR) * v / (p.J_leg + p.M * x(kR) * x(kR));
  } else {
    // (40) as printed: eps = J_body / (J_body + M r0^2), theta row M r0 / J_body.
    thd_plus = x(kThetad) - p.M * p.r0 * v / (p.J_body + p.M * p.r0 * p.r0);
  }
  (*xs)(kSTheta) = th;
  (*xs)(kSPhi) = x(kPhi);
  (*xs)(kSR) = x(kR);
  (*xs)(kSKhip) = x(kKhip);
  (*xs)(kSKleg) = x(kKleg);
  (*xs)(kSThetad) = thd_plus;
  (*xs)(kSPhid) = x(kPhid);
  (*xs)(kSRd) = -x(kXd) * s + x(kYd) * c;  // the impulse is normal to the leg: rd is continuous
  (*xs)(kSKhipd) = x(kKhipd);
  (*xs)(kSKlegd) = x(kKlegd);
}

template <typename T>
void HopperModel::TakeoffReset(const Eigen::Matrix<T, 10, 1>& xs, const T& foot_x,
                               Eigen::Matrix<T, 14, 1>* x) const {
  using namespace hopper;  // NOLINT
  using std::cos;
  using std::sin;
  const T& th = xs(kSTheta);
  const T& r = xs(kSR);
  const T& thd = xs(kSThetad);
  const T& rd = xs(kSRd);
  const T c = cos(th);
  const T s = sin(th);
  (*x)(kX) = foot_x - r * s;
  (*x)(kY) = r * c;
  if (params_.slope != 0.0) (*x)(kY) += foot_x * std::tan(params_.slope);  // foot on the slope
  (*x)(kTheta) = th;
  (*x)(kPhi) = xs(kSPhi);
  (*x)(kR) = r;
  (*x)(kKhip) = xs(kSKhip);
  (*x)(kKleg) = xs(kSKleg);
  (*x)(kXd) = -rd * s - r * thd * c;
  (*x)(kYd) = rd * c - r * thd * s;
  (*x)(kThetad) = thd;
  (*x)(kPhid) = xs(kSPhid);
  (*x)(kRd) = T(0.0) * rd;  // the massless leg stops extending when it leaves the ground
  (*x)(kKhipd) = xs(kSKhipd);
  (*x)(kKlegd) = xs(kSKlegd);
}

template <typename T>
T HopperModel::Clearance(const Eigen::Matrix<T, 14, 1>& x) const {
  using namespace hopper;  // NOLINT
  using std::cos;
  using std::sin;
  const T yf = x(kY) - x(kR) * cos(x(kTheta));
  if (params_.slope == 0.0) return yf;  // the paper's level floor, bit for bit
  const T xf = x(kX) + x(kR) * sin(x(kTheta));
  return std::cos(params_.slope) * yf - std::sin(params_.slope) * xf;
}

template <typename T>
T HopperModel::EnergyLoss(const Eigen::Matrix<T, 14, 1>& x) const {
  using namespace hopper;  // NOLINT
  using std::cos;
  using std::sin;
  const HopperParams& p = params_;
  const T v = x(kXd) * cos(x(kTheta)) + x(kYd) * sin(x(kTheta)) + x(kR) * x(kThetad);
  if (p.impact == ImpactModel::kMasslessLeg) {
    // 1/2 M J_leg / (J_leg + M r^2) v^2
    return 0.5 * p.M * p.J_leg / (p.J_leg + p.M * x(kR) * x(kR)) * v * v;
  }
  // (41) as printed (v with r0 for the literal variant, as in the paper's v_f_theta).
  const T vl = x(kXd) * cos(x(kTheta)) + x(kYd) * sin(x(kTheta)) + p.r0 * x(kThetad);
  return 0.5 * p.M * p.J_body / (p.J_body + p.M * p.r0 * p.r0) * vl * vl;
}

namespace hopper_detail {

/// First-order fixed-size AutoDiff scalar with N directions.
template <int N>
using Ad = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;

/// Seeds a = x with derivative directions offset .. offset + size - 1 of N.
template <int N, int S, typename Derived>
void Seed(const Eigen::MatrixBase<Derived>& x, int offset, Eigen::Matrix<Ad<N>, S, 1>* a) {
  for (int i = 0; i < S; ++i) {
    (*a)(i).value() = x(i);
    (*a)(i).derivatives() = Eigen::Matrix<double, N, 1>::Unit(offset + i);
  }
}

/// Second-order (nested) fixed-size AutoDiff scalar for gradients and Hessians.
template <int N>
using Ad2 = Eigen::AutoDiffScalar<Eigen::Matrix<Ad<N>, N, 1>>;

/// value, gradient (N) and Hessian (N x N) of a scalar function f (templated functor) at x.
template <int N, typename F>
double GradientHessian(const F& f, const Eigen::Matrix<double, N, 1>& x,
                       Eigen::Matrix<double, N, 1>* grad, Eigen::Matrix<double, N, N>* hess) {
  Eigen::Matrix<Ad2<N>, N, 1> a;
  for (int i = 0; i < N; ++i) {
    a(i).value() = Ad<N>(x(i), Eigen::Matrix<double, N, 1>::Unit(i));
    for (int j = 0; j < N; ++j) {
      a(i).derivatives()(j) = Ad<N>(i == j ? 1.0 : 0.0, Eigen::Matrix<double, N, 1>::Zero());
    }
  }
  const Ad2<N> y = f(a);
  for (int i = 0; i < N; ++i) {
    (*grad)(i) = y.value().derivatives()(i);
    for (int j = 0; j < N; ++j) (*hess)(i, j) = y.derivatives()(i).derivatives()(j);
  }
  return y.value().value();
}

}  // namespace hopper_detail

}  // namespace ddoc

#endif  // DDOC_SRC_HOPPER_HOPPER_MODEL_IMPL_H_
