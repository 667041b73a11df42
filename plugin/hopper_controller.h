// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The controller plugin: Algorithm 1, mRL or OC-FB hop by hop on the MJCF hopper.
//
// MuJoCo 2.2 has no engine-plugin API (it came with 2.3), so the controller attaches through the
// global mjcb_control; it is shaped like a 2.3 plugin: Create (fails clearly, never half an
// object), Reset, Compute. See plugin/README.md.
#ifndef DDOC_PLUGIN_HOPPER_CONTROLLER_H_
#define DDOC_PLUGIN_HOPPER_CONTROLLER_H_

#include <atomic>
#include <condition_variable>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <mujoco/mujoco.h>

#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/hopper_learning.h"
#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/identification.h"
#include "ddoc/hopper/nominal_gait.h"
#include "ddoc/hopper/vsa.h"
#include "ddoc/mujoco/contact_phase.h"
#include "ddoc/mujoco/hopper_mapping.h"
#include "ddoc/online_controller.h"
#include "ddoc/plant.h"
#include "ddoc/trial_driver.h"
#include "hop_report.h"

namespace ddoc::plugin {

/// An experiment, NOT the paper and not a default: the learned laws of hops >= from_hop multiply
/// the flight feedback on the body pitch phi and its rate phid by `scale`
/// (OnlineController::SetStateFeedbackScale); u^0 keeps its feedback. docs/experiments.md,
/// "Flight pitch feedback".
struct PitchFeedbackExperiment {
  double scale = 1.0;  ///< in [0, 1]; 1 = off (the law as computed)
  int from_hop = 10;   ///< first hop whose learned law is scaled, >= 0
};

/// Online identification of the model's mass and terms (docs/hopper.md, "Identifying the mass",
/// "Identifying the model terms"): every hop feeds MassIdentification and TermsIdentification;
/// when what is acted on (`mass`, `terms`) leaves the estimate's confidence region, u^0 is solved
/// again on the model with the estimates (through the law cache), and every method goes on from
/// it with a new driver. Off by default (the paper keeps the model fixed).
struct IdentificationSettings {
  bool mass = false;  ///< act on the mass estimate (re-solve u^0); false: estimate and report only
  /// Act on the estimates of b_leg, b_hip, J_body (J_leg scaled with it), c_d and the floor
  /// slope (HopperParams); default false.
  bool terms = false;
  TermsIdentification::Settings terms_estimator;  ///< their gates, confidence and tolerances
  /// The re-solved model's terms are the estimates rounded to these.
  TermsIdentification::Resolution term_resolution;
  /// The estimate's gate and confidence; default a decision after one stance (decide_after 1,
  /// its se from the relative floor 1e-3), the gate from the third (min_samples 2), z 3,
  /// relative_tolerance 1 %.
  MassIdentification::Settings estimator = DefaultEstimator();
  double mass_resolution = 0.001;  ///< the re-solved model's M is the estimate rounded to this, kg
  /// Whole hops of the new u^0 before the new driver's "Initialize" hop (the hop in which the
  /// new law took over is not counted), >= 0; default 2.
  int settle_hops = 2;
  /// After settle_hops, the "Initialize" hop is the first hop of the new u^0 whose cost (42) is
  /// at most settle_cost x u^0's cost on the model (the new u^0 has settled on its gait); 0 =
  /// the hop after settle_hops whatever its cost. >= 0; default 2 (docs/experiments.md,
  /// "Learning from a settled hop").
  double settle_cost = 2.0;
  /// Whole hops of the new u^0 at most before "Initialize" when none settles, >= settle_hops;
  /// default 30.
  int settle_hops_max = 30;
  /// Simulated s from the identifying hop's end until the re-solved u^0 may take over (the
  /// offline part loads or solves the gait and u^0 meanwhile; with measured_latency at least its
  /// wall time), >= 0; default 0.1 s: a law-cache load (about 6 ms here) with a margin, so that
  /// the new u^0 takes over in the next flight. A cold solve takes 0.5-50 s instead;
  /// ModelResolve::wall_ms says what this computer took.
  double resolve_latency = 0.1;
  /// With `mass` or `terms` on, the learner trusts the identified model's law: its trials tend
  /// to the law that produced the nominal exactly as alpha -> 0, clamping at the input bounds
  /// included (LearnerSettings::blend_feedforward), and take no step predicted to gain less than
  /// min_predicted_decrease |I^i|. Default true (docs/experiments.md, "The law at alpha -> 0 on an
  /// identified model").
  bool model_law = true;
  /// With model_law: LearnerSettings::min_predicted_decrease of the learner, >= 0; default 0.03.
  double min_predicted_decrease = 0.03;

