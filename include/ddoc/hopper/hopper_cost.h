// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The hopping cost (42) of paper Section V-B with the weights of Fig. 2, on the engine's
// SwitchedCost API (modes: 0 = flight, 1 = stance; see hopper_model.h).
#ifndef DDOC_HOPPER_HOPPER_COST_H_
#define DDOC_HOPPER_HOPPER_COST_H_

#include <Eigen/Dense>

#include "ddoc/hopper/hopper_model.h"
#include "ddoc/switched_system.h"

namespace ddoc {

/// w of the I4 penalty w y_f(T1)^2 (Fig. 2). The engine adds this penalty from the model's
/// switching surface h_0 = y_f: set Problem::surface_weights = [kHopperSurfaceWeight, 0].
constexpr double kHopperSurfaceWeight = 1e-3;

/// Weights of (42). Defaults: Fig. 2.
struct HopperCostWeights {
  /// diag(Q), 14 flight-state weights of I1. Fig. 2 prints 15 numbers,
  /// [0, 0, 600, 1000, 0, 0, 0, 1000, 10, 1, 1, 0, 0, 0, 0]; we read the first 14 against
  /// [x, y, theta, phi, r, k_hip, k_leg, xd, yd, thetad, phid, rd, k_hipd, k_legd], i.e.
  /// theta 600, phi 1000, xd 1000, yd 10, thetad 1, phid 1, everything else 0 (the trailing 0 is
  /// dropped; it is the only reading in which every weighted entry is a quantity that a periodic
  /// gait must repeat).
  Eigen::Matrix<double, 14, 1> q_diag =
      (Eigen::Matrix<double, 14, 1>() << 0, 0, 600, 1000, 0, 0, 0, 1000, 10, 1, 1, 0, 0, 0)
          .finished();
  /// diag(R) of I2 = 1/2 int u' R u dt: 1e-2 diag(1, 1e-2, 1e-4, 1e-4).
  Eigen::Vector4d r_diag = Eigen::Vector4d(1e-2, 1e-4, 1e-6, 1e-6);
  /// Weight of I3 = Delta E (41) (the paper uses 1).
  double energy_weight = 1.0;
  /// w of I4 (applied by the engine through Problem::surface_weights, reported by Terms()).
  double surface_weight = kHopperSurfaceWeight;
};

/// The four terms of (42) for one hop, separately.
struct HopperCostTerms {
  double i1 = 0.0;  ///< periodicity (takeoff(x^-(T2)) - x(0))' Q (...)
  double i2 = 0.0;  ///< effort 1/2 int u' R u dt
  double i3 = 0.0;  ///< touchdown energy loss Delta E (41)
  double i4 = 0.0;  ///< switching penalty w y_f(T1)^2
  double total() const { return i1 + i2 + i3 + i4; }
};

/// Cost (42) of one hop from takeoff (x(0), flight) through touchdown T1 to takeoff T2:
///   l_0 = l_1 = 1/2 u' R u                                    (I2)
///   phi_0(x^-(T1)) = energy_weight * Delta E(x^-(T1))          (I3, eq. (41))
///   phi_1(x^-(T2)) = (G(x^-(T2)) - x_ref)' Q (G(x^-(T2)) - x_ref)   (I1)
/// where G is the takeoff map (foot at x = 0) and x_ref = x(0) is set by SetReference.
/// I4 = w y_f(T1)^2 is NOT part of this class (the engine adds it from h_0).
/// Derivatives: exact (nested fixed-size AutoDiff for the Hessians).
class HopperCost : public SwitchedCost {
 public:
  explicit HopperCost(const HopperModel& model,
                      const HopperCostWeights& weights = HopperCostWeights());

  /// Sets x_ref = x(0), the 14-dim flight state at the start of the hop.
  void SetReference(const ConstVectorRef& x0_flight);
  const Eigen::Matrix<double, 14, 1>& reference() const { return x_ref_; }
  const HopperCostWeights& weights() const { return weights_; }

  /// I1..I4 of one hop: x_td is the flight state just before touchdown (14), x_to the stance state
  /// just before takeoff (10), effort_integral = int 1/2 u' R u dt over the hop (see InputCost).
  HopperCostTerms Terms(const ConstVectorRef& x_td, const ConstVectorRef& x_to,
                        double effort_integral) const;
  /// 1/2 u' R u.
  double InputCost(const ConstVectorRef& u) const;

 protected:
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override;
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u,
                            VectorRef lx, VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override;
  double DoSwitching(int k, const ConstVectorRef& x) const override;
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override;

 private:
  const HopperModel& model_;               // not owned; must outlive the cost
  HopperCostWeights weights_;
  Eigen::Matrix<double, 14, 1> x_ref_ = Eigen::Matrix<double, 14, 1>::Zero();  // x(0)
};

}  // namespace ddoc

#endif  // DDOC_HOPPER_HOPPER_COST_H_
