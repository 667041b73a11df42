// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ddoc-hop-experiment: hop-after-hop closed-loop experiments on the ANALYTIC hopper, to measure
// what makes forward hopping stable before going to MuJoCo. One hop = one trial, started at
// takeoff; the next hop starts at the measured takeoff state of the previous one (the cycle
// reset), exactly as on the robot.
//
//   --method ocfb   : solve OC-FB on the model (Learner::Solve), then apply ConvergedPolicy(alpha)
//                     unchanged hop after hop on the plant (which may differ from the model).
//   --method alg1   : hop 0 runs the OC-FB law, then incremental Algorithm 1 (NextTrial /
//                     CompleteTrial) on the plant, each hop one trial.
//   --floquet       : eigenvalues of the OC-FB closed-loop return map (takeoff -> takeoff) at the
//                     state reached after the run (finite differences).
// Output: one line per hop on stdout (CSV), a summary on stderr.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>

#include <Eigen/Eigenvalues>

#include "ddoc/cost.h"
#include "ddoc/hopper/hopper_cost.h"
#include "ddoc/hopper/hopper_model.h"
#include "ddoc/hopper/nominal_gait.h"
#include "ddoc/learner.h"
#include "ddoc/plant.h"

using namespace ddoc;

namespace {

struct Args {
  std::map<std::string, std::string> kv;
  double Get(const std::string& k, double d) const {
    auto it = kv.find(k);
    return it == kv.end() ? d : std::atof(it->second.c_str());
  }
  std::string Str(const std::string& k, const std::string& d) const {
    auto it = kv.find(k);
    return it == kv.end() ? d : it->second;
  }
  bool Has(const std::string& k) const { return kv.count(k) > 0; }
};

const char* kUsage =
    "ddoc-hop-experiment [--key value]...\n"
    "  --speed 0.5          gait forward speed (m/s)\n"
    "  --method ocfb|alg1   (ocfb)\n"
    "  --hops 100           closed-loop hops\n"
    "  --solve-trials 50    OC-FB model solve trials (0: the constant-input gait is the nominal)\n"
    "  --reg 0.1            OnlineControllerSettings::regularization (model solve and robot)\n"
    "  --riccati 0|1|2      BackwardPassSettings::equation: 0 kLyapunov (paper), 1 kRiccatiFeedback,\n"
    "                       2 kRiccati (mu = --reg)\n"
            "  --stance-open-loop 0|1  experiment: nominal inputs in stance, feedback in flight only\n"
    "  --stance-phase 0|1   experiment: stance tau from the leg spring phase, not the clock\n"
    "  --flight-phase 0|1   experiment: flight tau = t / (t + ballistic time to the nominal TD height)\n"
    "  --alpha-ff 0|1       alpha on the feed-forward only (1) or on all of b (0, the paper)\n"
    "  --ocfb-alpha 0       alpha of ConvergedPolicy\n"
    "  --c 1e-7 --gamma 0.5 --grow 0|1 --alpha0 1   Algorithm 1 line search\n"
    "  --reference own|nominal  x_ref of I1 for the learner on the plant\n"
    "  --q-y 0 --q-yd 10    I1 weights of y and yd (experiment; Fig. 2: 0, 10)\n"
    "  --cyclic 0           BackwardPassSettings::cyclic_value (periodic Riccati value)\n"
    "  --event 0|1          BackwardPassSettings::terminal_event (projected terminal cost)\n"
    "  --rebaseline 0 --isc 0   LearnerSettings::rebaseline_after, initial_state_correction\n"
    "  --kfb 1              OnlineControllerSettings::feedback_scale\n"
    "  --own-start 0|1      re-run (30) with I1's x(0) = the next hop's measured takeoff state\n"
    "  --model-M 10 --model-cd 0 --plant-M 10 --plant-cd 0\n"
    "  --pert 0.05          initial perturbation: xd += p, phi += p/5, phid += p\n"
    "  --push-hop -1 --push-dv 0   add dv to xd at the start of that hop\n"
    "  --floquet 0|1        return-map eigenvalues of the OC-FB law\n";

// Experiment: the law of `inner` in flight, only the nominal inputs (open loop) in stance.
class FlightFeedbackOnly : public Policy {
 public:
  FlightFeedbackOnly(Policy* inner, const Trajectory& nominal) : inner_(inner), open_(nominal) {}
  void BeginTrial() override {
    inner_->BeginTrial();
    open_.BeginTrial();
  }
  double PlannedDuration(int k) const override { return inner_->PlannedDuration(k); }
  void Step(int k, double t, const ConstVectorRef& x, VectorRef u) override {
    if (k == 0) {
      inner_->Step(k, t, x, u);
    } else {
      open_.Step(k, t, x, u);
    }
  }

