// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "hopper_run.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>

#include <unistd.h>

#include "mujoco_warnings.h"
#include "robot_variant.h"

#ifdef DDOC_HAVE_RENDER
#include "ddoc/render/frame_recorder.h"
#endif

namespace ddoc::app {

int RunTool(const char* tool, int (*run)(int argc, char** argv), int argc, char** argv) {
  RouteMujocoWarnings(tool);
  try {
    return run(argc, argv);
  } catch (const RunError& e) {
    std::fprintf(stderr, "%s: %s\n", tool, e.what());
    return e.code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: internal error: %s\n", tool, e.what());
    return kExitError;
  }
}

std::string FallReason(const FallLimits& lim, const Eigen::Matrix<double, 14, 1>& x,
                       double phase_time, double floor_slope) {
  char buf[160];
  if (!x.allFinite()) return "the measured state is not finite";
  if (floor_slope == 0.0 && x(hopper::kY) < lim.min_height) {
    std::snprintf(buf, sizeof(buf), "body height %.3f m below %.2f m", x(hopper::kY),
                  lim.min_height);
    return buf;
  }
  // On a sloped floor (the foot-centre line y = x tan(slope) through the origin) the height is
  // the COM's above the floor under it: a robot hopping down hill has not fallen.
  const double above_floor = x(hopper::kY) - x(hopper::kX) * std::tan(floor_slope);
  if (floor_slope != 0.0 && above_floor < lim.min_height) {
    std::snprintf(buf, sizeof(buf), "body height %.3f m above the floor below %.2f m",
                  above_floor, lim.min_height);
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
  if (n.b_leg) p.b_leg = *n.b_leg;
  if (n.b_hip) p.b_hip = *n.b_hip;
  if (n.slope) p.slope = *n.slope;
  p.Validate();
  return p;
}

plugin::ControllerConfig ControllerConfigFor(const Scenario& s, const HopperParams& model) {
  plugin::ControllerConfig config;
  const LearningOverrides& l = s.learning;
  if (l.paper) {
    // Algorithm 1 as printed on the paper's reading of the hopper (docs/hopper.md).
    config.driver = HopperTrialSettings(Preset::kPaper);
    config.model_learner.backward.cyclic_value = 0.0;
    config.model_learner.backward.terminal_event = false;
    config.anchor_reference = false;
  }
  config.driver.method = s.method;
  config.model = model;
  config.gait.forward_speed = s.forward_speed;
  if (s.gait_k0_hip) config.gait.k0_hip = *s.gait_k0_hip;
  if (s.gait_k0_leg) config.gait.k0_leg = *s.gait_k0_leg;
  LearnerSettings& learner = config.driver.learner;
  if (l.c) learner.c = *l.c;
  if (l.gamma) learner.gamma = *l.gamma;
  if (l.epsilon) learner.epsilon = *l.epsilon;
  if (l.delta_i) learner.delta_i = *l.delta_i;
  if (l.initial_hops) config.driver.warmup_trials = *l.initial_hops;
  if (l.alpha_min) learner.alpha_min = *l.alpha_min;
  if (l.max_duration_step) learner.switching.max_duration_step = *l.max_duration_step;
  if (l.reset_alpha_on_accept) {
    learner.alpha_after_accept =
        *l.reset_alpha_on_accept ? AlphaAfterAccept::kReset : AlphaAfterAccept::kGrow;
  }
  if (l.alpha_initial) learner.alpha_initial = *l.alpha_initial;
  if (l.remeasure) learner.remeasure_nominal = *l.remeasure;
  if (l.noise_margin) learner.noise_margin = *l.noise_margin;
  if (l.hops_per_trial) config.driver.runs_per_trial = *l.hops_per_trial;
  if (l.verify_hops) config.driver.guard.verify_trials = *l.verify_hops;
  if (l.verify_margin) config.driver.guard.margin = *l.verify_margin;
  if (l.watch_hops) config.driver.guard.watch_trials = *l.watch_hops;
  if (l.verify_debias) config.driver.guard.debias = *l.verify_debias;
  if (l.verify_interleave) config.driver.guard.interleave = *l.verify_interleave;
  if (l.verify_log) config.driver.guard.log_cost = *l.verify_log;
  if (l.verify_when_worse) config.driver.guard.only_when_worse = *l.verify_when_worse;
  if (l.verify_when_never) config.driver.guard.verify_accepted = !*l.verify_when_never;
  if (l.watch_ratio) config.driver.guard.watch_ratio = *l.watch_ratio;
  if (l.watch_u0) config.driver.guard.watch_initial = *l.watch_u0;
  if (l.watch_max_mass) config.watch_max_mass = *l.watch_max_mass;
  if (l.verify_hops && *l.verify_hops == 0) {
    // verify_hops="0" turns the harm guard off, its watch with it (unless set here as well).
    if (!l.watch_hops) config.driver.guard.watch_trials = 0;
    if (!l.watch_ratio) config.driver.guard.watch_ratio = 0.0;
    if (!l.verify_when_never) config.driver.guard.verify_accepted = true;
  }
  if (l.watch_max_mass && *l.watch_max_mass > 0 && config.driver.guard.watch_trials == 0) {
    throw ScenarioError("<learning watch_max_mass> > 0 needs the harm guard's watch "
                        "(watch_hops >= 2), which this scenario turns off");
  }
  if (l.curvature_scale_min) learner.curvature_scale_min = *l.curvature_scale_min;
  if (l.blend_feedback) learner.blend_feedback = *l.blend_feedback;
  if (l.blend_feedforward) learner.blend_feedforward = *l.blend_feedforward;
  if (l.min_predicted_decrease) learner.min_predicted_decrease = *l.min_predicted_decrease;
  if (l.start_correction) learner.start_correction = *l.start_correction;
  if (l.restart_alpha) learner.restart_alpha = *l.restart_alpha;
  // The regularization mu, the cyclic value and the terminal condition apply to both learners
  // (the model solve of u^0 and the robot's); mu is the floor of the one regularization of the
  // online QP (33) and the Riccati pass.
  for (LearnerSettings* ls : {&learner, &config.model_learner}) {
    if (l.regularization) ls->regularization_min = *l.regularization;
    if (l.cyclic_value) ls->backward.cyclic_value = *l.cyclic_value;
    if (l.terminal_event) ls->backward.terminal_event = *l.terminal_event;
  }
  if (l.anchor_reference) config.anchor_reference = *l.anchor_reference;
  if (l.anchor_weight) config.anchor_weight = *l.anchor_weight;
  if (l.reference_filter) config.reference_filter = *l.reference_filter;
  if (l.overspeed_latch) config.overspeed_latch = *l.overspeed_latch;
  const ExperimentOverrides& x = s.experiment;
  if (x.flight_pitch_feedback) config.pitch_experiment.scale = *x.flight_pitch_feedback;
  if (x.from_hop) config.pitch_experiment.from_hop = *x.from_hop;
  if (s.substep_events) config.contact.substep_events = *s.substep_events;
  if (s.identify_mass) config.identification.mass = *s.identify_mass;
  if (s.identify_terms) config.identification.terms = *s.identify_terms;
  if (s.identify_terms_acted) config.identification.terms_estimator.acted = *s.identify_terms_acted;
  if (s.settle_hops) config.identification.settle_hops = *s.settle_hops;
  if (s.settle_cost) config.identification.settle_cost = *s.settle_cost;
  if (s.settle_hops_max) config.identification.settle_hops_max = *s.settle_hops_max;
  if (s.resolve_latency) config.identification.resolve_latency = *s.resolve_latency;
  if (s.model_law) config.identification.model_law = *s.model_law;
  if (s.id_min_predicted_decrease) {
    config.identification.min_predicted_decrease = *s.id_min_predicted_decrease;
  }
  return config;
}

void RunOverrides::Register(CLI::App* cli, bool full) {
  cli->add_option("--method,-m", method, "alg1 | ocfb | mrl (overrides the scenario)");
  cli->add_option("--preset", preset,
                  "default | paper | identified: the learner and the hopper's reading; identified "
                  "= default with --identify (overrides the scenario)");
  cli->add_flag_function(
      "--identify,!--no-identify", [this](std::int64_t count) { identify = count > 0; },
      "identify the robot's mass from the stances and re-solve u^0 on it when the model's "
      "leaves the estimate's confidence region (<identification mass>; overrides the scenario)");
  cli->add_flag_function(
      "--identify-terms,!--no-identify-terms",
      [this](std::int64_t count) { identify_terms = count > 0; },
      "identify the leg and hip damping and the floor slope from the hops and re-solve u^0 on "
      "them when the model's leave the estimates' confidence regions (<identification terms>; "
      "overrides the scenario)");
  cli->add_option_function<std::string>(
         "--identify-terms-acted",
         [this](const std::string& text) {
           try {
             identify_terms_acted = ParseActedTerms(text);
           } catch (const InvalidArgument& error) {
             throw CLI::ValidationError("--identify-terms-acted", error.what());
           }
         },
         "the identified terms that re-solve u^0 (with --identify-terms): all (default), none or "
         "a comma-separated list of b_leg, b_hip, j_body, c_d, slope; the others are estimated "
         "and reported only (<identification terms_acted>; overrides the scenario)")
      ->type_name("LIST");
  cli->add_flag("--no-pushes", no_pushes, "ignore the scenario's pushes");
  cli->add_flag("--substep-events", substep_events,
                "locate touchdown and takeoff inside the physics step for the measured durations "
                "and cost (ContactPhaseSettings::substep_events; overrides the scenario)");
  cli->add_option_function<std::string>(
         "--offline-latency",
         [this](const std::string& text) {
           if (text == "measured") {
             measured_latency = true;
             return;
           }
           if (text == "modeled") return;  // the default
           double s = 0;
           if (!ParseFiniteNumber(text, &s)) {
             throw CLI::ValidationError(
                 "--offline-latency",
                 "\"" + text + "\" is neither a number of s, modeled nor measured");
           }
           offline_latency = s;
         },
         "simulated s from a hop's end until the law learned from it takes effect: modeled "
         "(default): max(0.02, the latency model's time for the hop's offline part: 1 ms + 3.6 "
         "us per integration step of its backward passes); measured: max(0.02, its wall time on "
         "this computer); a number: that, fixed (0: learn inside the control callback, "
         "synchronously)")
      ->type_name("modeled|measured|S");
  user_law_cache = true;
  CLI::Option* dir = cli->add_option(
      "--law-cache", law_cache,
      "directory of stored initial laws u^0: load u^0 when the model solve's inputs and binaries "
      "match, else solve and store it (default: $DDOC_LAW_CACHE, set and empty: off; unset: "
      "$XDG_CACHE_HOME/ddoc or ~/.cache/ddoc)");
  cli->add_flag("--no-law-cache", no_law_cache,
                "always solve u^0 on the model (about 1 s); nothing is read or stored")
      ->excludes(dir);
  if (!full) return;
  cli->add_option("--hops", hops, "number of hops (overrides the scenario)");
  cli->add_option("--seconds", seconds, "simulated seconds (overrides the scenario)");
  cli->add_option("--robot", robot, "robot MJCF (overrides the scenario)");
  cli->add_option("--robot-variant", robot_variant,
                  "the robot's numbers: KEY=VALUE,... with mass (torso, kg), j_body (kg m^2), c_d "
                  "(drag, kg/m), beta (VSA bandwidth, rad/s), hip_gain, leg_gain (motor strength, 1 = as "
                  "commanded), b_leg (N s/m), b_hip (N m s/rad) (joint damping), slope (floor, "
                  "rad, > 0 down hill), contact_timeconst (s), r0 (the leg's rest length, m), e.g. "
                  "mass=11,c_d=0.02");
  cli->add_option("--model-mjcf", model_mjcf, "model MJCF (overrides the scenario's model)");
  cli->add_option("--push", pushes,
                  "extra push TIME,FORCE,DURATION (s, N, s), or HOP@PHASE,FORCE,DURATION by the "
                  "phase of a hop (repeatable)");
}

bool IsPreset(const std::string& name) {
  return name == "default" || name == "paper" || name == "identified";
}

std::string DefaultLawCacheDir() {
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  if (xdg != nullptr && xdg[0] == '/') return std::string(xdg) + "/ddoc";
  const char* home = std::getenv("HOME");
  if (home != nullptr && home[0] != '\0') return std::string(home) + "/.cache/ddoc";
  return "";
}

namespace {

// The robot MJCF `path` with its includes inlined and `variant` applied (ExpandRobotMjcf), loaded
// from a temporary file; errors name `path`.
MjModelPtr LoadExpandedMjcf(const std::string& path, const RobotVariant& variant) {
  const std::string text = ExpandRobotMjcf(path, variant);
  char name[] = "/tmp/ddoc-robot-XXXXXX.xml";
  const int fd = mkstemps(name, 4);
  if (fd < 0) throw std::runtime_error("robot MJCF '" + path + "': cannot create a temporary file");
  const bool written = write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  close(fd);
  try {
    if (!written) throw std::runtime_error("cannot write " + std::string(name));
    MjModelPtr m = LoadMjcf(name);
    unlink(name);
    return m;
  } catch (const std::exception& e) {
    unlink(name);
    throw std::runtime_error("robot MJCF '" + path + "' (includes inlined into " + name +
                             "): " + e.what());
  }
}

// The scenario file with the command-line overrides applied and validated.
Scenario ScenarioWithOverrides(const std::string& path, const RunOverrides& o) {
  Scenario s = LoadScenario(path);
  if (!o.method.empty()) s.method = ParseMethod(o.method);
  if (!o.preset.empty()) {
    if (!IsPreset(o.preset)) {
      throw ScenarioError("--preset \"" + o.preset + "\": expected " + kPresetNames);
    }
    s.learning.paper = o.preset == "paper";
    if (o.preset == "identified") s.identify_mass = true;
  }
  if (o.hops && *o.hops < 0) {
    throw ScenarioError("--hops must be >= 0, got " + std::to_string(*o.hops));
  }
  if (o.seconds && !(*o.seconds >= 0 && std::isfinite(*o.seconds))) {
    throw ScenarioError("--seconds must be a finite number >= 0");
  }
  if (o.hops) s.hops = *o.hops;
  if (o.seconds) s.seconds = *o.seconds;
  if (o.hops && !o.seconds) s.seconds = 0;
  if (o.seconds && !o.hops) s.hops = 0;
  if (!o.robot.empty()) s.robot_mjcf = o.robot;
  if (!o.model_mjcf.empty()) {  // the flag replaces the scenario's model, numbers included
    s.model_mjcf = o.model_mjcf;
    s.model_numbers = ModelNumbers();
  }
  if (o.substep_events) s.substep_events = true;
  if (o.identify) s.identify_mass = *o.identify;
  if (o.identify_terms) s.identify_terms = *o.identify_terms;
  if (o.identify_terms_acted) s.identify_terms_acted = *o.identify_terms_acted;
  if (o.no_pushes) {
    s.pushes.clear();
    s.hop_pushes.clear();
  }
  for (const std::string& p : o.pushes) {
    if (p.find('@') != std::string::npos) {
      s.hop_pushes.push_back(ParseHopPush(p));
    } else {
      s.pushes.push_back(ParsePush(p));
    }
  }
  ValidateScenario(s);
  return s;
}

}  // namespace

LoadedRun LoadRun(const std::string& scenario_path, const RunOverrides& overrides,
                  bool start_controller) {
  LoadedRun run;
  HopperParams params;
  try {
    run.scenario = ScenarioWithOverrides(scenario_path, overrides);
    const std::string& robot = run.scenario.robot_mjcf;
    const RobotVariant variant = overrides.robot_variant.empty()
                                     ? RobotVariant()
                                     : ParseRobotVariant(overrides.robot_variant, "--robot-variant");
    run.robot_name = robot + (variant.empty() ? "" : " with " + variant.ToString());
    run.model = variant.empty() && !IncludesNeedResolving(robot) ? LoadMjcf(robot)
                                                               : LoadExpandedMjcf(robot, variant);
    const HopperMapping map = HopperMapping::Build(run.model.get(), run.scenario.robot_mjcf);
    CheckSpringsAreStableAtTheTimestep(run.model.get(), map, run.scenario.robot_mjcf);
    params = ModelParams(run.scenario);
    run.config = ControllerConfigFor(run.scenario, params);
    // The model's numbers against the RK4 steps of the model plant and the gait search.
    params.CheckRk4Step(run.config.dt_model, "scenario <model>");
    params.CheckRk4Step(run.config.gait.dt, "scenario <model>");
  } catch (const std::exception& e) {
    throw RunError(kExitBadInput, e.what());
  }
  if (overrides.offline_latency) {
    run.config.offline_latency = *overrides.offline_latency;
    run.config.modeled_latency = false;
  }
  if (overrides.measured_latency) {  // this computer instead of the model's
    run.config.measured_latency = true;
    run.config.modeled_latency = false;
  }
  run.config.law_cache = overrides.law_cache;
  if (overrides.no_law_cache) {
    run.config.law_cache.clear();
  } else if (run.config.law_cache.empty()) {
    const char* env = std::getenv("DDOC_LAW_CACHE");
    if (env != nullptr) {
      run.config.law_cache = env;
    } else if (overrides.user_law_cache) {
      run.config.law_cache = DefaultLawCacheDir();
    }
  }
  run.data.reset(mj_makeData(run.model.get()));
  if (start_controller) StartController(&run);
  return run;
}

void StartController(LoadedRun* run) {
  std::string error;
  run->controller = plugin::HopperController::Create(run->model.get(), run->config, &error);
  if (!run->controller) {
    // A bad --offline-latency, a gait the search cannot find, or settings the controller's
    // config, the learner or the trial driver refuse (a scenario's <learning> attributes that
    // are each in range but not together, e.g. alpha_min >= alpha_initial) are bad input;
    // anything else failed inside the controller.
    const bool input = error.find("offline_latency") != std::string::npos ||
                       error.find("FindNominalGait") != std::string::npos ||
                       error.find("Create: config.") != std::string::npos ||
                       error.find("LearnerSettings: ") != std::string::npos ||
                       error.find("TrialDriverSettings: ") != std::string::npos;
    throw RunError(input ? kExitBadInput : kExitError, error);
  }
  run->controller->Reset(run->model.get(), run->data.get());
}

RunStepper::RunStepper(LoadedRun* run)
    : run_(run), pushes_now_(run->scenario.pushes),
      hop_push_times_(run->scenario.hop_pushes.size()) {
  plugin::Attach(run->controller.get());
  Restarted();
}

RunStepper::~RunStepper() { plugin::Detach(); }

void RunStepper::Restarted() {
  phase_start_ = run_->data->time;
  mode_ = run_->controller->mode();
  hop_ = run_->controller->hop();
  hop_start_ = run_->data->time;
}

void RunStepper::HopStarted(double t_start) {
  const double previous = t_start - hop_start_;  // the previous hop, takeoff to takeoff
  hop_start_ = t_start;
  const std::vector<HopPush>& hop_pushes = run_->scenario.hop_pushes;
  for (size_t i = 0; i < hop_pushes.size(); ++i) {
    const HopPush& p = hop_pushes[i];
    if (p.hop != hop_ || hop_push_times_[i]) continue;
    // The step that detected the takeoff has been taken: a push acts from the next step on.
    const double t = std::max(t_start + p.phase * previous, run_->data->time);
    hop_push_times_[i] = t;
    pushes_now_.push_back({t, p.force, p.duration});
  }
}

namespace {

// MuJoCo's counts of the NaN/Inf/huge-value warnings (mj_checkPos/Vel/Acc reset the state).
int BadValueWarnings(const mjData* d) {
  return d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number +
         d->warning[mjWARN_BADQACC].number;
}

// "" when qpos, qvel, qacc and ctrl are finite and MuJoCo reported no bad value in this step.
// `t` is the time of the step (MuJoCo's reset sets d->time to 0).
std::string NonFiniteReason(const mjModel* m, const mjData* d, int warnings_before, double t) {
  char buf[200];
  if (BadValueWarnings(d) > warnings_before) {
    const char* what = d->warning[mjWARN_BADQACC].number > 0   ? "qacc"
                       : d->warning[mjWARN_BADQVEL].number > 0 ? "qvel"
                                                               : "qpos";
    std::snprintf(buf, sizeof(buf),
                  "non-finite state: MuJoCo found a NaN, Inf or huge value in %s at t = %.4f s "
                  "(the simulation is unstable; MuJoCo reset the state)",
                  what, t);
    return buf;
  }
  auto finite = [](const mjtNum* v, int n) {
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite(v[i])) return false;
    }
    return true;
  };
  const char* what = !finite(d->qpos, m->nq)   ? "qpos"
                     : !finite(d->qvel, m->nv) ? "qvel"
                     : !finite(d->qacc, m->nv) ? "qacc"
                     : !finite(d->ctrl, m->nu) ? "ctrl"
                                               : nullptr;
  if (what == nullptr) return "";
  std::snprintf(buf, sizeof(buf), "non-finite state: mjData %s is not finite at t = %.4f s", what,
                t);
  return buf;
}

}  // namespace

