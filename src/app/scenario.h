// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Scenario files for ddoc-hopper: which robot, which model, which method, how long,
// and which pushes. Parsing lives here, at the edge; the engine never sees XML.
#ifndef DDOC_APP_SCENARIO_H_
#define DDOC_APP_SCENARIO_H_

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ddoc/hopper/identification.h"
#include "ddoc/hopper/push.h"
#include "ddoc/trial_driver.h"

namespace ddoc::app {

/// A bad scenario file or flag. The message names the file, the line and the element.
class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// "alg1" | "ocfb" | "mrl" (ddoc::Method); throws ScenarioError naming the bad value.
Method ParseMethod(const std::string& name);
const char* MethodName(Method method);

/// Model parameters given as numbers (Table I); unset fields keep the defaults of
/// the analytic hopper. Used when the scenario has no model MJCF.
struct ModelNumbers {
  std::optional<double> mass;     // M [kg]
  std::optional<double> j_body;   // J_body [kg m^2]
  std::optional<double> j_leg;    // J_leg [kg m^2]
  std::optional<double> r0;       // natural leg length [m]
  std::optional<double> drag;     // c_d [kg/m]
  std::optional<double> beta;     // VSA bandwidth [rad/s]
  std::optional<double> gravity;  // g [m/s^2]
  std::optional<double> b_leg;    // leg damping [N s/m]
  std::optional<double> b_hip;    // hip damping [N m s/rad]
  std::optional<double> slope;    // floor slope [rad], > 0 rises towards +x
};

/// Algorithm 1 settings a scenario may override (LearnerSettings; unset = the plugin default).
struct LearningOverrides {
  bool paper = false;  // preset="paper": HopperPaperLearnerSettings, cyclic 0, terminal time, own

