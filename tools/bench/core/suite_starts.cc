// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The standard problems from other starts than the suite's: for each problem, N initial guesses
// (random durations that respect the duration bounds and sum to the final time, the suite's u^0
// plus a random constant in [-1, 1]), solved with a preset; prints per problem how many
// converged, the trials, and how many ended within 1e-3 of the reference cost and 1e-3 s of its
// switching instants (a converged run may sit on another stationary point of a nonconvex problem).
//
//   suite_starts [--starts 12] [--seed 7] [--preset default|paper] [--max-trials 100]
//                [--only NAME] [--curvature-scale-min S] [--verbose]
//
// --verbose prints every start on stderr: its durations and input offset, the status, the
// trials, the cost against I* and the switching instants against T*.
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
};

Tally RunStarts(const std::string& name, int starts, std::mt19937* rng,
                const LearnerSettings& settings, bool verbose) {
  Tally t;
  for (int s = 0; s < starts; ++s) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    const testing::RandomStart start = DrawRandomStart(*sp, rng);
    FunctionPolicy initial = RandomStartPolicy(*sp, start);
    const SolveResult r = testing::SolveOnModel(*sp, initial, settings);
    ++t.runs;
    t.converged += r.status == LearnerStatus::kConverged;
    const double cost_error = std::abs(r.cost - sp->reference_cost) / sp->reference_cost;
    const double T_error = (r.T - sp->reference_T).cwiseAbs().maxCoeff();
    t.at_reference += cost_error <= 1e-3 && T_error <= 1e-3;
    t.trials += r.trials;
    t.max_trials = std::max(t.max_trials, r.trials);
    if (verbose) {
      // Six digits: enough to pose the start again in a test (RandomStart).
      std::fprintf(stderr, "%s start %d: D^0 (", name.c_str(), s);
      for (int k = 0; k < start.durations.size(); ++k) {
        std::fprintf(stderr, "%s%.6f", k ? ", " : "", start.durations(k));
      }
      std::fprintf(stderr, ") s, u^0 %+.6f: %s, %d trials, cost %.6g x I*, max |T - T*| %.2e s\n",
                   start.offset, LearnerStatusName(r.status), r.trials, r.cost / sp->reference_cost,
                   T_error);
    }
  }
  return t;
}

int Main(int argc, char** argv) {
  CLI::App app("The standard problems from random starts");
  int starts = 12, seed = 7, max_trials = 100;
  double curvature_scale_min = 1;
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
  app.add_flag("--verbose", verbose, "every start on stderr");
  CLI11_PARSE(app, argc, argv);
  LearnerSettings settings = preset == "paper" ? LearnerSettings::Paper() : LearnerSettings{};
  settings.max_trials = max_trials;
  if (curvature->count() > 0) settings.curvature_scale_min = curvature_scale_min;
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::printf("| problem | converged | at the reference | trials (mean, max) |\n|---|---|---|---|\n");
  for (const std::string& name : testing::StandardProblemNames()) {
    if (!only.empty() && name != only) {
      // Draw and discard the skipped problem's starts, so --only gives the same starts.
      const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
      for (int s = 0; s < starts; ++s) DrawRandomStart(*sp, &rng);
      continue;
    }
    const Tally t = RunStarts(name, starts, &rng, settings, verbose);
    std::printf("| %s | %d/%d | %d/%d | %.1f, %d |\n", name.c_str(), t.converged, t.runs,
                t.at_reference, t.runs, static_cast<double>(t.trials) / t.runs, t.max_trials);
  }
  return 0;
}

}  // namespace
}  // namespace ddoc

int main(int argc, char** argv) { return ddoc::Main(argc, argv); }
