// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc.run_hopper: a ddoc-hopper scenario run from Python (built when the MuJoCo application is):
// LoadRun + RunStepper, the steps of ddoc-hopper's loop without its files; the per-hop table
// (the columns of hops.csv) and the per-step trajectory (the columns of trajectory.csv) as NumPy
// arrays, a progress callback per hop, PNG frames through app::RunFrames (ddoc::FrameRecorder)
// when the build renders.
#include <pybind11/eval.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <mujoco/mujoco.h>

#include "hopper_run.h"

namespace py = pybind11;

namespace ddoc {
namespace python {

namespace {

using plugin::HopReport;

// The columns of hops.csv (src/app/run_log.cc, RunLog::WriteHop) but `method`, which is one value.
struct HopColumn {
  const char* name;
  bool integer;
  double (*get)(const HopReport&);
};
const HopColumn kHopColumns[] = {
    {"hop", true, [](const HopReport& h) { return double(h.hop); }},
    {"t_start", false, [](const HopReport& h) { return h.t_start; }},
    {"t_end", false, [](const HopReport& h) { return h.t_end; }},
    {"cost", false, [](const HopReport& h) { return h.cost; }},
    {"I1", false, [](const HopReport& h) { return h.terms.i1; }},
    {"I2", false, [](const HopReport& h) { return h.terms.i2; }},
    {"I3", false, [](const HopReport& h) { return h.terms.i3; }},
    {"I4", false, [](const HopReport& h) { return h.terms.i4; }},
    {"T1", false, [](const HopReport& h) { return h.t1; }},
    {"T2", false, [](const HopReport& h) { return h.t2; }},
    {"step_length", false, [](const HopReport& h) { return h.step_length; }},
    {"speed", false, [](const HopReport& h) { return h.speed; }},
    {"apex", false, [](const HopReport& h) { return h.apex; }},
    {"alpha", false, [](const HopReport& h) { return h.alpha; }},
    {"accepted", true, [](const HopReport& h) { return h.accepted ? 1.0 : 0.0; }},
    {"du2", false, [](const HopReport& h) { return h.du2; }},
    {"dT2", false, [](const HopReport& h) { return h.dt2; }},
    {"start_shift", false, [](const HopReport& h) { return h.start_shift; }},
    {"restarted", true, [](const HopReport& h) { return h.restarted ? 1.0 : 0.0; }},
    {"remeasured", true, [](const HopReport& h) { return h.remeasured ? 1.0 : 0.0; }},
    {"learner_cost", false, [](const HopReport& h) { return h.learner_cost; }},
    {"nominal_cost", false, [](const HopReport& h) { return h.nominal_cost; }},
    {"predicted", false, [](const HopReport& h) { return h.predicted; }},
    {"optimality", false, [](const HopReport& h) { return h.optimality; }},
    {"stance_mass", false, [](const HopReport& h) { return h.stance_mass; }},
    {"reverted", true, [](const HopReport& h) { return h.reverted ? 1.0 : 0.0; }},
    {"identified_mass", false, [](const HopReport& h) { return h.identified_mass; }},
    {"model_mass", false, [](const HopReport& h) { return h.model_mass; }},
    {"latched", true, [](const HopReport& h) { return h.reference_latched ? 1.0 : 0.0; }},
    {"offline_ms", false, [](const HopReport& h) { return h.offline_ms; }},
    {"latency_ms", false, [](const HopReport& h) { return h.latency_ms; }},
    {"offline_steps", true,
     [](const HopReport& h) { return static_cast<double>(h.offline_steps); }},
    {"offline_cpu_ms", false, [](const HopReport& h) { return h.offline_cpu_ms; }},
};
constexpr size_t kNumHopColumns = sizeof(kHopColumns) / sizeof(kHopColumns[0]);

// The columns of trajectory.csv (src/app/run_log.cc): t, hop, phase, the 14 flight coordinates
// and rates, the 4 applied inputs, the push force.
const char* const kTrajectoryColumns[] = {
    "t",  "hop",    "phase",  "x",    "y",    "theta",  "phi",    "r",    "k_hip", "k_leg", "xd",
    "yd", "thetad", "phid",   "rd",   "kd_hip", "kd_leg", "tau0", "F0",   "k0_hip", "k0_leg",
    "push"};
constexpr size_t kNumTrajectoryColumns = sizeof(kTrajectoryColumns) / sizeof(kTrajectoryColumns[0]);

py::array_t<double> DoubleArray(const std::vector<double>& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::array_t<long> IntArray(const std::vector<double>& v) {
  py::array_t<long> a(static_cast<py::ssize_t>(v.size()));
  long* out = a.mutable_data();
  for (size_t i = 0; i < v.size(); ++i) out[i] = static_cast<long>(v[i]);
  return a;
}

// One push of `pushes` as ddoc-hopper's --push text: a string as is, (time, force, duration) or
// (hop, phase, force, duration) printed exactly (repr round-trips a double), then parsed by the
// app's ParsePush/ParseHopPush so that the checks are the command line's.
std::string PushText(const py::handle& item, size_t index) {
  const std::string name = "pushes[" + std::to_string(index) + "]";
  std::string text;
  if (py::isinstance<py::str>(item)) {
    text = item.cast<std::string>();
  } else if (py::isinstance<py::sequence>(item)) {
    const py::sequence seq = item.cast<py::sequence>();
    const size_t n = seq.size();
    if (n != 3 && n != 4) {
      throw py::value_error(name + ": expected (time, force, duration) or (hop, phase, force, "
                            "duration), got a sequence of length " + std::to_string(n));
    }
    std::vector<double> v;
    for (size_t i = 0; i < n; ++i) {
      try {
        v.push_back(py::cast<double>(seq[i]));
      } catch (const py::cast_error&) {
        throw py::value_error(name + "[" + std::to_string(i) + "]: expected a number, got " +
                              std::string(py::str(py::repr(seq[i]))));
      }
    }
    // Python's repr of a float: the shortest text that reads back as the same double.
    auto number = [](double x) { return std::string(py::repr(py::float_(x))); };
    if (n == 3) {
      text = number(v[0]) + "," + number(v[1]) + "," + number(v[2]);
    } else {
      const bool whole = v[0] == std::floor(v[0]) && std::abs(v[0]) < 1e15;
      text = (whole ? std::to_string(static_cast<long long>(v[0])) : number(v[0])) + "@" +
             number(v[1]) + "," + number(v[2]) + "," + number(v[3]);
    }
  } else {
    throw py::value_error(name + ": expected a string 'TIME,FORCE,DURATION' or "
                          "'HOP@PHASE,FORCE,DURATION', or a tuple of 3 or 4 numbers, got " +
                          std::string(py::str(py::type::handle_of(item).attr("__name__"))));
  }
  try {
    if (text.find('@') != std::string::npos) {
      app::ParseHopPush(text);
    } else {
      app::ParsePush(text);
    }
  } catch (const std::exception& e) {
    throw py::value_error(name + ": " + e.what());
  }
  return text;
}

// MuJoCo's warnings as Python RuntimeWarnings ("MuJoCo warning: ...") while run_hopper runs,
// instead of MuJoCo's default stdout and MUJOCO_LOG.TXT in the working directory.
void WarnInPython(const char* message) {
  py::gil_scoped_acquire gil;  // the stepping loop runs without the GIL
  const std::string text = std::string("MuJoCo warning: ") + message;
  if (PyErr_WarnEx(PyExc_RuntimeWarning, text.c_str(), 1) != 0) {
    // A warnings filter made it an error; it cannot propagate through MuJoCo: print it.
    PyErr_Clear();
    std::fprintf(stderr, "ddoc.run_hopper: %s\n", text.c_str());
  }
}

class ScopedMujocoWarnings {
 public:
  ScopedMujocoWarnings() : previous_(mju_user_warning) { mju_user_warning = WarnInPython; }
  ~ScopedMujocoWarnings() { mju_user_warning = previous_; }
  ScopedMujocoWarnings(const ScopedMujocoWarnings&) = delete;
  ScopedMujocoWarnings& operator=(const ScopedMujocoWarnings&) = delete;

 private:
  void (*previous_)(const char*);
};

std::string Repr(double x) { return std::string(py::repr(py::float_(x))); }

// run_hopper's keywords that are ddoc-hopper's flags, checked with the rules of LoadRun
// (ScenarioWithOverrides) before it, so that a message names the Python argument (`hops must be
// >= 0`), not the flag (`--hops must be >= 0`).
void CheckOverrides(const app::RunOverrides& o) {
  if (!o.method.empty() && o.method != "alg1" && o.method != "ocfb" && o.method != "mrl") {
    throw py::value_error("method \"" + o.method + "\": expected alg1, ocfb or mrl");
  }
  if (!o.preset.empty() && !app::IsPreset(o.preset)) {
    throw py::value_error("preset \"" + o.preset + "\": expected " + app::kPresetNames);
  }
  if (o.hops && *o.hops < 0) {
    throw py::value_error("hops must be >= 0, got " + std::to_string(*o.hops));
  }
  if (o.seconds && !(*o.seconds >= 0 && std::isfinite(*o.seconds))) {
    throw py::value_error("seconds must be a finite number >= 0, got " + Repr(*o.seconds));
  }
  if (o.offline_latency && !(*o.offline_latency >= 0 && std::isfinite(*o.offline_latency))) {
    throw py::value_error("offline_latency must be a finite number >= 0 (s), got " +
                          Repr(*o.offline_latency));
  }
  // As --robot and --model-mjcf, relative to the working directory (ValidateScenario checks them
  // too, but names the scenario file, which did not give them).
  for (const auto& [name, path] : {std::pair{"robot", &o.robot}, {"model_mjcf", &o.model_mjcf}}) {
    std::error_code ec;
    if (!path->empty() && !std::filesystem::is_regular_file(*path, ec)) {
      throw py::value_error(std::string(name) + " \"" + *path + "\": no such file");
    }
  }
}

app::LoadedRun Load(const std::string& scenario, const app::RunOverrides& overrides) {
  CheckOverrides(overrides);
  try {
    return app::LoadRun(scenario, overrides);
  } catch (const app::RunError& e) {
    std::string message = e.what();
    // The controller's check of the upper bound names its config field: name the argument too.
    if (overrides.offline_latency && message.find("config.offline_latency") != std::string::npos) {
      message = "offline_latency: " + message;
    }
    if (e.code() == app::kExitBadInput) throw py::value_error(message);
    throw std::runtime_error(message);
  }
}

py::dict HopDict(const HopReport& h) {
  py::dict d;
  for (const HopColumn& c : kHopColumns) {
    if (c.integer) {
      d[c.name] = static_cast<long>(c.get(h));
    } else {
      d[c.name] = c.get(h);
    }
  }
  return d;
}

py::dict RunHopper(const std::string& scenario, const std::string& method,
                   std::optional<int> hops, std::optional<double> seconds,
                   const std::string& robot, const std::string& model_mjcf,
                   const py::iterable& pushes, bool no_pushes, const std::string& preset,
                   const py::object& offline_latency, int log_every,
                   const py::object& progress, const std::string& render_dir, int width,
                   int height, double fps, const std::string& law_cache, bool substep_events,
                   std::optional<bool> identify, std::optional<bool> identify_terms,
                   const std::string& identify_terms_acted) {
  app::RunOverrides overrides;
  overrides.substep_events = substep_events;
  overrides.identify = identify;
  overrides.identify_terms = identify_terms;
  if (!identify_terms_acted.empty()) {
    try {
      overrides.identify_terms_acted = ParseActedTerms(identify_terms_acted);
    } catch (const InvalidArgument& error) {
      throw py::value_error(std::string("identify_terms_acted: ") + error.what());
    }
  }
  overrides.method = method;
  overrides.hops = hops;
  overrides.seconds = seconds;
  overrides.robot = robot;
  overrides.model_mjcf = model_mjcf;
  size_t index = 0;
  for (const py::handle item : pushes) overrides.pushes.push_back(PushText(item, index++));
  overrides.no_pushes = no_pushes;
  overrides.preset = preset;
  // "modeled" (the default), "measured" (ControllerConfig::measured_latency), or a number of s
  // (fixed).
  if (py::isinstance<py::str>(offline_latency)) {
    const std::string text = offline_latency.cast<std::string>();
    if (text != "measured" && text != "modeled") {
      throw py::value_error("offline_latency \"" + text +
                            "\": expected a number of s, \"modeled\" or \"measured\"");
    }
    overrides.measured_latency = text == "measured";
  } else if (!offline_latency.is_none()) {
    try {
      overrides.offline_latency = offline_latency.cast<double>();
    } catch (const py::cast_error&) {
      throw py::value_error(
          "offline_latency: expected a number of s, \"modeled\" or \"measured\", got " +
          py::repr(offline_latency).cast<std::string>());
    }
  }
  overrides.law_cache = law_cache;
  if (log_every < 0) throw py::value_error("log_every must be >= 0, got " + std::to_string(log_every));
  if (!progress.is_none() && !PyCallable_Check(progress.ptr())) {
    throw py::value_error("progress: expected a callable or None");
  }
  const ScopedMujocoWarnings warnings;
  app::LoadedRun run = Load(scenario, overrides);
  const std::string method_name = app::MethodName(run.scenario.method);
  std::unique_ptr<app::RunFrames> frames;
  try {
    frames = std::make_unique<app::RunFrames>(
        app::RunFrames::Settings{render_dir, width, height, fps}, run.model.get(), method_name,
        "render_dir");
  } catch (const app::RunError& e) {
    // RenderSettings' messages name width, height and fps; the rest is about the directory.
    std::string message = e.what();
    if (message.rfind("render: ", 0) == 0) message.erase(0, 8);
    const bool named = message.rfind("width", 0) == 0 || message.rfind("height", 0) == 0 ||
                       message.rfind("fps", 0) == 0 || message.rfind("render_dir", 0) == 0;
    throw py::value_error(named ? message : "render_dir: " + message);
  }

  std::vector<std::vector<double>> hop_table(kNumHopColumns), trajectory(kNumTrajectoryColumns);
  std::string fall_reason, error, end;  // end: summary.json's value when the run failed
  bool fell = false, interrupted = false;
  double last_cost = std::nan(""), last_speed = std::nan("");
  double sim_time = run.data->time;  // of the last finite state (MuJoCo's reset zeroes time)
  {
    py::gil_scoped_release release;
    app::RunStepper stepper(&run);
    const app::Scenario& s = run.scenario;
    const plugin::HopperController& c = *run.controller;
    auto done = [&] {
      return (s.hops > 0 && static_cast<int>(hop_table[0].size()) >= s.hops) ||
             (s.seconds > 0 && run.data->time >= s.seconds);
    };
    auto capture = [&] {
      frames->Capture(run.model.get(), run.data.get(), c.hop(), last_cost, last_speed);
    };
    capture();  // frame 0 shows the start state
    long step = 0;
    while (!done()) {
      const app::StepOutcome outcome = stepper.Step();
      ++step;
      if (outcome.kind == app::StepOutcome::Kind::kFailed ||
          outcome.kind == app::StepOutcome::Kind::kNonFinite) {
        // As ddoc-hopper's exits 1 and 6; MuJoCo reset the state after a non-finite one.
        error = outcome.reason;
        end = outcome.kind == app::StepOutcome::Kind::kFailed ? "error" : "nonfinite_state";
        break;
      }
      sim_time = run.data->time;
      if (log_every > 0 && step % log_every == 0) {
        const Eigen::Matrix<double, 14, 1>& x = stepper.state();
        trajectory[0].push_back(run.data->time);
        trajectory[1].push_back(c.hop());
        trajectory[2].push_back(c.mode());
        for (int i = 0; i < 14; ++i) trajectory[3 + i].push_back(x(i));
        for (int i = 0; i < 4; ++i) trajectory[17 + i].push_back(c.last_input()[i]);
        trajectory[21].push_back(stepper.push());
      }
      const std::vector<HopReport> reports = run.controller->TakeReports();
      for (const HopReport& h : reports) {
        for (size_t k = 0; k < kNumHopColumns; ++k) hop_table[k].push_back(kHopColumns[k].get(h));
        last_cost = h.cost;
        last_speed = h.speed;
      }
      if (!reports.empty() && !progress.is_none()) {
        py::gil_scoped_acquire gil;
        try {
          for (const HopReport& h : reports) progress(HopDict(h));
        } catch (py::error_already_set& e) {
          // Python runs its SIGINT handler in the next Python code, here the callback: a
          // KeyboardInterrupt from it is a Ctrl-C, which keeps the hops done (their rows are in
          // the table already); any other exception propagates.
          if (!e.matches(PyExc_KeyboardInterrupt)) throw;
          interrupted = true;
        }
      }
      capture();
      if (outcome.kind == app::StepOutcome::Kind::kFell) {
        fell = true;
        fall_reason = outcome.reason;
        break;
      }
      if (interrupted) break;
      if (step % 2000 == 0) {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
          PyErr_Clear();
          interrupted = true;
          break;
        }
      }
    }
  }
  std::string render_error;
  if (!frames->Finish(&render_error)) throw std::runtime_error("render: " + render_error);
  const long frame_count = frames->frame_count();
  py::dict out;
  for (size_t k = 0; k < kNumHopColumns; ++k) {
    out[kHopColumns[k].name] =
        kHopColumns[k].integer ? py::object(IntArray(hop_table[k])) : DoubleArray(hop_table[k]);
  }
  py::dict traj;
  for (size_t k = 0; k < kNumTrajectoryColumns; ++k) {
    traj[kTrajectoryColumns[k]] =
        (k == 1 || k == 2) ? py::object(IntArray(trajectory[k])) : DoubleArray(trajectory[k]);
  }
  out["trajectory"] = traj;
  out["method"] = method_name;
  out["fell"] = fell;
  out["fall_reason"] = fall_reason;
  out["sim_time"] = sim_time;
  out["frames"] = frame_count;
  out["initial_law"] = run.controller->law_cache_status();
  py::list resolves;  // summary.json's identification.resolves
  for (const plugin::ModelResolve& r : run.controller->resolves()) {
    py::dict d;
    d["hop"] = r.hop;
    for (const auto& [name, value] : plugin::ResolvedTerms(r.model)) d[name] = value;
    d["took_over_hop"] = r.took_over_hop;
    d["initialize_hop"] = r.initialize_hop;
    d["wall_ms"] = r.wall_ms;
    d["initial_law"] = r.law_cache;
    resolves.append(d);
  }
  out["resolves"] = resolves;
  if (!error.empty()) {
    py::object cls = py::module_::import("ddoc").attr("RunFailed");
    py::object exc = cls("run_hopper: " + error + " (after " +
                         std::to_string(hop_table[0].size()) +
                         " hops; the partial table is in .result)");
    exc.attr("result") = out;
    exc.attr("end") = end;
    PyErr_SetObject(cls.ptr(), exc.ptr());
    throw py::error_already_set();
  }
  if (interrupted) {
    py::object cls = py::module_::import("ddoc").attr("SolveInterrupted");
    py::object exc = cls("run_hopper interrupted after " + std::to_string(hop_table[0].size()) +
                         " hops; the partial table is in .result");
    exc.attr("result") = out;
    PyErr_SetObject(cls.ptr(), exc.ptr());
    throw py::error_already_set();
  }
  return out;
}

}  // namespace

void BindHopper(py::module_& mod) {
  py::exec(R"(
class RunFailed(RuntimeError):
    """run_hopper ended early: the controller failed (.end "error") or MuJoCo's state was not
    finite (.end "nonfinite_state"), as ddoc-hopper's exits 1 and 6; .result holds the table of
    the hops completed before."""
    result = None
    end = None
)", mod.attr("__dict__"));
  mod.attr("RunFailed").attr("__module__") = "ddoc";
#ifdef DDOC_HAVE_RENDER
  mod.attr("HAVE_RENDER") = true;  // the module links ddoc_render, as ddoc_app_run does
#else
  mod.attr("HAVE_RENDER") = false;
#endif
  mod.def("run_hopper", &RunHopper, py::arg("scenario"), py::arg("method") = "",
          py::arg("hops") = py::none(), py::arg("seconds") = py::none(), py::arg("robot") = "",
          py::arg("model_mjcf") = "", py::arg("pushes") = py::list(),
          py::arg("no_pushes") = false, py::arg("preset") = "",
          py::arg("offline_latency") = py::none(), py::arg("log_every") = 1,
          py::arg("progress") = py::none(), py::arg("render_dir") = "", py::arg("width") = 640,
          py::arg("height") = 480, py::arg("fps") = 60.0, py::arg("law_cache") = "",
          py::arg("substep_events") = false, py::arg("identify") = py::none(),
          py::arg("identify_terms") = py::none(), py::arg("identify_terms_acted") = "",
          R"(Runs a ddoc-hopper scenario file on the MuJoCo robot, as the command line does.

The arguments are ddoc-hopper's overrides; empty/None keeps the scenario's value:
  method           "alg1" | "ocfb" | "mrl" (--method)
  hops, seconds    --hops, --seconds (one alone: no limit on the other)
  robot, model_mjcf  --robot, --model-mjcf
  pushes           extra pushes (--push), each (time, force, duration) in s, N, s, or
                   (hop, phase, force, duration) by the phase of a hop, or the command line's
                   string 'TIME,FORCE,DURATION' / 'HOP@PHASE,FORCE,DURATION'
  no_pushes        drop the scenario's pushes (--no-pushes)
  preset           "default" | "paper" | "identified" (--preset)
  offline_latency  "modeled" (default): max(0.02 s, the latency model's time for the hop's
                   offline part); "measured": max(0.02 s, this computer's offline time); or s,
                   fixed (--offline-latency)
  log_every        keep every N-th physics step in the trajectory (--log-every; 0: none)
  progress         called after every hop with that hop's row (a dict of the table's columns);
                   an exception raised in it ends the run and propagates, but a
                   KeyboardInterrupt (Ctrl-C while it runs) is a Ctrl-C: SolveInterrupted
  render_dir, width, height, fps  PNG frames, as --render/--width/--height/--fps (only when
                   ddoc.HAVE_RENDER; otherwise a render_dir raises ValueError)
  law_cache        directory of stored u^0 laws (--law-cache; "": $DDOC_LAW_CACHE, unset: off)
  substep_events   locate touchdown and takeoff inside the physics step (--substep-events)
  identify         True/False: identify the mass and re-solve u^0 on it (--identify/--no-identify)
  identify_terms   True/False: identify b_leg, b_hip, J_body (J_leg with it), c_d and the floor
                   slope and re-solve u^0 on them (--identify-terms/--no-identify-terms)
  identify_terms_acted  the terms that re-solve u^0: "all", "none" or a comma-separated list
                   of b_leg, b_hip, j_body, c_d, slope (--identify-terms-acted; "": the
                   scenario's)

Returns a dict: the columns of hops.csv as NumPy arrays (hop, t_start, t_end, cost, I1..I4, T1,
T2, step_length, speed, apex, alpha, accepted, du2, dT2, start_shift, restarted, remeasured,
learner_cost, nominal_cost, predicted, optimality, stance_mass, reverted, identified_mass,
model_mass, latched) and offline_ms, latency_ms,
offline_steps, offline_cpu_ms (the wall time of the hop's offline part, the simulated latency of its
law, the integration steps of its backward passes and its thread CPU time); 'trajectory', a dict of the columns of trajectory.csv (t, hop, phase, x, y, theta, phi, r, k_hip, k_leg, xd, yd,
thetad, phid, rd, kd_hip, kd_leg, tau0, F0, k0_hip, k0_leg, push); method, fell, fall_reason,
sim_time, frames (PNG files written), initial_law (where u^0 came from, as summary.json's
initial_law) and resolves (the re-solves of u^0 on an identified model: hop, mass, b_leg, b_hip,
slope, j_body, j_leg, c_d, took_over_hop, initialize_hop, wall_ms, initial_law). ddoc.to_dataframe turns either table into a pandas
DataFrame. Bad input raises ValueError; the GIL is released while it runs; Ctrl-C raises
ddoc.SolveInterrupted with the partial result in .result; a controller failure or a non-finite
MuJoCo state raises ddoc.RunFailed with it in .result; MuJoCo's warnings are RuntimeWarnings.)");
}

}  // namespace python
}  // namespace ddoc