 private:
  Policy* inner_;
  OpenLoopPolicy open_;
};

// Experiment: stance time from the leg's spring phase instead of the clock. The phase
// psi = atan2(r0 - r, -rd / w) (0 at touchdown, pi/2 at maximum compression, pi at takeoff for a
// spring-mass stance) is tabulated along the nominal's stance samples; the measured psi (kept
// monotone) is looked up in that table and gives the normalized stance progress, which is passed
// to the inner policy as the time since touchdown. Flight keeps the clock.
class StancePhaseTime : public Policy {
 public:
  StancePhaseTime(Policy* inner, const Trajectory& nominal, double r0, bool stance, bool flight,
                  double g)
      : inner_(inner), r0_(r0), stance_(stance), flight_(flight), g_(g) {
    const ModeTrajectory& fl = nominal.modes[0];
    y_td_ = fl.x(hopper::kY, fl.num_samples() - 1);
    const ModeTrajectory& st = nominal.modes[1];
    const int N = st.num_samples();
    const double D = nominal.T(1) - nominal.T(0);
    w_ = M_PI / D;
    psi_.resize(N);
    s_.resize(N);
    double run = -1e9;
    for (int j = 0; j < N; ++j) {
      run = std::max(run, Psi(st.x(hopper::kSR, j), st.x(hopper::kSRd, j)));
      psi_(j) = run;
      s_(j) = (st.t(j) - nominal.T(0)) / D;
    }
  }
  void BeginTrial() override {
    inner_->BeginTrial();
    best_ = -1e9;
  }
  double PlannedDuration(int k) const override { return inner_->PlannedDuration(k); }
  void Step(int k, double t, const ConstVectorRef& x, VectorRef u) override {
    if (k == 0) {
      if (!flight_) {
        inner_->Step(k, t, x, u);
        return;
      }
      // Ballistic prediction of the remaining flight time to the nominal touchdown height.
      const double y = x(hopper::kY), yd = x(hopper::kYd);
      const double disc = yd * yd + 2 * g_ * std::max(0.0, y - y_td_);
      const double rem = (yd + std::sqrt(disc)) / g_;
      const double frac = t + rem > 0 ? t / (t + rem) : 1.0;
      inner_->Step(k, frac * inner_->PlannedDuration(k), x, u);
      return;
    }
    if (!stance_) {
      inner_->Step(k, t, x, u);
      return;
    }
    best_ = std::max(best_, Psi(x(hopper::kSR), x(hopper::kSRd)));
    const int N = static_cast<int>(psi_.size());
    double s = 1.0;
    if (best_ <= psi_(0)) {
      s = 0.0;
    } else {
      for (int j = 1; j < N; ++j) {
        if (psi_(j) >= best_) {
          const double span = psi_(j) - psi_(j - 1);
          const double w = span > 0 ? (best_ - psi_(j - 1)) / span : 1.0;
          s = s_(j - 1) + w * (s_(j) - s_(j - 1));
          break;
        }
      }
    }
    inner_->Step(k, s * inner_->PlannedDuration(k), x, u);
  }

