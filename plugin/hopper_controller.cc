// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "hopper_controller.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <exception>
#include <limits>
#include <sstream>

#include "law_cache.h"

namespace ddoc::plugin {
namespace {

// CPU time of the calling thread, s (the offline part's own time, whatever else the machine runs).
double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// The foot's x velocity in a flight-coordinate state: xd + d/dt(r sin theta).
double FootVelocityX(const Eigen::Matrix<double, 14, 1>& xf) {
  const double th = xf(hopper::kTheta);
  return xf(hopper::kXd) + xf(hopper::kRd) * std::sin(th) +
         xf(hopper::kR) * xf(hopper::kThetad) * std::cos(th);
}

// (x, y, xd, yd) of a flight-coordinate state.
Eigen::Vector4d BodyState(const Eigen::Matrix<double, 14, 1>& xf) {
  return Eigen::Vector4d(xf(hopper::kX), xf(hopper::kY), xf(hopper::kXd), xf(hopper::kYd));
}

// Throws InvalidArgument naming the first field out of range.
void ValidateConfig(const ControllerConfig& c) {
  auto fail = [](const std::string& field, double value, const char* expected) {
    std::ostringstream msg;
    msg << "config." << field << " = " << value << ", expected " << expected;
    throw InvalidArgument(msg.str());
  };
  if (!(c.dt_model > 0.0) || !std::isfinite(c.dt_model)) fail("dt_model", c.dt_model, "> 0");
  c.model.CheckRk4Step(c.dt_model, "config.dt_model");
  if (c.max_samples_per_mode < 10) {
    fail("max_samples_per_mode", c.max_samples_per_mode, ">= 10");
  }
  if (!(c.offline_hop_seconds >= 0.0) || !std::isfinite(c.offline_hop_seconds)) {
    fail("offline_hop_seconds", c.offline_hop_seconds, "finite and >= 0");
  }
  if (!(c.offline_step_seconds >= 0.0) || !std::isfinite(c.offline_step_seconds)) {
    fail("offline_step_seconds", c.offline_step_seconds, "finite and >= 0");
  }
  if (c.measured_latency) {
    // A law that comes after the flight waits for the next one (DeployLawWhenDue).
    if (!(c.offline_latency >= 0.0) || !std::isfinite(c.offline_latency)) {
      fail("offline_latency", c.offline_latency, "finite and >= 0 (measured_latency)");
    }
  } else if (!(c.offline_latency >= 0.0 && c.offline_latency < c.durations.flight_min)) {
    fail("offline_latency", c.offline_latency, "in [0, durations.flight_min)");
  }
  if (!(c.anchor_weight >= 0.0 && c.anchor_weight <= 1.0)) {
    fail("anchor_weight", c.anchor_weight, "in [0, 1]");
  }
  if (!(c.reference_filter > 0.0 && c.reference_filter <= 1.0)) {
    fail("reference_filter", c.reference_filter, "in (0, 1]");
  }
  if (!(c.overspeed_latch >= 0.0) || !std::isfinite(c.overspeed_latch)) {
    fail("overspeed_latch", c.overspeed_latch, "finite and >= 0");
  }
  if (!(c.watch_max_mass >= 0.0) || !std::isfinite(c.watch_max_mass)) {
    fail("watch_max_mass", c.watch_max_mass, "finite and >= 0");
  }
  if (c.overspeed_latch > 0.0 &&
      !(c.anchor_reference && c.anchor_weight < 1.0 && c.reference_filter < 1.0)) {
    fail("overspeed_latch", c.overspeed_latch,
         "0 unless the reference moves (anchor_reference, anchor_weight < 1, "
         "reference_filter < 1)");
  }
  if (!(c.pitch_experiment.scale >= 0.0 && c.pitch_experiment.scale <= 1.0)) {
    fail("pitch_experiment.scale", c.pitch_experiment.scale, "in [0, 1]");
  }
  if (c.pitch_experiment.from_hop < 0) {
    fail("pitch_experiment.from_hop", c.pitch_experiment.from_hop, ">= 0");
  }
  const IdentificationSettings& id = c.identification;
  if (id.settle_hops < 0) fail("identification.settle_hops", id.settle_hops, ">= 0");
  if (!(id.settle_cost >= 0.0) || !std::isfinite(id.settle_cost)) {
    fail("identification.settle_cost", id.settle_cost, "finite and >= 0");
  }
  if (id.settle_hops_max < id.settle_hops) {
    const std::string bound = ">= identification.settle_hops (" + std::to_string(id.settle_hops) + ")";
    fail("identification.settle_hops_max", id.settle_hops_max, bound.c_str());
  }
  if (!(id.mass_resolution > 0.0) || !std::isfinite(id.mass_resolution)) {
    fail("identification.mass_resolution", id.mass_resolution, "finite and > 0");
  }
  if (!(id.resolve_latency >= 0.0) || !std::isfinite(id.resolve_latency)) {
    fail("identification.resolve_latency", id.resolve_latency, "finite and >= 0");
  }
  if (!(id.min_predicted_decrease >= 0.0) || !std::isfinite(id.min_predicted_decrease)) {
    fail("identification.min_predicted_decrease", id.min_predicted_decrease, "finite and >= 0");
  }
  const TermsIdentification::Resolution& res = id.term_resolution;
  for (const auto& [name, value] : {std::pair{"b_leg", res.b_leg}, {"b_hip", res.b_hip},
                                    {"inertia", res.inertia}, {"slope", res.slope}}) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      fail(std::string("identification.term_resolution.") + name, value, "finite and > 0");
    }
  }
  MassIdentification check(id.estimator);  // throws naming a bad estimator setting
  TermsIdentification check_terms(id.terms_estimator);
}

