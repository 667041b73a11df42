// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The analytic planar one-legged VSA hopper of paper Section V-A on the engine's
// SwitchedSystem API. Two modes per hop, starting at takeoff:
//
//   mode 0 = flight (n = 14), eq. (38) + VSA;  touchdown reset g_0 = (40): 14 -> 10
//   mode 1 = stance (n = 10), eq. (39) + VSA;  takeoff map g_1 (cycle reset): 10 -> 14
//
// Conventions (docs/hopper.md, checked numerically against the MJCF robot): x right, y up; theta is the
// leg angle from the downward vertical, counter-clockwise positive; the foot is at
// (x, y) + r (sin theta, -cos theta); the hip torque acts +tau on the body and -tau on the leg.
#ifndef DDOC_HOPPER_HOPPER_MODEL_H_
#define DDOC_HOPPER_HOPPER_MODEL_H_

#include <Eigen/Dense>

#include "ddoc/hopper/vsa.h"
#include "ddoc/switched_system.h"

namespace ddoc {

namespace hopper {

constexpr int kFlight = 0;       ///< mode index of the flight phase
constexpr int kStance = 1;       ///< mode index of the stance phase
constexpr int kFlightDim = 14;   ///< n_0
constexpr int kStanceDim = 10;   ///< n_1
constexpr int kInputDim = 4;     ///< m

/// Flight state x in R^14 = [x, y, theta, phi, r, k_hip, k_leg, and their rates].
enum FlightIndex : int {
  kX = 0, kY, kTheta, kPhi, kR, kKhip, kKleg,
  kXd, kYd, kThetad, kPhid, kRd, kKhipd, kKlegd
};
/// Stance state x in R^10 = [theta, phi, r, k_hip, k_leg, and their rates]; the foot is fixed.
enum StanceIndex : int {
  kSTheta = 0, kSPhi, kSR, kSKhip, kSKleg,
  kSThetad, kSPhid, kSRd, kSKhipd, kSKlegd
};
/// Input u in R^4 = [tau0 (N m), F0 (N), k0_hip (N m/rad), k0_leg (N/m)].
enum InputIndex : int { kTau0 = 0, kF0, kK0hip, kK0leg };

/// Table I / Fig. 2 input bounds: u_min = [-4, -4, 10, 1780], u_max = [4, 4, 150, 2350].
Eigen::Vector4d InputLowerBound();
Eigen::Vector4d InputUpperBound();

}  // namespace hopper

/// Which velocity jump the touchdown reset (40)-(41) uses.
enum class ImpactModel {
  /// Physics of a massless leg with inertia J_leg pinned at the foot (default; matches the MJCF
  /// robot, see docs/hopper.md): ratio J_leg / (J_leg + M r^2) with the actual leg length r at touchdown.
  kMasslessLeg,
  /// The paper as printed: ratio J_body / (J_body + M r0^2), theta-row M r0 / J_body.
  kPaperLiteral,
};

/// Parameters of the analytic hopper (Table I). Defaults: the 10 kg robot without drag.
struct HopperParams {
  double M = 10.0;       ///< body mass, kg (> 0)
  double J_body = 2.5;   ///< body pitch inertia, kg m^2 (> 0)
  double J_leg = 0.25;   ///< leg inertia about the hip, kg m^2 (> 0)
  double r0 = 0.7;       ///< natural leg length, m (> 0)
  double c_d = 0.0;      ///< air drag, kg/m (>= 0); force -c_d v|v| per component, eq. (38)
  double beta = kDefaultVsaBeta;  ///< VSA stiffness bandwidth, rad/s (> 0)
  double g = 9.81;       ///< gravity, m/s^2 (> 0)
  /// Viscous damping of the leg, N s/m (>= 0; default 0 = the paper): a force -b_leg rd along
  /// the leg in stance, F = F0 - k_leg (r - r0) - b_leg rd (MJCF: damping of joint "leg").
  double b_leg = 0.0;
  /// Viscous damping of the hip, N m s/rad (>= 0; default 0 = the paper): a torque on the
  /// relative rate, tau = tau0 - k_hip (phi - theta) - b_hip (phid - thetad) (MJCF: joint "hip").
  double b_hip = 0.0;
  /// Floor slope alpha, rad (|alpha| < kMaxSlope; default 0 = the paper): the foot-centre floor is
  /// the line y = x tan(alpha) through the origin (alpha > 0 rises towards +x, i.e. uphill for
  /// forward hopping). Gravity stays vertical.
  double slope = 0.0;
  /// Largest accepted |slope|, rad (0.5 rad = 28.6 deg; the robot's leg reaches ~0.3 rad).
  static constexpr double kMaxSlope = 0.5;
  ImpactModel impact = ImpactModel::kMasslessLeg;  ///< touchdown reset variant

