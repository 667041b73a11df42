// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The standard problems from other starts than the suite's: for each problem, N initial guesses
// (random durations that respect the duration bounds and sum to the final time, the suite's u^0
// plus a random constant in [-1, 1]), solved with a preset; prints per problem how many
// converged, the trials, and how many ended within 1e-3 of the reference cost and 1e-3 s of its
// switching instants (a converged run may sit on another stationary point of a nonconvex problem).
//
//   suite_starts [--starts 12] [--seed 7] [--preset default|paper] [--max-trials 100]
//                [--only NAME] [--curvature-scale-min S] [--duration-min D] [--failure-raises N]
//                [--verbose]
//
// --verbose prints every start on stderr: its durations and input offset, the status, the
// trials, the cost against I* and the switching instants against T*, and the final durations.
// --duration-min D sets every mode's Bounds::duration_min to D on the problems with K > 1
// (the suite's is 0.01 s; 0 lets a mode vanish); the starts are drawn as without it. The column
// "stuck" counts the runs that end away from the reference with a mode on its lower bound.
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include <CLI/CLI.hpp>

#include "ddoc/ddoc.h"
#include "standard_problems.h"

namespace ddoc {
namespace {

using testing::DrawRandomStart;
using testing::MakeStandardProblem;
using testing::RandomStartPolicy;
using testing::StandardProblem;

struct Tally {
  int runs = 0, converged = 0, at_reference = 0, trials = 0, max_trials = 0;
  int stuck = 0;  // not at the reference, a duration on its lower bound
};

// duration_min < 0: the suite's bounds.
Tally RunStarts(const std::string& name, int starts, std::mt19937* rng,
                const LearnerSettings& settings, double duration_min, bool verbose) {
  Tally t;
  for (int s = 0; s < starts; ++s) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    const testing::RandomStart start = DrawRandomStart(*sp, rng);
    if (duration_min >= 0 && sp->num_modes() > 1) sp->problem.bounds.duration_min.setConstant(duration_min);
    FunctionPolicy initial = RandomStartPolicy(*sp, start);
    const SolveResult r = testing::SolveOnModel(*sp, initial, settings);
    ++t.runs;
    t.converged += r.status == LearnerStatus::kConverged;
    const double cost_error = std::abs(r.cost - sp->reference_cost) / sp->reference_cost;
    const double T_error = (r.T - sp->reference_T).cwiseAbs().maxCoeff();
    const bool at_reference = cost_error <= 1e-3 && T_error <= 1e-3;
    t.at_reference += at_reference;
    Vector D(r.T.size());
    bool on_bound = false;
    for (int k = 0; k < D.size(); ++k) {
      D(k) = r.T(k) - (k == 0 ? 0.0 : r.T(k - 1));
      on_bound = on_bound || D(k) <= sp->problem.bounds.duration_min(k) + 1e-6;
    }
    t.stuck += !at_reference && on_bound;
    t.trials += r.trials;
    t.max_trials = std::max(t.max_trials, r.trials);
    if (verbose) {
      // Six digits: enough to pose the start again in a test (RandomStart).
      std::fprintf(stderr, "%s start %d: D^0 (", name.c_str(), s);
      for (int k = 0; k < start.durations.size(); ++k) {
        std::fprintf(stderr, "%s%.6f", k ? ", " : "", start.durations(k));
      }
      std::fprintf(stderr, ") s, u^0 %+.6f: %s, %d trials, cost %.6g x I*, max |T - T*| %.2e s, D (",
                   start.offset, LearnerStatusName(r.status), r.trials, r.cost / sp->reference_cost,
                   T_error);
      for (int k = 0; k < D.size(); ++k) std::fprintf(stderr, "%s%.6f", k ? ", " : "", D(k));
      std::fprintf(stderr, ") s, projected gradient in D %.2e\n", r.optimality.times);
    }
  }
  return t;
}

int Main(int argc, char** argv) {
  CLI::App app("The standard problems from random starts");
  int starts = 12, seed = 7, max_trials = 100, failure_raises = -1;
  double curvature_scale_min = 1, duration_min = -1;
  std::string preset = "default", only;
  bool verbose = false;
  app.add_option("--starts", starts, "initial guesses per problem")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "random seed");
  app.add_option("--preset", preset, "default | paper")->check(CLI::IsMember({"default", "paper"}));
  app.add_option("--max-trials", max_trials, "trial budget per run")->check(CLI::PositiveNumber);
  app.add_option("--only", only, "one problem (the others still draw their starts)")
      ->check(CLI::IsMember(testing::StandardProblemNames()));
  CLI::Option* curvature = app.add_option(
      "--curvature-scale-min", curvature_scale_min,
      "LearnerSettings::curvature_scale_min (1 = the model's curvature never scaled; default: the "
      "preset's)");
  curvature->check([](const std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        return *end == '\0' && v > 0 && v <= 1 ? "" : "must be a number in (0, 1], got " + text;
      });
  app.add_option("--duration-min", duration_min,
                 "Bounds::duration_min of every mode on the problems with K > 1 (s; default: the "
                 "suite's 0.01; 0 lets a mode vanish)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--failure-raises", failure_raises,
                 "LearnerSettings::failure_raises (default: the preset's)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--verbose", verbose, "every start on stderr");
  CLI11_PARSE(app, argc, argv);
  LearnerSettings settings = preset == "paper" ? LearnerSettings::Paper() : LearnerSettings{};
  settings.max_trials = max_trials;
  if (curvature->count() > 0) settings.curvature_scale_min = curvature_scale_min;
  if (failure_raises >= 0) settings.failure_raises = failure_raises;
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::printf("| problem | converged | at the reference | stuck | trials (mean, max) |\n"
              "|---|---|---|---|---|\n");
  for (const std::string& name : testing::StandardProblemNames()) {
    if (!only.empty() && name != only) {
      // Draw and discard the skipped problem's starts, so --only gives the same starts.
      const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
      for (int s = 0; s < starts; ++s) DrawRandomStart(*sp, &rng);
      continue;
    }
    const Tally t = RunStarts(name, starts, &rng, settings, duration_min, verbose);
    std::printf("| %s | %d/%d | %d/%d | %d/%d | %.1f, %d |\n", name.c_str(), t.converged, t.runs,
                t.at_reference, t.runs, t.stuck, t.runs, static_cast<double>(t.trials) / t.runs,
                t.max_trials);
  }
  return 0;
}

}  // namespace
}  // namespace ddoc

int main(int argc, char** argv) { return ddoc::Main(argc, argv); }
