// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "hopper_controller.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <sstream>

#include "ddoc/cost.h"
#include "ddoc/policy.h"

namespace ddoc::plugin {
namespace {

Bounds HopperBounds(const ControllerConfig& c) {
  Bounds b;
  b.u_min = hopper::InputLowerBound();
  b.u_max = hopper::InputUpperBound();
  b.duration_min = Eigen::Vector2d(c.flight_min, c.stance_min);
  b.duration_max = Eigen::Vector2d(c.flight_max, c.stance_max);
  return b;
}

// (x, y, xd, yd) of a flight-coordinate state.
Eigen::Vector4d BodyState(const Eigen::Matrix<double, 14, 1>& xf) {
  return Eigen::Vector4d(xf(hopper::kX), xf(hopper::kY), xf(hopper::kXd), xf(hopper::kYd));
}

HopperController* g_attached = nullptr;

void ControlCallback(const mjModel* m, mjData* d) {
  if (g_attached != nullptr) g_attached->Compute(m, d);
}

}  // namespace

LearnerSettings HopperLearnerDefaults() {
  LearnerSettings s;
  s.c = 1e-7;
  s.gamma = 0.5;
  s.reset_alpha_on_accept = false;
  s.controller.alpha_scales_feedback = false;
  s.controller.regularization = 0.01;
  s.backward.equation = BackwardEquation::kRiccati;
  s.backward.psd_switching_hessians = true;
  s.alpha_initial = 0.1;
  s.backward.riccati_regularization = s.controller.regularization;
  return s;
}

HopperController::HopperController(const mjModel* m, const ControllerConfig& config)
    : config_(config),
      map_(HopperMapping::Build(m, "the robot's mjModel")),
      model_(config.model),
      cost_(model_, config.cost_weights),
      problem_{&model_, &cost_, HopperBounds(config),
               Eigen::Vector2d(cost_.weights().surface_weight, 0.0)},
      model_plant_(problem_),
      vsa_(map_.beta),
      detector_(config.contact) {}

std::unique_ptr<HopperController> HopperController::Create(const mjModel* m,
                                                           const ControllerConfig& config,
                                                           std::string* error) {
  std::string local;
  std::string* err = error != nullptr ? error : &local;
  if (m == nullptr) {
    *err = "HopperController::Create: mjModel is null";
    return nullptr;
  }
  try {
    std::unique_ptr<HopperController> c(new HopperController(m, config));
    c->Initialize();
    return c;
  } catch (const std::exception& e) {
    *err = std::string("HopperController::Create: ") + e.what();
    return nullptr;
  }
}

void HopperController::Initialize() {
  const ControllerConfig& c = config_;
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      std::ostringstream msg;
      msg << "config." << name << " must be a finite number > 0, got " << v;
      throw InvalidArgument(msg.str());
    }
  };
  positive(c.dt_model, "dt_model");
  if (c.initial_hops < 1) {
    throw InvalidArgument("config.initial_hops must be >= 1, got " +
                          std::to_string(c.initial_hops));
  }
  if (!(c.flight_pitch_feedback >= 0.0 && c.flight_pitch_feedback <= 1.0)) {
    throw InvalidArgument("config.flight_pitch_feedback must be in [0, 1], got " +
                          std::to_string(c.flight_pitch_feedback));
  }
  if (c.flight_pitch_feedback_from_hop < 0) {
    throw InvalidArgument("config.flight_pitch_feedback_from_hop must be >= 0, got " +
                          std::to_string(c.flight_pitch_feedback_from_hop));
  }
  if (c.flight_pitch_feedback != 1.0) {
    pitch_scale_ = {Vector::Ones(hopper::kFlightDim), Vector::Ones(hopper::kStanceDim)};
    pitch_scale_[hopper::kFlight](hopper::kPhi) = c.flight_pitch_feedback;
    pitch_scale_[hopper::kFlight](hopper::kPhid) = c.flight_pitch_feedback;
  }
  if (c.max_samples_per_mode < 10) {
    throw InvalidArgument("config.max_samples_per_mode must be >= 10, got " +
                          std::to_string(c.max_samples_per_mode));
  }
  problem_.Validate();  // duration bounds: reversed or non-positive -> named error
  if (c.sync_riccati_regularization) {
    for (LearnerSettings* ls : {&config_.learner, &config_.model_learner}) {
      ls->backward.riccati_regularization = ls->controller.regularization;
      ls->backward.regularization_scaling = ls->controller.regularization_scaling;
    }
  }

  model_plant_.settings().dt = c.dt_model;
  model_plant_.set_guard([this](int k, const ConstVectorRef& x, const ConstVectorRef& u) {
    return model_.Guard(k, x, u);
  });

  // u^0, T^0: the model-based optimal feedback policy (OC-FB) from a nominal constant-input gait.
  gait_ = FindNominalGait(config_.model, config_.gait);
  cost_.SetReference(gait_.x0);
  model_learner_ = std::make_unique<Learner>(problem_, config_.model_learner);
  const Eigen::Vector2d durations(gait_.T0(0), gait_.T0(1) - gait_.T0(0));
  const Eigen::Vector4d u0 = gait_.u0;
  FunctionPolicy initial(durations, [u0](int, double, const ConstVectorRef&, VectorRef u) {
    u = u0;
  });
  const SolveResult solved =
      model_learner_->Solve(model_plant_, model_plant_, gait_.x0, initial);
  model_cost_ = solved.cost;
  model_iterations_ = solved.iterations;
  if (!std::isfinite(model_cost_)) {
    throw InvalidArgument("the model-based initial solve produced a non-finite cost");
  }
  recorder_.Reserve(model_, config_.max_samples_per_mode);
  phase_psi_.setZero(config_.max_samples_per_mode);
  phase_s_.setZero(config_.max_samples_per_mode);
}