  /// Throws ddoc::InvalidArgument naming the first bad field (expected vs actual).
  void Validate() const;
  /// Throws ddoc::InvalidArgument, naming `who` and the fields, when an RK4 step dt is outside
  /// RK4's stability region for the stiffest motions at the input bounds: the flight hip spring
  /// (sqrt(k_hip (1/J_leg + 1/J_body)) dt < 2 sqrt(2)), the stance leg spring (sqrt(k_leg / M) dt
  /// < 2 sqrt(2)) and the VSA (beta dt < 2.78).
  void CheckRk4Step(double dt, const std::string& who) const;
};

/// The analytic hopper as a K = 2 switched system (flight, stance), m = 4.
///
/// Flight (38):  xdd = -c_d/M xd|xd|,  ydd = -g - c_d/M yd|yd|,  thetadd = -tau/J_leg,
///               phidd = tau/J_body,  rdd = 0.
/// Stance (39):  thetadd = [M (r g sin theta - 2 r rd thetad) - tau] / (J_leg + M r^2),
///               phidd = tau/J_body,  rdd = r thetad^2 - g cos theta + F/M.
/// VSA (both):   tau = tau0 - k_hip (phi - theta) - b_hip (phid - thetad),
///               F = F0 - k_leg (r - r0) - b_leg rd,
///               kdd_i = beta^2 (k0_i - k_i) - 2 beta kd_i.
///               (b_hip, b_leg: the dampers of HopperParams, 0 in the paper. F enters stance only,
///               flight keeps rdd = 0. The slope changes only the floor: h_0 and g_1 below; the
///               stance and touchdown equations hold as they are, the foot being a fixed pivot.)
/// Touchdown g_0 (40): v = xd cos th + yd sin th + r thd (foot velocity normal to the leg),
///               eps = J / (J + M r^2), J = J_leg (kMasslessLeg) or J_body and r -> r0 (literal):
///               thd+ = thd - eps (M r / J) v,  rd+ = -xd sin th + yd cos th (foot stops),
///               all positions, phid and the stiffness states are continuous.
/// Takeoff g_1 (cycle reset, stance -> flight), foot at x_f = 0 (x is relative to the last foothold;
///               add the absolute foot x yourself, see TakeoffMap):
///               x = x_f - r sin th, y = r cos th, xd = -rd sin th - r thd cos th,
///               yd = rd cos th - r thd sin th, rd+ = 0 (the massless leg stops extending at
///               F_leg = 0 and stays at its length during flight, consistent with rdd = 0).
///               With a slope the foot is at (x_f, x_f tan(alpha)): y = x_f tan(alpha) + r cos th
///               (the cycle reset, x_f = 0, keeps the foothold at the origin, on the floor line).
/// Switching surface h_0 (s_0 = 1): the foot's distance above the floor line,
///               h_0 = cos(alpha) y_f - sin(alpha) x_f with (x_f, y_f) = (x + r sin th, y - r cos th)
///               (= the foot height y_f at alpha = 0; the I4 penalty of (42)).
/// Derivatives: Eigen AutoDiff with fixed sizes (allocation-free).
class HopperModel : public SwitchedSystem {
 public:
  explicit HopperModel(const HopperParams& params);

