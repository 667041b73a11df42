// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Online identification of the hopper's mass and of the model terms of issue 44 (leg damping,
// hip damping, floor slope; the body's inertia, which also carries a weaker hip motor; the air
// drag) from measured hops: each hop gives the sums of a regression (the stance's vertical
// impulse for M, its radial balance for b_leg, the body's pitch balance for J_body and b_hip, the
// flight's horizontal momentum for c_d, the step between two footholds for the slope), estimated
// by least squares with an outlier gate and a standard error, and a decision whether the model's
// value is still inside the estimate's confidence region. No I/O; the plugin measures the hops
// (HopReport::identification), this unit does the arithmetic. docs/hopper.md, "Identifying the
// mass" and "Identifying the model terms".
#ifndef DDOC_HOPPER_IDENTIFICATION_H_
#define DDOC_HOPPER_IDENTIFICATION_H_

#include <algorithm>
#include <limits>
#include <optional>
#include <string>

#include <Eigen/Dense>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc {

/// Least squares for y = theta phi (no intercept), one sample at a time, with an outlier gate:
/// once min_samples samples are kept, a sample whose residual |y - theta phi| exceeds
/// gate x max(s, relative_floor |theta phi|, absolute_floor) is rejected. theta = sum(phi y) /
/// sum(phi^2), s^2 = sum((y - theta phi)^2) / (n - 1) over the kept samples (0 for one sample),
/// se(theta) = max(s, absolute_floor, relative_floor |theta| rms(phi)) / sqrt(sum(phi^2)): the
/// floors are the measurement's resolution, so that one sample or exact samples do not claim
/// more.
class OriginRegression {
 public:
  struct Settings {
    double gate = 4.0;            ///< residuals beyond gate x spread are outliers; > 0, default 4
    double relative_floor = 1e-3; ///< floor of the spread, relative to |theta phi|; default 1e-3
    /// Floor of the spread in y's unit, >= 0; default 0. The measurement's resolution where y
    /// can be 0 (a term the robot does not have), so that exact samples neither gate out the
    /// next one nor make se 0.
    double absolute_floor = 0.0;
    int min_samples = 3;          ///< samples before the gate acts; >= 2
    /// Samples before se is finite (the estimate can decide); >= 1, and with 1 a floor must be
    /// > 0. Default 3.
    int decide_after = 3;
  };
  OriginRegression() = default;
  /// Throws InvalidArgument naming a setting out of range.
  explicit OriginRegression(const Settings& settings);

  /// Adds a sample; returns false when it is not finite, has phi = 0 or is gated out.
  bool Add(double phi, double y);
  void Reset();

  double theta() const;           ///< NaN before the first sample
  double standard_error() const;  ///< se of theta; infinite before decide_after samples
  int samples() const { return n_; }         ///< samples kept
  int rejected() const { return rejected_; } ///< samples gated out

 private:
  double Spread() const;  // s: the residuals' spread (0 before two samples)
  Settings settings_;
  int n_ = 0, rejected_ = 0;
  double spp_ = 0, spy_ = 0, syy_ = 0;  // sums of phi^2, phi y, y^2 over the kept samples
};

