// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// `ddoc_testing`: the standard problems of tests/core/standard_problems.h for the Python tests:
// their data (to pose them from Python) and their direct C++ solve (Learner::Solve, exact-model
// ModelPlant, dt = 1e-3 s, as bench_suite runs them), to compare the two.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

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

}  // namespace

PYBIND11_MODULE(ddoc_testing, mod) {
  mod.doc() = "Test support: the C++ standard problems (tests/core/standard_problems.h).";
  mod.def("names", &StandardProblemNames);
  mod.def("data", &Data, py::arg("name"));
  mod.def("solve", &SolveDirect, py::arg("name"), py::arg("preset") = "default");
}