void HopperController::PlaceAtTakeoff(const mjModel* m, mjData* d, const double* x, double t) {
  mj_resetData(m, d);
  d->time = t;
  VsaState vs;
  WriteFlightState(map_, x, d, &vs);
  vsa_.Reset(vs);
  // The state is a takeoff: the foot starts on the ground, no phase change for min_phase_time.
  detector_.Reset(hopper::kFlight, t);
  started_ = false;  // the next step begins the hop (BeginHop) at this state
  have_prev_td_ = false;
  stance_first_ = false;
}

void HopperController::Reset(const mjModel* m, mjData* d) {
  PlaceAtTakeoff(m, d, gait_.x0.data(), 0.0);
  hop_ = 0;
  failed_ = false;
  error_.clear();
  reports_.clear();
  nonfinite_steps_ = 0;
  u_ = gait_.u0;
  frozen_ = false;
  learner_.reset();
  if (config_.method != Method::kOcfb) {
    learner_ = std::make_unique<Learner>(problem_, config_.learner);
  }
  policy_ = &model_learner_->ConvergedPolicy(config_.ocfb_alpha);
  initial_policy_ = policy_;  // the model learner no longer changes: every call gives this slot
  policy_->BeginTrial();
}

void HopperController::RestartHop(const mjModel* m, mjData* d,
                                  const Eigen::Matrix<double, 14, 1>& x) {
  if (!x.allFinite()) {
    throw InvalidArgument("HopperController::RestartHop: the start state is not finite");
  }
  PlaceAtTakeoff(m, d, x.data(), d->time);
  policy_->BeginTrial();
}

bool HopperController::LearnerStoppedBeforeAccepting() const {
  return learner_ && learner_->status() == LearnerStatus::kLineSearchFailed &&
         learner_->iteration() == 0;
}

bool HopperController::runs_initial_law() const { return policy_ == initial_policy_; }

std::vector<HopReport> HopperController::TakeReports() {
  std::vector<HopReport> out;
  out.swap(reports_);
  return out;
}

void HopperController::Sanitize() {
  const Vector& lo = problem_.bounds.u_min;
  const Vector& hi = problem_.bounds.u_max;
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(u_(i))) u_(i) = 0.5 * (lo(i) + hi(i));
    u_(i) = std::min(std::max(u_(i), lo(i)), hi(i));
  }
}