 private:
  double Psi(double r, double rd) const { return std::atan2(r0_ - r, -rd / w_); }
  Policy* inner_;
  double r0_;
  bool stance_, flight_;
  double g_, y_td_ = 0, w_ = 1, best_ = 0;
  Vector psi_, s_;
};

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    std::string k = argv[i];
    if (k == "--help" || k == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (k.rfind("--", 0) != 0 || i + 1 >= argc) {
      std::fprintf(stderr, "bad argument '%s'\n%s", k.c_str(), kUsage);
      return 2;
    }
    a.kv[k.substr(2)] = argv[++i];
  }
  const double speed = a.Get("speed", 0.5);
  const std::string method = a.Str("method", "ocfb");
  const int hops = static_cast<int>(a.Get("hops", 100));
  const std::string reference = a.Str("reference", "own");

  HopperParams mp;
  mp.M = a.Get("model-M", 10);
  mp.c_d = a.Get("model-cd", 0);
  HopperParams pp;
  pp.M = a.Get("plant-M", mp.M);
  pp.c_d = a.Get("plant-cd", mp.c_d);
  HopperModel model(mp), truth(pp);
  HopperCostWeights weights;
  weights.q_diag(hopper::kY) = a.Get("q-y", weights.q_diag(hopper::kY));
  weights.q_diag(hopper::kYd) = a.Get("q-yd", weights.q_diag(hopper::kYd));
  HopperCost cost(model, weights);
  Problem pr;
  pr.system = &model;
  pr.cost = &cost;
  pr.bounds.u_min = hopper::InputLowerBound();
  pr.bounds.u_max = hopper::InputUpperBound();
  pr.bounds.duration_min = Eigen::Vector2d(0.05, 0.05);
  pr.bounds.duration_max = Eigen::Vector2d(1.5, 1.0);
  pr.surface_weights = Eigen::Vector2d(kHopperSurfaceWeight, 0);

  NominalGaitSettings gs;
  gs.forward_speed = speed;
  const NominalGait g = FindNominalGait(mp, gs);
  cost.SetReference(g.x0);
  std::fprintf(stderr, "# gait u0 %.4f %.4f %.2f %.2f x0 theta %.4f phi %.4f yd %.4f thetad %.4f phid %.4f apex %.3f stance %.3f\n",
               g.u0(0), g.u0(1), g.u0(2), g.u0(3), g.x0(hopper::kTheta), g.x0(hopper::kPhi),
               g.x0(hopper::kYd), g.x0(hopper::kThetad), g.x0(hopper::kPhid), g.apex, g.stance_time);

  ModelPlant mplant(pr);
  mplant.set_guard(
      [&](int k, const ConstVectorRef& x, const ConstVectorRef& u) { return model.Guard(k, x, u); });
  ModelPlant plant(truth, pr.bounds);
  plant.set_guard(
      [&](int k, const ConstVectorRef& x, const ConstVectorRef& u) { return truth.Guard(k, x, u); });

  LearnerSettings ls;
  ls.c = a.Get("c", 1e-7);
  ls.gamma = a.Get("gamma", 0.5);
  ls.alpha_initial = a.Get("alpha0", 1.0);
  ls.alpha_min = std::min(1e-6, 0.5 * ls.alpha_initial);
  ls.reset_alpha_on_accept = a.Get("grow", 1) == 0;
  ls.controller.alpha_scales_feedback = a.Get("alpha-ff", 1) == 0;
  ls.controller.regularization = a.Get("reg", 0.1);
  ls.controller.feedback_scale = a.Get("kfb", 1.0);
  ls.backward.cyclic_value = a.Get("cyclic", 0.0);
  ls.backward.terminal_event = a.Get("event", 0) != 0;
  ls.rebaseline_after = static_cast<int>(a.Get("rebaseline", 0));
  ls.initial_state_correction = a.Get("isc", 0) != 0;
  const int riccati = static_cast<int>(a.Get("riccati", 0));
  if (riccati == 1) ls.backward.equation = BackwardEquation::kRiccatiFeedback;
  if (riccati == 2) ls.backward.equation = BackwardEquation::kRiccati;
  ls.backward.psd_switching_hessians = a.Get("psd", 1) != 0;
  ls.backward.riccati_regularization = ls.controller.regularization;
  ls.max_trials = std::max(1, static_cast<int>(a.Get("solve-trials", 50)));
  const bool solve = a.Get("solve-trials", 50) > 0;

