// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-hopper: runs a hopper scenario headless. The true robot is the MJCF hopper stepped by
// MuJoCo; the controller plugin (plugin/) runs Algorithm 1, OC-FB or mRL in mjcb_control.
//
// Exit codes (hopper_run.h; docs/reliability.md): 0 completed, 1 internal error, 2 bad input,
// 3 the robot fell, 4 interrupted (SIGINT/SIGTERM), 5 a log write failed, 6 non-finite state.
// Every one but 2 leaves every completed hop in hops.csv and "end" in summary.json.
#include <unistd.h>

#include <csignal>

#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <exception>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "hopper_run.h"
#include "run_log.h"

namespace ddoc::app {
namespace {

// The signal that asked the run to stop (SIGINT or SIGTERM), 0 while none did.
volatile std::sig_atomic_t g_stop_signal = 0;
// Stop signals received so far.
volatile std::sig_atomic_t g_stop_count = 0;

// The first and the second stop signal ask the run to end (the main thread checks every step
// and, during the start, every 50 ms, then writes the logs and summary.json); the third kills
// the process (the signal's default action), for a run that does not react.
extern "C" void OnStopSignal(int signal) {
  if (g_stop_signal == 0) g_stop_signal = signal;
  g_stop_count = g_stop_count + 1;
  if (g_stop_count >= 3) {
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}

// SIGINT and SIGTERM end the run after the current step, with the logs complete (OnStopSignal).
// A file size limit makes a write fail (EFBIG, reported as an I/O error) instead of killing the
// process with SIGXFSZ.
void InstallSignalHandlers() {
  struct sigaction sa = {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGXFSZ, SIG_IGN);
}

const char* StopSignalName() { return g_stop_signal == SIGINT ? "SIGINT" : "SIGTERM"; }

// The wall clock of the whole run (summary.json's wall_time_s): from the start of main.
const std::chrono::steady_clock::time_point g_wall0 = std::chrono::steady_clock::now();

double WallTime() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - g_wall0).count();
}

struct Options {
  std::string scenario, out, render_dir, video;
  int width = 640, height = 480, log_every = 1;
  double fps = 60;
  bool quiet = false;
  RunOverrides run;
};

// Parses the command line into *o. Returns -1 to go on, else the exit code.
int ParseOptions(int argc, char** argv, Options* o) {
  CLI::App cli{
      "ddoc-hopper: data-driven iterative optimal control (Algorithm 1) of the MuJoCo hopper.\n"
      "Exit codes: 0 completed, 1 internal error, 2 bad input, 3 the robot fell, 4 interrupted\n"
      "(SIGINT/SIGTERM), 5 a log write failed (disk full, file size limit, output directory\n"
      "gone), 6 non-finite state. Completed hops are always in hops.csv; summary.json's \"end\"\n"
      "says how the run ended."};
  cli.add_option("scenario", o->scenario, "scenario XML file (see models/scenarios/)")->required();
  cli.add_option("--out,-o", o->out, "output directory (default: out/<scenario name>)");
  o->run.Register(&cli, true);
  cli.add_option("--log-every", o->log_every, "write every N-th physics step to trajectory.csv");
  cli.add_option("--render", o->render_dir,
                 "write PNG frames into this directory (with --video: the video too)");
  cli.add_option("--width", o->width, "frame width in pixels (default 640)");
  cli.add_option("--height", o->height, "frame height in pixels (default 480)");
  cli.add_option("--fps", o->fps, "frames per second of simulated time (default 60)");
  cli.add_option("--video", o->video,
                 "stream the frames into this MP4 through ffmpeg (no PNG files unless --render)");
  cli.add_flag("--quiet,-q", o->quiet, "no progress display");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  if (o->log_every < 1) {
    std::fprintf(stderr, "ddoc-hopper: --log-every must be >= 1\n");
    return kExitBadInput;
  }
  return -1;
}

// The frames of a run (app::RunFrames): PNG files with --render, the MP4 streamed through ffmpeg
// with --video (no PNG files then). Every bad setting is reported before the run.
class Frames {
 public:
  // Throws RunError(kExitBadInput). `method` goes into the overlay.
  Frames(const Options& o, const mjModel* m, const std::string& method)
      : frames_({o.render_dir, o.width, o.height, o.fps, o.video}, m, method,
                o.render_dir.empty() ? "--video" : "--render"),
        video_(o.video) {}
  void Capture(const mjModel* m, mjData* d, int hop, double cost, double speed) {  // throws
    frames_.Capture(m, d, hop, cost, speed);
  }
  // Finishes the PNG files and the video; the exit code, kExitError when they failed on a run
  // that had none. *video: the MP4 when it was written.
  int Finish(int exit_code, std::string* video);
  bool active() const { return frames_.active(); }
  long frame_count() const { return frames_.frame_count(); }

