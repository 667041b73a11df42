// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// What ddoc-hopper and ddoc-return-map share: loading a run (scenario, command-line overrides,
// robot, model, controller) and stepping it (drag, pushes, the offline part, the fall limits).
#ifndef DDOC_APP_HOPPER_RUN_H_
#define DDOC_APP_HOPPER_RUN_H_

#include <Eigen/Core>

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ddoc/mujoco/hopper_sim.h"
#include "hopper_controller.h"
#include "scenario.h"

namespace CLI {
class App;
}  // namespace CLI

namespace ddoc::app {

/// Exit codes of the hopper tools (docs/reliability.md: the fault cases).
constexpr int kExitOk = 0;           ///< completed
constexpr int kExitError = 1;        ///< internal error (the message says what)
constexpr int kExitBadInput = 2;     ///< bad input, reported before the simulation starts
constexpr int kExitFall = 3;         ///< the robot fell (a valid result)
constexpr int kExitInterrupted = 4;  ///< SIGINT or SIGTERM
constexpr int kExitIo = 5;           ///< a log write failed (disk full, size limit, dir gone)
constexpr int kExitNonFinite = 6;    ///< a NaN, Inf or huge value in mjData

/// An error that ends a tool with `code` (kExitBadInput or kExitError); the message names it.
class RunError : public std::runtime_error {
 public:
  RunError(int code, const std::string& what) : std::runtime_error(what), code_(code) {}
  int code() const { return code_; }

 private:
  int code_;
};

/// The body of the tools' main(): sends MuJoCo's warnings to stderr (mujoco_warnings.h), runs
/// `run`; a RunError escaping it is printed as
/// "<tool>: <message>" and ends with its code, any other exception as "<tool>: internal error:
/// <message>" with kExitError.
int RunTool(const char* tool, int (*run)(int argc, char** argv), int argc, char** argv);

/// Fall limits: the run ends with exit code 3 when one holds.
struct FallLimits {
  double min_height = 0.3;     ///< COM height above the floor below this, m (the leg is 0.7 m)
  double max_pitch = 1.0;      ///< |phi| above this, rad (57 deg)
  double max_leg_angle = 1.2;  ///< |theta| above this, rad (69 deg): the leg nearly horizontal
  double max_phase = 3.0;      ///< a flight or stance phase longer than this, s (stalled)
};

/// Returns a non-empty reason when the robot has fallen. floor_slope (rad, HopperParams::slope's
/// sign: > 0 rises in +x) is the robot's floor (HopperMapping::floor_slope): the COM height is
/// then measured above the floor line y = x tan(floor_slope) under it.
std::string FallReason(const FallLimits& lim, const Eigen::Matrix<double, 14, 1>& x,
                       double phase_time, double floor_slope = 0.0);

/// The analytic model of a scenario: its model MJCF (if any), then the numbers on top.
HopperParams ModelParams(const Scenario& s);

/// The controller configuration of a scenario: method, model, gait, <learning>, <experiment>.
plugin::ControllerConfig ControllerConfigFor(const Scenario& s, const HopperParams& model);

/// Command-line overrides of a scenario (unset: the scenario's value).
struct RunOverrides {
  std::string method;                    ///< --method alg1 | ocfb | mrl
  std::optional<int> hops;               ///< --hops N (alone: no seconds limit)
  std::optional<double> seconds;         ///< --seconds S (alone: no hops limit)
  std::string robot;                     ///< --robot MJCF
  /// --robot-variant mass=KG,j_body=KGM2,c_d=KG_PER_M,beta=RAD_PER_S: the robot's numbers
  /// (robot_variant.h; docs/hopper.md, "Robot variants"); empty: the robot file's.
  std::string robot_variant;
  std::string model_mjcf;                ///< --model-mjcf MJCF: replaces the scenario's <model>
  std::vector<std::string> pushes;       ///< --push TIME,FORCE,DURATION, added to the scenario's
  bool no_pushes = false;                ///< --no-pushes: drop the scenario's pushes
  bool substep_events = false;  ///< --substep-events: ContactPhaseSettings::substep_events on
  /// --offline-latency S: ControllerConfig::offline_latency, fixed (modeled_latency off).
  std::optional<double> offline_latency;
  /// --offline-latency measured: ControllerConfig::measured_latency (the floor stays 0.02 s).
  bool measured_latency = false;
  /// --preset default | paper | identified (default with --identify; overrides the scenario)
  std::string preset;
  /// --identify / --no-identify: IdentificationSettings::mass (overrides the scenario and preset)
  std::optional<bool> identify;
  /// --identify-terms / --no-identify-terms: IdentificationSettings::terms (overrides the scenario)
  std::optional<bool> identify_terms;
  /// --identify-terms-acted LIST: TermsIdentification::Settings::acted (overrides the scenario)
  std::optional<TermsIdentification::Settings::Acted> identify_terms_acted;
  /// --law-cache DIR: stored u^0 laws (ControllerConfig::law_cache); unset: $DDOC_LAW_CACHE (set
  /// and empty: off), then, when `user_law_cache`, DefaultLawCacheDir(), else off.
  std::string law_cache;
  bool no_law_cache = false;  ///< --no-law-cache: always solve u^0 (no cache read or written)
  /// An unset law cache falls back to the per-user DefaultLawCacheDir(); Register sets it (the
  /// command-line tools), false (default) for other callers (Python's run_hopper).
  bool user_law_cache = false;

