// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-return-map: is the law a run has learned a stable gait on the robot, and if not, which
// hop-to-hop mode is the weak one?
//
// 1. Runs a scenario (MuJoCo robot, controller plugin) until hop N starts, then freezes the law
//    (HopperController::Freeze): every later hop runs the law of hop N.
// 2. Settles: S hops with the frozen law. The last takeoff state is the fixed point x*.
// 3. Perturbs x* along each of the 13 coordinates but x (+ and -, sizes --scale x the defaults
//    below), restarts a hop there (HopperController::RestartHop) and records H hops.
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
#include <memory>
#include <string>
#include <vector>

#include "ddoc/mujoco/hopper_mapping.h"
#include "ddoc/mujoco/hopper_sim.h"
#include "ddoc/return_map.h"
#include "hopper_controller.h"
#include "hopper_setup.h"
#include "scenario.h"

namespace ddoc::app {
namespace {

using State = Eigen::Matrix<double, 14, 1>;

constexpr const char* kNames[14] = {"x",  "y",  "theta",  "phi",  "r",  "k_hip",  "k_leg",
                                    "xd", "yd", "thetad", "phid", "rd", "kd_hip", "kd_leg"};
// Default perturbation sizes (also the fit's scaling): m, rad, N m/rad, N/m and their rates.
constexpr double kPerturbation[14] = {0.0,  0.005, 0.01, 0.01, 0.002, 0.5, 20.0,
                                      0.05, 0.05,  0.1,  0.1,  0.05,  5.0, 200.0};

// Steps the robot with the attached controller until the running hop ends (a takeoff) or the
// robot falls. Returns "" at a takeoff, else why it stopped.
class Stepper {
 public:
  Stepper(const Scenario& s, const mjModel* m, mjData* d, plugin::HopperController* c)
      : s_(s), m_(m), d_(d), c_(c) {}

  void Restarted() { phase_start_ = d_->time; mode_ = c_->mode(); }
  void set_pushes(bool on) { pushes_ = on; }

  std::string ToNextTakeoff(plugin::HopReport* report) {
    const mjModel* m = m_;
    mjData* d = d_;
    for (;;) {
      ApplyDragAndPush(c_->mapping(), m, d, pushes_ ? PushForce(s_.pushes, d->time) : 0.0);
      mj_step(m, d);
      if (c_->offline_pending()) c_->RunOffline();  // outside mjcb_control
      if (c_->failed()) return c_->error();
      const State x = FlightState(c_->mapping(), d, c_->vsa());
      if (c_->mode() != mode_) {
        mode_ = c_->mode();
        phase_start_ = d->time;
      }
      std::vector<plugin::HopReport> reports = c_->TakeReports();
      if (!reports.empty()) {
        *report = reports.back();
        return "";
      }
      const std::string fall = FallReason(limits_, x, d->time - phase_start_);
      if (!fall.empty()) return fall;
    }
  }

 private:
  const Scenario& s_;
  const mjModel* m_;
  mjData* d_;
  plugin::HopperController* c_;
  FallLimits limits_;
  bool pushes_ = true;
  int mode_ = hopper::kFlight;
  double phase_start_ = 0.0;
};

std::FILE* OpenOrThrow(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) throw std::runtime_error("cannot write '" + path + "'");
  return f;
}

void WriteStateColumns(std::FILE* f, const char* prefix) {
  for (int i = 1; i < 14; ++i) std::fprintf(f, ",%s%s", prefix, kNames[i]);
}

void WriteState(std::FILE* f, const State& x) {
  for (int i = 1; i < 14; ++i) std::fprintf(f, ",%.10g", x(i));
}

int Run(int argc, char** argv) {
  CLI::App cli{
      "ddoc-return-map: eigenvalues of the takeoff-to-takeoff map of a frozen learned law on the\n"
      "MuJoCo hopper (local stability of the gait it hops). Exit codes: 0 done, 1 internal\n"
      "error, 2 bad input, 3 the robot fell before the law was frozen or while settling."};
  std::string scenario_path, out_dir, method;
  int freeze_hop = 60, settle = 20, hops_per_run = 2;
  double scale = 1.0;
  bool no_pushes = false;
  cli.add_option("scenario", scenario_path, "scenario XML file (see models/scenarios/)")
      ->required();
  cli.add_option("--freeze-hop", freeze_hop, "freeze the law of this hop (default 60)");
  cli.add_option("--settle", settle, "hops run with the frozen law before measuring (default 20)");
  cli.add_option("--hops", hops_per_run, "hops recorded after each perturbation (default 2)");
  cli.add_option("--scale", scale, "multiplies the default perturbation sizes (default 1)");
  cli.add_option("--method,-m", method, "alg1 | ocfb | mrl (overrides the scenario)");
  cli.add_flag("--no-pushes", no_pushes, "ignore the scenario's pushes (they only act before the freeze)");
  cli.add_option("--out,-o", out_dir, "output directory (default: out/<scenario name>_return_map)");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = cli.exit(e);
    return code == 0 ? kExitOk : kExitBadInput;
  }