  const HopperParams& params() const { return params_; }

  /// Guard of the model plant (events are sign changes from > 0 to <= 0):
  ///   k = 0 (flight): FootClearance (the foot height y - r cos theta on a level floor);
  ///                   touchdown when it reaches 0 descending.
  ///   k = 1 (stance): leg force F_leg = F0 - k_leg (r - r0) - b_leg rd; takeoff when it reaches 0.
  double Guard(int k, const ConstVectorRef& x, const ConstVectorRef& u) const;

  /// Energy loss (41) at touchdown for the pre-impact flight state x^-:
  /// Delta E = 1/2 M eps v^2 (with the same eps, v as the reset).
  double ImpactEnergyLoss(const ConstVectorRef& x_flight) const;
  /// eps of the reset for leg length r (r0 in the literal variant).
  double ImpactRatio(double r) const;

  /// Takeoff map with an explicit absolute foot position foot_x (10 -> 14).
  void TakeoffMap(const ConstVectorRef& x_stance, double foot_x, VectorRef x_flight) const;
  /// Foot x at touchdown (flight state): x + r sin theta.
  static double FootX(const ConstVectorRef& x_flight);
  /// Foot height y - r cos theta (flight state).
  static double FootHeight(const ConstVectorRef& x_flight);
  /// The foot's distance above the (sloped) floor, h_0 = cos(alpha) y_f - sin(alpha) x_f, m;
  /// equal to FootHeight at slope 0 (flight state).
  double FootClearance(const ConstVectorRef& x_flight) const;

  /// Templated right-hand sides shared by the double and AutoDiff paths. Sizes: x 14 / 10, u 4.
  /// Defined in src/hopper; instantiated for double (usable anywhere) and for the AutoDiff types
  /// used inside src/hopper.
  template <typename T>
  void FlightRhs(const Eigen::Matrix<T, 14, 1>& x, const Eigen::Matrix<T, 4, 1>& u,
                 Eigen::Matrix<T, 14, 1>* xdot) const;
  template <typename T>
  void StanceRhs(const Eigen::Matrix<T, 10, 1>& x, const Eigen::Matrix<T, 4, 1>& u,
                 Eigen::Matrix<T, 10, 1>* xdot) const;
  template <typename T>
  void TouchdownReset(const Eigen::Matrix<T, 14, 1>& x, Eigen::Matrix<T, 10, 1>* xs) const;
  template <typename T>
  void TakeoffReset(const Eigen::Matrix<T, 10, 1>& xs, const T& foot_x,
                    Eigen::Matrix<T, 14, 1>* x) const;
  template <typename T>
  T EnergyLoss(const Eigen::Matrix<T, 14, 1>& x) const;
  /// h_0 of a flight state: the foot's distance above the floor line (FootClearance).
  template <typename T>
  T Clearance(const Eigen::Matrix<T, 14, 1>& x) const;

 protected:
  void DoFlow(int k, const ConstVectorRef& x, const ConstVectorRef& u,
              VectorRef xdot) const override;
  void DoFlowDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, MatrixRef fx,
                         MatrixRef fu) const override;
  void DoReset(int k, const ConstVectorRef& x, VectorRef x_next) const override;
  void DoResetDerivative(int k, const ConstVectorRef& x, MatrixRef gx) const override;
  void DoSurface(int k, const ConstVectorRef& x, VectorRef h) const override;
  void DoSurfaceDerivative(int k, const ConstVectorRef& x, MatrixRef hx) const override;
  /// d Guard / dx: flight, the clearance's gradient; stance, -k_leg on r, -(r - r0) on k_leg and
  /// -b_leg on rd.
  bool DoGuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                       VectorRef hx) const override;

 private:
  HopperParams params_;
};

}  // namespace ddoc

#endif  // DDOC_HOPPER_HOPPER_MODEL_H_
