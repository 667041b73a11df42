// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-hop-experiment: hop after hop on the ANALYTIC hopper, to measure what makes forward
// hopping stable before going to MuJoCo. The model plant (which may differ from the model: mass,
// drag) runs one hop per trial from takeoff to takeoff; the next hop starts at the takeoff state
// of the previous one (online, as on the robot). The trials are run by the engine's TrialDriver
// with the hopper's settings (HopperTrialSettings), u^0 = the OC-FB law of the model.
//
//   --floquet: eigenvalues of u^0's takeoff-to-takeoff map on the plant at the state the run
//   ended in (or, with --newton N, at the fixed point N Newton steps find), central differences.
//
// Output: one CSV line per hop on stdout, a summary on stderr. Exit codes: 0 done (fall or not),
// 2 bad input.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <complex>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "ddoc/check_derivatives.h"
#include "ddoc/cost.h"
#include "ddoc/hopper/hopper_learning.h"
#include "scenario.h"

namespace ddoc::app {
namespace {

using State = Eigen::Matrix<double, 14, 1>;

struct Options {
  double speed = 0.5;
  std::string method = "alg1";
  int hops = 100, warmup = 1, push_hop = -1, newton = 0;
  double model_mass = 10, model_drag = 0, plant_mass = -1, plant_drag = -1;
  double model_b_hip = 0, plant_b_hip = -1, plant_slope = 0;
  double perturbation = 0.05, push_dv = 0, cyclic = 0;
  bool event = false, floquet = false;
  std::string reference = "own";
  double anchor_weight = 1.0, reference_filter = 1.0, overspeed_latch = 0.0;
};

int ParseOptions(int argc, char** argv, Options* o) {
  CLI::App cli{"ddoc-hop-experiment: Algorithm 1, mRL or OC-FB hop after hop on the analytic "
               "hopper (no MuJoCo)."};
  cli.add_option("--speed", o->speed, "forward speed of the nominal gait, m/s")
      ->check(CLI::NonNegativeNumber);
  cli.add_option("--method", o->method, "alg1 | ocfb | mrl");
  cli.add_option("--hops", o->hops, "hops")->check(CLI::PositiveNumber);
  cli.add_option("--warmup", o->warmup, "hops run with u^0 first; the last initializes (>= 1)")
      ->check(CLI::PositiveNumber);
  cli.add_option("--model-M", o->model_mass, "model mass, kg")->check(CLI::PositiveNumber);
  cli.add_option("--model-cd", o->model_drag, "model drag c_d, kg/m")
      ->check(CLI::NonNegativeNumber);
  cli.add_option("--plant-M", o->plant_mass, "plant mass, kg (default: the model's)")
      ->check(CLI::PositiveNumber);
  cli.add_option("--plant-cd", o->plant_drag, "plant drag c_d, kg/m (default: the model's)")
      ->check(CLI::NonNegativeNumber);
  cli.add_option("--model-b-hip", o->model_b_hip, "model hip damper b_hip, N m s/rad")
      ->check(CLI::NonNegativeNumber);
  cli.add_option("--plant-b-hip", o->plant_b_hip,
                 "plant hip damper b_hip, N m s/rad (default: the model's)")
      ->check(CLI::NonNegativeNumber);
  cli.add_option("--plant-slope", o->plant_slope,
                 "plant floor slope, rad, > 0 rises in +x (HopperParams::slope; down hill < 0); "
                 "the model's floor stays level (default 0)");
  cli.add_option("--pert", o->perturbation,
                 "initial perturbation p: xd += p, phi += p/5, phid += p");
  cli.add_option("--push-hop", o->push_hop, "add --push-dv to xd at the start of this hop");
  cli.add_option("--push-dv", o->push_dv, "m/s");
  cli.add_option("--cyclic", o->cyclic, "BackwardPassSettings::cyclic_value")
      ->check(CLI::Range(0.0, 1.0));
  cli.add_flag("--event", o->event, "BackwardPassSettings::terminal_event");
  cli.add_option("--reference", o->reference, "I1 reference of the learner: own | gait")
      ->check(CLI::IsMember({"own", "gait"}));
  cli.add_option("--anchor-weight", o->anchor_weight,
                 "with --reference gait: w of the learner's I1 reference w x_gait + (1 - w) x(0) "
                 "(ControllerConfig::anchor_weight, default 1)")
      ->check(CLI::Range(0.0, 1.0));
  cli.add_option("--reference-filter", o->reference_filter,
                 "with --anchor-weight < 1: the gain b in (0, 1] of the filtered own start "
                 "(ControllerConfig::reference_filter, default 1)")
      ->check(CLI::Range(0.0, 1.0));
  cli.add_option("--overspeed-latch", o->overspeed_latch,
                 "with --anchor-weight < 1 and --reference-filter < 1: the gait's reference from "
                 "the first hop that starts faster than the gait by more than this, m/s "
                 "(ControllerConfig::overspeed_latch, default 0 = never)")
      ->check(CLI::NonNegativeNumber);
  cli.add_flag("--floquet", o->floquet, "eigenvalues of u^0's return map on the plant");
  cli.add_option("--newton", o->newton, "Newton steps to u^0's fixed point first (--floquet)")
      ->check(CLI::NonNegativeNumber);
  try {
    cli.parse(argc, argv);
    ParseMethod(o->method);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  } catch (const ScenarioError& e) {
    std::fprintf(stderr, "ddoc-hop-experiment: --method: %s\n", e.what());
    return 2;
  }
  if (o->reference != "gait" &&
      (o->anchor_weight != 1.0 || o->reference_filter != 1.0 || o->overspeed_latch != 0.0)) {
    std::fprintf(stderr, "ddoc-hop-experiment: --anchor-weight, --reference-filter and "
                         "--overspeed-latch need --reference gait\n");
    return 2;
  }
  if (o->overspeed_latch > 0.0 && !(o->anchor_weight < 1.0 && o->reference_filter < 1.0)) {
    std::fprintf(stderr, "ddoc-hop-experiment: --overspeed-latch needs --anchor-weight < 1 and "
                         "--reference-filter < 1 (a reference that moves)\n");
    return 2;
  }
  if (!(o->reference_filter > 0.0)) {
    std::fprintf(stderr, "ddoc-hop-experiment: --reference-filter %g: expected in (0, 1]\n",
                 o->reference_filter);
    return 2;
  }
  if (o->plant_mass < 0) o->plant_mass = o->model_mass;
  if (o->plant_drag < 0) o->plant_drag = o->model_drag;
  if (o->plant_b_hip < 0) o->plant_b_hip = o->model_b_hip;
  return -1;
}

// The model, the plant (a model of other parameters), the problem, the gait and u^0.
class Experiment {
 public:
  explicit Experiment(const Options& o);
  void RunHops();   // the hops, one CSV line each
  void Floquet();   // --floquet