 private:
  RunFrames frames_;
  std::string video_;  // --video
};

int Frames::Finish(int exit_code, std::string* video) {
  if (!frames_.active()) return exit_code;
  std::string error;
  const bool ok = frames_.Finish(&error);
  const std::string message = frames_.video_message();
  if (!ok) {
    std::fprintf(stderr, "ddoc-hopper: %s\n", error.c_str());
    return exit_code == kExitOk ? kExitError : exit_code;
  }
  if (!message.empty()) std::fprintf(stderr, "ddoc-hopper: %s\n", message.c_str());
  if (!video_.empty()) *video = video_;
  return exit_code;
}

// One run of ddoc-hopper: steps the loaded scenario and writes the logs as it goes.
class HopperRun {
 public:
  HopperRun(const Options& o, LoadedRun* run, RunLog* log, Frames* frames);
  // Steps until the scenario's hops or seconds, a fall, a signal or an error; returns the exit
  // code, with summary_.end saying how the run ended.
  int Loop();
  // Final summary and messages; returns the exit code.
  int Finish(int exit_code);

 private:
  int Steps();  // Loop without the log-error handling
  // Records how the run ended (summary.json's end, end_message) and returns `exit_code`.
  int End(int exit_code, const char* end, const std::string& message);
  bool Done() const;
  bool Capture();  // the frame due now; false (and the reason in the summary) on an error
  void LogStep();
  void LogPushEvents();
  void LogHops();
  void Fell(const std::string& reason);