ModelPlantSettings ModelPlantSettingsFor(const ControllerConfig& c) {
  ModelPlantSettings s;
  s.dt = c.dt_model;
  return s;
}

// Where u^0 came from (HopperController::law_cache_status()) and what the model solve gave.
struct InitialLaw {
  double cost = 0.0;
  int iterations = 0;
  Matrix cyclic_value;  // the model solve's (BackwardPass::cyclic_value()), or the stored one
  std::string status = "solved";
  bool trouble = false;
};

// The nominal gait of config.model into *gait and u^0 into *law: loaded from config.law_cache
// when a law stored there has this solve's key, else solved on (problem, plant, cost) and stored.
InitialLaw SolveInitialLaw(const ControllerConfig& config, const Problem& problem,
                           ModelPlant* plant, HopperCost* cost, OnlineController* law,
                           NominalGait* gait) {
  InitialLaw out;
  std::string key, unusable;  // unusable: " (<file>: <why>)" when a stored law was not usable
  if (!config.law_cache.empty()) {
    key = InitialLawKey(config);
    if (key.empty()) {
      out.status = "solved; not stored: no GNU build id to key the law by";
      out.trouble = true;
    }
  }
  if (!key.empty()) {
    StoredInitialLaw stored;
    std::string why;
    const std::string path = InitialLawPath(config.law_cache, key);
    bool loaded = ReadInitialLaw(config.law_cache, key, &stored, &why);
    if (loaded) {
      try {
        // The gait the solve started from, rebuilt from its search variables (the key holds
        // every input of the search).
        *gait = NominalGaitAt(config.model, config.gait, stored.gait_search);
        law->Allocate(problem, config.model_learner.max_samples, config.model_learner.controller);
        law->ImportLaw(stored.law);
      } catch (const InvalidArgument& e) {
        loaded = false;
        why = e.what();
      }
    }
    if (loaded) {
      cost->SetReference(gait->x0);  // as SolveFromGait leaves it
      out.cost = stored.model_cost;
      out.iterations = stored.model_iterations;
      out.cyclic_value = stored.cyclic_value;
      out.status = "loaded " + path;
      return out;
    }
    if (why != "no file") {
      unusable = " (" + path + ": " + why + ")";
      out.trouble = true;
    }
  }
  *gait = FindNominalGait(config.model, config.gait);
  Learner model_learner(problem, config.model_learner);
  const SolveResult solved = SolveFromGait(model_learner, *plant, cost, *gait);
  out.cost = solved.cost;
  out.iterations = solved.iterations;
  if (!std::isfinite(out.cost)) {
    throw InvalidArgument("the model-based initial solve produced a non-finite cost");
  }
  *law = model_learner.ConvergedPolicy(config.ocfb_alpha);
  out.cyclic_value = model_learner.backward_pass().cyclic_value();
  if (key.empty()) return out;
  StoredInitialLaw stored;
  stored.law = law->ExportLaw();
  stored.model_cost = out.cost;
  stored.model_iterations = out.iterations;
  stored.cyclic_value = out.cyclic_value;
  stored.gait_search = gait->search;
  std::string why;
  if (WriteInitialLaw(config.law_cache, key, stored, &why)) {
    out.status = "stored " + InitialLawPath(config.law_cache, key) + unusable;
  } else {
    out.status = "solved; not stored: " + why + unusable;
    out.trouble = true;
  }
  return out;
}

HopperController* g_attached = nullptr;

void ControlCallback(const mjModel* m, mjData* d) {
  if (g_attached != nullptr) g_attached->Compute(m, d);
}

}  // namespace

HopperController::HopperController(const mjModel* m, const ControllerConfig& config)
    : config_(config),
      map_(HopperMapping::Build(m, "the robot's mjModel")),
      model_(config.model),
      report_model_(config.model),
      cost_(model_, config.cost_weights),
      report_cost_(report_model_, config.cost_weights),
      problem_(HopperProblem(model_, cost_, config.durations)),
      model_plant_(problem_, ModelPlantSettingsFor(config)),
      detector_(config.contact),
      vsa_(map_.beta) {}

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
    ValidateConfig(config);
    std::unique_ptr<HopperController> c(new HopperController(m, config));
    CheckSpringsAreStableAtTheTimestep(m, c->map_, "the robot's mjModel");
    c->Initialize();
    return c;
  } catch (const std::exception& e) {
    *err = std::string("HopperController::Create: ") + e.what();
    return nullptr;
  }
}

