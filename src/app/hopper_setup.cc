// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "hopper_setup.h"

#include <cmath>
#include <cstdio>

#include "ddoc/mujoco/hopper_sim.h"

namespace ddoc::app {

std::string FallReason(const FallLimits& lim, const Eigen::Matrix<double, 14, 1>& x,
                       double phase_time) {
  char buf[160];
  if (!x.allFinite()) return "the measured state is not finite";
  if (x(hopper::kY) < lim.min_height) {
    std::snprintf(buf, sizeof(buf), "body height %.3f m below %.2f m", x(hopper::kY), lim.min_height);
    return buf;
  }
  if (std::abs(x(hopper::kPhi)) > lim.max_pitch) {
    std::snprintf(buf, sizeof(buf), "body pitch %.2f rad beyond +-%.2f rad", x(hopper::kPhi),
                  lim.max_pitch);
    return buf;
  }
  if (std::abs(x(hopper::kTheta)) > lim.max_leg_angle) {
    std::snprintf(buf, sizeof(buf), "leg angle %.2f rad beyond +-%.2f rad", x(hopper::kTheta),
                  lim.max_leg_angle);
    return buf;
  }
  if (phase_time > lim.max_phase) {
    std::snprintf(buf, sizeof(buf), "no touchdown or takeoff for %.1f s (stalled)", phase_time);
    return buf;
  }
  return "";
}

HopperParams ModelParams(const Scenario& s) {
  HopperParams p;
  if (!s.model_mjcf.empty()) p = LoadHopperParamsFromMjcf(s.model_mjcf);
  const ModelNumbers& n = s.model_numbers;
  if (n.mass) p.M = *n.mass;
  if (n.j_body) p.J_body = *n.j_body;
  if (n.j_leg) p.J_leg = *n.j_leg;
  if (n.r0) p.r0 = *n.r0;
  if (n.drag) p.c_d = *n.drag;
  if (n.beta) p.beta = *n.beta;
  if (n.gravity) p.g = *n.gravity;
  p.Validate();
  return p;
}

plugin::ControllerConfig ControllerConfigFor(const Scenario& s, const HopperParams& model) {
  plugin::ControllerConfig config;
  config.driver.method = s.method;
  config.model = model;
  config.gait.forward_speed = s.forward_speed;
  if (s.gait_k0_hip) config.gait.k0_hip = *s.gait_k0_hip;
  if (s.gait_k0_leg) config.gait.k0_leg = *s.gait_k0_leg;
  const LearningOverrides& l = s.learning;
  LearnerSettings& learner = config.driver.learner;
  if (l.c) learner.c = *l.c;
  if (l.gamma) learner.gamma = *l.gamma;
  if (l.epsilon) learner.epsilon = *l.epsilon;
  if (l.delta_i) learner.delta_i = *l.delta_i;
  if (l.initial_hops) config.driver.warmup_trials = *l.initial_hops;
  if (l.alpha_min) learner.alpha_min = *l.alpha_min;
  if (l.max_duration_step) learner.switching.max_duration_step = *l.max_duration_step;
  if (l.alpha_scales_feedback) learner.controller.alpha_scales_feedback = *l.alpha_scales_feedback;
  if (l.reset_alpha_on_accept) learner.reset_alpha_on_accept = *l.reset_alpha_on_accept;
  if (l.alpha_initial) learner.alpha_initial = *l.alpha_initial;
  // The regularization mu, the cyclic value and the terminal condition apply to both learners
  // (the model solve of u^0 and the robot's); mu is the same in the online QP (33) and the
  // Riccati pass.
  for (LearnerSettings* ls : {&learner, &config.model_learner}) {
    if (l.regularization) {
      ls->controller.regularization = *l.regularization;
      ls->backward.riccati_regularization = *l.regularization;
    }
    if (l.cyclic_value) ls->backward.cyclic_value = *l.cyclic_value;
    if (l.terminal_event) ls->backward.terminal_event = *l.terminal_event;
  }
  if (l.anchor_reference) config.anchor_reference = *l.anchor_reference;
  const ExperimentOverrides& x = s.experiment;
  if (x.flight_pitch_feedback) config.pitch_experiment.scale = *x.flight_pitch_feedback;
  if (x.from_hop) config.pitch_experiment.from_hop = *x.from_hop;
  return config;
}

}  // namespace ddoc::app