void HopperController::WriteHeld(const mjModel* m, mjData* d) {
  Sanitize();
  WriteActuation(map_, m, d, vsa_.state(), u_.data());
  // A non-finite state would make the spring terms non-finite: never hand MuJoCo a NaN.
  for (int a : {map_.act_hip, map_.act_leg}) {
    if (!std::isfinite(d->ctrl[a])) d->ctrl[a] = 0.0;
  }
}

void HopperController::Compute(const mjModel* m, mjData* d) {
  if (in_compute_) {  // nested call (e.g. a finite-difference mj_forward inside a step)
    WriteHeld(m, d);
    return;
  }
  in_compute_ = true;
  try {
    if (!failed_ && !hold_ && (!started_ || d->time > last_time_)) {
      NewStep(m, d);
    }
    WriteHeld(m, d);
  } catch (const std::exception& e) {
    failed_ = true;
    error_ = std::string("controller: ") + e.what();
    WriteHeld(m, d);
  } catch (...) {
    failed_ = true;
    error_ = "controller: unknown exception";
    WriteHeld(m, d);
  }
  in_compute_ = false;
}

double HopperController::LegPhase(double r, double rd) const {
  return std::atan2(config_.model.r0 - r, -rd / phase_w_);
}

void HopperController::LoadPhaseTable() {
  const bool learning = learner_ && config_.method != Method::kOcfb && hop_ >= config_.initial_hops;
  const Trajectory& nominal = learning ? learner_->nominal() : model_learner_->nominal();
  const ModeTrajectory& fl = nominal.modes[hopper::kFlight];
  const ModeTrajectory& st = nominal.modes[hopper::kStance];
  phase_y_td_ = fl.x(hopper::kY, fl.num_samples() - 1);
  const double D = nominal.T(1) - nominal.T(0);
  phase_w_ = D > 0 ? M_PI / D : 1.0;
  phase_count_ = std::min<int>(st.num_samples(), static_cast<int>(phase_psi_.size()));
  double run = -1e9;
  for (int j = 0; j < phase_count_; ++j) {
    run = std::max(run, LegPhase(st.x(hopper::kSR, j), st.x(hopper::kSRd, j)));
    phase_psi_(j) = run;
    phase_s_(j) = D > 0 ? (st.t(j) - nominal.T(0)) / D : 0.0;
  }
  phase_best_ = -1e9;
}

double HopperController::PolicyTime(double t_in_mode, const double* x) {
  const double D = policy_->PlannedDuration(mode());
  if (!std::isfinite(t_in_mode)) return t_in_mode;
  if (mode() == hopper::kFlight) {
    const double y = x[hopper::kY], yd = x[hopper::kYd];
    const double g = config_.model.g;
    const double rem = (yd + std::sqrt(yd * yd + 2.0 * g * std::max(0.0, y - phase_y_td_))) / g;
    if (!std::isfinite(rem) || t_in_mode + rem <= 0) return t_in_mode;
    return D * t_in_mode / (t_in_mode + rem);
  }
  const double psi = LegPhase(x[hopper::kSR], x[hopper::kSRd]);
  if (!std::isfinite(psi) || phase_count_ < 2) return t_in_mode;
  phase_best_ = std::max(phase_best_, psi);
  if (phase_best_ <= phase_psi_(0)) return 0.0;
  for (int j = 1; j < phase_count_; ++j) {
    if (phase_psi_(j) >= phase_best_) {
      const double span = phase_psi_(j) - phase_psi_(j - 1);
      const double w = span > 0 ? (phase_best_ - phase_psi_(j - 1)) / span : 1.0;
      return D * (phase_s_(j - 1) + w * (phase_s_(j) - phase_s_(j - 1)));
    }
  }
  return D;  // past the nominal's takeoff phase
}

void HopperController::BeginHop(double t, const mjData* d) {
  if (config_.phase_time) LoadPhaseTable();
  MapFlightState(map_, d, vsa_.state(), xf_.data());
  if (config_.zero_flight_leg_rate) xf_(hopper::kRd) = 0.0;
  recorder_.Clear();
  recorder_.BeginMode(hopper::kFlight);
  hop_start_ = t;
  phase_start_ = t;
  x0_hop_ = xf_;
  hop_x_start_ = xf_(hopper::kX);
  apex_ = xf_(hopper::kY);
  effort_ = 0.0;
  hop_nonfinite_ = 0;
}