/// Least squares y = a' theta, theta in R^2, from blocks of samples (one block per hop, many
/// samples each), with a gate on whole blocks: once min_blocks blocks are kept, a block whose rms
/// residual against the pooled fit exceeds gate x max(s, absolute_floor) is rejected, s^2 = the
/// kept samples' residual sum of squares / (n - 2). theta = A^-1 sum(a y), A = sum(a a'),
/// se(theta_i) = max(s, absolute_floor) sqrt((A^-1)_ii).
class BlockRegression {
 public:
  using Vec = Eigen::Vector2d;
  using Mat = Eigen::Matrix2d;
  /// One block's sums (the plugin adds a hop's steps); no allocation.
  struct Block {
    Mat aa = Mat::Zero();  ///< sum a a'
    Vec ay = Vec::Zero();  ///< sum a y
    double yy = 0.0;       ///< sum y^2
    int n = 0;             ///< samples
    void Add(const Vec& a, double y) {
      aa.noalias() += a * a.transpose();
      ay += a * y;
      yy += y * y;
      ++n;
    }
    /// sum (y - a' theta)^2
    double Rss(const Vec& theta) const {
      return std::max(0.0, yy - 2.0 * theta.dot(ay) + theta.dot(aa * theta));
    }
  };
  struct Settings {
    double gate = 4.0;           ///< blocks whose rms residual is beyond gate x spread; > 0
    double absolute_floor = 0.0; ///< floor of the spread in y's unit, >= 0; default 0
    int min_blocks = 2;          ///< blocks before the gate acts (and se is finite); >= 1
  };
  BlockRegression() = default;
  /// Throws InvalidArgument naming a setting out of range.
  explicit BlockRegression(const Settings& settings);

  /// Adds a block; returns false when it is not finite, has fewer than 2 samples, leaves A
  /// singular (with the kept blocks) or is gated out.
  bool Add(const Block& block);
  void Reset();

  Vec theta() const;           ///< NaN before A is invertible
  Vec standard_error() const;  ///< infinite before min_blocks blocks
  int blocks() const { return blocks_; }      ///< blocks kept
  int rejected() const { return rejected_; }  ///< blocks gated out

 private:
  double Spread() const;  // s over the kept samples (0 with n <= 2)
  Settings settings_;
  Block sum_;
  int blocks_ = 0, rejected_ = 0;
};

/// What one hop measured for identification (filled by the plugin; NaN = not measured).
/// docs/hopper.md, "The mass from a stance" and "Identifying the model terms".
struct HopIdentificationData {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  /// The floor's vertical impulse on the robot over the stance, N s, and yd(takeoff) -
  /// yd(touchdown) + g T_stance, m/s: impulse = M x stance_velocity.
  double stance_impulse = kNaN;
  double stance_velocity = kNaN;
  /// The stance's radial balance, the body's Newton equation along the leg (foot to hip, e_r =
  /// (-sin theta, cos theta)): M (dv . e_r + g cos theta h) = (F_leg - b_leg rd) h per step,
  /// dv the body's velocity change over the step, F_leg the leg force held over it, rd the leg
  /// rate at the step's end (MuJoCo's implicit damping). Weighted by w = the step's mean rd and
  /// summed over the stance's steps after the impact step: leg_work = sum F_leg w h (J),
  /// leg_motion = sum (dv . e_r + g cos theta h) w (J/kg), leg_rate_sq = sum rd w h (m^2/s), so
  /// that leg_work - M leg_motion = b_leg leg_rate_sq.
  double leg_work = kNaN;
  double leg_motion = kNaN;
  double leg_rate_sq = kNaN;
  /// The body's pitch balance, theta = (J_body, b_hip): per step h of the hop (flight and stance:
  /// the hip is at the body's centre of mass, so only the hip torque turns the body) J_body dphid
  /// + b_hip (phid - thetad) h = tau_hip h, a = (dphid, (phid - thetad) h), y = tau_hip h, with
  /// tau_hip the commanded torque held over the step and the rates at its end (MuJoCo's implicit
  /// damping). A hip motor of strength g reads as J_body / g and b_hip / g.
  BlockRegression::Block hip;
  /// The flight's horizontal momentum balance, the robot's momentum M xd + m_foot v_foot,x
  /// changed only by the drag -c_d xd|xd| on the body (the leg's spring moves the 2 g foot against
  /// the body, which the foot's momentum takes out): from the hop's start to its touchdown
  /// x^-(T1), flight_dxd = the body's xd change (m/s), flight_foot_dp = m_foot times the foot's x
  /// velocity change (N s; m_foot the robot's foot), flight_drag = sum xd|xd| h with the xd each
  /// step's drag was applied at (m^2/s): -(M flight_dxd + flight_foot_dp) = c_d flight_drag.
  double flight_dxd = kNaN;
  double flight_foot_dp = kNaN;
  double flight_drag = kNaN;
  /// The foot centre at the hop's start and at its end (the takeoffs that begin and end it:
  /// the footholds of the stance before and of its own), world frame, m. On the floor line y =
  /// x tan(slope) + c, dy = tan(slope) dx between them (both unloaded, as the foot leaves).
  double start_foot_x = kNaN;
  double start_foot_y = kNaN;
  double end_foot_x = kNaN;
  double end_foot_y = kNaN;
};

