// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A small event-locating integrator for ONE hop of the analytic hopper (takeoff -> touchdown ->
// takeoff) under a given input. It is the hopper's own model plant for the nominal-gait search
// and the analytic-vs-MuJoCo tests (the engine's generic ModelPlant is independent of it).
#ifndef DDOC_HOPPER_HOP_SIMULATOR_H_
#define DDOC_HOPPER_HOP_SIMULATOR_H_

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ddoc/hopper/hopper_model.h"

namespace ddoc {

/// Settings of SimulateHop.
struct HopSimSettings {
  double dt = 1e-3;          ///< RK4 step, s
  double max_flight = 2.0;   ///< give up if flight lasts longer, s
  double max_stance = 1.0;   ///< give up if stance lasts longer, s
  int bisections = 60;       ///< bisection steps locating each event inside an RK4 step
  bool record = false;       ///< store the sampled trajectory (t, mode, x)
  bool stop_at_touchdown = false;  ///< end after the flight phase (touchdown reset applied)
};

/// One sample of a recorded hop. x has n_mode entries.
struct HopSample {
  double t = 0.0;
  int mode = 0;
  Eigen::VectorXd x;
};

/// The result of one hop from a flight state x0.
struct HopResult {
  bool ok = false;          ///< false: no touchdown/takeoff within the limits (see message)
  std::string message;      ///< why not ok
  double t1 = 0.0;          ///< touchdown time T1, s
  double t2 = 0.0;          ///< takeoff time T2, s
  double foot_x = 0.0;      ///< absolute foot x during stance
  Eigen::Matrix<double, 14, 1> x_td_minus;  ///< flight state just before touchdown
  Eigen::Matrix<double, 10, 1> x_td_plus;   ///< stance state just after touchdown
  Eigen::Matrix<double, 10, 1> x_to_minus;  ///< stance state just before takeoff
  Eigen::Matrix<double, 14, 1> x_to_plus;   ///< flight state after takeoff (absolute x)
  double apex = 0.0;        ///< highest COM height during the flight phase, m
  double effort = 0.0;      ///< int 1/2 u' R u dt with R of Fig. 2 (I2)
  std::vector<HopSample> samples;  ///< filled when settings.record
};

/// Input as a function of (time since takeoff, mode, state).
using HopPolicy = std::function<Eigen::Vector4d(double t, int mode, const Eigen::VectorXd& x)>;

/// Integrates flight (mode 0) from x0 (14) until the foot height crosses 0 descending, applies
/// the touchdown reset, integrates stance (mode 1) until F_leg crosses 0 from above, applies the
/// takeoff map with the absolute foot x. RK4 with fixed dt; events located by bisection.
HopResult SimulateHop(const HopperModel& model, const Eigen::Matrix<double, 14, 1>& x0,
                      const HopPolicy& policy, const HopSimSettings& settings = HopSimSettings());

/// Convenience overload with a constant input u.
HopResult SimulateHop(const HopperModel& model, const Eigen::Matrix<double, 14, 1>& x0,
                      const Eigen::Vector4d& u, const HopSimSettings& settings = HopSimSettings());

/// Integrates one mode for a fixed duration (no events). x has n_k entries; returns the samples
/// every dt (including t = 0 and t = duration).
std::vector<HopSample> IntegrateMode(const HopperModel& model, int k, const Eigen::VectorXd& x0,
                                     const Eigen::Vector4d& u, double duration, double dt);

}  // namespace ddoc

#endif  // DDOC_HOPPER_HOP_SIMULATOR_H_
