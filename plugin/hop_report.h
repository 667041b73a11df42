// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// What one hop (one trial) did on the robot: the one hop report type, written to the logs as is.
#ifndef DDOC_PLUGIN_HOP_REPORT_H_
#define DDOC_PLUGIN_HOP_REPORT_H_

#include <array>
#include <limits>
#include <string>
#include <utility>

#include <Eigen/Core>

#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/identification.h"
#include "ddoc/learner.h"

namespace ddoc::plugin {

/// One hop, measured on the robot, and what the learner made of it.
struct HopReport {
  int hop = 0;                  ///< 0-based
  double t_start = 0.0;         ///< takeoff time that started the hop, s
  double t_touchdown = 0.0;     ///< s
  double t_end = 0.0;           ///< time of the hop's last stance sample, s
  HopperCostTerms terms;        ///< I1..I4 of (42), I1 against the hop's own start
  double cost = 0.0;            ///< I1 + I2 + I3 + I4
  double t1 = 0.0;              ///< flight duration, s
  double t2 = 0.0;              ///< period, s
  double step_length = 0.0;     ///< touchdown foot x minus the previous touchdown foot x, m
  double speed = 0.0;           ///< (x_end - x_start) / t2, m/s
  double apex = 0.0;            ///< max COM height during flight, m
  double foot_height_td = 0.0;  ///< foot height at touchdown (the I4 surface), m
  double alpha = 0.0;           ///< line-search parameter of the law that ended the hop
  double du2 = 0.0;             ///< int |du|^2 dtau of that law over the hop
  double dt2 = 0.0;             ///< |dT|^2 of that law (planned vs nominal)
  int nonfinite = 0;            ///< steps with a non-finite measured state in this hop
  /// COM (x, y, xd, yd), world frame, at touchdown (the last pre-impact state) and at the
  /// takeoff that ends the hop (the first flight state).
  Eigen::Vector4d body_touchdown = Eigen::Vector4d::Zero();
  Eigen::Vector4d body_takeoff = Eigen::Vector4d::Zero();
  /// The robot's mass from the hop's stance (docs/hopper.md, "The mass from a stance"), kg: the
  /// floor's vertical impulse / (yd(takeoff) - yd(touchdown) + g T_stance). NaN: no stance.
  double stance_mass = std::numeric_limits<double>::quiet_NaN();
  /// The stance's balance for MassIdentification (docs/hopper.md, "Identifying the mass").
  HopIdentificationData identification;
  /// MassIdentification's estimate after this hop's stance, kg (NaN: no stance yet).
  double identified_mass = std::numeric_limits<double>::quiet_NaN();
  /// The model's M when the hop ended, kg (changes only with ControllerConfig::identification).
  double model_mass = std::numeric_limits<double>::quiet_NaN();
  /// TermsIdentification's estimates after this hop (NaN before their first sample; the
  /// standard errors infinite until determined) and the model's terms when the hop ended.
  TermsIdentification::Estimate identified_terms;
  HopperParams model_params;
  // From the trial driver (TrialOutcome):
  bool accepted = false;        ///< (36) held (true for trials it does not judge)
  double learner_cost = 0.0;    ///< the measured cost the driver saw (EvaluateCost)
  LearnerStatus status = LearnerStatus::kRunning;  ///< the learner's status after the hop
  double start_shift = 0.0;  ///< TrialOutcome::start_shift: the start correction of (36)
  bool restarted = false;    ///< TrialOutcome::restarted: the line search restarted after it
  bool remeasured = false;   ///< TrialOutcome::remeasured: the hop re-ran the nominal's law
  bool reverted = false;     ///< TrialOutcome::reverted: the harm guard abandoned the law after it
  /// The learner's I1 reference was latched to the gait's state (ControllerConfig::overspeed_latch)
  bool reference_latched = false;
  /// TrialOutcome::nominal_cost: the I^i that learner_cost was compared with (NaN: not judged)
  double nominal_cost = std::numeric_limits<double>::quiet_NaN();
  /// TrialOutcome::predicted: the predicted change dI_pred(alpha) of the trial (NaN: not judged)
  double predicted = std::numeric_limits<double>::quiet_NaN();
  /// TrialOutcome::optimality: the nominal's first-order optimality after the hop (NaN: not judged)
  double optimality = std::numeric_limits<double>::quiet_NaN();
  /// Wall time of the offline part that learned from this hop, ms (NaN: the hop was not handed
  /// to it).
  double offline_ms = std::numeric_limits<double>::quiet_NaN();
  /// Simulated time from the hop's end until the law learned from it took effect, ms: the
  /// configured offline_latency, with modeled_latency at least the model's time for
  /// offline_steps, with measured_latency at least offline_ms (NaN: no law).
  double latency_ms = std::numeric_limits<double>::quiet_NaN();
  /// Integration steps of the backward passes in the offline part of this hop (0: none; -1: the
  /// hop was not handed to it).
  long offline_steps = -1;
  /// CPU time of the thread that ran that offline part, ms (NaN: not handed to it): its own
  /// time, without the waits of a loaded machine (the latency model's calibration).
  double offline_cpu_ms = std::numeric_limits<double>::quiet_NaN();
};

/// One re-solve of u^0 on an identified model (IdentificationSettings).
struct ModelResolve {
  int hop = 0;            ///< the hop whose stance made the model leave the estimate's region
  HopperParams model;     ///< the new model (ResolvedTerms: what identification may change)
  double wall_ms = 0.0;   ///< wall time of the re-solve (gait + u^0, or the law cache), ms
  int took_over_hop = -1; ///< the hop in which the new u^0 took over (-1: not yet)
  /// The new driver's "Initialize" hop (settle_hops, settle_cost; -1: not yet, or OC-FB).
  int initialize_hop = -1;
  std::string law_cache;  ///< where the new u^0 came from (as law_cache_status())
};

/// The terms of a model that identification may change, named as in summary.json's
/// identification.resolves and Python's run_hopper()["resolves"]: mass (M), b_leg, b_hip, slope,
/// j_body, j_leg, c_d.
inline std::array<std::pair<const char*, double>, 7> ResolvedTerms(const HopperParams& p) {
  return {{{"mass", p.M},
           {"b_leg", p.b_leg},
           {"b_hip", p.b_hip},
           {"slope", p.slope},
           {"j_body", p.J_body},
           {"j_leg", p.J_leg},
           {"c_d", p.c_d}}};
}

}  // namespace ddoc::plugin

#endif  // DDOC_PLUGIN_HOP_REPORT_H_
