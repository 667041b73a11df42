// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/hopper_model.h"

#include <cmath>
#include <sstream>
#include <string>

#include "hopper_model_impl.h"

namespace ddoc {

namespace hopper {

Eigen::Vector4d InputLowerBound() { return Eigen::Vector4d(-4.0, -4.0, 10.0, 1780.0); }
Eigen::Vector4d InputUpperBound() { return Eigen::Vector4d(4.0, 4.0, 150.0, 2350.0); }

}  // namespace hopper

namespace {

void CheckPositive(const char* name, double value, bool allow_zero = false) {
  const bool ok = std::isfinite(value) && (allow_zero ? value >= 0.0 : value > 0.0);
  if (!ok) {
    std::ostringstream os;
    os << "HopperParams: " << name << " = " << value << ", expected a finite value "
       << (allow_zero ? ">= 0" : "> 0");
    throw InvalidArgument(os.str());
  }
}

}  // namespace

void HopperParams::Validate() const {
  CheckPositive("M", M);
  CheckPositive("J_body", J_body);
  CheckPositive("J_leg", J_leg);
  CheckPositive("r0", r0);
  CheckPositive("c_d", c_d, /*allow_zero=*/true);
  CheckPositive("beta", beta);
  CheckPositive("g", g);
  CheckPositive("b_leg", b_leg, /*allow_zero=*/true);
  CheckPositive("b_hip", b_hip, /*allow_zero=*/true);
  if (!(std::abs(slope) < kMaxSlope)) {
    std::ostringstream os;
    os << "HopperParams: slope = " << slope << " rad, expected a finite value with |slope| < "
       << kMaxSlope << " rad";
    throw InvalidArgument(os.str());
  }
}

void HopperParams::CheckRk4Step(double dt, const std::string& who) const {
  Validate();
  const double k_hip = hopper::InputUpperBound()(2), k_leg = hopper::InputUpperBound()(3);
  // RK4 is stable for an undamped oscillator while omega dt < 2 sqrt(2), and for a real
  // eigenvalue -lambda while lambda dt < 2.785.
  struct Motion {
    double rate;
    double limit;
    const char* what;
  };
  const Motion motions[] = {
      {std::sqrt(k_hip * (1.0 / J_leg + 1.0 / J_body)), 2.0 * std::sqrt(2.0),
       "sqrt(k_hip (1/J_leg + 1/J_body)) * dt, the flight hip spring at k_hip = 150 N m/rad,"},
      {std::sqrt(k_leg / M), 2.0 * std::sqrt(2.0),
       "sqrt(k_leg / M) * dt, the stance leg spring at k_leg = 2350 N/m,"},
      {beta, 2.785, "beta * dt, the VSA stiffness response,"}};
  for (const Motion& mo : motions) {
    if (!(mo.rate * dt < mo.limit)) {
      std::ostringstream msg;
      msg << who << ": the model (M = " << M << ", J_body = " << J_body << ", J_leg = " << J_leg
          << ", beta = " << beta << ") is too stiff for its RK4 step dt = " << dt << " s: "
          << mo.what << " is " << mo.rate * dt << ", RK4 is stable below " << mo.limit
          << " (dt below " << mo.limit / mo.rate << " s)";
      throw InvalidArgument(msg.str());
    }
  }
}

HopperModel::HopperModel(const HopperParams& params)
    : SwitchedSystem({hopper::kFlightDim, hopper::kStanceDim}, hopper::kInputDim, {1, 0},
                     /*has_cycle_reset=*/true),
      params_(params) {
  params_.Validate();
}

double HopperModel::ImpactRatio(double r) const {
  const HopperParams& p = params_;
  if (p.impact == ImpactModel::kMasslessLeg) return p.J_leg / (p.J_leg + p.M * r * r);
  return p.J_body / (p.J_body + p.M * p.r0 * p.r0);
}

double HopperModel::ImpactEnergyLoss(const ConstVectorRef& x_flight) const {
  if (x_flight.size() != hopper::kFlightDim) {
    throw InvalidArgument("ImpactEnergyLoss: x has size " + std::to_string(x_flight.size()) +
                          ", expected 14");
  }
  const Eigen::Matrix<double, 14, 1> x = x_flight;
  return EnergyLoss<double>(x);
}

double HopperModel::FootX(const ConstVectorRef& x) {
  return x(hopper::kX) + x(hopper::kR) * std::sin(x(hopper::kTheta));
}

double HopperModel::FootHeight(const ConstVectorRef& x) {
  return x(hopper::kY) - x(hopper::kR) * std::cos(x(hopper::kTheta));
}

double HopperModel::FootClearance(const ConstVectorRef& x_flight) const {
  if (x_flight.size() != hopper::kFlightDim) {
    throw InvalidArgument("FootClearance: x has size " + std::to_string(x_flight.size()) +
                          ", expected 14");
  }
  const Eigen::Matrix<double, 14, 1> x = x_flight;
  return Clearance<double>(x);
}

double HopperModel::Guard(int k, const ConstVectorRef& x, const ConstVectorRef& u) const {
  if (k < 0 || k > 1 || x.size() != state_dim(k) || u.size() != hopper::kInputDim) {
    std::ostringstream os;
    os << "HopperModel::Guard(k=" << k << "): x has size " << x.size() << ", u has size "
       << u.size() << ", expected k in {0,1}, x of size n_k, u of size 4";
    throw InvalidArgument(os.str());
  }
  if (k == hopper::kFlight) return FootClearance(x);
  double force = u(hopper::kF0) - x(hopper::kSKleg) * (x(hopper::kSR) - params_.r0);
  if (params_.b_leg != 0.0) force -= params_.b_leg * x(hopper::kSRd);
  return force;
}

void HopperModel::TakeoffMap(const ConstVectorRef& x_stance, double foot_x,
                             VectorRef x_flight) const {
  if (x_stance.size() != hopper::kStanceDim || x_flight.size() != hopper::kFlightDim) {
    throw InvalidArgument("TakeoffMap: x_stance has size " + std::to_string(x_stance.size()) +
                          " (expected 10), x_flight has size " +
                          std::to_string(x_flight.size()) + " (expected 14)");
  }
  const Eigen::Matrix<double, 10, 1> xs = x_stance;
  Eigen::Matrix<double, 14, 1> xf;
  TakeoffReset<double>(xs, foot_x, &xf);
  x_flight = xf;
}

void HopperModel::DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                         VectorRef xdot) const {
  const Eigen::Matrix<double, 4, 1> uu = u;
  if (k == hopper::kFlight) {
    const Eigen::Matrix<double, 14, 1> xx = x;
    Eigen::Matrix<double, 14, 1> f;
    FlightRhs<double>(xx, uu, &f);
    xdot = f;
  } else {
    const Eigen::Matrix<double, 10, 1> xx = x;
    Eigen::Matrix<double, 10, 1> f;
    StanceRhs<double>(xx, uu, &f);
    xdot = f;
  }
}

