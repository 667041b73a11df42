// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-return-map: is the law a run has learned a stable gait on the robot, and if not, which
// hop-to-hop mode is the weak one?
//
// 1. Runs a scenario (MuJoCo robot, controller plugin) until hop N starts, then freezes the law
//    (HopperController::Freeze): every later hop runs the law of hop N.
// 2. Settles: S hops with the frozen law, then S hops each restarted (RestartHop) at the previous
//    takeoff state. The last takeoff state is the fixed point x*.
// 3. Perturbs x* along each of the 13 coordinates but x (+ and -, sizes --scale x the defaults
//    below), restarts a hop there and records H hops.
// 4. Fits x_{k+1} - x* = A (x_k - x*) to all recorded takeoff-to-takeoff pairs (FitReturnMap)
//    and prints and writes A's eigenvalues. |lambda| < 1 for all: the frozen gait is locally
//    stable; lambda near -1: a period-2 (alternating) mode.
//
// Exit codes: 0 done (whatever the spectrum), 1 internal error, 2 bad input, 3 the robot fell
// before the law was frozen or while settling.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ddoc/return_map.h"
#include "hopper_run.h"

namespace ddoc::app {
namespace {

using State = Eigen::Matrix<double, 14, 1>;

constexpr const char* kNames[14] = {"x",  "y",  "theta",  "phi",  "r",  "k_hip",  "k_leg",
                                    "xd", "yd", "thetad", "phid", "rd", "kd_hip", "kd_leg"};
// Default perturbation sizes (also the fit's scaling): m, rad, N m/rad, N/m and their rates.
constexpr double kPerturbation[14] = {0.0,  0.005, 0.01, 0.01, 0.002, 0.5, 20.0,
                                      0.05, 0.05,  0.1,  0.1,  0.05,  5.0, 200.0};

struct Options {
  std::string scenario, out;
  int freeze_hop = 60, settle = 20, hops_per_run = 2;
  double scale = 1.0;
  RunOverrides run;
};

// Parses and checks the command line. Returns -1 to go on, else the exit code.
int ParseOptions(int argc, char** argv, Options* o) {
  CLI::App cli{
      "ddoc-return-map: eigenvalues of the takeoff-to-takeoff map of a frozen learned law on the\n"
      "MuJoCo hopper (local stability of the gait it hops). Exit codes: 0 done, 1 internal\n"
      "error, 2 bad input, 3 the robot fell before the law was frozen or while settling."};
  cli.add_option("scenario", o->scenario, "scenario XML file (see models/scenarios/)")->required();
  cli.add_option("--freeze-hop", o->freeze_hop, "freeze the law of this hop (default 60)");
  cli.add_option("--settle", o->settle,
                 "hops run with the frozen law before measuring (default 20)");
  cli.add_option("--hops", o->hops_per_run, "hops recorded after each perturbation (default 2)");
  cli.add_option("--scale", o->scale, "multiplies the default perturbation sizes (default 1)");
  cli.add_option("--out,-o", o->out, "output directory (default: out/<scenario name>_return_map)");
  o->run.Register(&cli, false);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  const char* bad = o->freeze_hop < 0                            ? "--freeze-hop must be >= 0"
                    : o->settle < 2                              ? "--settle must be >= 2"
                    : o->hops_per_run < 1                        ? "--hops must be >= 1"
                    : !(o->scale > 0) || !std::isfinite(o->scale) ? "--scale must be > 0"
                                                                 : nullptr;
  if (bad == nullptr) return -1;
  std::fprintf(stderr, "ddoc-return-map: %s\n", bad);
  return kExitBadInput;
}

// A CSV file written with printf formats; closed with the object.
class CsvFile {
 public:
  explicit CsvFile(const std::string& path) : f_(std::fopen(path.c_str(), "w")) {
    if (f_ == nullptr) throw RunError(kExitBadInput, "cannot write '" + path + "'");
  }
  ~CsvFile() { std::fclose(f_); }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;
  std::FILE* get() const { return f_; }