void HopperController::NewStep(const mjModel* /*m*/, mjData* d) {
  const double t = d->time;
  if (!started_) {
    started_ = true;
    last_time_ = t;
    BeginHop(t, d);
  } else {
    // The stiffness commands of the previous step were held over [last_time_, t].
    vsa_.Advance(t - last_time_, u_(2), u_(3));
  }
  const double step = t - last_time_;
  last_time_ = t;

  // Phase detection (ContactPhaseDetector): at a touchdown the current state is the last one
  // before the impact, at a takeoff the first one of the flight.
  const ContactChange change = detector_.Update(map_, d);
  if (change == ContactChange::kTouchdown) {
    MapFlightState(map_, d, vsa_.state(), xf_.data());
    if (config_.zero_flight_leg_rate) xf_(hopper::kRd) = 0.0;
    recorder_.AddSample(t - hop_start_, xf_, u_);  // x^-(T1)
    recorder_.EndMode();
    recorder_.BeginMode(hopper::kStance);
    x_td_ = xf_;
    body_td_ = BodyState(xf_);
    t_touchdown_ = t;
    foot_td_x_ = xf_(hopper::kX) + xf_(hopper::kR) * std::sin(xf_(hopper::kTheta));
    foot_td_h_ = HopperModel::FootHeight(xf_);
    phase_start_ = t;
    stance_first_ = true;
    phase_best_ = -1e9;
  } else if (change == ContactChange::kTakeoff) {
    EndHop();
    BeginHop(t, d);
    reports_.back().body_takeoff = BodyState(xf_);
  }

  // The measured state in the model's coordinates of the current mode.
  double* x = nullptr;
  int n = 0;
  if (mode() == hopper::kFlight) {
    MapFlightState(map_, d, vsa_.state(), xf_.data());
    if (config_.zero_flight_leg_rate) xf_(hopper::kRd) = 0.0;
    x = xf_.data();
    n = hopper::kFlightDim;
    apex_ = std::max(apex_, xf_(hopper::kY));
  } else {
    MapStanceState(map_, d, vsa_.state(), xs_.data());
    x = xs_.data();
    n = hopper::kStanceDim;
  }
  Eigen::Map<const Vector> xm(x, n);
  if (!xm.allFinite()) {
    ++nonfinite_steps_;
    ++hop_nonfinite_;
  }

  // Online update (33)-(35): the policy clamps into the bounds and never returns NaN for a
  // non-finite state; Sanitize() is the last guard.
  const double t_in_mode = t - phase_start_;
  policy_->Step(mode(), config_.phase_time ? PolicyTime(t_in_mode, x) : t_in_mode, xm, u_);
  Sanitize();
  effort_ += cost_.InputCost(u_) * std::max(step, map_.timestep);

  // Record the sample. The touchdown step already holds x^-(T1) as the flight mode's last
  // sample; the first stance sample is the first post-impact measurement (the next step),
  // stamped at the switching instant T1.
  if (mode() == hopper::kStance && stance_first_) {
    if (t > t_touchdown_) {
      recorder_.AddSample(t_touchdown_ - hop_start_, xm, u_);
      stance_first_ = false;
    }
  } else if (xm.allFinite()) {
    recorder_.AddSample(t - hop_start_, xm, u_);
  }
  if (mode() == hopper::kStance) last_stance_ = xs_;
}

