// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc.run_hopper: a ddoc-hopper scenario run from Python (built when the MuJoCo application is):
// LoadRun + RunStepper, the steps of ddoc-hopper's loop without its files, the per-hop table
// (the columns of hops.csv) as NumPy arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "hopper_run.h"

namespace py = pybind11;

namespace ddoc {
namespace python {

namespace {

struct HopTable {
  std::vector<int> hop, accepted;
  std::vector<double> t_start, t_end, cost, I1, I2, I3, I4, T1, T2, step_length, speed, apex,
      alpha, du2, dt2;
  void Add(const plugin::HopReport& h) {
    hop.push_back(h.hop);
    t_start.push_back(h.t_start);
    t_end.push_back(h.t_end);
    cost.push_back(h.cost);
    I1.push_back(h.terms.i1);
    I2.push_back(h.terms.i2);
    I3.push_back(h.terms.i3);
    I4.push_back(h.terms.i4);
    T1.push_back(h.t1);
    T2.push_back(h.t2);
    step_length.push_back(h.step_length);
    speed.push_back(h.speed);
    apex.push_back(h.apex);
    alpha.push_back(h.alpha);
    accepted.push_back(h.accepted ? 1 : 0);
    du2.push_back(h.du2);
    dt2.push_back(h.dt2);
  }
};

template <class T>
py::array_t<T> Array(const std::vector<T>& v) {
  py::array_t<T> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

app::LoadedRun Load(const std::string& scenario, const app::RunOverrides& overrides) {
  try {
    return app::LoadRun(scenario, overrides);
  } catch (const app::RunError& e) {
    if (e.code() == app::kExitBadInput) throw py::value_error(e.what());
    throw std::runtime_error(e.what());
  }
}

py::dict RunHopper(const std::string& scenario, const std::string& method,
                   std::optional<int> hops, std::optional<double> seconds,
                   const std::string& robot, const std::string& model_mjcf,
                   const std::vector<std::string>& pushes, bool no_pushes) {
  app::RunOverrides overrides;
  overrides.method = method;
  overrides.hops = hops;
  overrides.seconds = seconds;
  overrides.robot = robot;
  overrides.model_mjcf = model_mjcf;
  overrides.pushes = pushes;
  overrides.no_pushes = no_pushes;
  HopTable table;
  std::string fall_reason, error;
  bool fell = false, interrupted = false;
  double sim_time = 0;
  std::string method_name;
  app::LoadedRun run = Load(scenario, overrides);
  {
    py::gil_scoped_release release;
    method_name = app::MethodName(run.scenario.method);
    app::RunStepper stepper(&run);
    const app::Scenario& s = run.scenario;
    long step = 0;
    while (!((s.hops > 0 && static_cast<int>(table.hop.size()) >= s.hops) ||
             (s.seconds > 0 && run.data->time >= s.seconds))) {
      const app::StepOutcome outcome = stepper.Step();
      if (outcome.kind == app::StepOutcome::Kind::kFailed) {
        error = outcome.reason;
        break;
      }
      for (const plugin::HopReport& h : run.controller->TakeReports()) table.Add(h);
      if (outcome.kind == app::StepOutcome::Kind::kFell) {
        fell = true;
        fall_reason = outcome.reason;
        break;
      }
      if (++step % 2000 == 0) {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
          PyErr_Clear();
          interrupted = true;
          break;
        }
      }
    }
    sim_time = run.data->time;
  }
  if (!error.empty()) throw std::runtime_error("run_hopper: " + error);
  py::dict out;
  out["hop"] = Array(table.hop);
  out["t_start"] = Array(table.t_start);
  out["t_end"] = Array(table.t_end);
  out["cost"] = Array(table.cost);
  out["I1"] = Array(table.I1);
  out["I2"] = Array(table.I2);
  out["I3"] = Array(table.I3);
  out["I4"] = Array(table.I4);
  out["T1"] = Array(table.T1);
  out["T2"] = Array(table.T2);
  out["step_length"] = Array(table.step_length);
  out["speed"] = Array(table.speed);
  out["apex"] = Array(table.apex);
  out["alpha"] = Array(table.alpha);
  out["accepted"] = Array(table.accepted);
  out["du2"] = Array(table.du2);
  out["dT2"] = Array(table.dt2);
  out["method"] = method_name;
  out["fell"] = fell;
  out["fall_reason"] = fall_reason;
  out["sim_time"] = sim_time;
  if (interrupted) {
    py::object cls = py::module_::import("ddoc").attr("SolveInterrupted");
    py::object exc = cls("run_hopper interrupted after " + std::to_string(table.hop.size()) +
                         " hops; the partial table is in .result");
    exc.attr("result") = out;
    PyErr_SetObject(cls.ptr(), exc.ptr());
    throw py::error_already_set();
  }
  return out;
}

}  // namespace

void BindHopper(py::module_& mod) {
  mod.def("run_hopper", &RunHopper, py::arg("scenario"), py::arg("method") = "",
          py::arg("hops") = py::none(), py::arg("seconds") = py::none(), py::arg("robot") = "",
          py::arg("model_mjcf") = "", py::arg("pushes") = std::vector<std::string>(),
          py::arg("no_pushes") = false,
          R"(Runs a ddoc-hopper scenario file on the MuJoCo robot, as the command line does.

The arguments are ddoc-hopper's overrides (--method alg1|ocfb|mrl, --hops, --seconds, --robot,
--model-mjcf, --push 'TIME,FORCE,DURATION', --no-pushes); empty/None keeps the scenario's value.
Returns a dict: the columns of hops.csv as NumPy arrays (hop, t_start, t_end, cost, I1..I4, T1,
T2, step_length, speed, apex, alpha, accepted, du2, dT2), plus method, fell, fall_reason and
sim_time. Bad input raises ValueError; the GIL is released while it runs; Ctrl-C raises
ddoc.SolveInterrupted with the partial table in .result.)");
}

}  // namespace python
}  // namespace ddoc