StepOutcome RunStepper::Step() {
  const mjModel* m = run_->model.get();
  mjData* d = run_->data.get();
  plugin::HopperController& c = *run_->controller;
  push_ = pushes_ ? PushForce(pushes_now_, d->time) : 0.0;
  ApplyDragAndPush(c.mapping(), m, d, push_);
  const int warnings_before = BadValueWarnings(d);
  const double t_before = d->time;
  mj_step(m, d);
  if (c.hop() != hop_) {  // the takeoff at the control of this step began hop c.hop()
    hop_ = c.hop();
    HopStarted(t_before);
  }
  if (c.offline_pending()) c.RunOffline();  // between steps, outside mjcb_control
  if (c.failed()) return {StepOutcome::Kind::kFailed, c.error()};
  const std::string non_finite = NonFiniteReason(m, d, warnings_before, t_before);
  if (!non_finite.empty()) return {StepOutcome::Kind::kNonFinite, non_finite};
  x_ = FlightState(c.mapping(), d, c.vsa());
  if (!x_.allFinite()) {
    return {StepOutcome::Kind::kNonFinite, "non-finite state: the measured hopper state is not "
                                           "finite at t = " + std::to_string(d->time) + " s"};
  }
  if (c.mode() != mode_) {
    mode_ = c.mode();
    phase_start_ = d->time;
  }
  const std::string fall =
      FallReason(limits_, x_, d->time - phase_start_, c.mapping().floor_slope);
  if (!fall.empty()) return {StepOutcome::Kind::kFell, fall};
  return {};
}