  /// Registers the flags shared by ddoc-hopper and ddoc-return-map on `cli`; `full` adds those
  /// only ddoc-hopper takes (--hops, --seconds, --robot, --robot-variant, --model-mjcf, --push).
  void Register(CLI::App* cli, bool full);
};

/// The presets of --preset (and Python's preset=), as an error message lists them.
constexpr const char* kPresetNames = "default, paper or identified";
/// True when `name` is one of kPresetNames.
bool IsPreset(const std::string& name);

/// The per-user directory of stored u^0 laws: $XDG_CACHE_HOME/ddoc when XDG_CACHE_HOME is an
/// absolute path, else $HOME/.cache/ddoc; "" (no cache) when neither is set.
std::string DefaultLawCacheDir();

/// A scenario loaded and ready to step.
struct LoadedRun {
  Scenario scenario;
  /// The robot's MJCF as summary.json names it: the file, and " with mass=..." for a variant.
  std::string robot_name;
  plugin::ControllerConfig config;
  MjModelPtr model;
  MjDataPtr data;
  std::unique_ptr<plugin::HopperController> controller;  ///< created and Reset
};

/// The load-a-run step: the scenario with the overrides, validated; the robot MJCF; the model's
/// parameters; then (StartController) the controller (Create + Reset). Throws RunError:
/// kExitBadInput for bad input (the message names the file, flag or element), kExitError when the
/// controller cannot be created. Without `start_controller` the controller is left empty, so that
/// the caller can check its own settings before the controller's start (which derives u^0 on the
/// model, seconds of work) and call StartController then.
LoadedRun LoadRun(const std::string& scenario_path, const RunOverrides& overrides,
                  bool start_controller = true);
void StartController(LoadedRun* run);

/// What one step of a run ended with.
struct StepOutcome {
  // kFailed: the controller failed; kFell: a fall limit; kNonFinite: MuJoCo found a NaN, Inf or
  // huge value in qpos, qvel or qacc (and reset the state), or the state is not finite.
  enum class Kind { kOk, kFailed, kFell, kNonFinite };
  Kind kind = Kind::kOk;
  std::string reason;  ///< the controller's error, or why the robot fell, or what is not finite
};

/// Steps a loaded run: drag and the active pushes into xfrc_applied, mj_step (the controller runs
/// in mjcb_control), the offline part between steps (RunOffline), the fall limits. Attaches the
/// controller for its lifetime.
class RunStepper {
 public:
  explicit RunStepper(LoadedRun* run);
  ~RunStepper();
  RunStepper(const RunStepper&) = delete;
  RunStepper& operator=(const RunStepper&) = delete;

  StepOutcome Step();
  /// After HopperController::RestartHop: the phase clock of the fall limits restarts.
  void Restarted();
  /// Pushes act (default) or not.
  void set_pushes(bool on) { pushes_ = on; }
  double push() const { return push_; }  ///< the push force of the last step, N
  /// The scenario's timed pushes, then its hop pushes in the order they were resolved (at the
  /// start of their hop: hop start + phase x the previous hop's duration, takeoff to takeoff,
  /// and not before the step after the takeoff).
  const std::vector<Push>& pushes() const { return pushes_now_; }
  /// Per scenario hop push: its start time once its hop has started.
  const std::vector<std::optional<double>>& hop_push_times() const { return hop_push_times_; }
  /// Flight coordinates of the state after the last step.
  const Eigen::Matrix<double, 14, 1>& state() const { return x_; }

 private:
  void HopStarted(double t_start);

  LoadedRun* run_;
  FallLimits limits_;
  bool pushes_ = true;
  double push_ = 0.0;
  int mode_ = hopper::kFlight;
  double phase_start_ = 0.0;
  int hop_ = 0;             // the controller's hop after the last step
  double hop_start_ = 0.0;  // when it started (the takeoff's step), s
  std::vector<Push> pushes_now_;
  std::vector<std::optional<double>> hop_push_times_;
  Eigen::Matrix<double, 14, 1> x_ = Eigen::Matrix<double, 14, 1>::Zero();
};

/// PNG frames and/or the video of a run (ddoc-hopper --render, --video;
/// ddoc.run_hopper(render_dir=...)): a FrameRecorder with the hopper's overlay (method, hop, last
/// cost, speed); nothing when `dir` and `video` are empty.
class RunFrames {
 public:
  struct Settings {
    std::string dir;  ///< PNG directory; empty: no frames
    int width = 640, height = 480;
    double fps = 60;
    std::string video{};  ///< MP4 streamed through ffmpeg (no PNG needed); empty: no video
  };
  /// Throws RunError(kExitBadInput) for a bad setting, or a `dir` in a build without rendering;
  /// `flag` names the option in the message ("--render" -> "--render: this build has no ...").
  RunFrames(const Settings& settings, const mjModel* m, const std::string& method,
            const std::string& flag);
  ~RunFrames();
  RunFrames(const RunFrames&) = delete;
  RunFrames& operator=(const RunFrames&) = delete;
  /// The frames due now (FrameRecorder::MaybeCapture); throws std::runtime_error naming the file.
  void Capture(const mjModel* m, mjData* d, int hop, double cost, double speed);
  /// Waits for the queued writes and finishes the video; false and *error when one failed.
  bool Finish(std::string* error);
  /// After Finish: "video: wrote PATH (...)" or why it failed; "" without a video.
  std::string video_message() const;
  /// Frames written or queued so far.
  long frame_count() const;
  bool active() const { return impl_ != nullptr; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ddoc::app

#endif  // DDOC_APP_HOPPER_RUN_H_