  static MassIdentification::Settings DefaultEstimator() {
    MassIdentification::Settings s;
    s.regression.min_samples = 2;
    s.regression.decide_after = 1;
    return s;
  }
};

/// Configuration of HopperController. Plain struct; every field has a default.
struct ControllerConfig {
  TrialDriverSettings driver = HopperTrialSettings();  ///< method, warm-up hops, Algorithm 1
  HopperParams model;                                  ///< the (possibly inexact) analytic model
  HopperCostWeights cost_weights;                      ///< weights of (42); default Fig. 2
  NominalGaitSettings gait;                            ///< the gait u^0 is solved from
  LearnerSettings model_learner = HopperModelSolveSettings();  ///< the OC-FB solve on the model
  /// alpha of u^0 = Learner::ConvergedPolicy(alpha) of the model solve; 0 = nominal + feedback.
  double ocfb_alpha = 0.0;
  double dt_model = 1e-3;                ///< RK4 step of the model plant, s
  HopperModeDurations durations;         ///< duration bounds of flight and stance, s
  ContactPhaseSettings contact;          ///< the contact-phase detector (src/mujoco)
  int max_samples_per_mode = 4000;       ///< preallocated samples per mode, >= 10
  /// I1 reference of the learner: true (default) the model gait's takeoff state (NOT the
  /// paper), false the hop's own start (42).
  bool anchor_reference = true;
  /// With anchor_reference: I1's x_ref for the learner is w x the gait's takeoff state + (1 - w)
  /// x the hop's own start, w in [0, 1]; 1 = the gait's alone. Default 1.
  double anchor_weight = 1.0;
  /// With anchor_weight < 1: gain b in (0, 1] of the filter of the hop's own start in that
  /// blend, s <- s + b (x(0) - s) from the gait's takeoff state (HopperCostReference); 1 = the
  /// hop's own start unfiltered. Default 1.
  double reference_filter = 1.0;
  /// With anchor_weight < 1 and reference_filter < 1: once a learner's hop starts faster than the
  /// gait's takeoff xd by more than this (m/s), the gait's state is I1's reference for the rest
  /// of the run (until a re-solve of u^0); 0 = never. Default 0.
  double overspeed_latch = 0.0;
  /// s from a hop's end until the law learned from it takes effect (u^0 runs meanwhile), in
  /// [0, durations.flight_min); 0 = learn inside Compute (synchronous). docs/design.md.
  double offline_latency = 0.02;
  /// true: the law takes effect max(offline_latency, the wall time its offline part took on this
  /// computer) after the hop, and never outside a flight (a hop that ends first is not learned
  /// from): offline_latency="measured". Default false. docs/design.md, "Honest latency".
  bool measured_latency = false;
  /// true (default): the law takes effect max(offline_latency, the latency model's time for the
  /// hop's offline part) after the hop, never outside a flight (as measured_latency, but
  /// deterministic); false with measured_latency false: offline_latency, fixed. Off in the
  /// synchronous mode (offline_latency 0). docs/design.md, "Honest latency".
  bool modeled_latency = true;
  /// The latency model's robot computer: a hop's offline part takes offline_hop_seconds +
  /// offline_step_seconds x the backward passes' integration steps in it
  /// (TrialDriver::integration_steps). Defaults 1 ms and 3.6 us: the thread CPU time of the
  /// offline parts on this project's build machine (AMD EPYC, one core; docs/design.md).
  double offline_hop_seconds = 1e-3;
  double offline_step_seconds = 3.6e-6;
  /// true: the offline part runs on a worker thread (as on a robot); false: in RunOffline().
  bool offline_thread = false;
  PitchFeedbackExperiment pitch_experiment;  ///< off by default
  IdentificationSettings identification;     ///< mass estimate always; acting on it off
  /// > 0: the harm guard's watch goes back to an earlier law only while the identified mass
  /// (every hop, whether or not identification acts) is at most this x `model.M`, the given
  /// model's (TrialDriver::SetWatching); 0 = always; no effect without driver.guard.watch_trials.
  /// Default 1.05. docs/hopper.md.
  double watch_max_mass = 1.05;
  /// Directory of stored u^0 laws (plugin/law_cache.h): Create loads u^0 from it when the model
  /// solve's inputs and binaries match, else solves and stores. "" (default) = always solve.
  std::string law_cache;
};

/// The controller. One instance per mjData. Compute, TakeReports and the observers belong to the
/// simulation thread; only the offline part may run elsewhere (offline_thread).
class HopperController {
 public:
  using FlightState14 = Eigen::Matrix<double, 14, 1>;