 private:
  static HopperParams Params(double mass, double drag, double b_hip, double slope = 0.0) {
    HopperParams p;
    p.M = mass;
    p.c_d = drag;
    p.b_hip = b_hip;
    p.slope = slope;
    return p;
  }
  // The takeoff state of the next hop from a measured hop (foot at x = 0).
  Vector NextStart(const Trajectory& hop) const {
    State x;
    truth_.TakeoffMap(hop.modes[1].x.rightCols(1), 0.0, x);
    return x;
  }

  const Options& o_;
  HopperModel model_, truth_;
  HopperCost cost_;
  Problem problem_;
  ModelPlant model_plant_, plant_;
  HopperPredictionPlant prediction_{&model_plant_};
  NominalGait gait_;
  OnlineController u0_;
  Vector x_end_;  // the start state of the hop after the run
  bool survived_ = false;
};

Experiment::Experiment(const Options& o)
    : o_(o),
      model_(Params(o.model_mass, o.model_drag, o.model_b_hip)),
      truth_(Params(o.plant_mass, o.plant_drag, o.plant_b_hip, o.plant_slope)),
      cost_(model_),
      problem_(HopperProblem(model_, cost_)),
      model_plant_(problem_),
      plant_(truth_, problem_.bounds) {
  model_plant_.set_guard([this](int k, const ConstVectorRef& x, const ConstVectorRef& u) {
    return model_.Guard(k, x, u);
  });
  plant_.set_guard([this](int k, const ConstVectorRef& x, const ConstVectorRef& u) {
    return truth_.Guard(k, x, u);
  });
  NominalGaitSettings gs;
  gs.forward_speed = o.speed;
  gait_ = FindNominalGait(model_.params(), gs);
  LearnerSettings ls = HopperModelSolveSettings();
  ls.backward.cyclic_value = o.cyclic;
  ls.backward.terminal_event = o.event;
  Learner model_learner(problem_, ls);
  const SolveResult r = SolveFromGait(model_learner, model_plant_, &cost_, gait_);
  std::fprintf(stderr, "# gait apex %.3f stance %.3f; OC-FB on the model: %d iterations, %d trials, "
               "cost %.4f -> %.4f, status %s\n", gait_.apex, gait_.stance_time, r.iterations,
               r.trials, r.cost_history.front(), r.cost, LearnerStatusName(r.status));
  u0_ = model_learner.ConvergedPolicy(0.0);
}

void Experiment::RunHops() {
  TrialDriverSettings ds = HopperTrialSettings();
  ds.method = ParseMethod(o_.method);
  ds.warmup_trials = o_.warmup;
  ds.learner.backward.cyclic_value = o_.cyclic;
  ds.learner.backward.terminal_event = o_.event;
  const Vector anchor = o_.reference == "gait" ? Vector(gait_.x0) : Vector();
  // A reference that moves between hops: the nominal is compared under the present one (as the
  // plugin's controller does).
  if (HopperReferenceMoves(anchor, o_.anchor_weight, o_.reference_filter)) {
    ds.learner.reference_shift = true;
  }
  TrialDriver driver(problem_, ds, u0_, ds.method == Method::kMrl ? &prediction_ : nullptr,
                     HopperCostReference(&cost_, anchor, o_.anchor_weight, o_.reference_filter,
                                         o_.overspeed_latch));
  Vector x0 = gait_.x0;
  x0(hopper::kXd) += o_.perturbation;
  x0(hopper::kPhi) += o_.perturbation / 5;
  x0(hopper::kPhid) += o_.perturbation;
  std::printf("hop,cost,i1,T1,T2,theta0,phi0,xd0,yd0,alpha,accepted,learner_cost\n");
  Trajectory hop;
  int survived = 0;
  for (int i = 0; i < o_.hops; ++i) {
    if (i == o_.push_hop) x0(hopper::kXd) += o_.push_dv;
    const double alpha = driver.learned_law() ? driver.learned_law()->alpha() : 0.0;
    const TrialOutcome out = driver.RunTrial(plant_, x0, &hop);
    cost_.SetReference(hop.x0);  // the reported cost: (42) against the hop's own start
    const CostBreakdown cb = EvaluateCost(problem_, hop);
    std::printf("%d,%.5f,%.5f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4g,%d,%.5f\n", i, cb.total,
                cb.switching(1), hop.T(0), hop.T(1), x0(hopper::kTheta), x0(hopper::kPhi),
                x0(hopper::kXd), x0(hopper::kYd), alpha, out.accepted ? 1 : 0, out.cost);
    x0 = NextStart(hop);
    const bool fell = std::abs(x0(hopper::kPhi)) > 1.0 || std::abs(x0(hopper::kTheta)) > 1.0 ||
                      !(x0(hopper::kY) > 0.3) || !std::isfinite(cb.total) || cb.total > 1e3;
    if (fell) {
      std::fprintf(stderr, "# hop %d: fell or diverged (phi %.3f theta %.3f y %.3f cost %.3g)\n",
                   i, x0(hopper::kPhi), x0(hopper::kTheta), x0(hopper::kY), cb.total);
      break;
    }
    ++survived;
  }
  std::fprintf(stderr, "# survived %d/%d hops\n", survived, o_.hops);
  x_end_ = x0;
  survived_ = survived == o_.hops;
}

void Experiment::Floquet() {
  const std::function<Vector(const Vector&)> map = [this](const Vector& x) {
    Trajectory t;
    plant_.Run(x, u0_, &t);
    return NextStart(t);
  };
  Vector x = survived_ ? x_end_ : Vector(gait_.x0);
  for (int it = 0; it < o_.newton; ++it) {  // Newton steps to the fixed point x = map(x)
    const Matrix A = CentralDifferenceJacobian(map, x) - Matrix::Identity(14, 14);
    x -= A.completeOrthogonalDecomposition().solve(map(x) - x);
    std::fprintf(stderr, "# newton %d: |map(x) - x| = %.3g\n", it, (map(x) - x).norm());
  }
  Eigen::EigenSolver<Matrix> es(CentralDifferenceJacobian(map, x));
  std::vector<std::complex<double>> ev(es.eigenvalues().data(), es.eigenvalues().data() + 14);
  std::sort(ev.begin(), ev.end(), [](auto a, auto b) { return std::abs(a) > std::abs(b); });
  std::fprintf(stderr, "# return-map eigenvalues of u^0 (largest first):");
  for (const auto& e : ev) {
    if (std::abs(e) > 0.05) std::fprintf(stderr, " (%.3f%+.3fi)", e.real(), e.imag());
  }
  std::fprintf(stderr, "\n# at theta %.4f phi %.4f xd %.4f yd %.4f; |map(x) - x| = %.3g\n",
               x(hopper::kTheta), x(hopper::kPhi), x(hopper::kXd), x(hopper::kYd),
               (map(x) - x).norm());
}

}  // namespace
}  // namespace ddoc::app

int main(int argc, char** argv) {
  ddoc::app::Options o;
  const int parsed = ddoc::app::ParseOptions(argc, argv, &o);
  if (parsed >= 0) return parsed;
  try {
    ddoc::app::Experiment experiment(o);
    experiment.RunHops();
    if (o.floquet) experiment.Floquet();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ddoc-hop-experiment: %s\n", e.what());
    return 2;
  }
  return 0;
}