HopperController::~HopperController() { StopWorker(); }

void HopperController::Initialize() {
  model_plant_.set_guard([this](int k, const ConstVectorRef& x, const ConstVectorRef& u) {
    return model_.Guard(k, x, u);
  });
  mass_id_ = MassIdentification(config_.identification.estimator);
  terms_id_ = TermsIdentification(config_.identification.terms_estimator);
  // u^0, T^0: the model-based optimal feedback policy (OC-FB) from a nominal constant-input gait.
  const InitialLaw u0 =
      SolveInitialLaw(config_, problem_, &model_plant_, &cost_, &fallback_, &gait_);
  model_cost_ = u0.cost;
  model_iterations_ = u0.iterations;
  cyclic_value_ = u0.cyclic_value;
  law_cache_status_ = u0.status;
  law_cache_trouble_ = u0.trouble;
  bridge_ = fallback_;
  MakeDriver(config_.driver.warmup_trials);
  if (config_.pitch_experiment.scale != 1.0) {
    pitch_scale_ = {Vector::Ones(hopper::kFlightDim), Vector::Ones(hopper::kStanceDim)};
    pitch_scale_[hopper::kFlight](hopper::kPhi) = config_.pitch_experiment.scale;
    pitch_scale_[hopper::kFlight](hopper::kPhid) = config_.pitch_experiment.scale;
  }
  for (TrajectoryRecorder& r : recorders_) r.Reserve(model_, config_.max_samples_per_mode);
  waiting_.reserve(8);
  if (config_.offline_thread && !Synchronous()) {
    worker_ = std::thread([this] { WorkerLoop(); });
  }
}

void HopperController::MakeDriver(int warmup) {
  TrialDriverSettings settings = config_.driver;
  settings.warmup_trials = std::max(settings.warmup_trials, warmup);
  const bool mrl = settings.method == Method::kMrl;
  // A filtered own state moves the learner's reference between hops: the nominal is compared
  // under the present one.
  const Vector anchor = config_.anchor_reference ? Vector(gait_.x0) : Vector();
  if (HopperReferenceMoves(anchor, config_.anchor_weight, config_.reference_filter)) {
    settings.learner.reference_shift = true;
  }
  const IdentificationSettings& id = config_.identification;
  if ((id.mass || id.terms) && id.model_law) {
    settings.learner.blend_feedforward = settings.learner.blend_feedback;
    settings.learner.min_predicted_decrease =
        std::max(settings.learner.min_predicted_decrease, id.min_predicted_decrease);
  }
  driver_ = std::make_unique<TrialDriver>(
      problem_, settings, fallback_, mrl ? &prediction_plant_ : nullptr,
      HopperCostReference(&cost_, anchor, config_.anchor_weight, config_.reference_filter,
                          config_.overspeed_latch, latched_));
  // The Initialize hop's pass sweeps its periodic value from u^0's fixed point on the model.
  driver_->SeedCyclicValue(cyclic_value_);
}