  /// Builds the mapping from the mjModel, validates the config, finds the nominal gait of the
  /// model and solves the model-based optimal control problem from it (u^0, the OC-FB law).
  /// Returns null and sets *error on any misconfiguration.
  static std::unique_ptr<HopperController> Create(const mjModel* m, const ControllerConfig& config,
                                                  std::string* error);
  ~HopperController();
  HopperController(const HopperController&) = delete;
  HopperController& operator=(const HopperController&) = delete;

  /// Puts the robot at the nominal gait's takeoff state at time 0 and restarts learning from u^0
  /// (a model that identification re-solved stays).
  void Reset(const mjModel* m, mjData* d);

  /// The per-step work (mjcb_control): maps the state once, detects the contact phase, advances
  /// the VSA, steps the current law, writes ctrl; at a takeoff hands the measured hop to the
  /// offline part. Never blocks, never throws, never writes a non-finite or out-of-bounds input.
  /// A call at the same simulated time as the previous one, a nested call or a call while held
  /// only rewrites the held input. A call with another (m, d) than the last Reset's (MuJoCo's
  /// callback is global: compiling or forwarding another model calls it too) does nothing.
  void Compute(const mjModel* m, mjData* d);

  /// True when a measured hop waits for RunOffline (host mode, offline_thread = false).
  bool offline_pending() const { return job_ == Job::kPosted && !worker_.joinable(); }
  /// The offline part for the last measured hop (trial driver: (36), (30), (31), the next law).
  /// Host mode: call between steps when offline_pending(). Allocates.
  void RunOffline();
  /// Blocks until the offline part of the last hop has run (either mode), then takes its result.
  void FinishOffline();

  /// While held, Compute only rewrites the held input (see HoldScope).
  void set_hold(bool hold) { hold_ = hold; }
  bool hold() const { return hold_; }

  /// From the next hop on every hop runs the law of the running hop; reports go on (accepted,
  /// learner_cost measured). Reset() unfreezes. Waits for the offline part first.
  void Freeze();
  bool frozen() const { return driver_->frozen(); }

  /// Abandons the running hop (no report) and starts a new one at the flight state x (14, model
  /// coordinates) at the current time, with the law the running hop used. mjData is reset first,
  /// so the hop depends on x and the law only. Call between steps. Waits for the offline part.
  /// Throws InvalidArgument when x is not finite.
  void RestartHop(const mjModel* m, mjData* d, const FlightState14& x);

  /// The measured flight state at the start (takeoff) of the running hop.
  const FlightState14& hop_start_state() const { return hop_start_state_; }
  /// Reports of the hops completed since the last call (moves them out).
  std::vector<HopReport> TakeReports();

