// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "hopper_setup.h"

#include <cmath>
#include <cstdio>

#include "ddoc/mujoco/hopper_sim.h"

namespace ddoc::app {
namespace {

plugin::Method ToPluginMethod(Method m) {
  switch (m) {
    case Method::kAlg1: return plugin::Method::kAlg1;
    case Method::kOcfb: return plugin::Method::kOcfb;
    case Method::kMrl: return plugin::Method::kMrl;
  }
  return plugin::Method::kAlg1;
}

}  // namespace

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
  config.method = ToPluginMethod(s.method);
  config.model = model;
  config.gait.forward_speed = s.forward_speed;
  if (s.gait_k0_hip) config.gait.k0_hip = *s.gait_k0_hip;
  if (s.gait_k0_leg) config.gait.k0_leg = *s.gait_k0_leg;
  const LearningOverrides& l = s.learning;
  if (l.c) config.learner.c = *l.c;
  if (l.gamma) config.learner.gamma = *l.gamma;
  if (l.epsilon) config.learner.epsilon = *l.epsilon;
  if (l.delta_i) config.learner.delta_i = *l.delta_i;
  if (l.initial_hops) config.initial_hops = *l.initial_hops;
  if (l.alpha_min) config.learner.alpha_min = *l.alpha_min;
  if (l.max_duration_step) config.learner.switching.max_duration_step = *l.max_duration_step;
  if (l.alpha_scales_feedback) config.learner.controller.alpha_scales_feedback = *l.alpha_scales_feedback;
  if (l.regularization) {
    config.learner.controller.regularization = *l.regularization;
    config.model_learner.controller.regularization = *l.regularization;
  }
  if (l.per_input_regularization) {
    const RegularizationScaling scaling = *l.per_input_regularization
                                              ? RegularizationScaling::kPerInput
                                              : RegularizationScaling::kScalar;
    for (LearnerSettings* ls : {&config.learner, &config.model_learner}) {
      ls->controller.regularization_scaling = scaling;
      ls->backward.regularization_scaling = scaling;
    }
  }
  if (l.reset_alpha_on_accept) config.learner.reset_alpha_on_accept = *l.reset_alpha_on_accept;
  if (l.alpha_initial) config.learner.alpha_initial = *l.alpha_initial;
  if (l.cyclic_value) {
    config.learner.backward.cyclic_value = *l.cyclic_value;
    config.model_learner.backward.cyclic_value = *l.cyclic_value;
  }
  if (l.terminal_event) {
    config.learner.backward.terminal_event = *l.terminal_event;
    config.model_learner.backward.terminal_event = *l.terminal_event;
  }
  if (l.anchor_reference) config.anchor_reference = *l.anchor_reference;
  if (l.flight_pitch_feedback) config.flight_pitch_feedback = *l.flight_pitch_feedback;
  if (l.flight_pitch_feedback_from_hop) {
    config.flight_pitch_feedback_from_hop = *l.flight_pitch_feedback_from_hop;
  }
  return config;
}

}  // namespace ddoc::app