void HopperController::ResolveModel(const HopperParams& params) {
  const auto start = std::chrono::steady_clock::now();
  // Objects of its own: the simulation side keeps using model_ and fallback_ meanwhile.
  ControllerConfig config = config_;
  config.model = params;
  HopperModel model(config.model);
  HopperCost cost(model, config.cost_weights);
  const Problem problem = HopperProblem(model, cost, config.durations);
  ModelPlant plant(problem, ModelPlantSettingsFor(config));
  plant.set_guard([&model](int k, const ConstVectorRef& x, const ConstVectorRef& u) {
    return model.Guard(k, x, u);
  });
  OnlineController law;
  const InitialLaw u0 = SolveInitialLaw(config, problem, &plant, &cost, &law, &staged_.gait);
  // The staged law belongs to problem_ (the same sizes and bounds; its system becomes this
  // model when it takes over).
  staged_.law.Allocate(problem_, config.model_learner.max_samples,
                       config.model_learner.controller);
  staged_.law.ImportLaw(law.ExportLaw());
  staged_.params = config.model;
  staged_.cost = u0.cost;
  staged_.iterations = u0.iterations;
  staged_.cyclic_value = u0.cyclic_value;
  staged_.ready = true;
  staged_.record = ModelResolve();
  staged_.record.hop = job_hop_;
  staged_.record.model = params;
  staged_.record.law_cache = u0.status;
  staged_.record.wall_ms =
      1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void HopperController::TakeOverResolvedModel() {
  model_ = HopperModel(staged_.params);  // problem_, cost_ and the plants point at model_
  gait_ = staged_.gait;
  std::swap(fallback_, staged_.law);
  bridge_ = fallback_;
  model_cost_ = staged_.cost;
  model_iterations_ = staged_.iterations;
  cyclic_value_ = staged_.cyclic_value;
  staged_.ready = false;
  resolves_.back().took_over_hop = hop_;
  // The running hop is the new driver's trial 0, settle_hops whole hops follow, then its
  // "Initialize" hop: settle_hops + 2 warm-up trials.
  MakeDriver(config_.identification.settle_hops + 2);
  law_ = &fallback_;
  law_->BeginTrial();
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
  FinishOffline();
  robot_model_ = m;
  robot_data_ = d;
  // What identification learned stays (the same robot): a staged u^0 takes over now.
  if (staged_.ready) TakeOverResolvedModel();
  resolve_request_.reset();
  driver_->Reset();
  waiting_.clear();
  reports_.clear();
  law_ = &fallback_;
  law_pending_ = false;
  PlaceAtTakeoff(m, d, gait_.x0.data(), 0.0);
  hop_ = 0;
  failed_ = false;
  error_.clear();
  nonfinite_steps_ = 0;
  u_ = gait_.u0;
  law_->BeginTrial();
}

void HopperController::RestartHop(const mjModel* m, mjData* d, const FlightState14& x) {
  if (!x.allFinite()) {
    throw InvalidArgument("HopperController::RestartHop: the start state is not finite");
  }
  FinishOffline();
  if (law_pending_) {  // the law of the running hop takes effect now
    law_ = next_law_;
    law_pending_ = false;
    if (staged_.ready) TakeOverResolvedModel();
  }
  PlaceAtTakeoff(m, d, x.data(), d->time);
  law_->BeginTrial();
}

void HopperController::Freeze() {
  FinishOffline();
  driver_->Freeze();
}

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
  if (m != robot_model_ || d != robot_data_) return;  // another model's pass, not our robot
  if (in_compute_) {  // nested call (e.g. a finite-difference mj_forward inside a step)
    WriteHeld(m, d);
    return;
  }
  in_compute_ = true;
  try {
    if (!failed_ && !hold_ && (!started_ || d->time > last_time_)) Step(d);
  } catch (const std::exception& e) {
    failed_ = true;
    error_ = std::string("controller: ") + e.what();
  } catch (...) {
    failed_ = true;
    error_ = "controller: unknown exception";
  }
  WriteHeld(m, d);
  in_compute_ = false;
}

void HopperController::Step(const mjData* d) {
  const double t = d->time;
  // The stiffness commands of the previous step were held over [last_time_, t].
  if (started_) vsa_.Advance(t - last_time_, u_(2), u_(3));
  const double step = started_ ? t - last_time_ : 0.0;
  const double t_prev = last_time_;
  last_time_ = t;

  // Phase (ContactPhaseDetector), then the state, mapped once in the coordinates this step needs:
  // flight for the control in flight and for x^-(T1) at a touchdown, stance in stance.
  const bool was_stance = started_ && mode() == hopper::kStance;
  const ContactChange change = detector_.Update(map_, d);
  const bool flight = mode() == hopper::kFlight;
  const bool substep = config_.contact.substep_events;  // also keeps the flight state in stance
  if (flight || change == ContactChange::kTouchdown || substep) {
    MapFlightState(map_, d, vsa_.state(), xf_.data());
  }
  if (!flight) MapStanceState(map_, d, vsa_.state(), xs_.data());
  if (was_stance) AddStanceImpulse(d, step);
  if (started_) AddBalances(d, was_stance, t_prev, step);
  prev_phid_ = flight ? xf_(hopper::kPhid) : xs_(hopper::kSPhid);
  prev_body_v_ << d->qvel[map_.dof_x], d->qvel[map_.dof_z];
  if (!started_) {
    started_ = true;
    BeginHop(t, xf_);
    // A state placed by Reset or RestartHop, not a takeoff from the floor: no foothold (on a
    // soft floor the feet of the takeoffs are sunk, the placed one is not).
    balances_.start_foot_x = balances_.start_foot_y = HopIdentificationData::kNaN;
  }
  if (change == ContactChange::kTouchdown && substep && t > hist_t_[0]) {
    // x^-(T1) between the last flight step and this one, at the detector's instant.
    const double w = std::max(1e-3, (detector_.event_time() - hist_t_[0]) / (t - hist_t_[0]));
    Touchdown(hist_t_[0] + w * (t - hist_t_[0]), hist_xf_[0] + w * (xf_ - hist_xf_[0]));
  } else if (change == ContactChange::kTouchdown) {
    Touchdown(t, xf_);
  }
  if (change == ContactChange::kTakeoff && substep) {
    TakeoffInsideStep(t);
  } else if (change == ContactChange::kTakeoff) {
    EndHop(t, xf_);
    BeginHop(t, xf_);
  }
  if (flight && !flight_clear_) StartFlightBalance(d);
  if (job_.load(std::memory_order_acquire) == Job::kDone) TakeOfflineResult();
  DeployLawWhenDue(t);

  const Eigen::Map<const Vector> x(flight ? xf_.data() : xs_.data(),
                                   flight ? hopper::kFlightDim : hopper::kStanceDim);
  if (flight) report_.apex = std::max(report_.apex, xf_(hopper::kY));
  if (!x.allFinite()) {
    ++nonfinite_steps_;
    ++report_.nonfinite;
  }
  // The online update (33)-(35): the law clamps into the bounds and never returns NaN for a
  // non-finite state; Sanitize() is the last guard.
  law_->Step(mode(), t - phase_start_, x, u_);
  Sanitize();
  effort_ += report_cost_.InputCost(u_) * std::max(step, map_.timestep);
  Record(t);
  if (!flight) {
    if (substep) prev_stance_ = last_stance_;
    last_stance_ = xs_;
  }
  if (substep) {
    hist_t_[1] = hist_t_[0];
    hist_t_[0] = t;
    hist_xf_[1] = hist_xf_[0];
    hist_xf_[0] = xf_;
    hist_u_[1] = hist_u_[0];
    hist_u_[0] = u_;
  }
}