 private:
  std::FILE* f_;
};

void WriteStateColumns(std::FILE* f, const char* prefix) {
  for (int i = 1; i < 14; ++i) std::fprintf(f, ",%s%s", prefix, kNames[i]);
}

void WriteState(std::FILE* f, const State& x) {
  for (int i = 1; i < 14; ++i) std::fprintf(f, ",%.10g", x(i));
}

// The steps of the measurement on one loaded run.
class ReturnMap {
 public:
  ReturnMap(const Options& o, LoadedRun* run);
  void LearnFreezeAndSettle();  // 1-2; throws RunError(kExitFall)
  void PerturbedRuns();         // 3
  ReturnMapFit Fit() const;     // 4
  void WriteJson(const ReturnMapFit& fit) const;
  void Print(const ReturnMapFit& fit) const;

 private:
  // Steps to the end of the running hop; returns "" or why it stopped.
  std::string ToNextTakeoff(plugin::HopReport* report);
  void Restart(const State& x);
  // A row of settle.csv: the hop, frozen (0 learning, 1 frozen, 2 restarted), its start state.
  void WriteSettleRow(const plugin::HopReport& report, int frozen);
  double ScaledChange(const State& a, const State& b) const {
    return ((a - b).tail<13>().cwiseQuotient(h_)).norm() / std::sqrt(13.0);
  }