#ifdef DDOC_HAVE_RENDER
struct RunFrames::Impl {
  std::unique_ptr<FrameRecorder> recorder;
  Overlay overlay;
};

RunFrames::RunFrames(const Settings& s, const mjModel* m, const std::string& method,
                     const std::string&) {
  if (s.dir.empty() && s.video.empty()) return;
  RenderSettings render;
  render.dir = s.dir;
  render.video = s.video;
  render.width = s.width;
  render.height = s.height;
  render.fps = s.fps;
  std::string error;
  if (!render.Validate(&error)) throw RunError(kExitBadInput, error);
  impl_ = std::make_unique<Impl>();
  impl_->recorder = FrameRecorder::Create(m, render, &error);
  if (!impl_->recorder) throw RunError(kExitBadInput, error);
  impl_->overlay.method = method;
}

void RunFrames::Capture(const mjModel* m, mjData* d, int hop, double cost, double speed) {
  if (!impl_) return;
  impl_->overlay.hop = hop;
  impl_->overlay.last_cost = cost;
  impl_->overlay.forward_speed = speed;
  impl_->recorder->MaybeCapture(m, d, impl_->overlay);
}

bool RunFrames::Finish(std::string* error) { return !impl_ || impl_->recorder->Finish(error); }

long RunFrames::frame_count() const {
  return impl_ ? static_cast<long>(impl_->recorder->frame_count()) : 0;
}

std::string RunFrames::video_message() const {
  return impl_ ? impl_->recorder->video_message() : "";
}
#else
struct RunFrames::Impl {};

RunFrames::RunFrames(const Settings& s, const mjModel*, const std::string&,
                     const std::string& flag) {
  if (!s.dir.empty() || !s.video.empty()) {
    throw RunError(kExitBadInput, flag + ": this build has no OSMesa rendering");
  }
}
void RunFrames::Capture(const mjModel*, mjData*, int, double, double) {}
bool RunFrames::Finish(std::string*) { return true; }
long RunFrames::frame_count() const { return 0; }
std::string RunFrames::video_message() const { return ""; }
#endif

RunFrames::~RunFrames() = default;

}  // namespace ddoc::app