void HopperController::TakeoffInsideStep(double t) {
  const double t0 = hist_t_[1], t1 = hist_t_[0];  // the last two steps, both in stance
  if (!(t1 > t0)) {
    EndHop(t, xf_);
    BeginHop(t, xf_);
    return;
  }
  // The detector puts the takeoff in [t0, t1]: x^-(T2) and the next hop's start are the states
  // there, interpolated; the stance sample of t1 (still pending, see Record) is not recorded.
  const double tau = std::min(t1, std::max(t0 + 1e-3 * (t1 - t0), detector_.event_time()));
  const double w = (tau - t0) / (t1 - t0);
  last_stance_ = prev_stance_ + w * (last_stance_ - prev_stance_);
  last_sample_t_ = tau - hop_start_;
  recorders_[recording_].AddSample(last_sample_t_, last_stance_, hist_u_[1]);
  stance_pending_ = false;
  // The inputs held after tau belong to the next hop: hist_u_[1] until t1, hist_u_[0] until t.
  const double carried = report_cost_.InputCost(hist_u_[1]) * (t1 - tau) +
                         report_cost_.InputCost(hist_u_[0]) * (t - t1);
  effort_ -= carried;
  const FlightState14 start = hist_xf_[1] + w * (hist_xf_[0] - hist_xf_[1]);
  EndHop(tau, start);
  BeginHop(tau, start);
  effort_ = carried;
  TrajectoryRecorder& rec = recorders_[recording_];
  rec.AddSample(0.0, start, hist_u_[1]);
  if (t1 - tau > 1e-3 * (t1 - t0)) rec.AddSample(t1 - tau, hist_xf_[0], hist_u_[0]);
  last_sample_t_ = t1 - tau;
}

void HopperController::AddStanceImpulse(const mjData* d, double h) {
  // Over [t - h, t] the actuators held d->ctrl (written at t - h) on the state last_stance_. The
  // foot is massless along the leg, so the floor's force R on it has -F_leg along the leg; the
  // leg turns about the hip, so R's moment about the hip is J_leg thetadd + tau_hip. R_y follows.
  const double theta = last_stance_(hopper::kSTheta), r = last_stance_(hopper::kSR);
  const double thetad = mode() == hopper::kFlight ? xf_(hopper::kThetad) : xs_(hopper::kSThetad);
  const double thetadd = (thetad - last_stance_(hopper::kSThetad)) / h;
  const double tau_hip = d->ctrl[map_.act_hip], f_leg = d->ctrl[map_.act_leg];
  const double tangential = (config_.model.J_leg * thetadd + tau_hip) / r;
  stance_impulse_ += (f_leg * std::cos(theta) + tangential * std::sin(theta)) * h;
}

void HopperController::AddBalances(const mjData* d, bool was_stance, double t_prev, double h) {
  const bool flight = mode() == hopper::kFlight;
  // The pitch balance: the damper acts on the step's end rate (MuJoCo's implicit damping).
  const double phid = flight ? xf_(hopper::kPhid) : xs_(hopper::kSPhid);
  const double thetad = flight ? xf_(hopper::kThetad) : xs_(hopper::kSThetad);
  balances_.hip.Add(Eigen::Vector2d(phid - prev_phid_, (phid - thetad) * h),
                    d->ctrl[map_.act_hip] * h);
  // The flight's drag, at the body's rate when the step's drag was applied, over the steps from
  // the first state whose foot is clear of the floor (StartFlightBalance) to the touchdown state
  // (the touchdown step ends before the impact).
  if (flight_clear_ && !was_stance) {
    balances_.flight_drag += prev_body_v_(0) * std::abs(prev_body_v_(0)) * h;
  }
  // The radial balance over a step with both ends in stance, after the impact step.
  if (flight || !was_stance || !(t_prev > touchdown_step_)) return;
  const double theta = last_stance_(hopper::kSTheta);
  const double rd0 = last_stance_(hopper::kSRd), rd1 = xs_(hopper::kSRd), wr = 0.5 * (rd0 + rd1);
  const double g = -robot_model_->opt.gravity[2];
  // The body's velocity change along the leg (foot to hip), (-sin theta, cos theta).
  const double dv = (d->qvel[map_.dof_x] - prev_body_v_(0)) * -std::sin(theta) +
                    (d->qvel[map_.dof_z] - prev_body_v_(1)) * std::cos(theta);
  balances_.leg_work += d->ctrl[map_.act_leg] * wr * h;
  balances_.leg_motion += (dv + g * std::cos(theta) * h) * wr;
  balances_.leg_rate_sq += rd1 * wr * h;
}

