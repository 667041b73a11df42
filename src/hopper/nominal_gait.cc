// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "ddoc/hopper/nominal_gait.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "ddoc/check_derivatives.h"
#include "ddoc/hopper/hopper_cost.h"

namespace ddoc {

namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// The Q-weighted entries of I1 (Fig. 2): theta, phi, xd, yd, thetad, phid.
constexpr int kWeighted[6] = {hopper::kTheta, hopper::kPhi, hopper::kXd,
                              hopper::kYd,    hopper::kThetad, hopper::kPhid};

/// Builds (x0, u0) from the search variables p.
void Assemble(const HopperParams& prm, const NominalGaitSettings& s, double speed, const Vec6& p,
              Eigen::Matrix<double, 14, 1>* x0, Eigen::Vector4d* u0) {
  using namespace hopper;  // NOLINT
  *u0 << p(5), 0.0, s.k0_hip, s.k0_leg;
  x0->setZero();
  const double r = prm.r0;  // F0 = 0: the leg is at its natural length at takeoff
  (*x0)(kX) = -r * std::sin(p(0));
  (*x0)(kY) = r * std::cos(p(0));
  (*x0)(kTheta) = p(0);
  (*x0)(kPhi) = p(1);
  (*x0)(kR) = r;
  (*x0)(kKhip) = s.k0_hip;
  (*x0)(kKleg) = s.k0_leg;
  (*x0)(kXd) = speed;
  (*x0)(kYd) = p(2);
  (*x0)(kThetad) = p(3);
  (*x0)(kPhid) = p(4);
}

/// sqrt(Q)-weighted periodicity residual; a failed hop gives a large residual.
Vec6 Residual(const HopperModel& model, const HopperCostWeights& w, const NominalGaitSettings& s,
              double speed, const Vec6& p, HopResult* hop_out) {
  Eigen::Matrix<double, 14, 1> x0;
  Eigen::Vector4d u0;
  Assemble(model.params(), s, speed, p, &x0, &u0);
  HopSimSettings hs;
  hs.dt = s.dt;
  HopResult hop = SimulateHop(model, x0, u0, hs);
  Vec6 res;
  if (!hop.ok) {
    res.setConstant(1e3);
  } else {
    for (int i = 0; i < 6; ++i) {
      const int j = kWeighted[i];
      res(i) = std::sqrt(w.q_diag(j)) * (hop.x_to_plus(j) - x0(j));
    }
  }
  if (hop_out) *hop_out = hop;
  return res;
}

/// Levenberg-Marquardt on Residual with a central-difference Jacobian.
Vec6 Solve(const HopperModel& model, const HopperCostWeights& w, const NominalGaitSettings& s,
           double speed, Vec6 p, bool hold_yd0) {
  double lambda = 1e-3;
  Vec6 res = Residual(model, w, s, speed, p, nullptr);
  for (int it = 0; it < s.max_iterations; ++it) {
    Mat6 jac = CentralDifferenceJacobian(
        [&](const Vector& q) { return Vector(Residual(model, w, s, speed, Vec6(q), nullptr)); },
        p, 1e-6);
    // Optionally yd0 (index 2) is held at the value that sets the requested apex height: with
    // drag a constant-input hop cannot be periodic, and a free yd0 may drift to the degenerate
    // "no hop" solution yd0 -> 0.
    if (hold_yd0) jac.col(2).setZero();
    const Mat6 jtj = jac.transpose() * jac;
    const Vec6 jtr = jac.transpose() * res;
    bool improved = false;
    for (int tries = 0; tries < 12; ++tries) {
      Mat6 a = jtj;
      a.diagonal() += lambda * (jtj.diagonal().array() + 1e-9).matrix();
      if (hold_yd0) a(2, 2) += 1.0;  // no step in the held yd0
      const Vec6 step = -a.ldlt().solve(jtr);
      const Vec6 p_new = p + step;
      const Vec6 res_new = Residual(model, w, s, speed, p_new, nullptr);
      if (res_new.squaredNorm() < res.squaredNorm()) {
        p = p_new;
        res = res_new;
        lambda = std::max(lambda * 0.3, 1e-9);
        improved = true;
        break;
      }
      lambda *= 10.0;
    }
    if (!improved || res.squaredNorm() < 1e-20) break;
  }
  return p;
}

// Throws InvalidArgument for params or settings no gait search accepts.
void CheckGaitInputs(const HopperParams& params, const NominalGaitSettings& s) {
  params.Validate();
  if (s.dt > 0.0) params.CheckRk4Step(s.dt, "FindNominalGait");
  const Eigen::Vector4d lo = hopper::InputLowerBound();
  const Eigen::Vector4d hi = hopper::InputUpperBound();
  if (!(s.k0_hip >= lo(2) && s.k0_hip <= hi(2) && s.k0_leg >= lo(3) && s.k0_leg <= hi(3))) {
    throw InvalidArgument("FindNominalGait: k0_hip = " + std::to_string(s.k0_hip) +
                          ", k0_leg = " + std::to_string(s.k0_leg) +
                          ", expected within [10, 150] and [1780, 2350]");
  }
  if (!(s.apex_height > params.r0) || !(s.dt > 0.0) || s.continuation_stages < 1 ||
      !std::isfinite(s.forward_speed)) {
    throw InvalidArgument("FindNominalGait: need apex_height > r0 (" +
                          std::to_string(s.apex_height) + "), dt > 0, continuation_stages >= 1");
  }
}

// With the dampers or a slope (issue 44) no constant input is periodic: the dampers take energy
// out of every hop and the slope puts M g step tan(alpha) in. The search runs on the model
// without them (the paper's); its x0, u0 are then simulated on the full model.
HopperParams SearchParams(const HopperParams& params) {
  HopperParams search_params = params;
  search_params.b_leg = 0.0;
  search_params.b_hip = 0.0;
  search_params.slope = 0.0;
  return search_params;
}

}  // namespace

