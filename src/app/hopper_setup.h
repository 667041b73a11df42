// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// What ddoc-hopper and ddoc-return-map share: the model and controller configuration a scenario
// describes, the pushes, and the documented fall limits.
#ifndef DDOC_APP_HOPPER_SETUP_H_
#define DDOC_APP_HOPPER_SETUP_H_

#include <Eigen/Core>

#include <string>

#include "hopper_controller.h"
#include "scenario.h"

namespace ddoc::app {

/// Exit codes of the hopper tools.
constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitFall = 3;

/// Fall limits (documented in the README): the run ends with exit code 3 when one holds.
struct FallLimits {
  double min_height = 0.3;     // COM height y below this, m (the leg is 0.7 m long)
  double max_pitch = 1.0;      // |phi| above this, rad (57 deg)
  double max_leg_angle = 1.2;  // |theta| above this, rad (69 deg): the leg is nearly horizontal
  double max_phase = 3.0;      // a flight or stance phase longer than this, s (stalled)
};

/// Returns a non-empty reason when the robot has fallen.
std::string FallReason(const FallLimits& lim, const Eigen::Matrix<double, 14, 1>& x,
                       double phase_time);

/// The analytic model of a scenario: its model MJCF (if any), then the numbers on top.
HopperParams ModelParams(const Scenario& s);

/// The controller configuration of a scenario: method, model, gait and <learning> overrides.
plugin::ControllerConfig ControllerConfigFor(const Scenario& s, const HopperParams& model);

}  // namespace ddoc::app

#endif  // DDOC_APP_HOPPER_SETUP_H_