  Scenario s;
  HopperParams params;
  MjModelPtr model;
  try {
    s = LoadScenario(scenario_path);
    if (!method.empty()) s.method = ParseMethod(method);
    if (no_pushes) s.pushes.clear();
    ValidateScenario(s);
    if (freeze_hop < 0) throw ScenarioError("--freeze-hop must be >= 0");
    if (settle < 2) throw ScenarioError("--settle must be >= 2");
    if (hops_per_run < 1) throw ScenarioError("--hops must be >= 1");
    if (!(scale > 0) || !std::isfinite(scale)) throw ScenarioError("--scale must be > 0");
    model = LoadMjcf(s.robot_mjcf);
    HopperMapping::Build(model.get(), s.robot_mjcf);
    params = ModelParams(s);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-return-map: %s\n", e.what());
    return kExitBadInput;
  }
  if (out_dir.empty()) out_dir = "out/" + s.name + "_return_map";

  const mjModel* m = model.get();
  MjDataPtr data(mj_makeData(m));
  mjData* d = data.get();
  std::string error;
  std::unique_ptr<plugin::HopperController> c =
      plugin::HopperController::Create(m, ControllerConfigFor(s, params), &error);
  if (!c) {
    std::fprintf(stderr, "ddoc-return-map: %s\n", error.c_str());
    return kExitError;
  }
  std::FILE* hops_csv = nullptr;
  std::FILE* pairs_csv = nullptr;
  try {
    std::filesystem::create_directories(out_dir);
    hops_csv = OpenOrThrow(out_dir + "/settle.csv");
    pairs_csv = OpenOrThrow(out_dir + "/pairs.csv");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-return-map: %s\n", e.what());
    if (hops_csv) std::fclose(hops_csv);
    return kExitBadInput;
  }
  std::fprintf(hops_csv, "hop,frozen,cost,speed,t2");
  WriteStateColumns(hops_csv, "");
  std::fputc('\n', hops_csv);
  std::fprintf(pairs_csv, "run,coordinate,sign,hop,fell");
  WriteStateColumns(pairs_csv, "from_");
  WriteStateColumns(pairs_csv, "to_");
  std::fputc('\n', pairs_csv);

  c->Reset(m, d);
  plugin::Attach(c.get());
  Stepper stepper(s, m, d, c.get());
  auto finish = [&](int code) {
    plugin::Detach();
    std::fclose(hops_csv);
    std::fclose(pairs_csv);
    return code;
  };