  // Observers (read between steps).
  int mode() const { return detector_.mode(); }           ///< hopper::kFlight / kStance
  int hop() const { return hop_; }                        ///< index of the running hop
  const double* last_input() const { return u_.data(); }  ///< 4: u applied at the last step
  const VsaState& vsa() const { return vsa_.state(); }
  const HopperMapping& mapping() const { return map_; }
  const NominalGait& gait() const { return gait_; }
  const TrialDriver& driver() const { return *driver_; }
  const Learner* learner() const { return driver_->learner(); }
  /// True while the running law is u^0 (warm-up, OC-FB, a learner stopped before accepting,
  /// and the latency after a hop whose law is being learned).
  bool runs_initial_law() const { return law_ == &fallback_ || law_ == &bridge_; }
  double model_cost() const { return model_cost_; }  ///< converged OC-FB cost on the model
  int model_iterations() const { return model_iterations_; }
  /// Where u^0 came from: "solved" (no law_cache), "loaded <file>", "stored <file>", or "solved;
  /// not stored: <why>"; a stored file that could not be used adds " (<file>: <why>)".
  const std::string& law_cache_status() const { return law_cache_status_; }
  /// The stances' mass estimate (IdentificationSettings; kept whether or not it is acted on).
  const MassIdentification& mass_identification() const { return mass_id_; }
  /// The hops' estimates of b_leg, b_hip and the slope (kept whether or not they are acted on).
  const TermsIdentification& terms_identification() const { return terms_id_; }
  /// The re-solves of u^0 on an identified model, in order (empty when identification is off).
  const std::vector<ModelResolve>& resolves() const { return resolves_; }
  /// The model the laws are computed on now (config().model until a re-solve took over).
  const HopperParams& model_params() const { return model_.params(); }
  /// True when the law cache could not store u^0 or held a file it could not use.
  bool law_cache_trouble() const { return law_cache_trouble_; }
  /// Set when the controller caught an internal error (the message says what failed); it then
  /// holds the last safe input until Reset.
  bool failed() const { return failed_; }
  const std::string& error() const { return error_; }
  long nonfinite_steps() const { return nonfinite_steps_; }  ///< steps with a non-finite state
  const ControllerConfig& config() const { return config_; }
  const Vector& u_min() const { return problem_.bounds.u_min; }  ///< Table I
  const Vector& u_max() const { return problem_.bounds.u_max; }  ///< Table I

 private:
  enum class Job { kIdle, kPosted, kDone };  // the offline part of the last hop
  struct Waiting {                           // a report and whether it waits for an outcome
    HopReport report;
    bool needs_outcome = true;
  };

  HopperController(const mjModel* m, const ControllerConfig& config);
  void Initialize();  // gait, u^0, driver; throws
  // A new driver of config_.driver on fallback_ (warm-up at least `warmup` trials).
  void MakeDriver(int warmup);
  // Offline side: the gait and u^0 of the model `params`, into staged_ (law cache first).
  void ResolveModel(const HopperParams& params);
  // Simulation side, in flight: the staged model, gait and u^0 take over; a new driver.
  void TakeOverResolvedModel();
  void PlaceAtTakeoff(const mjModel* m, mjData* d, const double* x, double t);
  void Step(const mjData* d);
  // The touchdown at t with x^-(T1) = x.
  void Touchdown(double t, const FlightState14& x);
  // ContactPhaseSettings::substep_events: the takeoff at the detector's event_time(), between the
  // last two steps; the samples and the effort on either side go to their hop (step time t).
  void TakeoffInsideStep(double t);
  // Adds the floor's vertical force over the last step [t - h, t] of a stance to stance_impulse_.
  void AddStanceImpulse(const mjData* d, double h);
  // Adds the last step [t_prev, t_prev + h] to the hop's pitch balance and, for a stance step
  // from the first post-impact state on (t_prev > the touchdown step), to its radial balance.
  void AddBalances(const mjData* d, bool was_stance, double t_prev, double h);
  // In flight: starts the flight's momentum balance at this state once the foot has no contact.
  void StartFlightBalance(const mjData* d);
  // The hop ends at t; x: the flight state there (the next hop's start).
  void EndHop(double t, const FlightState14& x);
  void BeginHop(double t, const FlightState14& x);
  void Record(double t);
  void TakeOfflineResult();
  void DeployLawWhenDue(double t);
  void WorkerLoop();
  void StopWorker();
  void WriteHeld(const mjModel* m, mjData* d);
  void Sanitize();  // u_ finite and inside the bounds
  // The offline part runs inside Compute at the hop's end (offline_latency 0, not measured).
  bool Synchronous() const { return config_.offline_latency == 0.0 && !config_.measured_latency; }