void HopperModel::DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                    MatrixRef fx, MatrixRef fu) const {
  using hopper_detail::Ad;
  using hopper_detail::Seed;
  if (k == hopper::kFlight) {
    constexpr int N = 18;  // 14 states + 4 inputs
    Eigen::Matrix<Ad<N>, 14, 1> xa;
    Eigen::Matrix<Ad<N>, 4, 1> ua;
    Seed<N, 14>(x, 0, &xa);
    Seed<N, 4>(u, 14, &ua);
    Eigen::Matrix<Ad<N>, 14, 1> f;
    FlightRhs<Ad<N>>(xa, ua, &f);
    for (int i = 0; i < 14; ++i) {
      fx.row(i) = f(i).derivatives().head<14>().transpose();
      fu.row(i) = f(i).derivatives().tail<4>().transpose();
    }
  } else {
    constexpr int N = 14;  // 10 states + 4 inputs
    Eigen::Matrix<Ad<N>, 10, 1> xa;
    Eigen::Matrix<Ad<N>, 4, 1> ua;
    Seed<N, 10>(x, 0, &xa);
    Seed<N, 4>(u, 10, &ua);
    Eigen::Matrix<Ad<N>, 10, 1> f;
    StanceRhs<Ad<N>>(xa, ua, &f);
    for (int i = 0; i < 10; ++i) {
      fx.row(i) = f(i).derivatives().head<10>().transpose();
      fu.row(i) = f(i).derivatives().tail<4>().transpose();
    }
  }
}

