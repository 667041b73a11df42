// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-hopper: runs a hopper scenario headless. The true robot is the MJCF hopper stepped by
// MuJoCo; the controller plugin (plugin/) runs Algorithm 1, OC-FB or mRL inside mjcb_control.
//
// Exit codes: 0 success, 1 internal error, 2 bad input, 3 the robot fell.
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "ddoc/mujoco/hopper_mapping.h"
#include "ddoc/mujoco/hopper_sim.h"
#include "hopper_controller.h"
#include "hopper_setup.h"
#include "run_log.h"
#include "scenario.h"
#ifdef DDOC_HAVE_RENDER
#include "ddoc/render/frame_recorder.h"
#include "ddoc/render/video.h"
#endif

namespace ddoc::app {
namespace {

const char* LearnerStatusName(LearnerStatus status) {
  switch (status) {
    case LearnerStatus::kRunning: return "running";
    case LearnerStatus::kConverged: return "converged";
    case LearnerStatus::kLineSearchFailed: return "line_search_failed";
    case LearnerStatus::kMaxTrials: return "max_trials";
  }
  return "?";
}

int Run(int argc, char** argv) {
  CLI::App cli{
      "ddoc-hopper: data-driven iterative optimal control (Algorithm 1) of the MuJoCo hopper.\n"
      "Exit codes: 0 success, 1 internal error, 2 bad input, 3 the robot fell."};
  std::string scenario_path, out_dir, method, robot, model_mjcf, render_dir, video;
  int hops = -1, width = 640, height = 480, log_every = 1;
  double seconds = -1, fps = 60, latency = -1;
  std::vector<std::string> pushes;
  bool no_pushes = false, quiet = false;
  cli.add_option("scenario", scenario_path, "scenario XML file (see models/scenarios/)")
      ->required();
  cli.add_option("--out,-o", out_dir, "output directory (default: out/<scenario name>)");
  cli.add_option("--method,-m", method, "alg1 | ocfb | mrl (overrides the scenario)");
  CLI::Option* hops_opt = cli.add_option("--hops", hops, "number of hops (overrides the scenario)");
  CLI::Option* seconds_opt =
      cli.add_option("--seconds", seconds, "simulated seconds (overrides the scenario)");
  cli.add_option("--robot", robot, "robot MJCF (overrides the scenario)");
  cli.add_option("--model-mjcf", model_mjcf, "model MJCF (overrides the scenario's model)");
  cli.add_option("--push", pushes, "extra push TIME,FORCE,DURATION (repeatable)");
  cli.add_flag("--no-pushes", no_pushes, "ignore the scenario's pushes");
  cli.add_option("--log-every", log_every, "write every N-th physics step to trajectory.csv");
  cli.add_option("--render", render_dir, "write PNG frames into this directory");
  cli.add_option("--width", width, "frame width in pixels (default 640)");
  cli.add_option("--height", height, "frame height in pixels (default 480)");
  cli.add_option("--fps", fps, "frames per second of simulated time (default 60)");
  cli.add_option("--video", video, "assemble the frames into this MP4 with ffmpeg");
  cli.add_flag("--quiet,-q", quiet, "no progress display");
  CLI::Option* latency_opt = cli.add_option(
      "--offline-latency", latency,
      "simulated s from a hop's end until the law learned from it takes effect (0: synchronous)");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = cli.exit(e);
    return code == 0 ? kExitOk : kExitBadInput;
  }