  ControllerConfig config_;
  HopperMapping map_;
  HopperModel model_;         // the model the laws are computed on (a re-solve replaces it)
  HopperModel report_model_;  // config.model, kept: the reports' (42) stays comparable
  HopperCost cost_;         // the problem's cost (the offline part sets its reference)
  HopperCost report_cost_;  // the reports' I1..I4 (Compute), against the hop's own start
  Problem problem_;
  ModelPlant model_plant_;
  HopperPredictionPlant prediction_plant_{&model_plant_};  // mRL's direction plant
  NominalGait gait_;
  OnlineController fallback_;  // u^0, the OC-FB law of the model solve (the driver's fallback)
  Matrix cyclic_value_;        // u^0's model solve's cyclic value: the drivers' learners' seed
  OnlineController bridge_;    // a copy of u^0 that runs while the offline part works
  std::unique_ptr<TrialDriver> driver_;
  double model_cost_ = 0.0;
  int model_iterations_ = 0;
  std::string law_cache_status_ = "solved";
  bool law_cache_trouble_ = false;
  // Identification: the estimate (simulation side), the model's mass asked for (NaN: none), the
  // re-solve the offline part staged, and the record.
  MassIdentification mass_id_;
  TermsIdentification terms_id_;
  std::optional<HopperParams> resolve_request_;
  std::optional<HopperParams> job_resolve_;  // the job's request
  struct Staged {
    bool ready = false;  // the offline part solved it; it takes over when due, in flight
    HopperParams params;
    NominalGait gait;
    OnlineController law;
    double cost = 0.0;
    int iterations = 0;
    Matrix cyclic_value;
    ModelResolve record;  // resolves_ gets it on the simulation side (TakeOfflineResult)
  } staged_;
  std::vector<ModelResolve> resolves_;
  std::vector<Vector> pitch_scale_;  // PitchFeedbackExperiment: per mode, empty when off

  // Per-step state (Compute).
  const mjModel* robot_model_ = nullptr;  // the (m, d) of the last Reset: Compute's only target
  const mjData* robot_data_ = nullptr;
  ContactPhaseDetector detector_;
  Vsa vsa_;
  OnlineController* law_ = nullptr;              // the law that runs now
  Eigen::Vector4d u_ = Eigen::Vector4d::Zero();  // input held over the current step
  FlightState14 xf_;                              // flight coordinates of the current state
  Eigen::Matrix<double, 10, 1> xs_;               // stance coordinates of the current state
  Eigen::Matrix<double, 10, 1> last_stance_;      // stance state of the previous step
  bool started_ = false, in_compute_ = false, hold_ = false;
  double last_time_ = 0.0;    // simulated time of the last new step
  double phase_start_ = 0.0;  // absolute time the current mode started
  long nonfinite_steps_ = 0;

