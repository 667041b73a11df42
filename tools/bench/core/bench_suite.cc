// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// bench_suite: every standard problem (tests/core/standard_problems.h) solved by Algorithm 1
// with each preset, LearnerSettings{} (the default) and LearnerSettings::Paper(), the exact
// model as the plant (ModelPlant, dt = 1e-3 s), from the problem's u^0, T^0.
//
//   bench_suite [Google Benchmark flags] [--max_trials=N]
//       one benchmark per problem and preset; the time is the wall time of Learner::Solve;
//       counters: cost_err (|I - I*| / I*, the reported cost), true_cost_err (the final
//       nominal's inputs simulated independently), T_err (max_k |T_k - T*_k|, s), trials,
//       iterations, status (0 running, 1 converged, 2 line search failed, 3 max trials; also
//       the label).
//   bench_suite --markdown [--max_trials=N]
//       prints two markdown tables instead: the problems with their references, and the
//       results (problem x preset: status, errors, trials, wall time) for docs/.
//
// --max_trials=N caps the presets' max_trials (default: each preset's own value).
// Each solve runs in a child process, so that a crash or a hang of the engine on one problem
// (m = 0 crashed at the time of writing) is reported as such and the others still run.
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "ddoc/learner.h"
#include "ddoc/plant.h"
#include "standard_problems.h"
#include "standard_references.h"

