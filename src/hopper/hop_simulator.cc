// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/hop_simulator.h"

#include <algorithm>
#include <cmath>

namespace ddoc {

namespace {

/// One classical RK4 step of mode k with the input held at u.
Eigen::VectorXd Rk4(const HopperModel& model, int k, const Eigen::VectorXd& x,
                    const Eigen::Vector4d& u, double h) {
  const int n = static_cast<int>(x.size());
  Eigen::VectorXd k1(n), k2(n), k3(n), k4(n);
  model.Flow(k, x, u, k1);
  model.Flow(k, x + 0.5 * h * k1, u, k2);
  model.Flow(k, x + 0.5 * h * k2, u, k3);
  model.Flow(k, x + h * k3, u, k4);
  return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

// Fig. 2 input weights (I2), used for the effort figure only.
const Eigen::Vector4d kR(1e-2, 1e-4, 1e-6, 1e-6);

/// Integrates mode k from x until its guard crosses from > 0 to <= 0. Returns false on timeout.
/// On success x holds the state at the event and t the event time.
bool RunMode(const HopperModel& model, int k, const HopPolicy& policy, const HopSimSettings& s,
             double t_max, Eigen::VectorXd* x, double* t, HopResult* result) {
  const double t_start = *t;
  Eigen::Vector4d u = policy(*t, k, *x);
  double g = model.Guard(k, *x, u);
  while (*t - t_start < t_max) {
    if (s.record) result->samples.push_back({*t, k, *x});
    u = policy(*t, k, *x);
    const Eigen::VectorXd x_next = Rk4(model, k, *x, u, s.dt);
    const double g_next = model.Guard(k, x_next, u);
    if (k == hopper::kFlight) result->apex = std::max(result->apex, (*x)(hopper::kY));
    if (g > 0.0 && g_next <= 0.0) {
      // Bisection on the sub-step length with the same held input.
      double lo = 0.0, hi = s.dt;
      for (int i = 0; i < s.bisections; ++i) {
        const double mid = 0.5 * (lo + hi);
        if (model.Guard(k, Rk4(model, k, *x, u, mid), u) > 0.0) lo = mid; else hi = mid;
      }
      result->effort += 0.5 * (kR.array() * u.array().square()).sum() * hi;
      *x = Rk4(model, k, *x, u, hi);
      *t += hi;
      return true;
    }
    result->effort += 0.5 * (kR.array() * u.array().square()).sum() * s.dt;
    *x = x_next;
    *t += s.dt;
    g = g_next;
  }
  return false;
}

}  // namespace

HopResult SimulateHop(const HopperModel& model, const Eigen::Matrix<double, 14, 1>& x0,
                      const HopPolicy& policy, const HopSimSettings& settings) {
  HopResult r;
  if (!(settings.dt > 0.0)) {
    throw InvalidArgument("SimulateHop: dt = " + std::to_string(settings.dt) + ", expected > 0");
  }
  if (!x0.allFinite()) throw InvalidArgument("SimulateHop: x0 is not finite");
  Eigen::VectorXd x = x0;
  double t = 0.0;
  r.apex = x0(hopper::kY);
  if (!RunMode(model, hopper::kFlight, policy, settings, settings.max_flight, &x, &t, &r)) {
    r.message = "no touchdown within max_flight";
    return r;
  }
  r.t1 = t;
  r.x_td_minus = x;
  r.foot_x = HopperModel::FootX(x);
  Eigen::VectorXd xs(hopper::kStanceDim);
  model.Reset(hopper::kFlight, x, xs);
  r.x_td_plus = xs;
  if (settings.stop_at_touchdown) {
    if (settings.record) r.samples.push_back({t, hopper::kStance, xs});
    r.ok = true;
    return r;
  }
  if (!RunMode(model, hopper::kStance, policy, settings, settings.max_stance, &xs, &t, &r)) {
    r.message = "no takeoff within max_stance";
    return r;
  }
  r.t2 = t;
  r.x_to_minus = xs;
  Eigen::VectorXd xf(hopper::kFlightDim);
  model.TakeoffMap(xs, r.foot_x, xf);
  r.x_to_plus = xf;
  if (settings.record) r.samples.push_back({t, hopper::kFlight, xf});
  r.ok = true;
  return r;
}

HopResult SimulateHop(const HopperModel& model, const Eigen::Matrix<double, 14, 1>& x0,
                      const Eigen::Vector4d& u, const HopSimSettings& settings) {
  return SimulateHop(
      model, x0, [u](double, int, const Eigen::VectorXd&) { return u; }, settings);
}

std::vector<HopSample> IntegrateMode(const HopperModel& model, int k, const Eigen::VectorXd& x0,
                                     const Eigen::Vector4d& u, double duration, double dt) {
  std::vector<HopSample> out;
  Eigen::VectorXd x = x0;
  const int steps = static_cast<int>(std::lround(duration / dt));
  out.push_back({0.0, k, x});
  for (int i = 1; i <= steps; ++i) {
    x = Rk4(model, k, x, u, dt);
    out.push_back({i * dt, k, x});
  }
  return out;
}

}  // namespace ddoc
