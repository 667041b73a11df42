// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// `ddoc_testing`: the standard problems of tests/core/standard_problems.h for the Python tests:
// their data (to pose them from Python) and their direct C++ solve (Learner::Solve, exact-model
// ModelPlant, dt = 1e-3 s, as bench_suite runs them), to compare the two.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <string>

#include "ddoc/learner.h"
#include "ddoc/plant.h"
#include "standard_problems.h"

namespace py = pybind11;
using namespace ddoc;           // NOLINT
using namespace ddoc::testing;  // NOLINT

namespace {

py::dict LqDict(const LinearQuadraticData& d) {
  py::dict out;
  out["A"] = d.A;
  out["B"] = d.B;
  out["E"] = d.E;
  out["Q"] = d.Q;
  out["r"] = d.r;
  out["R"] = d.R;
  out["rho"] = d.rho;
  out["S"] = d.S;
  out["s"] = d.s;
  out["u_min"] = d.u_min;
  out["u_max"] = d.u_max;
  out["x0"] = d.x0;
  out["final_time"] = d.final_time;
  return out;
}

py::dict Data(const std::string& name) {
  py::dict out;
  if (name == "lqr") out = LqDict(LqrData());
  else if (name == "sto2_linear") out = LqDict(StoLinearData(2));
  else if (name == "sto9_linear") out = LqDict(StoLinearData(9));
  else if (name == "exp0") out = LqDict(Exp0Data(std::numeric_limits<double>::infinity()));
  else if (name == "exp0_bounded") out = LqDict(Exp0Data(kExp0InputBound));
  else if (name == "state_size_lq") out = LqDict(StateSizeData());
  else if (name == "fishing") {
    const FishingData d = FishingProblemData(3);
    out["c0"] = d.c0;
    out["c1"] = d.c1;
    out["weight"] = d.weight;
    out["fishing"] = d.fishing;
    out["x0"] = d.x0;
    out["final_time"] = d.final_time;
  } else if (name == "exp1") {
    const Exp1Data d = Exp1ProblemData();
    out["target"] = d.target;
    out["x0"] = d.x0;
    out["final_time"] = d.final_time;
  } else {
    throw InvalidArgument("unknown problem '" + name + "'");
  }
  const auto sp = MakeStandardProblem(name);
  out["kind"] = name == "fishing" || name == "exp1" ? "nonlinear" : "lq";
  out["initial_durations"] = sp->initial_durations;
  out["reference_cost"] = sp->reference_cost;
  out["reference_T"] = sp->reference_T;
  return out;
}

py::dict SolveDirect(const std::string& name, const std::string& preset) {
  const auto sp = MakeStandardProblem(name);
  LearnerSettings settings = PresetSettings(preset == "paper" ? Preset::kPaper : Preset::kDefault);
  ModelPlant plant(sp->problem);
  Learner learner(sp->problem, settings);
  FunctionPolicy initial_policy = sp->InitialPolicy();
  const SolveResult r = learner.Solve(plant, plant, sp->x0, initial_policy);
  py::dict out;
  out["status"] = LearnerStatusName(r.status);
  out["trials"] = r.trials;
  out["iterations"] = r.iterations;
  out["cost"] = r.cost;
  out["T"] = r.T;
  out["optimality"] = r.optimality.total;
  out["cost_history"] = r.cost_history;
  std::vector<Matrix> x;
  for (const auto& mode : learner.nominal().modes) x.push_back(mode.x);
  out["x"] = x;
  return out;
}

// Seconds per call of system.Flow(k, x, u) (points = 0) or of system.FlowBatch at `points`
// copies of (x, u), over `calls` calls with the GIL released, as in a solve's trial (a Python
// system's callables re-acquire it): the cost of one C++ -> Python call (tools/bench/python).
double TimeFlow(const py::object& system_in, int k, const Vector& x, const Vector& u, int calls,
                int points, bool release_gil) {
  // A ddoc.System, or the name of a standard problem: its C++ system.
  std::unique_ptr<StandardProblem> sp;
  if (py::isinstance<py::str>(system_in)) sp = MakeStandardProblem(system_in.cast<std::string>());
  const SwitchedSystem& system = sp ? *sp->problem.system : system_in.cast<const SwitchedSystem&>();
  std::unique_ptr<py::gil_scoped_release> release;
  if (release_gil) release = std::make_unique<py::gil_scoped_release>();
  Vector xdot(x.size());
  const Matrix X = x.replicate(1, std::max(points, 1)), U = u.replicate(1, std::max(points, 1));
  Matrix F(x.size(), X.cols());
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < calls; ++i) {
    if (points == 0) {
      system.Flow(k, x, u, xdot);
    } else {
      system.FlowBatch(k, X, U, F);
    }
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / calls;
}

// One ModelPlant run (the solve's simulation, dt = 1e-3 s) of `system` (None: the C++ twin's)
// with the standard problem `name`'s initial policy, the GIL released: {"seconds", "steps"}
// (median of repeats).
py::dict TimeSimulation(const py::object& system, const std::string& name, int repeats) {
  const auto sp = MakeStandardProblem(name);
  ModelPlant plant(system.is_none() ? *sp->problem.system : system.cast<const SwitchedSystem&>(),
                   sp->problem.bounds);
  FunctionPolicy policy = sp->InitialPolicy();
  std::vector<double> times;
  Trajectory out;
  {
    py::gil_scoped_release release;
    for (int r = 0; r < repeats; ++r) {
      const auto start = std::chrono::steady_clock::now();
      plant.Run(sp->x0, policy, &out);
      times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
                          .count());
    }
  }
  std::sort(times.begin(), times.end());
  py::dict d;
  d["seconds"] = times[times.size() / 2];
  d["steps"] = out.total_samples() - out.num_modes();  // each mode's last sample is no step
  return d;
}

}  // namespace

PYBIND11_MODULE(ddoc_testing, mod) {
  mod.doc() = "Test support: the C++ standard problems (tests/core/standard_problems.h).";
  mod.def("names", &StandardProblemNames);
  mod.def("data", &Data, py::arg("name"));
  mod.def("solve", &SolveDirect, py::arg("name"), py::arg("preset") = "default");
  mod.def("time_flow", &TimeFlow, py::arg("system"), py::arg("k"), py::arg("x"), py::arg("u"),
          py::arg("calls"), py::arg("points") = 0, py::arg("release_gil") = true);
  mod.def("time_simulation", &TimeSimulation, py::arg("system"), py::arg("name"),
          py::arg("repeats") = 3);
}