void HopperController::EndHop() {
  // The stance mode ends with its last recorded sample, x^-(T2).
  recorder_.EndMode();
  recorder_.Finish(&trial_);
  x_to_ = last_stance_;

  HopReport r;
  r.hop = hop_;
  r.t_start = hop_start_;
  r.t_touchdown = t_touchdown_;
  r.t_end = hop_start_ + trial_.T(1);
  r.t1 = trial_.T(0);
  r.t2 = trial_.T(1);
  cost_.SetReference(x0_hop_);
  r.terms = cost_.Terms(x_td_, x_to_, effort_);
  r.cost = r.terms.total();
  r.apex = apex_;
  r.foot_height_td = foot_td_h_;
  r.step_length = have_prev_td_ ? foot_td_x_ - prev_foot_td_x_ : 0.0;
  prev_foot_td_x_ = foot_td_x_;
  have_prev_td_ = true;
  // COM x at takeoff from the takeoff map of the measured stance state.
  const double x_end = foot_td_x_ - x_to_(hopper::kSR) * std::sin(x_to_(hopper::kSTheta));
  r.speed = r.t2 > 0 ? (x_end - hop_x_start_) / r.t2 : 0.0;
  r.alpha = policy_->alpha();
  r.du2 = policy_->du_squared_integral();
  r.dt2 = policy_->dT().squaredNorm();
  r.nonfinite = hop_nonfinite_;
  r.body_touchdown = body_td_;

  // The offline part for the next hop.
  if (frozen_) {
    cost_.SetReference(trial_.x0);
    r.accepted = true;
    r.learner_cost = EvaluateCost(problem_, trial_).total;
    if (learner_) r.status = learner_->status();
  } else if (config_.method == Method::kOcfb) {
    r.accepted = true;
    r.learner_cost = EvaluateCost(problem_, trial_).total;
    policy_ = &model_learner_->ConvergedPolicy(config_.ocfb_alpha);
  } else if (hop_ + 1 < config_.initial_hops) {
    // Warm-up: the robot settles onto its own closed-loop cycle of the initial law.
    cost_.SetReference(trial_.x0);
    r.accepted = true;
    r.learner_cost = EvaluateCost(problem_, trial_).total;
    policy_ = &model_learner_->ConvergedPolicy(config_.ocfb_alpha);
  } else if (hop_ + 1 == config_.initial_hops) {
    // This hop ran u^0, T^0 (the OC-FB law): Algorithm 1's "Initialize".
    cost_.SetReference(config_.anchor_reference ? Vector(gait_.x0) : trial_.x0);
    if (config_.method == Method::kMrl) {
      Trajectory predicted;
      mrl_plant_.Run(trial_.x0, model_learner_->ConvergedPolicy(config_.ocfb_alpha), &predicted);
      learner_->Initialize(trial_, &predicted);
    } else {
      learner_->Initialize(trial_);
    }
    r.accepted = true;
    r.learner_cost = learner_->nominal_cost();
    r.status = learner_->status();
    policy_ = &learner_->NextTrial();
  } else {
    cost_.SetReference(config_.anchor_reference ? Vector(gait_.x0) : trial_.x0);
    const TrialResult tr = learner_->CompleteTrial(
        trial_, config_.method == Method::kMrl ? &mrl_plant_ : nullptr);
    r.accepted = tr.accepted;
    r.learner_cost = tr.cost;
    r.status = tr.status;
    policy_ = &learner_->NextTrial();
    // Terminated before any trial passed (36): the law of iteration 0 is u^0, the OC-FB law
    // that produced the nominal, not a replay of the nominal's inputs (Learner::NextTrial).
    if (LearnerStoppedBeforeAccepting()) {
      policy_ = &model_learner_->ConvergedPolicy(config_.ocfb_alpha);
    }
  }
  SetPitchFeedback();
  policy_->BeginTrial();
  reports_.push_back(r);
  ++hop_;
}

void HopperController::SetPitchFeedback() {
  if (pitch_scale_.empty() || runs_initial_law()) return;  // u^0 keeps its feedback
  std::vector<Vector>& scale = policy_->settings().state_feedback_scale;
  if (hop_ + 1 >= config_.flight_pitch_feedback_from_hop) {
    if (scale.empty()) scale = pitch_scale_;  // the learner's two slots: once each
  } else if (!scale.empty()) {
    scale.clear();
  }
}

void MeasuredStartModelPlant::Run(const ConstVectorRef& x0, Policy& policy, Trajectory* out) {
  x0_ = x0;
  if (x0_.size() == hopper::kFlightDim) x0_(hopper::kRd) = 0.0;
  model_->Run(x0_, policy, out);
}

void Attach(HopperController* controller) {
  g_attached = controller;
  mjcb_control = controller != nullptr ? ControlCallback : nullptr;
}

void Detach() { Attach(nullptr); }

HopperController* Attached() { return g_attached; }

}  // namespace ddoc::plugin