NominalGait FindNominalGait(const HopperParams& params, const NominalGaitSettings& s) {
  CheckGaitInputs(params, s);
  const HopperModel model(SearchParams(params));
  const HopperCostWeights w;
  // Start from vertical hopping in place (exactly periodic: theta = 0 gives v_f_theta = 0) and
  // ramp the forward speed, re-solving at each stage.
  // yd0 is free first (exactly periodic gaits exist without drag); if the search collapses to a
  // hop whose apex is less than a quarter of the way from r0 to apex_height, redo it with yd0 held.
  Vec6 start;
  start << 0.0, 0.0, std::sqrt(2.0 * params.g * (s.apex_height - params.r0)), 0.0, 0.0, 0.0;
  Vec6 p = start;
  for (bool hold : {false, true}) {
    p = start;
    for (int stage = 1; stage <= s.continuation_stages; ++stage) {
      const double speed = s.forward_speed * stage / s.continuation_stages;
      p = Solve(model, w, s, speed, p, hold);
    }
    HopResult hop;
    Residual(model, w, s, s.forward_speed, p, &hop);
    if (hop.ok && hop.apex > params.r0 + 0.25 * (s.apex_height - params.r0)) break;
  }
  return NominalGaitAt(params, s, p);
}

NominalGait NominalGaitAt(const HopperParams& params, const NominalGaitSettings& s,
                          const Eigen::Matrix<double, 6, 1>& p) {
  CheckGaitInputs(params, s);
  if (!p.allFinite()) throw InvalidArgument("NominalGaitAt: the search variables are not finite");
  const Eigen::Vector4d lo = hopper::InputLowerBound();
  const Eigen::Vector4d hi = hopper::InputUpperBound();
  const bool has_terms = params.b_leg != 0.0 || params.b_hip != 0.0 || params.slope != 0.0;
  const HopperModel model(SearchParams(params));
  const HopperModel full_model(params);
  const HopperCostWeights w;
  NominalGait g;
  g.search = p;
  Assemble(params, s, s.forward_speed, p, &g.x0, &g.u0);
  // u0[0] = tau0 must respect the bounds; clamp (the search rarely leaves them).
  g.u0 = g.u0.cwiseMax(lo).cwiseMin(hi);
  HopSimSettings hs;
  hs.dt = s.dt;
  g.hop = SimulateHop(model, g.x0, g.u0, hs);
  if (!g.hop.ok) {
    throw InvalidArgument("FindNominalGait: the final hop failed (" + g.hop.message + ")");
  }
  HopperCost cost(model, w);
  cost.SetReference(g.x0);
  g.periodicity = cost.Switching(hopper::kStance, g.hop.x_to_minus);
  const double search_periodicity = g.periodicity;
  if (has_terms) {  // the hop, times and residual of the full model
    g.hop = SimulateHop(full_model, g.x0, g.u0, hs);
    if (!g.hop.ok) {
      throw InvalidArgument("FindNominalGait: the hop with b_leg, b_hip, slope failed (" +
                            g.hop.message + ")");
    }
    HopperCost full_cost(full_model, w);
    full_cost.SetReference(g.x0);
    g.periodicity = full_cost.Switching(hopper::kStance, g.hop.x_to_minus);
  }
  g.T0 << g.hop.t1, g.hop.t2;
  if (!(search_periodicity <= s.max_periodicity)) {
    std::ostringstream msg;
    msg << "FindNominalGait: no periodic gait at " << s.forward_speed << " m/s (apex "
        << s.apex_height << " m, k0_hip " << s.k0_hip << ", k0_leg " << s.k0_leg
        << "): the search ends at I1 = " << search_periodicity << ", above " << s.max_periodicity
        << "; a lower speed may have one";
    throw InvalidArgument(msg.str());
  }
  for (int j : kWeighted) {
    g.max_abs_residual = std::max(g.max_abs_residual, std::abs(g.hop.x_to_plus(j) - g.x0(j)));
  }
  g.apex = g.hop.apex;
  g.stance_time = g.hop.t2 - g.hop.t1;
  g.period = g.hop.t2;
  g.forward_speed = g.x0(hopper::kXd);
  g.step_length = g.hop.x_to_plus(hopper::kX) - g.x0(hopper::kX);
  g.energy_loss = full_model.ImpactEnergyLoss(g.hop.x_td_minus);
  return g;
}

}  // namespace ddoc