  // The running hop (one trial): samples and the measured part of its report.
  int hop_ = 0;
  double hop_start_ = 0.0;  // absolute time of its takeoff (trial t = 0)
  FlightState14 hop_start_state_;
  TrajectoryRecorder recorders_[2];  // [recording_] records this hop; the other is handed over
  int recording_ = 0;
  double last_sample_t_ = 0.0;  // trial time of the last recorded sample
  bool stance_first_ = false;   // the first stance sample (stamped at T1) is pending
  double touchdown_step_ = 0.0;  // the step time of the touchdown (t_touchdown without substep)
  // substep_events: the last two steps' times, flight states (both modes), inputs, the stance
  // state of the step before last_stance_, and whether last_stance_ waits to be recorded (a
  // takeoff found at the next step may fall before it).
  double hist_t_[2] = {0.0, 0.0};
  FlightState14 hist_xf_[2];
  Eigen::Vector4d hist_u_[2];
  Eigen::Matrix<double, 10, 1> prev_stance_;
  bool stance_pending_ = false;
  HopReport report_;            // measured part, filled as the hop runs
  FlightState14 x_touchdown_;
  double effort_ = 0.0;         // int 1/2 u'Ru dt over the hop
  double stance_impulse_ = 0.0;  // the floor's vertical impulse over the hop's stance, N s
  HopIdentificationData balances_;  // the hop's radial and pitch sums (identification)
  double prev_phid_ = 0.0;          // phid of the previous step (the pitch balance)
  Eigen::Vector2d prev_body_v_ = Eigen::Vector2d::Zero();  // (xd, yd) of the previous step
  // The flight balance's start (xd, the foot's x rate) and whether it has started (the foot clear).
  Eigen::Vector2d start_momentum_ = Eigen::Vector2d::Zero();
  bool flight_clear_ = false;
  double foot_td_x_ = 0.0, prev_foot_td_x_ = 0.0;
  bool have_prev_td_ = false;

  // The offline part: the hop handed over, its result, and the law it makes.
  std::atomic<Job> job_{Job::kIdle};
  bool watching_ = true;  // watch_max_mass, from the last hop's mass estimate
  Trajectory trial_;                    // the handed-over hop (offline side)
  TrialOutcome outcome_;                // its result (offline side)
  std::shared_ptr<bool> latched_ = std::make_shared<bool>(false);  // the overspeed latch (offline)
  bool outcome_latched_ = false;        // *latched_ after the job (offline side)
  int job_hop_ = 0;                     // the hop handed over
  std::string offline_error_;           // what failed in the offline part
  std::vector<Waiting> waiting_;        // reports in hop order, until their outcome arrived
  std::vector<HopReport> reports_;      // completed reports
  OnlineController* next_law_ = nullptr;  // the law the offline part chose
  bool law_pending_ = false;            // next_law_ takes effect at law_due_
  double law_due_ = 0.0;
  double job_end_ = 0.0;                // simulated time of the handed-over hop's end, s
  double offline_seconds_ = 0.0;        // wall time of the last offline part, s
  long offline_steps_ = 0;              // the backward passes' integration steps in it
  double offline_cpu_seconds_ = 0.0;    // its thread CPU time, s
  std::thread worker_;
  std::mutex worker_mutex_;
  std::condition_variable worker_cv_;
  bool worker_stop_ = false;
  bool failed_ = false;
  std::string error_;
};

/// Holds a controller for the scope's lifetime (see HopperController::set_hold): wrap code that
/// calls mj_step/mj_forward on the robot's mjData for other purposes, notably mjd_transitionFD,
/// which in MuJoCo 2.2 advances d->time on each of its internal steps.
class HoldScope {
 public:
  explicit HoldScope(HopperController* c) : c_(c), was_(c->hold()) { c_->set_hold(true); }
  ~HoldScope() { c_->set_hold(was_); }
  HoldScope(const HoldScope&) = delete;
  HoldScope& operator=(const HoldScope&) = delete;

 private:
  HopperController* c_;
  bool was_;
};

/// Attaches `controller` to MuJoCo's global mjcb_control (one controller per process: MuJoCo
/// 2.2's callback is global). Attach(nullptr) or Detach() clears it.
void Attach(HopperController* controller);
void Detach();
/// The attached controller, or null.
HopperController* Attached();

}  // namespace ddoc::plugin

#endif  // DDOC_PLUGIN_HOPPER_CONTROLLER_H_