  const Options& o_;
  LoadedRun* run_;
  RunStepper stepper_;
  CsvFile settle_csv_, pairs_csv_;
  Eigen::Matrix<double, 13, 1> h_;  // perturbation sizes
  std::vector<State> takeoffs_;      // after the freeze
  State x_natural_, x_star_;
  double change1_ = 0, change2_ = 0;
  std::vector<State> from_, to_;     // recorded pairs
  int runs_ = 0, falls_ = 0;
};

ReturnMap::ReturnMap(const Options& o, LoadedRun* run)
    : o_(o), run_(run), stepper_(run), settle_csv_(o.out + "/settle.csv"),
      pairs_csv_(o.out + "/pairs.csv") {
  for (int i = 1; i < 14; ++i) h_(i - 1) = o.scale * kPerturbation[i];
  std::fprintf(settle_csv_.get(), "hop,frozen,cost,speed,t2");
  WriteStateColumns(settle_csv_.get(), "");
  std::fputc('\n', settle_csv_.get());
  std::fprintf(pairs_csv_.get(), "run,coordinate,sign,hop,fell");
  WriteStateColumns(pairs_csv_.get(), "from_");
  WriteStateColumns(pairs_csv_.get(), "to_");
  std::fputc('\n', pairs_csv_.get());
}

std::string ReturnMap::ToNextTakeoff(plugin::HopReport* report) {
  for (;;) {
    const StepOutcome outcome = stepper_.Step();
    if (outcome.kind == StepOutcome::Kind::kFailed) throw RunError(kExitError, outcome.reason);
    std::vector<plugin::HopReport> reports = run_->controller->TakeReports();
    if (!reports.empty()) {
      *report = reports.back();
      return "";
    }
    // A non-finite state from a perturbed restart counts as a fall of that restart.
    if (outcome.kind == StepOutcome::Kind::kFell || outcome.kind == StepOutcome::Kind::kNonFinite) {
      return outcome.reason;
    }
  }
}

void ReturnMap::Restart(const State& x) {
  run_->controller->RestartHop(run_->model.get(), run_->data.get(), x);
  stepper_.Restarted();
}

void ReturnMap::WriteSettleRow(const plugin::HopReport& report, int frozen) {
  std::FILE* f = settle_csv_.get();
  std::fprintf(f, "%d,%d,%.8g,%.8g,%.8g", report.hop, frozen, report.cost, report.speed,
               report.t2);
  WriteState(f, run_->controller->hop_start_state());
  std::fputc('\n', f);
}

void ReturnMap::LearnFreezeAndSettle() {
  plugin::HopperController& c = *run_->controller;
  plugin::HopReport report;
  for (int hop = 0; hop < o_.freeze_hop + o_.settle; ++hop) {
    if (hop == o_.freeze_hop) {
      c.Freeze();
      stepper_.set_pushes(false);
    }
    const std::string why = ToNextTakeoff(&report);
    if (!why.empty()) {
      throw RunError(kExitFall, "the robot fell in hop " + std::to_string(hop) + " (" +
                                    (hop < o_.freeze_hop ? "before the freeze" : "while settling") +
                                    "): " + why);
    }
    WriteSettleRow(report, hop >= o_.freeze_hop ? 1 : 0);
    if (hop >= o_.freeze_hop) takeoffs_.push_back(c.hop_start_state());
  }
  // The perturbed runs start with RestartHop, which resets mjData (e.g. the contact solver's warm
  // start), so their map differs slightly from the natural hop-to-hop one. Its fixed point is
  // found by iterating it from the natural one: x <- P(x).
  x_natural_ = takeoffs_.back();
  for (int k = 0; k < o_.settle; ++k) {
    Restart(takeoffs_.back());
    const std::string why = ToNextTakeoff(&report);
    if (!why.empty()) {
      throw RunError(kExitFall, "a restarted hop from the settled state fell: " + why);
    }
    WriteSettleRow(report, 2);
    takeoffs_.push_back(c.hop_start_state());
  }
  std::fflush(settle_csv_.get());
  const size_t n = takeoffs_.size();
  x_star_ = takeoffs_.back();
  change1_ = ScaledChange(takeoffs_[n - 1], takeoffs_[n - 2]);
  change2_ = n >= 3 ? ScaledChange(takeoffs_[n - 1], takeoffs_[n - 3]) : NAN;
}

void ReturnMap::PerturbedRuns() {
  plugin::HopReport report;
  for (int i = 1; i < 14; ++i) {
    for (int sign : {1, -1}) {
      State prev = x_star_;
      prev(i) += sign * o_.scale * kPerturbation[i];
      Restart(prev);
      for (int k = 0; k < o_.hops_per_run; ++k) {
        const bool fell = !ToNextTakeoff(&report).empty();
        std::FILE* f = pairs_csv_.get();
        std::fprintf(f, "%d,%s,%d,%d,%d", runs_, kNames[i], sign, k, fell ? 1 : 0);
        WriteState(f, prev);
        if (fell) {
          for (int j = 1; j < 14; ++j) std::fprintf(f, ",nan");
          std::fputc('\n', f);
          ++falls_;
          break;
        }
        const State next = run_->controller->hop_start_state();
        WriteState(f, next);
        std::fputc('\n', f);
        from_.push_back(prev);
        to_.push_back(next);
        prev = next;
      }
      ++runs_;
    }
  }
  std::fflush(pairs_csv_.get());
}

ReturnMapFit ReturnMap::Fit() const {
  const Eigen::Index n = static_cast<Eigen::Index>(from_.size());
  Matrix F(13, n), T(13, n);  // 13 coordinates: x is cyclic
  for (Eigen::Index j = 0; j < n; ++j) {
    F.col(j) = from_[static_cast<size_t>(j)].tail<13>();
    T.col(j) = to_[static_cast<size_t>(j)].tail<13>();
  }
  try {
    return FitReturnMap(F, T, x_star_.tail<13>(), h_);
  } catch (const std::exception& e) {
    throw RunError(kExitError, std::string(e.what()) + " (" + std::to_string(falls_) + " of " +
                                   std::to_string(runs_) + " perturbed runs fell)");
  }
}

void ReturnMap::WriteJson(const ReturnMapFit& fit) const {
  nlohmann::ordered_json j;
  j["scenario"] = run_->scenario.name;
  j["method"] = MethodName(run_->scenario.method);
  j["freeze_hop"] = o_.freeze_hop;
  j["settle_hops"] = o_.settle;
  j["hops_per_run"] = o_.hops_per_run;
  j["settle_change_1"] = change1_;
  j["settle_change_2"] = change2_;
  j["restart_offset"] = ScaledChange(x_star_, x_natural_);
  j["runs"] = runs_;
  j["runs_fell"] = falls_;
  j["samples"] = fit.samples;
  j["residual_rms"] = fit.residual_rms;
  j["target_rms"] = fit.target_rms;
  for (int i = 1; i < 14; ++i) j["coordinates"].push_back(kNames[i]);
  for (int i = 1; i < 14; ++i) j["fixed_point"].push_back(x_star_(i));
  for (int i = 0; i < 13; ++i) j["perturbation"].push_back(h_(i));
  j["spectral_radius"] = fit.spectral_radius();
  j["eigenvalues"] = nlohmann::ordered_json::array();
  for (Eigen::Index k = 0; k < fit.eigenvalues.size(); ++k) {
    const std::complex<double> l = fit.eigenvalues(k);
    nlohmann::ordered_json e{{"re", l.real()}, {"im", l.imag()}, {"abs", std::abs(l)}};
    for (int i = 0; i < 13; ++i) e["vector_abs"].push_back(std::abs(fit.eigenvectors(i, k)));
    j["eigenvalues"].push_back(e);
  }
  for (int r = 0; r < 13; ++r) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (int k = 0; k < 13; ++k) row.push_back(fit.A(r, k));
    j["A"].push_back(row);
  }
  std::ofstream out(o_.out + "/return_map.json");
  out << j.dump(2) << "\n";
  if (!out) throw RunError(kExitBadInput, "cannot write '" + o_.out + "/return_map.json'");
}

void ReturnMap::Print(const ReturnMapFit& fit) const {
  const char* name = run_->scenario.name.c_str();
  std::fprintf(stderr,
               "ddoc-return-map: %s %s, law of hop %d frozen, %d settling hops (last change %.3g, "
               "two-hop change %.3g, in perturbation units)\n",
               name, MethodName(run_->scenario.method), o_.freeze_hop, o_.settle, change1_,
               change2_);
  std::fprintf(stderr, "  restart fixed point - natural fixed point: %.3g (perturbation units)\n",
               ScaledChange(x_star_, x_natural_));
  std::fprintf(stderr, "  %d pairs from %d perturbed runs (%d fell); fit residual %.3g of %.3g\n",
               fit.samples, runs_, falls_, fit.residual_rms, fit.target_rms);
  std::fprintf(stderr, "  spectral radius %.3f; eigenvalues (largest first):\n",
               fit.spectral_radius());
  for (Eigen::Index j = 0; j < std::min<Eigen::Index>(6, fit.eigenvalues.size()); ++j) {
    const std::complex<double> l = fit.eigenvalues(j);
    std::fprintf(stderr, "    %+.3f %+.3fi  |%.3f|  main components:", l.real(), l.imag(),
                 std::abs(l));
    // The three largest components of the eigenvector (perturbation units).
    std::vector<int> idx(13);
    for (int i = 0; i < 13; ++i) idx[static_cast<size_t>(i)] = i;
    std::partial_sort(idx.begin(), idx.begin() + 3, idx.end(), [&](int a, int b) {
      return std::abs(fit.eigenvectors(a, j)) > std::abs(fit.eigenvectors(b, j));
    });
    for (int k = 0; k < 3; ++k) {
      const int i = idx[static_cast<size_t>(k)];
      std::fprintf(stderr, " %s %.2f", kNames[i + 1], std::abs(fit.eigenvectors(i, j)));
    }
    std::fputc('\n', stderr);
  }
  std::fprintf(stderr, "  wrote %s/return_map.json, settle.csv, pairs.csv\n", o_.out.c_str());
}

int Run(int argc, char** argv) {
  Options o;
  const int parsed = ParseOptions(argc, argv, &o);
  if (parsed >= 0) return parsed;
  LoadedRun run = LoadRun(o.scenario, o.run);  // RunError: RunTool prints it
  if (o.out.empty()) o.out = "out/" + run.scenario.name + "_return_map";
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  ReturnMap map(o, &run);
  map.LearnFreezeAndSettle();
  map.PerturbedRuns();
  const ReturnMapFit fit = map.Fit();
  map.WriteJson(fit);
  map.Print(fit);
  return kExitOk;
}

}  // namespace
}  // namespace ddoc::app

int main(int argc, char** argv) {
  return ddoc::app::RunTool("ddoc-return-map", ddoc::app::Run, argc, argv);
}