  // Scenario and overrides: every bad input is reported before the simulation starts.
  Scenario s;
  try {
    s = LoadScenario(scenario_path);
    if (!method.empty()) s.method = ParseMethod(method);
    if (*hops_opt && hops < 0) throw ScenarioError("--hops must be >= 0, got " + std::to_string(hops));
    if (*seconds_opt && !(seconds >= 0)) throw ScenarioError("--seconds must be >= 0");
    if (*hops_opt) s.hops = hops;
    if (*seconds_opt) s.seconds = seconds;
    if (*hops_opt && !*seconds_opt) s.seconds = 0;
    if (*seconds_opt && !*hops_opt) s.hops = 0;
    if (!robot.empty()) s.robot_mjcf = robot;
    if (!model_mjcf.empty()) s.model_mjcf = model_mjcf;
    if (no_pushes) s.pushes.clear();
    for (const std::string& p : pushes) s.pushes.push_back(ParsePush(p));
    if (log_every < 1) throw ScenarioError("--log-every must be >= 1");
    ValidateScenario(s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-hopper: %s\n", e.what());
    return kExitBadInput;
  }
  if (out_dir.empty()) out_dir = "out/" + s.name;
  if (!video.empty() && render_dir.empty()) render_dir = out_dir + "/frames";

#ifdef DDOC_HAVE_RENDER
  RenderSettings render;
  render.dir = render_dir;
  render.width = width;
  render.height = height;
  render.fps = fps;
  if (!render_dir.empty()) {
    std::string error;
    if (!render.Validate(&error)) {
      std::fprintf(stderr, "ddoc-hopper: %s\n", error.c_str());
      return kExitBadInput;
    }
  }
#else
  if (!render_dir.empty()) {
    std::fprintf(stderr, "ddoc-hopper: --render: this build has no OSMesa rendering\n");
    return kExitBadInput;
  }
#endif

  // The true robot.
  MjModelPtr model;
  HopperParams params;
  try {
    model = LoadMjcf(s.robot_mjcf);
    HopperMapping::Build(model.get(), s.robot_mjcf);  // names checked, errors name the file
    params = ModelParams(s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-hopper: %s\n", e.what());
    return kExitBadInput;
  }
  MjDataPtr data(mj_makeData(model.get()));
  mjModel* m = model.get();
  mjData* d = data.get();

  plugin::ControllerConfig config = ControllerConfigFor(s, params);
  if (*latency_opt) config.offline_latency = latency;
  std::string error;
  const auto t_wall0 = std::chrono::steady_clock::now();
  std::unique_ptr<plugin::HopperController> controller =
      plugin::HopperController::Create(m, config, &error);
  if (!controller) {
    std::fprintf(stderr, "ddoc-hopper: %s\n", error.c_str());
    return kExitError;
  }
  controller->Reset(m, d);
  plugin::Attach(controller.get());
  const HopperMapping& map = controller->mapping();

  std::unique_ptr<RunLog> log;
  try {
    log = std::make_unique<RunLog>(out_dir, MethodName(s.method));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-hopper: %s\n", e.what());
    plugin::Detach();
    return kExitBadInput;
  }

#ifdef DDOC_HAVE_RENDER
  std::unique_ptr<FrameRecorder> frames;
  if (!render_dir.empty()) {
    frames = FrameRecorder::Create(m, render, &error);
    if (!frames) {
      std::fprintf(stderr, "ddoc-hopper: %s\n", error.c_str());
      plugin::Detach();
      return kExitBadInput;
    }
  }
#endif

  Summary summary;
  summary.scenario = s.name;
  summary.method = MethodName(s.method);
  summary.robot = s.robot_mjcf;
  summary.model = s.model_mjcf.empty() ? "numbers" : s.model_mjcf;
  summary.pushes = s.pushes;
  log->WriteSummary(summary);

  const bool progress = !quiet && isatty(STDERR_FILENO);
  const FallLimits limits;
  int exit_code = kExitOk;
  long step = 0;
  double last_cost = std::nan(""), last_speed = std::nan("");
  double speed_sum = 0, period_sum = 0;
  int tail_count = 0;
  double phase_start = 0.0;
  int last_mode = controller->mode();
  std::vector<bool> push_started(s.pushes.size(), false), push_ended(s.pushes.size(), false);

  auto done = [&]() {
    if (s.hops > 0 && summary.hops >= s.hops) return true;
    if (s.seconds > 0 && d->time >= s.seconds) return true;
    return false;
  };

#ifdef DDOC_HAVE_RENDER
  Overlay overlay;
  overlay.method = summary.method;
  auto capture = [&]() {
    if (!frames) return;
    overlay.hop = controller->hop();
    overlay.last_cost = last_cost;
    overlay.forward_speed = last_speed;
    frames->MaybeCapture(m, d, overlay);  // throws std::runtime_error naming the file
  };
  try {
    capture();  // frame 0 shows the start state
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-hopper: --render: %s\n", e.what());
    plugin::Detach();
    return kExitError;
  }
#endif

  while (!done()) {
    const double t = d->time;
    const double push = PushForce(s.pushes, t);
    ApplyDragAndPush(map, m, d, push);
    mj_step(m, d);
    ++step;
    if (controller->offline_pending()) controller->RunOffline();  // outside mjcb_control

    if (controller->failed()) {
      std::fprintf(stderr, "\nddoc-hopper: %s\n", controller->error().c_str());
      summary.fall_reason = controller->error();
      exit_code = kExitError;
      break;
    }

    const Eigen::Matrix<double, 14, 1> x = FlightState(map, d, controller->vsa());
    if (controller->mode() != last_mode) {
      last_mode = controller->mode();
      phase_start = d->time;
    }
    if (step % log_every == 0) {
      SampleRecord r;
      r.t = d->time;
      r.hop = controller->hop();
      r.phase = controller->mode();
      for (int i = 0; i < 14; ++i) r.q[i] = x(i);
      for (int i = 0; i < 4; ++i) r.u[i] = controller->last_input()[i];
      r.push = push;
      log->WriteSample(r);
    }
    for (size_t i = 0; i < s.pushes.size(); ++i) {
      const Push& p = s.pushes[i];
      EventRecord e{d->time, controller->hop(), "", x(hopper::kX), x(hopper::kY),
                    x(hopper::kXd), x(hopper::kYd)};
      if (!push_started[i] && d->time >= p.time) {
        push_started[i] = true;
        e.type = "push_start";
        log->WriteEvent(e);
      }
      if (!push_ended[i] && d->time >= p.time + p.duration) {
        push_ended[i] = true;
        e.type = "push_end";
        log->WriteEvent(e);
      }
    }

    for (const plugin::HopReport& h : controller->TakeReports()) {
      const Eigen::Vector4d& td = h.body_touchdown;
      const Eigen::Vector4d& to = h.body_takeoff;
      log->WriteEvent({h.t_touchdown, h.hop, "touchdown", td(0), td(1), td(2), td(3)});
      log->WriteEvent({h.t_end, h.hop, "takeoff", to(0), to(1), to(2), to(3)});
      HopRecord r;
      r.hop = h.hop;
      r.t_start = h.t_start;
      r.t_end = h.t_end;
      r.cost = h.cost;
      r.i1 = h.terms.i1;
      r.i2 = h.terms.i2;
      r.i3 = h.terms.i3;
      r.i4 = h.terms.i4;
      r.t1 = h.t1;
      r.t2 = h.t2;
      r.step_length = h.step_length;
      r.speed = h.speed;
      r.apex = h.apex;
      r.alpha = h.alpha;
      r.accepted = h.accepted;
      r.du2 = h.du2;
      r.dt2 = h.dt2;
      log->WriteHop(r);
      summary.hops = h.hop + 1;
      summary.final_cost = h.cost;
      summary.final_i4 = h.terms.i4;
      (h.accepted ? summary.accepted : summary.rejected) += 1;
      if (summary.converged_hop < 0 && h.status == LearnerStatus::kConverged) {
        summary.converged_hop = h.hop;
      }
      if (summary.stopped_hop < 0 && h.status == LearnerStatus::kLineSearchFailed) {
        summary.stopped_hop = h.hop;
      }
      summary.learner_status = s.method == Method::kOcfb ? "none" : LearnerStatusName(h.status);
      speed_sum += h.speed;
      period_sum += h.t2;
      ++tail_count;
      summary.mean_speed = speed_sum / tail_count;
      summary.mean_period = period_sum / tail_count;
      summary.sim_time_s = d->time;
      summary.wall_time_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_wall0).count();
      log->WriteSummary(summary);
      last_cost = h.cost;
      last_speed = h.speed;
      if (progress) {
        std::fprintf(stderr, "\rhop %4d  cost %10.4g  speed %6.3f m/s  period %5.3f s  %s   ",
                     h.hop, h.cost, h.speed, h.t2, h.accepted ? "accepted" : "rejected");
        std::fflush(stderr);
      }
    }

#ifdef DDOC_HAVE_RENDER
    try {
      capture();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "\nddoc-hopper: --render: %s\n", e.what());
      summary.fall_reason = std::string("render: ") + e.what();
      exit_code = kExitError;
      break;
    }
#endif

    const std::string fall = FallReason(limits, x, d->time - phase_start);
    if (!fall.empty()) {
      log->WriteEvent({d->time, controller->hop(), "fall", x(hopper::kX), x(hopper::kY),
                       x(hopper::kXd), x(hopper::kYd)});
      summary.fell = true;
      summary.fall_reason = fall;
      if (progress) std::fputc('\n', stderr);
      std::fprintf(stderr, "ddoc-hopper: the robot fell in hop %d at t = %.3f s: %s\n",
                   controller->hop(), d->time, fall.c_str());
      exit_code = kExitFall;
      break;
    }
  }
  plugin::Detach();
  if (progress) std::fputc('\n', stderr);

  summary.sim_time_s = d->time;
  summary.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_wall0).count();
  log->WriteSummary(summary);
  log->Flush();

#ifdef DDOC_HAVE_RENDER
  if (frames) {
    if (!frames->Finish(&error)) {
      std::fprintf(stderr, "ddoc-hopper: %s\n", error.c_str());
      return kExitError;
    }
    if (!video.empty()) {
      std::string message;
      if (!AssembleVideo(render_dir, fps, video, &message)) {
        std::fprintf(stderr, "ddoc-hopper: --video: %s\n", message.c_str());
        if (exit_code == kExitOk) exit_code = kExitError;
      }
    }
  }
#endif
  std::fprintf(stderr, "ddoc-hopper: %s %s: %d hops, %s, final cost %.4g, wrote %s\n",
               s.name.c_str(), summary.method.c_str(), summary.hops,
               summary.fell ? "FELL" : "no fall", summary.final_cost, out_dir.c_str());
  return exit_code;
}

}  // namespace
}  // namespace ddoc::app

int main(int argc, char** argv) {
  try {
    return ddoc::app::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-hopper: internal error: %s\n", e.what());
    return 1;
  }
}