  // 1-2. Learn until hop N starts, freeze, settle.
  std::vector<State> takeoffs;
  plugin::HopReport report;
  const int total = freeze_hop + settle;
  for (int hop = 0; hop < total; ++hop) {
    if (hop == freeze_hop) {
      c->Freeze();
      stepper.set_pushes(false);
    }
    const std::string why = stepper.ToNextTakeoff(&report);
    if (!why.empty()) {
      std::fprintf(stderr, "ddoc-return-map: the robot fell in hop %d (%s): %s\n", hop,
                   hop < freeze_hop ? "before the freeze" : "while settling", why.c_str());
      return finish(kExitFall);
    }
    std::fprintf(hops_csv, "%d,%d,%.8g,%.8g,%.8g", report.hop, hop >= freeze_hop ? 1 : 0,
                 report.cost, report.speed, report.t2);
    WriteState(hops_csv, c->hop_start_state());
    std::fputc('\n', hops_csv);
    if (hop >= freeze_hop) takeoffs.push_back(c->hop_start_state());
  }
  // The perturbed runs start with RestartHop, which resets mjData (e.g. the contact solver's warm
  // start), so their map differs slightly from the natural hop-to-hop one. Its fixed point is
  // found by iterating it from the natural one: x <- P(x).
  const State x_natural = takeoffs.back();
  for (int k = 0; k < settle; ++k) {
    c->RestartHop(m, d, takeoffs.back());
    stepper.Restarted();
    const std::string why = stepper.ToNextTakeoff(&report);
    if (!why.empty()) {
      std::fprintf(stderr, "ddoc-return-map: a restarted hop from the settled state fell: %s\n",
                   why.c_str());
      return finish(kExitFall);
    }
    std::fprintf(hops_csv, "%d,2,%.8g,%.8g,%.8g", report.hop, report.cost, report.speed,
                 report.t2);
    WriteState(hops_csv, c->hop_start_state());
    std::fputc('\n', hops_csv);
    takeoffs.push_back(c->hop_start_state());
  }
  std::fflush(hops_csv);
  const State x_star = takeoffs.back();
  Eigen::Matrix<double, 13, 1> h;
  for (int i = 1; i < 14; ++i) h(i - 1) = scale * kPerturbation[i];
  auto scaled_change = [&](const State& a, const State& b) {
    return ((a - b).tail<13>().cwiseQuotient(h)).norm() / std::sqrt(13.0);
  };
  const double change1 = scaled_change(takeoffs[takeoffs.size() - 1], takeoffs[takeoffs.size() - 2]);
  const double change2 =
      takeoffs.size() >= 3 ? scaled_change(takeoffs.back(), takeoffs[takeoffs.size() - 3]) : NAN;

  // 3. Perturbed restarts.
  std::vector<State> from, to;
  int runs = 0, falls = 0;
  for (int i = 1; i < 14; ++i) {
    for (int sign : {1, -1}) {
      State x0 = x_star;
      x0(i) += sign * scale * kPerturbation[i];
      c->RestartHop(m, d, x0);
      stepper.Restarted();
      State prev = x0;
      for (int k = 0; k < hops_per_run; ++k) {
        const std::string why = stepper.ToNextTakeoff(&report);
        if (c->failed()) {
          std::fprintf(stderr, "ddoc-return-map: %s\n", c->error().c_str());
          return finish(kExitError);
        }
        const bool fell = !why.empty();
        std::fprintf(pairs_csv, "%d,%s,%d,%d,%d", runs, kNames[i], sign, k, fell ? 1 : 0);
        WriteState(pairs_csv, prev);
        if (fell) {
          for (int j = 1; j < 14; ++j) std::fprintf(pairs_csv, ",nan");
          std::fputc('\n', pairs_csv);
          ++falls;
          break;
        }
        const State next = c->hop_start_state();
        WriteState(pairs_csv, next);
        std::fputc('\n', pairs_csv);
        from.push_back(prev);
        to.push_back(next);
        prev = next;
      }
      ++runs;
    }
  }
  std::fflush(pairs_csv);