void HopperModel::DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const {
  if (k == hopper::kFlight) {
    const Eigen::Matrix<double, 14, 1> xx = x;
    Eigen::Matrix<double, 10, 1> xs;
    TouchdownReset<double>(xx, &xs);
    x_next = xs;
  } else {
    const Eigen::Matrix<double, 10, 1> xs = x;
    Eigen::Matrix<double, 14, 1> xf;
    TakeoffReset<double>(xs, 0.0, &xf);
    x_next = xf;
  }
}

void HopperModel::DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const {
  using hopper_detail::Ad;
  using hopper_detail::Seed;
  if (k == hopper::kFlight) {
    Eigen::Matrix<Ad<14>, 14, 1> xa;
    Seed<14, 14>(x, 0, &xa);
    Eigen::Matrix<Ad<14>, 10, 1> xs;
    TouchdownReset<Ad<14>>(xa, &xs);
    for (int i = 0; i < 10; ++i) gx.row(i) = xs(i).derivatives().transpose();
  } else {
    Eigen::Matrix<Ad<10>, 10, 1> xa;
    Seed<10, 10>(x, 0, &xa);
    Eigen::Matrix<Ad<10>, 14, 1> xf;
    TakeoffReset<Ad<10>>(xa, Ad<10>(0.0), &xf);
    for (int i = 0; i < 14; ++i) gx.row(i) = xf(i).derivatives().transpose();
  }
}

void HopperModel::DoSurface(int k, const ConstVectorRef& x, VectorRef h) const {
  (void)k;  // only mode 0 has a surface (s_0 = 1, s_1 = 0)
  h(0) = FootClearance(x);
}

void HopperModel::DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const {
  (void)k;
  // y_f = y - r cos(theta): d/dy = 1, d/dr = -cos(theta), d/dtheta = r sin(theta).
  hx.setZero();
  hx(0, hopper::kY) = 1.0;
  hx(0, hopper::kR) = -std::cos(x(hopper::kTheta));
  hx(0, hopper::kTheta) = x(hopper::kR) * std::sin(x(hopper::kTheta));
  const double a = params_.slope;
  if (a != 0.0) {
    // h_0 = cos(a) y_f - sin(a) x_f, x_f = x + r sin(theta): d/dx = -sin(a), d/dy = cos(a),
    // d/dr = -cos(theta - a), d/dtheta = r sin(theta - a).
    const double th = x(hopper::kTheta);
    hx(0, hopper::kX) = -std::sin(a);
    hx(0, hopper::kY) = std::cos(a);
    hx(0, hopper::kR) = -std::cos(th - a);
    hx(0, hopper::kTheta) = x(hopper::kR) * std::sin(th - a);
  }
}

bool HopperModel::DoGuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                                  VectorRef hx) const {
  (void)u;  // F0 enters the takeoff guard additively
  if (k == hopper::kFlight) {  // the foot height: the touchdown surface's gradient
    Eigen::Map<Eigen::MatrixXd> row(hx.data(), 1, hx.size());
    DoSurfaceDerivative(k, x, row);
    return true;
  }
  hx.setZero();
  hx(hopper::kSR) = -x(hopper::kSKleg);
  hx(hopper::kSKleg) = -(x(hopper::kSR) - params_.r0);
  hx(hopper::kSRd) = -params_.b_leg;
  return true;
}

// Explicit double instantiations, so the templated right-hand sides are usable outside src/hopper.
template void HopperModel::FlightRhs<double>(const Eigen::Matrix<double, 14, 1>&,
                                             const Eigen::Matrix<double, 4, 1>&,
                                             Eigen::Matrix<double, 14, 1>*) const;
template void HopperModel::StanceRhs<double>(const Eigen::Matrix<double, 10, 1>&,
                                             const Eigen::Matrix<double, 4, 1>&,
                                             Eigen::Matrix<double, 10, 1>*) const;
template void HopperModel::TouchdownReset<double>(const Eigen::Matrix<double, 14, 1>&,
                                                  Eigen::Matrix<double, 10, 1>*) const;
template void HopperModel::TakeoffReset<double>(const Eigen::Matrix<double, 10, 1>&,
                                                const double&, Eigen::Matrix<double, 14, 1>*) const;
template double HopperModel::EnergyLoss<double>(const Eigen::Matrix<double, 14, 1>&) const;
template double HopperModel::Clearance<double>(const Eigen::Matrix<double, 14, 1>&) const;

}  // namespace ddoc