  Learner ocfb(pr, ls);
  const Eigen::Vector2d D(g.T0(0), g.T0(1) - g.T0(0));
  const Eigen::Vector4d u0 = g.u0;
  FunctionPolicy init(D, [u0](int, double, const ConstVectorRef&, VectorRef u) { u = u0; });
  if (solve) {
    SolveResult r = ocfb.Solve(mplant, mplant, g.x0, init);
    std::fprintf(stderr, "# gait I1 %.4g T %.3f %.3f; OC-FB solve status %d iters %d trials %d cost %.4f -> %.4f\n",
                 g.periodicity, g.T0(0), g.T0(1), static_cast<int>(r.status), r.iterations,
                 r.trials, r.cost_history.front(), r.cost);
  } else {
    Trajectory t0;
    mplant.Run(g.x0, init, &t0);
    ocfb.Initialize(t0);
    std::fprintf(stderr, "# gait I1 %.4g, nominal = constant-input gait, cost %.4f\n",
                 g.periodicity, ocfb.nominal_cost());
  }
  const double ocfb_alpha = a.Get("ocfb-alpha", 0.0);

  // Takeoff state of the next hop from a measured hop (foot at x = 0).
  auto next_x0 = [&](const Trajectory& tr) {
    Eigen::Matrix<double, 14, 1> xn;
    truth.TakeoffMap(tr.modes[1].x.rightCols(1), 0.0, xn);
    return Vector(xn);
  };
  auto hop_cost = [&](const Trajectory& tr) {
    cost.SetReference(tr.x0);
    return EvaluateCost(pr, tr);
  };

  Vector x0 = g.x0;
  const double pert = a.Get("pert", 0.05);
  x0(hopper::kXd) += pert;
  x0(hopper::kPhi) += pert / 5;
  x0(hopper::kPhid) += pert;
  const int push_hop = static_cast<int>(a.Get("push-hop", -1));
  const double push_dv = a.Get("push-dv", 0.0);