/// The mass M (kg) from the stances, and whether a model's mass is outside its confidence region.
class MassIdentification {
 public:
  struct Settings {
    OriginRegression::Settings regression;  ///< the regression's gate and floor
    /// The model is left when |M_hat - M_model| > max(z se, relative_tolerance M_model).
    double z = 3.0;                    ///< default 3 (99.7 % for a normal error)
    double relative_tolerance = 0.01;  ///< of the model's mass, default 1 %
  };
  struct Estimate {
    double mass = std::numeric_limits<double>::quiet_NaN();    ///< kg
    double mass_se = std::numeric_limits<double>::infinity();  ///< kg
    int hops = 0;      ///< stances kept
    int rejected = 0;  ///< stances gated out (a push, a slip)
  };

  MassIdentification() = default;
  /// Throws InvalidArgument naming a setting out of range.
  explicit MassIdentification(const Settings& settings);

  /// Adds one hop's measurement (a NaN one is skipped).
  void Add(const HopIdentificationData& hop);
  void Reset() { mass_.Reset(); }
  Estimate estimate() const;
  /// True when the mass is determined (min_samples stances kept) and the model's differs beyond
  /// the confidence region: the model's u^0 should be solved again.
  bool LeavesModel(double model_mass) const;

 private:
  Settings settings_;
  OriginRegression mass_;
};

/// The model terms b_leg, b_hip, J_body, c_d and slope (HopperParams) from the hops: b_leg from
/// leg_work - M leg_motion = b_leg leg_rate_sq (M: the mass estimate, MassIdentification),
/// (J_body, b_hip) from the body's pitch balance (BlockRegression), c_d from the flight's
/// momentum, -(M flight_dxd + flight_foot_dp) = c_d flight_drag, tan(slope) from the step between
/// the footholds, dy = tan(slope) dx; each with its gate and standard error. A
/// term leaves the model when |estimate - model's| > max(z se, its tolerance); the tolerances are
/// the smallest differences worth a new u^0. The pitch balance reads the commanded torque, so a
/// hip motor of strength g gives J_body / g: the identified model scales J_leg with J_body
/// (both leg and hip motors weaker by g are then the model with M, J_body, J_leg, b_leg and
/// b_hip / g, exactly; docs/hopper.md, "Identifying the model terms").
class TermsIdentification {
 public:
  struct Settings {
    OriginRegression::Settings leg = DefaultLeg();      ///< y in J
    BlockRegression::Settings hip = DefaultHip();       ///< y in N m s
    OriginRegression::Settings drag = DefaultDrag();    ///< y in N s
    OriginRegression::Settings slope = DefaultSlope();  ///< y in m (the footholds' height step)
    double z = 3.0;                   ///< default 3 (99.7 % for a normal error)
    double b_leg_tolerance = 0.1;     ///< N s/m, >= 0
    double b_hip_tolerance = 0.02;    ///< N m s/rad, >= 0
    double inertia_tolerance = 0.01;  ///< relative to the model's J_body, >= 0
    double drag_tolerance = 0.005;    ///< kg/m, >= 0 (half the shipped robots' drag)
    double slope_tolerance = 0.001;   ///< rad, >= 0
    /// The terms acted on (LeavesModel, Identified); the others are estimated and reported only.
    /// Default all (ParseActedTerms; docs/hopper.md, "Identifying the model terms").
    struct Acted {
      bool b_leg = true, b_hip = true, j_body = true, c_d = true, slope = true;
      bool operator==(const Acted& o) const {
        return b_leg == o.b_leg && b_hip == o.b_hip && j_body == o.j_body && c_d == o.c_d &&
               slope == o.slope;
      }
    } acted;