void HopperController::StartFlightBalance(const mjData* d) {
  // After the takeoff the foot can touch the floor for a step or two with a normal force below
  // the detector's 0.5 N and a friction force up to 1000 times it; the balance starts at the
  // first state without a foot-floor contact (the next step's solve has none).
  if (FootTouchesFloor(map_, d, 0.0)) return;
  flight_clear_ = true;
  start_momentum_ << xf_(hopper::kXd), FootVelocityX(xf_);
}

void HopperController::Record(double t) {
  TrajectoryRecorder& rec = recorders_[recording_];
  const bool flight = mode() == hopper::kFlight;
  const Eigen::Map<const Vector> x(flight ? xf_.data() : xs_.data(),
                                   flight ? hopper::kFlightDim : hopper::kStanceDim);
  // The touchdown step recorded x^-(T1) as the flight's last sample; the first stance sample is
  // the first post-impact measurement (the next step), stamped at the switching instant T1.
  if (!flight && stance_first_) {
    if (t > touchdown_step_) {
      last_sample_t_ = report_.t_touchdown - hop_start_;
      rec.AddSample(last_sample_t_, x, u_);
      stance_first_ = false;
    }
  } else if (!flight && config_.contact.substep_events) {
    // One step late: a takeoff found at the next step may fall before it (TakeoffInsideStep).
    if (stance_pending_) rec.AddSample(hist_t_[0] - hop_start_, last_stance_, hist_u_[0]);
    stance_pending_ = x.allFinite();
    if (stance_pending_) last_sample_t_ = t - hop_start_;
  } else if (x.allFinite()) {
    last_sample_t_ = t - hop_start_;
    rec.AddSample(last_sample_t_, x, u_);
  }
}

void HopperController::BeginHop(double t, const FlightState14& x) {
  TrajectoryRecorder& rec = recorders_[recording_];
  rec.Clear();
  rec.BeginMode(hopper::kFlight);
  hop_start_ = t;
  phase_start_ = t;
  hop_start_state_ = x;
  report_ = HopReport();
  report_.hop = hop_;
  report_.t_start = t;
  report_.apex = x(hopper::kY);
  stance_pending_ = false;
  effort_ = 0.0;
  stance_impulse_ = 0.0;
  balances_ = HopIdentificationData();
  balances_.flight_drag = 0.0;
  flight_clear_ = false;
  balances_.start_foot_x = HopperModel::FootX(x);
  balances_.start_foot_y = HopperModel::FootHeight(x);
  balances_.leg_work = balances_.leg_motion = balances_.leg_rate_sq = 0.0;
}

void HopperController::Touchdown(double t, const FlightState14& x) {
  TrajectoryRecorder& rec = recorders_[recording_];
  last_sample_t_ = t - hop_start_;
  rec.AddSample(last_sample_t_, x, u_);  // x^-(T1) with the input held over the last step
  rec.EndMode();
  rec.BeginMode(hopper::kStance);
  x_touchdown_ = x;
  report_.t_touchdown = t;
  report_.t1 = last_sample_t_;
  report_.body_touchdown = BodyState(x);
  report_.foot_height_td = HopperModel::FootHeight(x);
  foot_td_x_ = x(hopper::kX) + x(hopper::kR) * std::sin(x(hopper::kTheta));
  balances_.flight_dxd = x(hopper::kXd) - start_momentum_(0);
  balances_.flight_foot_dp =
      robot_model_->body_mass[map_.body_foot] * (FootVelocityX(x) - start_momentum_(1));
  phase_start_ = t;
  stance_first_ = true;
  touchdown_step_ = last_time_;
  stance_pending_ = false;
}