  const Options& o_;
  LoadedRun* run_;
  RunLog* log_;
  Frames* frames_;
  RunStepper stepper_;
  Summary summary_;
  long step_ = 0;
  double last_cost_ = std::nan(""), last_speed_ = std::nan("");
  double sim_time_ = 0;  // of the last finite state (MuJoCo's reset after a bad value zeroes time)
  std::vector<bool> push_started_, push_ended_;
  std::deque<plugin::HopReport> pending_;  // hops taken from the controller, not yet in hops.csv
  bool progress_;
};

// The fields of summary.json that the scenario sets (before the controller starts).
Summary ScenarioSummary(const LoadedRun& run) {
  const Scenario& s = run.scenario;
  Summary summary;
  summary.scenario = s.name;
  summary.method = MethodName(s.method);
  summary.robot = run.robot_name;
  summary.model = s.model_mjcf.empty() ? "numbers" : s.model_mjcf;
  summary.offline_latency_s = run.config.offline_latency;
  summary.offline_latency_measured = run.config.measured_latency;
  summary.offline_latency_mode = run.config.measured_latency ? "measured"
                                 : run.config.modeled_latency ? "modeled"
                                                              : "fixed";
  summary.pushes = s.pushes;
  summary.hop_pushes = s.hop_pushes;
  return summary;
}

HopperRun::HopperRun(const Options& o, LoadedRun* run, RunLog* log, Frames* frames)
    : o_(o), run_(run), log_(log), frames_(frames), stepper_(run),
      progress_(!o.quiet && isatty(STDERR_FILENO)) {
  summary_ = ScenarioSummary(*run);
  summary_.initial_law = run->controller->law_cache_status();
  summary_.identify_mass = run->config.identification.mass;
  summary_.identify_terms = run->config.identification.terms;
  summary_.identify_terms_acted =
      ActedTermsName(run->config.identification.terms_estimator.acted);
  // A law cache that could not be written, or held a file it could not use, is worth a line.
  if (run->controller->law_cache_trouble()) {
    std::fprintf(stderr, "ddoc-hopper: warning: law cache: %s (the run goes on)\n",
                 summary_.initial_law.c_str());
  }
  summary_.hop_push_times = stepper_.hop_push_times();
  log_->WriteSummary(summary_);
}

bool HopperRun::Done() const {
  const Scenario& s = run_->scenario;
  if (s.hops > 0 && summary_.hops >= s.hops) return true;
  return s.seconds > 0 && run_->data->time >= s.seconds;
}

bool HopperRun::Capture() {
  try {
    frames_->Capture(run_->model.get(), run_->data.get(), run_->controller->hop(), last_cost_,
                     last_speed_);
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\nddoc-hopper: --render: %s\n", e.what());
    summary_.fall_reason = std::string("render: ") + e.what();
    return false;
  }
}

int HopperRun::End(int exit_code, const char* end, const std::string& message) {
  summary_.end = end;
  summary_.end_message = message;
  return exit_code;
}

int HopperRun::Loop() {
  try {
    return Steps();
  } catch (const RunLogError& e) {
    // Keep what can be kept: the hops completed in the failing step go to hops.csv if it still
    // takes writes (the failed file is usually trajectory.csv, the largest).
    for (const plugin::HopReport& h : run_->controller->TakeReports()) pending_.push_back(h);
    for (const plugin::HopReport& h : pending_) {
      try {
        log_->WriteHop(h);
        summary_.AddHop(h, run_->scenario.method != Method::kOcfb);
      } catch (const RunLogError&) {
        break;
      }
    }
    if (progress_) std::fputc('\n', stderr);
    std::fprintf(stderr, "ddoc-hopper: %s\n", e.what());
    return End(kExitIo, "io_error", e.what());
  }
}

int HopperRun::Steps() {
  if (!Capture()) return End(kExitError, "error", summary_.fall_reason);  // frame 0: the start
  while (!Done()) {
    if (g_stop_signal != 0) {
      const std::string message = std::string("interrupted by ") + StopSignalName() + " at t = " +
                                  std::to_string(run_->data->time) + " s";
      if (progress_) std::fputc('\n', stderr);
      std::fprintf(stderr, "ddoc-hopper: %s\n", message.c_str());
      return End(kExitInterrupted, "interrupted", message);
    }
    const StepOutcome outcome = stepper_.Step();
    ++step_;
    if (outcome.kind != StepOutcome::Kind::kNonFinite) sim_time_ = run_->data->time;
    if (outcome.kind == StepOutcome::Kind::kFailed) {
      std::fprintf(stderr, "\nddoc-hopper: %s\n", outcome.reason.c_str());
      summary_.fall_reason = outcome.reason;
      return End(kExitError, "error", outcome.reason);
    }
    if (outcome.kind == StepOutcome::Kind::kNonFinite) {
      // Nothing of this step is logged: MuJoCo reset the state to the initial pose, and the
      // controller saw that pose.
      if (progress_) std::fputc('\n', stderr);
      std::fprintf(stderr, "ddoc-hopper: %s\n", outcome.reason.c_str());
      return End(kExitNonFinite, "nonfinite_state", outcome.reason);
    }
    LogStep();
    LogPushEvents();
    LogHops();
    if (!Capture()) return End(kExitError, "error", summary_.fall_reason);
    if (outcome.kind == StepOutcome::Kind::kFell) {
      Fell(outcome.reason);
      return End(kExitFall, "fell", outcome.reason);
    }
  }
  return End(kExitOk, "completed", "");
}

void HopperRun::LogStep() {
  if (step_ % o_.log_every != 0) return;
  const plugin::HopperController& c = *run_->controller;
  SampleRecord r;
  r.t = run_->data->time;
  r.hop = c.hop();
  r.phase = c.mode();
  for (int i = 0; i < 14; ++i) r.q[i] = stepper_.state()(i);
  for (int i = 0; i < 4; ++i) r.u[i] = c.last_input()[i];
  r.push = stepper_.push();
  log_->WriteSample(r);
}

void HopperRun::LogPushEvents() {
  const std::vector<Push>& pushes = stepper_.pushes();  // grows when a hop push is resolved
  if (pushes.size() != push_started_.size()) {
    push_started_.resize(pushes.size(), false);
    push_ended_.resize(pushes.size(), false);
    summary_.pushes = pushes;
    summary_.hop_push_times = stepper_.hop_push_times();
    log_->WriteSummary(summary_);
  }
  const double t = run_->data->time;
  const Eigen::Matrix<double, 14, 1>& x = stepper_.state();
  for (size_t i = 0; i < pushes.size(); ++i) {
    EventRecord e{t, run_->controller->hop(), "", x(hopper::kX), x(hopper::kY), x(hopper::kXd),
                  x(hopper::kYd)};
    if (!push_started_[i] && t >= pushes[i].time) {
      push_started_[i] = true;
      e.type = "push_start";
      log_->WriteEvent(e);
    }
    if (!push_ended_[i] && t >= pushes[i].time + pushes[i].duration) {
      push_ended_[i] = true;
      e.type = "push_end";
      log_->WriteEvent(e);
    }
  }
}

void HopperRun::LogHops() {
  const bool learns = run_->scenario.method != Method::kOcfb;
  for (const plugin::HopReport& h : run_->controller->TakeReports()) pending_.push_back(h);
  while (!pending_.empty()) {
    // The hop row first (flushed), so a failing write of another file never loses a hop.
    const plugin::HopReport h = pending_.front();
    pending_.pop_front();
    log_->WriteHop(h);
    summary_.AddHop(h, learns);
    summary_.resolves = run_->controller->resolves();
    const Eigen::Vector4d& td = h.body_touchdown;
    const Eigen::Vector4d& to = h.body_takeoff;
    log_->WriteEvent({h.t_touchdown, h.hop, "touchdown", td(0), td(1), td(2), td(3)});
    log_->WriteEvent({h.t_end, h.hop, "takeoff", to(0), to(1), to(2), to(3)});
    summary_.sim_time_s = sim_time_;
    summary_.wall_time_s = WallTime();
    log_->WriteSummary(summary_);
    last_cost_ = h.cost;
    last_speed_ = h.speed;
    if (progress_) {
      std::fprintf(stderr, "\rhop %4d  cost %10.4g  speed %6.3f m/s  period %5.3f s  %s", h.hop,
                   h.cost, h.speed, h.t2, h.accepted ? "accepted" : "rejected");
      if (frames_->active()) {
        std::fprintf(stderr, "  frame %ld  t %.1f s in %.1f s", frames_->frame_count(), sim_time_,
                     WallTime());
      }
      std::fputs("   ", stderr);
      std::fflush(stderr);
    }
  }
}

void HopperRun::Fell(const std::string& reason) {
  const Eigen::Matrix<double, 14, 1>& x = stepper_.state();
  const int hop = run_->controller->hop();
  log_->WriteEvent({run_->data->time, hop, "fall", x(hopper::kX), x(hopper::kY), x(hopper::kXd),
                    x(hopper::kYd)});
  summary_.fell = true;
  summary_.fall_reason = reason;
  if (progress_) std::fputc('\n', stderr);
  std::fprintf(stderr, "ddoc-hopper: the robot fell in hop %d at t = %.3f s: %s\n", hop,
               run_->data->time, reason.c_str());
}

int HopperRun::Finish(int exit_code) {
  if (progress_) std::fputc('\n', stderr);
  summary_.sim_time_s = sim_time_;
  summary_.wall_time_s = WallTime();
  try {
    log_->Flush();
  } catch (const RunLogError& e) {
    if (exit_code != kExitIo) {
      std::fprintf(stderr, "ddoc-hopper: %s\n", e.what());
      exit_code = End(kExitIo, "io_error", e.what());
    }
  }
  try {
    log_->WriteSummary(summary_);
  } catch (const RunLogError& e) {
    std::fprintf(stderr, "ddoc-hopper: summary.json does not record the end (%s): %s\n",
                 summary_.end.c_str(), e.what());
    if (exit_code == kExitOk || exit_code == kExitFall) exit_code = kExitIo;
  }
  log_->FlushQuietly();
  std::string video;
  exit_code = frames_->Finish(exit_code, &video);
  if (summary_.late_hops > 0) {  // the result assumes a faster offline computer than this one
    std::fprintf(stderr,
                 "ddoc-hopper: the offline part took longer than the simulated latency (%g s) on "
                 "%d hops (longest %.0f ms): --offline-latency measured simulates this computer\n",
                 summary_.offline_latency_s, summary_.late_hops, summary_.offline_max_ms);
  }
  char cost[48] = "";
  if (summary_.hops > 0) std::snprintf(cost, sizeof(cost), ", final cost %.4g", summary_.final_cost);
  // The last line: how the run ended and where its files are (the video's path included).
  std::fprintf(stderr, "ddoc-hopper: %s %s: %d hops, %s%s, wrote %s%s%s\n",
               summary_.scenario.c_str(), summary_.method.c_str(), summary_.hops,
               summary_.fell ? "FELL" : summary_.end.c_str(), cost, o_.out.c_str(),
               video.empty() ? "" : " and the video ", video.c_str());
  return exit_code;
}

// Starts the controller (StartController: the nominal gait and, without a stored law, the u^0
// solve on the model, about 1 s cold) on a thread while this thread shows the elapsed time on a
// terminal and checks for SIGINT/SIGTERM every 50 ms. Returns false when a signal came first: the
// start is abandoned and the thread left running (the caller ends the process with _Exit).
// Rethrows what StartController threw.
bool StartControllerWatched(LoadedRun* run, bool progress) {
  std::atomic<bool> done{false};
  std::exception_ptr error;
  std::thread start([&] {
    try {
      StartController(run);
    } catch (...) {
      error = std::current_exception();
    }
    done.store(true);
  });
  const double t0 = WallTime();
  const char* cache = run->config.law_cache.empty() ? "law cache off" : "law cache on";
  while (!done.load()) {
    if (g_stop_signal != 0) {
      start.detach();
      return false;
    }
    if (progress) {
      std::fprintf(stderr, "\rddoc-hopper: starting: the nominal gait and u^0 on the model (%s) %5.1f s ",
                   cache, WallTime() - t0);
      std::fflush(stderr);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  start.join();
  if (error) std::rethrow_exception(error);
  if (progress) {
    std::fprintf(stderr, "\rddoc-hopper: started in %.1f s; u^0 %s\033[K\n", WallTime() - t0,
                 run->controller->law_cache_status().c_str());
  }
  return true;
}

// A signal during the start: summary.json says so (no hop ran), then the process ends at once
// with exit code 4 (the start's thread is still computing).
[[noreturn]] void EndDuringStart(const Options& o, const LoadedRun& run, RunLog* log,
                                 bool progress) {
  Summary summary = ScenarioSummary(run);
  summary.initial_law = "not derived: interrupted";
  summary.wall_time_s = WallTime();
  summary.end = "interrupted";
  char message[160];
  std::snprintf(message, sizeof(message),
                "interrupted by %s during the start (deriving u^0), %.2f s after it began",
                StopSignalName(), summary.wall_time_s);
  summary.end_message = message;
  if (progress) std::fputc('\n', stderr);
  std::fprintf(stderr, "ddoc-hopper: %s\n", message);
  int code = kExitInterrupted;
  try {
    log->Flush();
    log->WriteSummary(summary);
  } catch (const RunLogError& e) {
    std::fprintf(stderr, "ddoc-hopper: %s\n", e.what());
    code = kExitIo;
  }
  log->FlushQuietly();
  std::fprintf(stderr, "ddoc-hopper: %s %s: 0 hops, interrupted, wrote %s\n",
               summary.scenario.c_str(), summary.method.c_str(), o.out.c_str());
  std::fflush(stderr);
  std::_Exit(code);
}

int Run(int argc, char** argv) {
  InstallSignalHandlers();
  Options o;
  const int parsed = ParseOptions(argc, argv, &o);
  if (parsed >= 0) return parsed;
  // RunError: RunTool prints it. The controller starts after the frames and the log: bad render
  // settings and an unwritable --out fail at once, not after u^0 is derived.
  LoadedRun run = LoadRun(o.scenario, o.run, /*start_controller=*/false);
  if (o.out.empty()) o.out = "out/" + run.scenario.name;
  Frames frames(o, run.model.get(), MethodName(run.scenario.method));
  std::unique_ptr<RunLog> log;
  try {
    log = std::make_unique<RunLog>(o.out, MethodName(run.scenario.method));
  } catch (const std::exception& e) {
    throw RunError(kExitBadInput, e.what());
  }
  const bool progress = !o.quiet && isatty(STDERR_FILENO);
  if (!StartControllerWatched(&run, progress)) EndDuringStart(o, run, log.get(), progress);
  std::unique_ptr<HopperRun> hopper;
  try {
    hopper = std::make_unique<HopperRun>(o, &run, log.get(), &frames);  // writes summary.json
  } catch (const RunLogError& e) {
    throw RunError(kExitBadInput, e.what());
  }
  return hopper->Finish(hopper->Loop());
}

}  // namespace
}  // namespace ddoc::app

int main(int argc, char** argv) {
  return ddoc::app::RunTool("ddoc-hopper", ddoc::app::Run, argc, argv);
}