  // 4. Fit (13 coordinates: x is cyclic).
  Matrix F(13, static_cast<Eigen::Index>(from.size())), T(13, static_cast<Eigen::Index>(to.size()));
  for (size_t j = 0; j < from.size(); ++j) {
    F.col(static_cast<Eigen::Index>(j)) = from[j].tail<13>();
    T.col(static_cast<Eigen::Index>(j)) = to[j].tail<13>();
  }
  ReturnMapFit fit;
  try {
    fit = FitReturnMap(F, T, x_star.tail<13>(), h);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-return-map: %s (%d of %d perturbed runs fell)\n", e.what(), falls,
                 runs);
    return finish(kExitError);
  }

  std::FILE* json = nullptr;
  try {
    json = OpenOrThrow(out_dir + "/return_map.json");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-return-map: %s\n", e.what());
    return finish(kExitBadInput);
  }
  std::fprintf(json, "{\n  \"scenario\": \"%s\",\n  \"method\": \"%s\",\n", s.name.c_str(),
               MethodName(s.method));
  std::fprintf(json, "  \"freeze_hop\": %d,\n  \"settle_hops\": %d,\n  \"hops_per_run\": %d,\n",
               freeze_hop, settle, hops_per_run);
  std::fprintf(json, "  \"settle_change_1\": %.6g,\n  \"settle_change_2\": %.6g,\n", change1,
               change2);
  std::fprintf(json, "  \"restart_offset\": %.6g,\n", scaled_change(x_star, x_natural));
  std::fprintf(json, "  \"runs\": %d,\n  \"runs_fell\": %d,\n  \"samples\": %d,\n", runs, falls,
               fit.samples);
  std::fprintf(json, "  \"residual_rms\": %.6g,\n  \"target_rms\": %.6g,\n", fit.residual_rms,
               fit.target_rms);
  std::fprintf(json, "  \"coordinates\": [");
  for (int i = 1; i < 14; ++i) std::fprintf(json, "%s\"%s\"", i > 1 ? ", " : "", kNames[i]);
  std::fprintf(json, "],\n  \"fixed_point\": [");
  for (int i = 1; i < 14; ++i) std::fprintf(json, "%s%.10g", i > 1 ? ", " : "", x_star(i));
  std::fprintf(json, "],\n  \"perturbation\": [");
  for (int i = 0; i < 13; ++i) std::fprintf(json, "%s%.6g", i > 0 ? ", " : "", h(i));
  std::fprintf(json, "],\n  \"spectral_radius\": %.6g,\n  \"eigenvalues\": [\n",
               fit.spectral_radius());
  for (Eigen::Index j = 0; j < fit.eigenvalues.size(); ++j) {
    const std::complex<double> l = fit.eigenvalues(j);
    std::fprintf(json, "    {\"re\": %.6g, \"im\": %.6g, \"abs\": %.6g, \"vector_abs\": [",
                 l.real(), l.imag(), std::abs(l));
    for (int i = 0; i < 13; ++i) {
      std::fprintf(json, "%s%.4g", i > 0 ? ", " : "", std::abs(fit.eigenvectors(i, j)));
    }
    std::fprintf(json, "]}%s\n", j + 1 < fit.eigenvalues.size() ? "," : "");
  }
  std::fprintf(json, "  ],\n  \"A\": [\n");
  for (int r = 0; r < 13; ++r) {
    std::fprintf(json, "    [");
    for (int k = 0; k < 13; ++k) std::fprintf(json, "%s%.6g", k > 0 ? ", " : "", fit.A(r, k));
    std::fprintf(json, "]%s\n", r < 12 ? "," : "");
  }
  std::fprintf(json, "  ]\n}\n");
  std::fclose(json);

  std::fprintf(stderr,
               "ddoc-return-map: %s %s, law of hop %d frozen, %d settling hops (last change %.3g, "
               "two-hop change %.3g, in perturbation units)\n",
               s.name.c_str(), MethodName(s.method), freeze_hop, settle, change1, change2);
  std::fprintf(stderr, "  restart fixed point - natural fixed point: %.3g (perturbation units)\n",
               scaled_change(x_star, x_natural));
  std::fprintf(stderr, "  %d pairs from %d perturbed runs (%d fell); fit residual %.3g of %.3g\n",
               fit.samples, runs, falls, fit.residual_rms, fit.target_rms);
  std::fprintf(stderr, "  spectral radius %.3f; eigenvalues (largest first):\n",
               fit.spectral_radius());
  for (Eigen::Index j = 0; j < std::min<Eigen::Index>(6, fit.eigenvalues.size()); ++j) {
    const std::complex<double> l = fit.eigenvalues(j);
    std::fprintf(stderr, "    %+.3f %+.3fi  |%.3f|  main components:", l.real(), l.imag(),
                 std::abs(l));
    // The three largest components of the eigenvector (perturbation units).
    std::vector<int> idx(13);
    for (int i = 0; i < 13; ++i) idx[i] = i;
    std::partial_sort(idx.begin(), idx.begin() + 3, idx.end(), [&](int a, int b) {
      return std::abs(fit.eigenvectors(a, j)) > std::abs(fit.eigenvectors(b, j));
    });
    for (int k = 0; k < 3; ++k) {
      std::fprintf(stderr, " %s %.2f", kNames[idx[k] + 1], std::abs(fit.eigenvectors(idx[k], j)));
    }
    std::fputc('\n', stderr);
  }
  std::fprintf(stderr, "  wrote %s/return_map.json, settle.csv, pairs.csv\n", out_dir.c_str());
  return finish(kExitOk);
}

}  // namespace
}  // namespace ddoc::app

int main(int argc, char** argv) {
  try {
    return ddoc::app::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-return-map: internal error: %s\n", e.what());
    return 1;
  }
}
