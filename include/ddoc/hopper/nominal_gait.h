// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A nominal hopping gait of the analytic model under a CONSTANT input: the starting point
// (x0, u0, T0) for the optimizer (Algorithm 1 needs an initial control that hops).
#ifndef DDOC_HOPPER_NOMINAL_GAIT_H_
#define DDOC_HOPPER_NOMINAL_GAIT_H_

#include <Eigen/Dense>

#include "ddoc/hopper/hop_simulator.h"
#include "ddoc/hopper/hopper_model.h"

namespace ddoc {

/// Settings of FindNominalGait.
struct NominalGaitSettings {
  double forward_speed = 0.5;  ///< takeoff xd of the gait, m/s (held fixed by the search)
  double apex_height = 0.8;    ///< initial yd0 = sqrt(2 g (apex - r0)), m (held if the free search collapses)
  double k0_hip = 50.0;        ///< constant hip stiffness command, N m/rad (u0[2])
  double k0_leg = 2000.0;      ///< constant leg stiffness command, N/m (u0[3])
  int max_iterations = 60;     ///< Levenberg-Marquardt iterations per continuation stage
  int continuation_stages = 4; ///< forward speed is ramped 0 -> forward_speed in this many stages
  double dt = 1e-3;            ///< RK4 step of the hop simulation, s
  double max_periodicity = 1e-2;  ///< largest I1 of the result accepted as a gait (else throws)
};

/// A near-periodic hop of the analytic model under constant u0.
struct NominalGait {
  Eigen::Matrix<double, 14, 1> x0;  ///< flight state at takeoff (foot at x = 0, on the ground)
  Eigen::Vector4d u0;               ///< constant input [tau0, F0, k0_hip, k0_leg]
  Eigen::Vector2d T0;               ///< (T1, T2): touchdown and takeoff times of the hop, s
  HopResult hop;                    ///< the simulated hop from x0 under u0
  double periodicity = 0.0;  ///< I1 = (x(T2) - x0)' Q (x(T2) - x0) with Fig. 2's Q (0 = periodic)
  double max_abs_residual = 0.0;  ///< max |x_i(T2) - x0_i| over the Q-weighted entries
  double apex = 0.0;          ///< apex COM height, m
  double stance_time = 0.0;   ///< T2 - T1, s
  double period = 0.0;        ///< T2, s
  double forward_speed = 0.0; ///< xd at takeoff, m/s
  double step_length = 0.0;   ///< horizontal COM travel over the hop, m
  double energy_loss = 0.0;   ///< Delta E at touchdown (41), J
  /// The search variables [theta0, phi0, yd0, thetad0, phid0, tau0] the gait is built from
  /// (NominalGaitAt rebuilds the same gait from them).
  Eigen::Matrix<double, 6, 1> search = Eigen::Matrix<double, 6, 1>::Zero();
};

/// Shooting search (Levenberg-Marquardt, finite-difference Jacobian) over
/// p = [theta0, phi0, yd0, thetad0, phid0, tau0] with xd0 = forward_speed, r = r0, F0 = 0,
/// k = k0 (at rest), minimizing the Q-weighted takeoff-to-takeoff residual of I1, by continuation
/// from vertical hopping at yd0 = sqrt(2 g (apex_height - r0)). If the result's apex is less than
/// r0 + (apex_height - r0)/4 (with drag the free search can collapse to yd0 -> 0), the search is
/// redone with yd0 held at its initial value.
/// A constant-input hop is conservative except for the touchdown loss (41), so exact periodicity
/// needs v_f_theta = 0 at touchdown; the residual left is reported in the result.
/// With b_leg, b_hip or slope nonzero no constant input is periodic (the dampers dissipate, a
/// slope adds M g step tan(alpha) per hop): the search then runs on params without them, and
/// x0, u0 are that gait's while hop, T0, periodicity and the figures below are of the full model
/// under u0 (a start for the model solve, which has the terms). At zero terms nothing changes.
/// Throws ddoc::InvalidArgument for invalid params/settings, and when the search ends at
/// I1 > max_periodicity: no periodic gait at that speed (e.g. 2.7 m/s and more on the 10 kg model).
NominalGait FindNominalGait(const HopperParams& params,
                            const NominalGaitSettings& settings = NominalGaitSettings());

/// The gait FindNominalGait(params, settings) returns when its search ends at `search`
/// (NominalGait::search), bit for bit, without the search: one or two simulated hops instead of
/// the continuation (about 100 ms). The law cache stores `search` beside u^0. Throws as
/// FindNominalGait.
NominalGait NominalGaitAt(const HopperParams& params, const NominalGaitSettings& settings,
                          const Eigen::Matrix<double, 6, 1>& search);

}  // namespace ddoc

#endif  // DDOC_HOPPER_NOMINAL_GAIT_H_