  std::optional<double> c;                  // sufficient-decrease constant of (36)
  std::optional<double> gamma;              // backtracking factor
  std::optional<double> epsilon;            // convergence threshold on int|du|^2 + |dT|^2
  std::optional<int> delta_i;               // convergence window (accepted iterations)
  std::optional<int> initial_hops;          // TrialDriverSettings::warmup_trials, >= 1
  std::optional<double> alpha_min;          // line search gives up below this alpha
  std::optional<double> max_duration_step;  // cap on |dD_k| of (31), s
  std::optional<double> regularization;     // LearnerSettings::regularization_min (both learners)
  std::optional<bool> reset_alpha_on_accept;  // alpha_after_accept="reset" (paper) | "grow"
  std::optional<double> alpha_initial;      // alpha_0 of the line search, in (0, 1]
  std::optional<double> cyclic_value;       // BackwardPassSettings::cyclic_value, in [0, 1]
  std::optional<bool> terminal_event;       // terminal="time" (paper) | "event" (terminal_event)
  // reference="own" (paper: I1 compares the takeoff state with the hop's own start) | "gait" (the
  // model gait's takeoff state: ControllerConfig::anchor_reference)
  std::optional<bool> anchor_reference;
  std::optional<double> anchor_weight;  // ControllerConfig::anchor_weight, in [0, 1]
  std::optional<double> reference_filter;  // ControllerConfig::reference_filter, in (0, 1]
  std::optional<double> overspeed_latch;   // ControllerConfig::overspeed_latch, m/s, >= 0
  std::optional<bool> remeasure;        // remeasure="on": LearnerSettings::remeasure_nominal
  std::optional<double> noise_margin;   // LearnerSettings::noise_margin (with remeasure="on")
  std::optional<int> hops_per_trial;    // TrialDriverSettings::runs_per_trial, >= 1
  std::optional<int> verify_hops;       // HarmGuardSettings::verify_trials, 0 or >= 2
  std::optional<double> verify_margin;  // HarmGuardSettings::margin, >= 0
  std::optional<int> watch_hops;        // HarmGuardSettings::watch_trials, >= 2
  std::optional<bool> verify_debias;    // HarmGuardSettings::debias
  std::optional<bool> verify_interleave;  // HarmGuardSettings::interleave
  std::optional<bool> verify_log;       // HarmGuardSettings::log_cost
  std::optional<bool> verify_when_worse;  // HarmGuardSettings::only_when_worse
  std::optional<bool> verify_when_never;  // verify_when="never": !HarmGuardSettings::verify_accepted
  std::optional<double> watch_ratio;    // HarmGuardSettings::watch_ratio, 0 or >= 1
  std::optional<bool> watch_u0;         // "on"/"off": HarmGuardSettings::watch_initial
  std::optional<double> watch_max_mass;  // ControllerConfig::watch_max_mass, >= 0
  std::optional<double> curvature_scale_min;  // LearnerSettings::curvature_scale_min, (0, 1]
  std::optional<bool> blend_feedback;   // "on"/"off": LearnerSettings::blend_feedback
  std::optional<bool> blend_feedforward;  // "on"/"off": LearnerSettings::blend_feedforward
  std::optional<double> min_predicted_decrease;  // LearnerSettings::min_predicted_decrease, >= 0
  std::optional<bool> start_correction;  // "on"/"off": LearnerSettings::start_correction
  std::optional<double> restart_alpha;   // LearnerSettings::restart_alpha, in (0, 1]
};

/// <experiment .../>: settings that are NOT the paper and not defaults (docs/experiments.md).
struct ExperimentOverrides {
  std::optional<double> flight_pitch_feedback;  // PitchFeedbackExperiment::scale, in [0, 1]
  std::optional<int> from_hop;                  // PitchFeedbackExperiment::from_hop, >= 1
};

/// A push placed by the phase of a hop: it starts phase x (the previous hop's duration, takeoff to
/// takeoff) after hop `hop` starts (its takeoff, hops.csv t_start), and is resolved to a Push when
/// that hop starts (RunStepper). <push hop="15" phase="0.375" force=".." duration=".."/>.
struct HopPush {
  int hop = 1;            ///< >= 1 (hop 0 has no previous hop)
  double phase = 0.0;     ///< in [0, 1)
  double force = 0.0;     ///< N
  double duration = 0.1;  ///< s, > 0
};

/// Everything one run needs. Paths are absolute or relative to the current directory
/// (relative paths in the file are resolved against the scenario file's folder).
struct Scenario {
  std::string name;                  // label used in logs and plots
  std::string file;                  // the scenario file itself ("" when built from flags)
  std::string robot_mjcf;            // the true robot (required)
  std::string model_mjcf;            // the model as an MJCF ("" = use model_numbers)
  ModelNumbers model_numbers;        // the model as numbers
  Method method = Method::kAlg1;     // alg1 | ocfb | mrl (ddoc::Method)
  int hops = 100;                    // stop after this many hops (0 = use seconds)
  double seconds = 0.0;              // stop after this simulated time (0 = use hops)
  std::vector<Push> pushes;          // in time order
  std::vector<HopPush> hop_pushes;   // in (hop, phase) order
  double forward_speed = 0.0;        // forward speed of the nominal gait [m/s]
  // Constant stiffness commands of the nominal gait (NominalGaitSettings; unset = 50 N m/rad and
  // 2000 N/m). They must lie in the input bounds [10, 150] and [1780, 2350].
  std::optional<double> gait_k0_hip, gait_k0_leg;
  LearningOverrides learning;        // <learning .../>
  ExperimentOverrides experiment;    // <experiment .../>
  // <contact substep_events="on|off"/>: ContactPhaseSettings::substep_events (unset: off)
  std::optional<bool> substep_events;
  // <identification mass="on|off" terms="on|off" terms_acted="LIST" settle_hops="N"
  // settle_cost="F" settle_hops_max="N" resolve_latency="S" model_law="on|off"
  // min_predicted_decrease="F"/>: IdentificationSettings (unset: off, off, all, 2, 2, 30, 0.1 s,
  // on, 0.03); terms_acted as ParseActedTerms reads it
  std::optional<bool> identify_mass;
  std::optional<bool> identify_terms;
  std::optional<TermsIdentification::Settings::Acted> identify_terms_acted;
  std::optional<int> settle_hops;
  std::optional<double> settle_cost;
  std::optional<int> settle_hops_max;
  std::optional<double> resolve_latency;
  std::optional<bool> model_law;
  std::optional<double> id_min_predicted_decrease;
};

/// Reads a scenario file; throws ScenarioError naming the file, line and element.
Scenario LoadScenario(const std::string& path);

/// Checks ranges and files (robot/model MJCF exist, hops/seconds, pushes). Throws ScenarioError.
void ValidateScenario(const Scenario& scenario);

/// Parses "TIME,FORCE,DURATION" (the --push format of every executable). Throws ScenarioError.
Push ParsePush(const std::string& text);

/// Parses "HOP@PHASE,FORCE,DURATION" (ddoc-hopper's --push by hop phase). Throws ScenarioError.
HopPush ParseHopPush(const std::string& text);

/// Parses "a,b,c" into exactly n finite numbers (ddoc-drop's --state and --u). Throws
/// ScenarioError naming `option` and the bad item or the count.
std::vector<double> ParseNumberList(const std::string& text, size_t n, const char* option);

/// Parses a whole string as one finite number (no trailing characters, no nan/inf); false if not.
bool ParseFiniteNumber(const std::string& text, double* value);

}  // namespace ddoc::app

#endif  // DDOC_APP_SCENARIO_H_