  std::unique_ptr<Learner> learner;
  if (method == "alg1") learner = std::make_unique<Learner>(pr, ls);
  std::printf("hop,cost,i1,T1,T2,theta0,phi0,xd0,yd0,alpha,accepted,nominal_cost\n");
  Trajectory tr;
  int survived = 0;
  double last_cost = 0, min_cost = 1e300;
  for (int hop = 0; hop < hops; ++hop) {
    if (hop == push_hop) x0(hopper::kXd) += push_dv;
    OnlineController* pol = nullptr;
    if (method == "ocfb" || hop == 0) {
      cost.SetReference(g.x0);
      pol = &ocfb.ConvergedPolicy(ocfb_alpha);
    } else {
      pol = &learner->NextTrial();
    }
    std::unique_ptr<FlightFeedbackOnly> wrap;
    std::unique_ptr<StancePhaseTime> phase;
    Policy* run = pol;
    if (a.Get("stance-phase", 0) != 0 || a.Get("flight-phase", 0) != 0) {
      phase = std::make_unique<StancePhaseTime>(
          pol, method == "ocfb" || hop == 0 ? ocfb.nominal() : learner->nominal(), mp.r0,
          a.Get("stance-phase", 0) != 0, a.Get("flight-phase", 0) != 0, mp.g);
      run = phase.get();
    }
    if (a.Get("stance-open-loop", 0) != 0) {
      wrap = std::make_unique<FlightFeedbackOnly>(
          run, method == "ocfb" || hop == 0 ? ocfb.nominal() : learner->nominal());
      run = wrap.get();
    }
    try {
      plant.Run(x0, *run, &tr);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "# hop %d: plant failed: %s\n", hop, e.what());
      break;
    }
    const CostBreakdown cb = hop_cost(tr);
    double alpha = pol->alpha();
    int accepted = 1;
    double ncost = cb.total;
    if (learner) {
      if (reference == "nominal") cost.SetReference(g.x0);
      else cost.SetReference(tr.x0);
      if (hop == 0) {
        learner->Initialize(tr);
      } else {
        TrialResult r = learner->CompleteTrial(tr);
        accepted = r.accepted;
        ncost = learner->nominal_cost();
      }
    }
    std::printf("%d,%.5f,%.5f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4g,%d,%.5f\n", hop, cb.total,
                cb.switching(1), tr.T(0), tr.T(1), x0(hopper::kTheta), x0(hopper::kPhi),
                x0(hopper::kXd), x0(hopper::kYd), alpha, accepted, ncost);
    x0 = next_x0(tr);
    if (learner && a.Get("own-start", 0) != 0) {
      // I1's x(0) of the next trial is its measured takeoff state: re-run (30) with it.
      cost.SetReference(x0);
      learner->RecomputeDirection();
    }
    const bool fell = std::abs(x0(hopper::kPhi)) > 1.0 || std::abs(x0(hopper::kTheta)) > 1.0 ||
                      !(x0(hopper::kY) > 0.3) || !std::isfinite(cb.total) || cb.total > 1e3;
    if (fell) {
      std::fprintf(stderr, "# hop %d: fell / diverged (phi %.3f theta %.3f y %.3f cost %.3g)\n",
                   hop, x0(hopper::kPhi), x0(hopper::kTheta), x0(hopper::kY), cb.total);
      break;
    }
    ++survived;
    last_cost = cb.total;
    min_cost = std::min(min_cost, cb.total);
  }
  std::fprintf(stderr, "# survived %d/%d hops, last cost %.4f, min %.4f, final theta0 %.4f xd0 %.4f\n",
               survived, hops, last_cost, min_cost, x0(hopper::kTheta), x0(hopper::kXd));

  if (a.Get("floquet", 0) != 0) {
    // Return map of the OC-FB law at the current state (finite differences, all 14 entries).
    cost.SetReference(g.x0);
    OnlineController& pol = ocfb.ConvergedPolicy(ocfb_alpha);
    auto map = [&](const Vector& x) {
      Trajectory t;
      plant.Run(x, pol, &t);
      return next_x0(t);
    };
    Vector xs = survived == hops ? x0 : Vector(g.x0);
    const double h = 1e-6;
    Matrix J(14, 14);
    auto jacobian = [&]() {
      for (int i = 0; i < 14; ++i) {
        Vector xp = xs, xm = xs;
        xp(i) += h;
        xm(i) -= h;
        J.col(i) = (map(xp) - map(xm)) / (2 * h);
      }
    };
    // --newton N: N Newton steps towards the law's fixed point (periodic orbit) on the plant.
    for (int it = 0; it < static_cast<int>(a.Get("newton", 0)); ++it) {
      jacobian();
      const Vector r = map(xs) - xs;
      const Matrix A = J - Matrix::Identity(14, 14);
      xs -= A.completeOrthogonalDecomposition().solve(r);
      std::fprintf(stderr, "# newton %d: |map(x)-x| = %.3g\n", it, (map(xs) - xs).norm());
    }
    if (a.Get("newton", 0) > 0) {
      std::fprintf(stderr, "# fixed point: theta %.4f phi %.4f xd %.4f yd %.4f thetad %.4f phid %.4f\n",
                   xs(hopper::kTheta), xs(hopper::kPhi), xs(hopper::kXd), xs(hopper::kYd),
                   xs(hopper::kThetad), xs(hopper::kPhid));
    }
    jacobian();
    Eigen::EigenSolver<Matrix> es(J);
    std::fprintf(stderr, "# eigenvalues:");
    for (int i = 0; i < 14; ++i) {
      const auto e = es.eigenvalues()(i);
      if (std::abs(e) > 0.05) std::fprintf(stderr, " (%.3f%+.3fi)", e.real(), e.imag());
    }
    std::fprintf(stderr, "\n");
    std::fprintf(stderr, "# return-map |eigenvalues|:");
    Vector mags = es.eigenvalues().cwiseAbs();
    std::sort(mags.data(), mags.data() + mags.size(), std::greater<double>());
    for (int i = 0; i < 14; ++i) std::fprintf(stderr, " %.3f", mags(i));
    std::fprintf(stderr, "\n# fixed-point residual |map(x)-x| = %.3g\n", (map(xs) - xs).norm());
  }
  return 0;
}
