// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Online identification of the hopper's mass from measured hops (issue 44): each stance gives one
// equation impulse = M (dyd + g T_stance), a regression through the origin estimated by least
// squares with an outlier gate and a standard error, and a decision whether the model's mass is
// still inside the estimate's confidence region. No I/O; the plugin measures the hops
// (HopReport::identification), this unit does the arithmetic. docs/hopper.md, "Identifying the
// mass".
#ifndef DDOC_HOPPER_IDENTIFICATION_H_
#define DDOC_HOPPER_IDENTIFICATION_H_

#include <limits>

namespace ddoc {

/// Least squares for y = theta phi (no intercept), one sample at a time, with an outlier gate:
/// once min_samples samples are kept, a sample whose residual |y - theta phi| exceeds
/// gate x max(s, relative_floor |theta phi|) is rejected. theta = sum(phi y) / sum(phi^2), s^2 =
/// sum((y - theta phi)^2) / (n - 1) over the kept samples, se(theta) = s / sqrt(sum(phi^2)).
class OriginRegression {
 public:
  struct Settings {
    double gate = 4.0;            ///< residuals beyond gate x spread are outliers; > 0, default 4
    double relative_floor = 1e-3; ///< floor of the spread, relative to |theta phi|; default 1e-3
    int min_samples = 3;          ///< samples before the gate acts (and se is finite); >= 2
  };
  OriginRegression() = default;
  /// Throws InvalidArgument naming a setting out of range.
  explicit OriginRegression(const Settings& settings);

  /// Adds a sample; returns false when it is not finite, has phi = 0 or is gated out.
  bool Add(double phi, double y);
  void Reset();

  double theta() const;           ///< NaN before the first sample
  double standard_error() const;  ///< se of theta; infinite before min_samples samples
  int samples() const { return n_; }         ///< samples kept
  int rejected() const { return rejected_; } ///< samples gated out

 private:
  double Spread() const;  // s: the residuals' spread (0 before two samples)
  Settings settings_;
  int n_ = 0, rejected_ = 0;
  double spp_ = 0, spy_ = 0, syy_ = 0;  // sums of phi^2, phi y, y^2 over the kept samples
};

/// What one hop measured for identification (filled by the plugin; NaN = not measured): the
/// floor's vertical impulse on the robot over the stance, N s, and yd(takeoff) - yd(touchdown) +
/// g T_stance, m/s, so that impulse = M x that (docs/hopper.md, "The mass from a stance").
struct HopIdentificationData {
  double stance_impulse = std::numeric_limits<double>::quiet_NaN();
  double stance_velocity = std::numeric_limits<double>::quiet_NaN();
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

}  // namespace ddoc

#endif  // DDOC_HOPPER_IDENTIFICATION_H_
