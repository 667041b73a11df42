// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/hopper_cost.h"

#include <cmath>
#include <string>

#include "hopper_model_impl.h"

namespace ddoc {

namespace {

/// phi_1 as a templated functor of the stance state (for nested AutoDiff).
struct PeriodicityTerm {
  const HopperModel* model;
  const Eigen::Matrix<double, 14, 1>* q;
  const Eigen::Matrix<double, 14, 1>* ref;
  template <typename T>
  T operator()(const Eigen::Matrix<T, 10, 1>& xs) const {
    Eigen::Matrix<T, 14, 1> xf;
    model->TakeoffReset<T>(xs, T(0.0), &xf);
    T sum(0.0);
    for (int i = 0; i < 14; ++i) {
      if ((*q)(i) == 0.0) continue;
      const T d = xf(i) - (*ref)(i);
      sum += (*q)(i) * d * d;
    }
    return sum;
  }
};

/// phi_0 as a templated functor of the flight state.
struct EnergyTerm {
  const HopperModel* model;
  double weight;
  template <typename T>
  T operator()(const Eigen::Matrix<T, 14, 1>& x) const {
    return weight * model->EnergyLoss<T>(x);
  }
};

}  // namespace

HopperCost::HopperCost(const HopperModel& model, const HopperCostWeights& weights)
    : model_(model), weights_(weights) {
  for (int i = 0; i < 14; ++i) {
    if (!(weights_.q_diag(i) >= 0.0) || !std::isfinite(weights_.q_diag(i))) {
      throw InvalidArgument("HopperCost: q_diag(" + std::to_string(i) + ") = " +
                            std::to_string(weights_.q_diag(i)) + ", expected finite >= 0");
    }
  }
  for (int i = 0; i < 4; ++i) {
    if (!(weights_.r_diag(i) > 0.0) || !std::isfinite(weights_.r_diag(i))) {
      throw InvalidArgument("HopperCost: r_diag(" + std::to_string(i) + ") = " +
                            std::to_string(weights_.r_diag(i)) + ", expected finite > 0");
    }
  }
  if (!(weights_.energy_weight >= 0.0) || !(weights_.surface_weight >= 0.0)) {
    throw InvalidArgument("HopperCost: energy_weight and surface_weight must be >= 0");
  }
}

void HopperCost::SetReference(const ConstVectorRef& x0_flight) {
  if (x0_flight.size() != hopper::kFlightDim || !x0_flight.allFinite()) {
    throw InvalidArgument("HopperCost::SetReference: x0 has size " +
                          std::to_string(x0_flight.size()) + ", expected 14 finite values");
  }
  x_ref_ = x0_flight;
}

double HopperCost::InputCost(const ConstVectorRef& u) const {
  return 0.5 * (weights_.r_diag.array() * u.array().square()).sum();
}

HopperCostTerms HopperCost::Terms(const ConstVectorRef& x_td, const ConstVectorRef& x_to,
                                  double effort_integral) const {
  if (x_td.size() != hopper::kFlightDim || x_to.size() != hopper::kStanceDim) {
    throw InvalidArgument("HopperCost::Terms: x_td has size " + std::to_string(x_td.size()) +
                          " (expected 14), x_to has size " + std::to_string(x_to.size()) +
                          " (expected 10)");
  }
  HopperCostTerms t;
  t.i1 = Switching(hopper::kStance, x_to);
  t.i2 = effort_integral;
  t.i3 = Switching(hopper::kFlight, x_td);
  const double yf = model_.FootClearance(x_td);  // the foot height on a level floor
  t.i4 = weights_.surface_weight * yf * yf;
  return t;
}

double HopperCost::DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const {
  (void)k;
  (void)x;
  return InputCost(u);
}

void HopperCost::DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                      VectorRef lx, VectorRef lu, MatrixRef lxx, MatrixRef luu,
                                      MatrixRef lux) const {
  (void)k;
  (void)x;
  lx.setZero();
  lxx.setZero();
  lux.setZero();
  lu = weights_.r_diag.cwiseProduct(Eigen::Vector4d(u));
  luu.setZero();
  luu.diagonal() = weights_.r_diag;
}

double HopperCost::DoSwitching(int k, const ConstVectorRef& x) const {
  if (k == hopper::kFlight) {
    const Eigen::Matrix<double, 14, 1> xx = x;
    return weights_.energy_weight * model_.EnergyLoss<double>(xx);
  }
  const Eigen::Matrix<double, 10, 1> xs = x;
  return PeriodicityTerm{&model_, &weights_.q_diag, &x_ref_}(xs);
}

void HopperCost::DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                                        MatrixRef phixx) const {
  if (k == hopper::kFlight) {
    const Eigen::Matrix<double, 14, 1> xx = x;
    Eigen::Matrix<double, 14, 1> g;
    Eigen::Matrix<double, 14, 14> h;
    hopper_detail::GradientHessian<14>(EnergyTerm{&model_, weights_.energy_weight}, xx, &g, &h);
    phix = g;
    phixx = h;
  } else {
    const Eigen::Matrix<double, 10, 1> xs = x;
    Eigen::Matrix<double, 10, 1> g;
    Eigen::Matrix<double, 10, 10> h;
    hopper_detail::GradientHessian<10>(PeriodicityTerm{&model_, &weights_.q_diag, &x_ref_}, xs,
                                       &g, &h);
    phix = g;
    phixx = h;
  }
}

}  // namespace ddoc