    static OriginRegression::Settings DefaultLeg();
    static BlockRegression::Settings DefaultHip();
    static OriginRegression::Settings DefaultDrag();
    static OriginRegression::Settings DefaultSlope();
  };
  /// One term's estimate: value (NaN before a sample), its standard error (infinite until
  /// determined), the samples (hops) kept and gated out.
  struct Term {
    double value = std::numeric_limits<double>::quiet_NaN();
    double se = std::numeric_limits<double>::infinity();
    int samples = 0;
    int rejected = 0;
    bool determined() const { return se < std::numeric_limits<double>::infinity(); }
  };
  struct Estimate {
    Term b_leg;   ///< N s/m
    Term b_hip;   ///< N m s/rad
    Term j_body;  ///< kg m^2
    Term c_d;     ///< kg/m
    Term slope;   ///< rad, HopperParams::slope's sign (> 0 rises towards +x)
  };
  /// The re-solved model's terms are the estimates rounded to these steps.
  struct Resolution {
    double b_leg = 0.01;    ///< N s/m
    double b_hip = 0.001;   ///< N m s/rad
    double inertia = 1e-4;  ///< relative to the model's J_body
    double c_d = 1e-4;      ///< kg/m
    double slope = 1e-4;    ///< rad
  };

  TermsIdentification() : TermsIdentification(Settings()) {}
  /// Throws InvalidArgument naming a setting out of range.
  explicit TermsIdentification(const Settings& settings);

  /// Adds one hop's measurement; mass (kg) is the current mass estimate. NaN parts are skipped.
  void Add(const HopIdentificationData& hop, double mass);
  void Reset();
  Estimate estimate() const;
  /// True when every term is determined.
  bool Determined() const;
  /// True when a determined term of `model` that is acted on (Settings::acted) lies outside its
  /// estimate's confidence region.
  bool LeavesModel(const HopperParams& model) const;
  /// `model` with each acted-on term that leaves it set to its estimate rounded to `resolution`
  /// (J_leg scaled as J_body), the dampers and the drag clamped at >= 0, the inertias at >= 1 %
  /// of the model's and the slope inside the model's range; the other terms as in `model`.
  HopperParams Identified(const HopperParams& model, const Resolution& resolution) const;

 private:
  Settings settings_;
  OriginRegression leg_, drag_, slope_;
  BlockRegression hip_;
};

/// The terms named in `list`: comma-separated names of b_leg, b_hip, j_body, c_d, slope, or
/// "all" or "none"; throws InvalidArgument naming an unknown or repeated name.
TermsIdentification::Settings::Acted ParseActedTerms(const std::string& list);
/// The acted-on terms as ParseActedTerms reads them ("all", "none" or the names in order).
std::string ActedTermsName(const TermsIdentification::Settings::Acted& acted);

/// The model u^0 should be solved again on, or nullopt when `model` is still inside the
/// confidence regions of what is acted on: with act_on_mass, M = the mass estimate rounded to
/// mass_resolution when it leaves (MassIdentification::LeavesModel); with act_on_terms, the
/// determined terms that leave (TermsIdentification::Identified). Nothing is decided before the
/// mass is determined (when acted on); a term determined later (the slope, after the first hop
/// between two takeoffs) can make a second re-solve.
std::optional<HopperParams> IdentifiedModel(const HopperParams& model,
                                            const MassIdentification& mass, bool act_on_mass,
                                            double mass_resolution,
                                            const TermsIdentification& terms, bool act_on_terms,
                                            const TermsIdentification::Resolution& resolution);

}  // namespace ddoc

#endif  // DDOC_HOPPER_IDENTIFICATION_H_