namespace ddoc {
namespace testing {
namespace {

constexpr unsigned kTimeoutSeconds = 600;  // per solve (child process)

/// What one solve gave (plain data: it crosses a pipe from the child process).
struct SuiteRun {
  bool ok = false;          // the solve returned (no exception, crash or timeout)
  char error[256] = {0};    // what happened otherwise
  int status = 0;           // LearnerStatus
  int trials = 0;
  int iterations = 0;
  double cost_error = 0;       // |I - I*| / I*, reported cost
  double true_cost_error = 0;  // the same for the independent cost of the final nominal
  double T_error = 0;          // max_k |T_k - T*_k| (s)
  double wall_s = 0;           // wall time of Learner::Solve (s)
};

LearnerSettings Preset(const std::string& preset, int max_trials) {
  LearnerSettings s = preset == "paper" ? LearnerSettings::Paper() : LearnerSettings{};
  if (max_trials > 0) s.max_trials = max_trials;
  return s;
}

SuiteRun SolveInProcess(const std::string& name, const std::string& preset, int max_trials) {
  SuiteRun out;
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
  const LearnerSettings settings = Preset(preset, max_trials);
  ModelPlant plant(sp->problem);
  Learner learner(sp->problem, settings);
  FunctionPolicy initial_policy = sp->InitialPolicy();
  const auto start = std::chrono::steady_clock::now();
  const SolveResult r = learner.Solve(plant, plant, sp->x0, initial_policy);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.ok = true;
  out.status = static_cast<int>(r.status);
  out.trials = r.trials;
  out.iterations = r.iterations;
  out.cost_error = std::abs(r.cost - sp->reference_cost) / sp->reference_cost;
  out.T_error = r.T.size() == sp->reference_T.size()
                    ? (r.T - sp->reference_T).cwiseAbs().maxCoeff()
                    : std::numeric_limits<double>::infinity();
  // The final nominal's held inputs and instants, simulated by the independent model.
  const Trajectory& nominal = learner.nominal();
  std::vector<HeldInputs> modes(nominal.num_modes());
  for (int k = 0; k < nominal.num_modes(); ++k) {
    modes[k].t = nominal.modes[k].t;
    modes[k].u = nominal.modes[k].u;
  }
  const double true_cost = HeldInputCost(IndependentModelOf(*sp), nominal.x0, modes, 4);
  out.true_cost_error = std::abs(true_cost - sp->reference_cost) / sp->reference_cost;
  return out;
}

/// Runs SolveInProcess in a child process and returns its result, or the reason it has none.
SuiteRun SolveIsolated(const std::string& name, const std::string& preset, int max_trials) {
  SuiteRun out;
  int fd[2];
  if (pipe(fd) != 0) {
    std::snprintf(out.error, sizeof(out.error), "pipe failed");
    return out;
  }
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    std::snprintf(out.error, sizeof(out.error), "fork failed");
    return out;
  }
  if (pid == 0) {  // child
    close(fd[0]);
    alarm(kTimeoutSeconds);
    SuiteRun r;
    try {
      r = SolveInProcess(name, preset, max_trials);
    } catch (const std::exception& e) {
      std::snprintf(r.error, sizeof(r.error), "threw: %s", e.what());
    }
    const ssize_t written = write(fd[1], &r, sizeof(r));
    _exit(written == static_cast<ssize_t>(sizeof(r)) ? 0 : 1);
  }
  close(fd[1]);
  SuiteRun r;
  size_t got = 0;
  while (got < sizeof(r)) {
    const ssize_t n = read(fd[0], reinterpret_cast<char*>(&r) + got, sizeof(r) - got);
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  close(fd[0]);
  int wstatus = 0;
  waitpid(pid, &wstatus, 0);
  if (got == sizeof(r)) return r;
  if (WIFSIGNALED(wstatus)) {
    const int sig = WTERMSIG(wstatus);
    std::snprintf(out.error, sizeof(out.error), "%s (signal %d: %s)",
                  sig == SIGALRM ? "timed out" : "crashed", sig, strsignal(sig));
  } else {
    std::snprintf(out.error, sizeof(out.error), "child exited with %d",
                  WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1);
  }
  return out;
}

const std::vector<std::string>& Presets() {
  static const std::vector<std::string> presets = {"default", "paper"};
  return presets;
}

std::string Format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

// Markdown cells cannot hold a bare '|'.
std::string Cell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

std::string Instants(const Vector& T) {
  std::string s;
  for (int k = 0; k < T.size(); ++k) s += (k ? ", " : "") + Format("%.6f", T(k));
  return s;
}

void PrintMarkdown(int max_trials) {
  std::printf("| problem | source | K | n_k | m | inputs | final time (s) | I* | T* (s) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& name : StandardProblemNames()) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    std::string dims;
    for (int k = 0; k < sp->num_modes(); ++k) {
      const std::string n = std::to_string(sp->system->state_dim(k));
      if (dims.find(n) == std::string::npos) dims += (dims.empty() ? "" : ", ") + n;
    }
    std::string inputs = "none";
    if (sp->input_dim() > 0) {
      inputs = std::isinf(sp->problem.bounds.u_max(0))
                   ? "unbounded"
                   : "|u| <= " + Format("%g", sp->problem.bounds.u_max(0)) +
                         (sp->bounds_active ? " (active)" : "");
    }
    std::printf("| %s | %s | %d | %s | %d | %s | %g | %.10g | %s |\n", name.c_str(),
                Cell(sp->citation).c_str(), sp->num_modes(), dims.c_str(), sp->input_dim(),
                Cell(inputs).c_str(), sp->final_time(), sp->reference_cost,
                Instants(sp->reference_T).c_str());
  }
  std::printf("\n| problem | preset | status | cost error | true cost error | max \\|T - T*\\| (s) "
              "| trials (target) | iterations | wall (s) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& name : StandardProblemNames()) {
    const int budget = MakeStandardProblem(name)->trial_budget();
    for (const std::string& preset : Presets()) {
      const SuiteRun r = SolveIsolated(name, preset, max_trials);
      if (!r.ok) {
        std::printf("| %s | %s | %s | - | - | - | - | - | - |\n", name.c_str(), preset.c_str(),
                    r.error);
      } else {
        std::printf("| %s | %s | %s | %.1e | %.1e | %.1e | %d (%d) | %d | %.2f |\n",
                    name.c_str(), preset.c_str(),
                    LearnerStatusName(static_cast<LearnerStatus>(r.status)), r.cost_error,
                    r.true_cost_error, r.T_error, r.trials, budget, r.iterations, r.wall_s);
      }
      std::fflush(stdout);
    }
  }
}

void RegisterAll(int max_trials) {
  for (const std::string& name : StandardProblemNames()) {
    for (const std::string& preset : Presets()) {
      benchmark::RegisterBenchmark(
          ("suite/" + name + "/" + preset).c_str(),
          [name, preset, max_trials](benchmark::State& state) {
            SuiteRun r;
            for (auto _ : state) {
              r = SolveIsolated(name, preset, max_trials);
              state.SetIterationTime(r.ok ? r.wall_s : 0.0);
            }
            if (!r.ok) {
              state.SkipWithError(r.error);
              return;
            }
            state.counters["cost_err"] = r.cost_error;
            state.counters["true_cost_err"] = r.true_cost_error;
            state.counters["T_err"] = r.T_error;
            state.counters["trials"] = r.trials;
            state.counters["iterations"] = r.iterations;
            state.counters["status"] = r.status;
            state.SetLabel(LearnerStatusName(static_cast<LearnerStatus>(r.status)));
          })
          ->UseManualTime()
          ->Iterations(1)
          ->Unit(benchmark::kMillisecond);
    }
  }
}

}  // namespace
}  // namespace testing
}  // namespace ddoc

int main(int argc, char** argv) {
  // Own flags first; the rest goes to Google Benchmark.
  bool markdown = false;
  int max_trials = 0;
  std::vector<char*> rest = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--markdown") {
      markdown = true;
    } else if (arg.rfind("--max_trials=", 0) == 0) {
      max_trials = std::stoi(arg.substr(13));
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (markdown) {
    ddoc::testing::PrintMarkdown(max_trials);
    return 0;
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  if (benchmark::ReportUnrecognizedArguments(rest_argc, rest.data())) return 1;
  ddoc::testing::RegisterAll(max_trials);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
