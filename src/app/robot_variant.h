// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Robot variants from anywhere: a robot MJCF with its <include>s written into one file (absolute
// include paths taken as they are, which MuJoCo 2.2 joins onto the model's directory), and the
// numbers of a variant (ddoc-hopper --robot-variant mass=11,c_d=0.02) applied to it.
#ifndef DDOC_APP_ROBOT_VARIANT_H_
#define DDOC_APP_ROBOT_VARIANT_H_

#include <optional>
#include <string>

namespace ddoc::app {

/// The numbers of a robot variant (docs/hopper.md, "Robot variants"); unset: the robot file's.
struct RobotVariant {
  std::optional<double> mass;    ///< torso <inertial mass>, kg, > 0 (the variant files' M)
  std::optional<double> j_body;  ///< torso diaginertia (all three), kg m^2, > 0
  std::optional<double> c_d;     ///< <numeric name="drag_cd">, air drag of (38), kg/m, >= 0
  std::optional<double> beta;    ///< <numeric name="vsa_beta">, stiffness bandwidth, rad/s, > 0
  /// Strength of the hip motor: its gainprm[0] times this (0.8 = delivers 80 % of the commanded
  /// torque; the model does not know), > 0.
  std::optional<double> hip_gain;
  std::optional<double> leg_gain;  ///< strength of the leg motor, as hip_gain, > 0
  /// Viscous damping of the leg's slide joint "leg" (its <joint damping>), N s/m, >= 0: a force
  /// -b_leg rd along the leg (models/hopper_damped_leg.xml has 4).
  std::optional<double> b_leg;
  /// Viscous damping of the hip hinge "hip", N m s/rad, >= 0 (models/hopper_damped_hip.xml: 0.5).
  std::optional<double> b_hip;
  /// Floor tilt about the axis normal to the sagittal plane, rad, |slope| < kMaxSlope; positive =
  /// downhill in +x (the floor of models/hopper_slope_down.xml has slope 0.034906585 = 2 deg).
  std::optional<double> slope;
  /// Time constant of the foot-floor contact (solref[0] of the floor and the foot), s, >= 2 x the
  /// MJCF's timestep (MuJoCo's smallest; the shipped robots have 0.001 = 2 x 0.5 ms).
  std::optional<double> contact_timeconst;
  /// Rest length of the leg, m, > 0: the body "foot" at pos = (0, 0, -r0) below the hip, where
  /// the leg spring is relaxed (the shipped robots' 0.7 = the model's r0; 0.72 = 2 cm longer).
  std::optional<double> r0;
  static constexpr double kMaxSlope = 0.3;  ///< bound of |slope|, rad (17 deg)
  bool empty() const {
    return !mass && !j_body && !c_d && !beta && !hip_gain && !leg_gain && !b_leg && !b_hip &&
           !slope && !contact_timeconst && !r0;
  }
  /// "mass=11,c_d=0.02" (the keys set, in this order).
  std::string ToString() const;
};

/// Parses "KEY=VALUE,..." with keys mass, j_body, c_d, beta, hip_gain, leg_gain, b_leg, b_hip,
/// slope, contact_timeconst, r0. Throws std::invalid_argument naming the flag (`flag`), the key or
/// value and the bound ("--robot-variant: mass=-1, expected > 0"); contact_timeconst's bound of
/// 2 x timestep is checked by ExpandRobotMjcf, which knows the timestep.
RobotVariant ParseRobotVariant(const std::string& text, const std::string& flag);

/// True when the MJCF `path` (or a file it includes) has an <include> that MuJoCo 2.2 would not
/// find: an absolute path (MuJoCo joins it onto the model's directory) or a relative one missing
/// from that directory (a variant copied out of models/). ExpandRobotMjcf resolves the first and
/// names the second.
bool IncludesNeedResolving(const std::string& path);

/// The MJCF `path` as one self-contained text: every <include> replaced by the children of the
/// included file's <mujoco> (a relative file= against the directory of `path`, as MuJoCo does; an
/// absolute one as it is), then `variant` applied: the body "torso", the <numeric>s, the motors,
/// the joints "leg" and "hip", the plane "floor" (slope: turned about -y by -slope, at pos = foot
/// radius x (-sin slope, 0, -cos slope) so that the foot centre touches on z = -x tan(slope)
/// through the origin, as models/hopper_slope_down.xml) and the solref of the floor and the foot.
/// Throws std::runtime_error naming the file, line and what is wrong (an include not found says
/// how a copied variant finds its includes; contact_timeconst below 2 x timestep names both); a
/// file= of another element (assets) is not supported.
std::string ExpandRobotMjcf(const std::string& path, const RobotVariant& variant);

}  // namespace ddoc::app

#endif  // DDOC_APP_ROBOT_VARIANT_H_