void HopperController::EndHop(double t, const FlightState14& x) {
  // The measured part of the report. The stance ends with its last recorded sample, x^-(T2).
  recorders_[recording_].EndMode();
  HopReport& r = report_;
  r.t2 = last_sample_t_;
  r.t_end = hop_start_ + r.t2;
  report_cost_.SetReference(hop_start_state_);
  r.terms = report_cost_.Terms(x_touchdown_, last_stance_, effort_);
  r.cost = r.terms.total();
  r.step_length = have_prev_td_ ? foot_td_x_ - prev_foot_td_x_ : 0.0;
  prev_foot_td_x_ = foot_td_x_;
  have_prev_td_ = true;
  // COM x at takeoff from the takeoff map of the last stance state.
  const double x_end =
      foot_td_x_ - last_stance_(hopper::kSR) * std::sin(last_stance_(hopper::kSTheta));
  r.speed = r.t2 > 0 ? (x_end - hop_start_state_(hopper::kX)) / r.t2 : 0.0;
  r.alpha = law_->alpha();
  r.du2 = law_->du_squared_integral();
  r.dt2 = law_->dT().squaredNorm();
  r.body_takeoff = BodyState(x);
  const double stance_time = t - r.t_touchdown;
  const double dyd =
      r.body_takeoff(3) - r.body_touchdown(3) - robot_model_->opt.gravity[2] * stance_time;
  r.identification = balances_;
  r.identification.end_foot_x = HopperModel::FootX(x);
  r.identification.end_foot_y = HopperModel::FootHeight(x);
  if (!(balances_.leg_rate_sq > 0.0)) {  // no step after the impact: no radial balance
    r.identification.leg_work = r.identification.leg_motion = r.identification.leg_rate_sq =
        HopIdentificationData::kNaN;
  }
  if (stance_time > 0 && dyd > 0) {
    r.stance_mass = stance_impulse_ / dyd;
    r.identification.stance_impulse = stance_impulse_;
    r.identification.stance_velocity = dyd;
  }
  mass_id_.Add(r.identification);
  const MassIdentification::Estimate estimate = mass_id_.estimate();
  terms_id_.Add(r.identification, estimate.mass);
  const TermsIdentification::Estimate terms = terms_id_.estimate();
  r.identified_mass = estimate.mass;
  r.model_mass = model_.params().M;
  if (config_.watch_max_mass > 0) {
    watching_ = !(estimate.mass > config_.watch_max_mass * config_.model.M);
  }
  r.identified_terms = terms;
  const HopperParams& model = model_.params();
  r.model_params = model;
  const IdentificationSettings& id = config_.identification;
  if ((id.mass || id.terms) && !resolve_request_ && !job_resolve_ && !staged_.ready) {
    resolve_request_ = IdentifiedModel(model, mass_id_, id.mass, id.mass_resolution, terms_id_,
                                       id.terms, id.term_resolution);
  }

  // Hand the hop to the offline part, unless it is still busy with the previous one (worker
  // thread only) or the law it learned has not taken effect yet (measured_latency): then this
  // hop is not learned from.
  if (job_.load(std::memory_order_acquire) != Job::kIdle || law_pending_) {
    r.accepted = false;
    r.learner_cost = std::numeric_limits<double>::quiet_NaN();
    waiting_.push_back({r, false});
    ++hop_;
    law_->BeginTrial();
    return;
  }
  // After a re-solve the new driver's "Initialize" waits for a hop of the new u^0 that has
  // settled on its gait (settle_cost), at the latest its trial settle_hops_max + 1 (trial 0 is
  // the hop the new u^0 took over in).
  ModelResolve* resolve = resolves_.empty() ? nullptr : &resolves_.back();
  if (resolve != nullptr && resolve->took_over_hop >= 0 && resolve->initialize_hop < 0 &&
      driver_->CompletionLearns() && !driver_->initialized()) {
    if (id.settle_cost > 0.0 && !(r.cost <= id.settle_cost * model_cost_) &&
        driver_->trial() <= id.settle_hops_max) {
      driver_->DelayInitialize();
    } else {
      resolve->initialize_hop = hop_;
    }
  }
  const bool learns = driver_->CompletionLearns();
  waiting_.push_back({r, true});
  recording_ = 1 - recording_;  // the finished hop's recorder now belongs to the offline part
  job_hop_ = hop_;
  job_end_ = t;
  job_resolve_ = resolve_request_;  // the offline part re-solves u^0 after the trial
  resolve_request_.reset();
  ++hop_;
  job_.store(Job::kPosted, std::memory_order_release);
  if (Synchronous()) {
    RunOffline();  // synchronous: the old behaviour, for comparison only
    law_ = next_law_;
    if (staged_.ready) TakeOverResolvedModel();
  } else {
    if (worker_.joinable()) {
      { std::lock_guard<std::mutex> lock(worker_mutex_); }
      worker_cv_.notify_one();
    }
    if (learns) {  // u^0 runs until the law learned from this hop takes effect
      law_ = &bridge_;
      law_pending_ = true;
      law_due_ = t + config_.offline_latency;
    }
  }
  law_->BeginTrial();
}

void HopperController::RunOffline() {
  if (job_.load(std::memory_order_acquire) != Job::kPosted) return;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ThreadCpuSeconds();
  const long steps = driver_->integration_steps();
  try {
    recorders_[1 - recording_].Finish(&trial_);
    driver_->SetWatching(watching_);
    outcome_ = driver_->CompleteTrial(trial_);
    outcome_latched_ = *latched_;
    OnlineController* learned = driver_->learned_law();
    if (outcome_.learned && learned != nullptr && !pitch_scale_.empty()) {
      learned->SetStateFeedbackScale(job_hop_ + 1 >= config_.pitch_experiment.from_hop
                                         ? pitch_scale_
                                         : std::vector<Vector>());
    }
    next_law_ = learned != nullptr ? learned : &fallback_;
    if (job_resolve_) ResolveModel(*job_resolve_);
    offline_error_.clear();
  } catch (const std::exception& e) {
    offline_error_ = std::string("offline part: ") + e.what();
    next_law_ = &fallback_;
  }
  offline_seconds_ =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  offline_steps_ = driver_->integration_steps() - steps;
  offline_cpu_seconds_ = ThreadCpuSeconds() - cpu_start;
  job_.store(Job::kDone, std::memory_order_release);
  if (!worker_.joinable()) TakeOfflineResult();
}

void HopperController::TakeOfflineResult() {
  if (job_.load(std::memory_order_acquire) != Job::kDone) return;
  if (!offline_error_.empty()) {
    failed_ = true;
    error_ = offline_error_;
  }
  // The law takes effect no sooner than the latency model's computer (modeled_latency) or this
  // one (measured_latency) produced it.
  double latency = config_.offline_latency;
  if (config_.modeled_latency && !Synchronous()) {
    latency = std::max(latency, config_.offline_hop_seconds +
                                    config_.offline_step_seconds *
                                        static_cast<double>(offline_steps_));
  }
  if (config_.measured_latency) latency = std::max(latency, offline_seconds_);
  if (job_resolve_ && staged_.ready) {  // this hop re-solved u^0: it takes over
    resolves_.push_back(staged_.record);
    if (!Synchronous()) law_pending_ = true;
    latency = std::max(latency, config_.identification.resolve_latency);
  }
  job_resolve_.reset();
  if (law_pending_) law_due_ = job_end_ + latency;
  for (Waiting& w : waiting_) {
    if (!w.needs_outcome) continue;
    w.report.offline_ms = 1e3 * offline_seconds_;
    w.report.offline_steps = offline_steps_;
    w.report.offline_cpu_ms = 1e3 * offline_cpu_seconds_;
    if (law_pending_) w.report.latency_ms = 1e3 * latency;
    w.report.accepted = outcome_.accepted;
    w.report.learner_cost = outcome_.cost;
    w.report.status = outcome_.status;
    w.report.start_shift = outcome_.start_shift;
    w.report.restarted = outcome_.restarted;
    w.report.remeasured = outcome_.remeasured;
    w.report.reverted = outcome_.reverted;
    w.report.reference_latched = outcome_latched_;
    w.report.nominal_cost = outcome_.nominal_cost;
    w.report.predicted = outcome_.predicted;
    w.report.optimality = outcome_.optimality;
    w.needs_outcome = false;
    break;
  }
  size_t done = 0;
  while (done < waiting_.size() && !waiting_[done].needs_outcome) {
    reports_.push_back(waiting_[done].report);
    ++done;
  }
  waiting_.erase(waiting_.begin(), waiting_.begin() + static_cast<std::ptrdiff_t>(done));
  job_.store(Job::kIdle, std::memory_order_release);
}

void HopperController::DeployLawWhenDue(double t) {
  if (!law_pending_ || job_.load(std::memory_order_acquire) != Job::kIdle || t < law_due_) return;
  // A law changes only in flight: one that arrives in stance waits for the next hop, which then
  // runs u^0 and is not learned from (EndHop).
  if (mode() != hopper::kFlight) return;
  law_pending_ = false;
  if (staged_.ready) {  // a re-solved u^0 (identification) rather than a learned law
    TakeOverResolvedModel();
    return;
  }
  law_ = next_law_;
  law_->BeginTrial();
}

void HopperController::FinishOffline() {
  if (worker_.joinable()) {
    while (job_.load(std::memory_order_acquire) == Job::kPosted) std::this_thread::yield();
  } else {
    RunOffline();
  }
  TakeOfflineResult();
}

void HopperController::WorkerLoop() {
  std::unique_lock<std::mutex> lock(worker_mutex_);
  for (;;) {
    worker_cv_.wait(lock, [this] {
      return worker_stop_ || job_.load(std::memory_order_acquire) == Job::kPosted;
    });
    if (worker_stop_) return;
    lock.unlock();
    RunOffline();
    lock.lock();
  }
}

void HopperController::StopWorker() {
  if (!worker_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(worker_mutex_);
    worker_stop_ = true;
  }
  worker_cv_.notify_one();
  worker_.join();
}

void Attach(HopperController* controller) {
  g_attached = controller;
  mjcb_control = controller != nullptr ? ControlCallback : nullptr;
}

void Detach() { Attach(nullptr); }

HopperController* Attached() { return g_attached; }

}  // namespace ddoc::plugin
