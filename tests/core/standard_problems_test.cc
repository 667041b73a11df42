// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The public suite of standard problems (standard_problems.h):
//   (a) every reference optimum, recomputed here without the engine and justified by checks of
//       its own (central-difference gradients of an independent cost ~ 0, a second method,
//       published values where they exist, dense searches), and the gap between the
//       continuous optimum and what the plant's discretization (dt = 1e-3 s) can reach;
//   (b) the engine as a user runs it (`LearnerSettings settings;`, the exact model as the
//       plant) must reach every reference within 1e-3 relative cost and 1e-3 s in every
//       switching instant, in at most 30 trials (60 with active input bounds): the target of
//       issue 17. These tests fail until the engine meets it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/check_derivatives.h"
#include "ddoc/learner.h"
#include "ddoc/plant.h"
#include "standard_problems.h"
#include "standard_references.h"

namespace ddoc {
namespace testing {
namespace {

// The scalar input u(k, t) of every mode held on a grid of n intervals per mode at its interval
// midpoints (the last sample holds the value at the mode's end), for HeldInputCost.
std::vector<HeldInputs> HeldMidpointInputs(const std::function<double(int, double)>& u,
                                           const Vector& T, int n) {
  std::vector<HeldInputs> modes(static_cast<size_t>(T.size()));
  for (int k = 0; k < T.size(); ++k) {
    HeldInputs& mode = modes[static_cast<size_t>(k)];
    mode.t = Vector::LinSpaced(n + 1, k == 0 ? 0.0 : T(k - 1), T(k));
    mode.u.resize(1, n + 1);
    for (int j = 0; j <= n; ++j) mode.u(0, j) = u(k, j < n ? 0.5 * (mode.t(j) + mode.t(j + 1)) : T(k));
  }
  return modes;
}

constexpr double kInf = std::numeric_limits<double>::infinity();

double RelativeError(double value, double reference) {
  return std::abs(value - reference) / std::abs(reference);
}

// Free instants tau = T_0..T_{K-2} <-> all instants.
Vector Free(const Vector& T) { return T.head(T.size() - 1); }
Vector WithFinal(const Vector& tau, double tf) {
  Vector T(tau.size() + 1);
  T << tau, tf;
  return T;
}

// The reference recomputed by the independent solvers agrees with the pinned numbers.
void ExpectPinned(const StandardProblem& sp, const ReferenceOptimum& r) {
  EXPECT_LT(RelativeError(r.cost, sp.reference_cost), 1e-9)
      << sp.name << ": recomputed " << r.cost << ", pinned " << sp.reference_cost;
  ASSERT_EQ(r.T.size(), sp.reference_T.size());
  EXPECT_LT((r.T - sp.reference_T).cwiseAbs().maxCoeff(), 1e-8)
      << sp.name << ": recomputed T " << r.T.transpose() << ", pinned "
      << sp.reference_T.transpose();
  EXPECT_TRUE(r.active_durations.empty()) << sp.name << ": a duration sits on its bound";
}

// Central-difference gradient of J over the free instants at T.
Vector FdGradient(const std::function<double(const Vector& T)>& J, const Vector& T, double h) {
  const double tf = T(T.size() - 1);
  return CentralDifferenceGradient([&](const Vector& tau) { return J(WithFinal(tau, tf)); },
                                   Free(T), h);
}

// ---------------------------------------------------------------------------------------------
// (a) Definitions and references.

TEST(StandardProblems, DefinitionsAreConsistent) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const std::vector<std::string> names = StandardProblemNames();
  ASSERT_GE(names.size(), 6u);
  int bounded = 0, unbounded = 0, no_input = 0, nonlinear_or_size = 0;
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    EXPECT_EQ(sp->name, name);
    EXPECT_FALSE(sp->citation.empty());
    const Problem& p = sp->problem;
    EXPECT_NO_THROW(p.Validate());
    const int K = sp->num_modes(), m = sp->input_dim();
    EXPECT_EQ(p.bounds.final_time_min, p.bounds.final_time_max);  // fixed final time
    ASSERT_EQ(sp->initial_durations.size(), K);
    EXPECT_NEAR(sp->initial_durations.sum(), sp->final_time(), 1e-12);
    ASSERT_EQ(sp->reference_T.size(), K);
    EXPECT_EQ(sp->reference_T(K - 1), sp->final_time());
    for (int k = 0; k < K; ++k) {
      const double d = sp->reference_T(k) - (k == 0 ? 0.0 : sp->reference_T(k - 1));
      if (p.bounds.duration_min(k) < p.bounds.duration_max(k)) {  // a free duration
        EXPECT_GE(d, p.bounds.duration_min(k) + 0.05) << "mode " << k << " near its bound";
      }
      EXPECT_GE(d, p.bounds.duration_min(k));
      EXPECT_LE(d, p.bounds.duration_max(k));
    }
    EXPECT_EQ(sp->x0.size(), sp->system->state_dim(0));
    if (m == 0) ++no_input;
    if (m > 0 && std::isinf(p.bounds.u_max(0))) ++unbounded;
    if (sp->bounds_active) ++bounded;
    if (name == "fishing" || name == "exp1" || name == "state_size_lq") ++nonlinear_or_size;

    // The ddoc definition and the independent model agree at random points; the hand-written
    // derivatives agree with central differences.
    const IndependentModel model = IndependentModelOf(*sp);
    ASSERT_EQ(model.num_modes, K);
    for (int k = 0; k < K; ++k) {
      for (int trial = 0; trial < 3; ++trial) {
        const int n = sp->system->state_dim(k);
        Vector x(n), u(m);
        for (int i = 0; i < n; ++i) x(i) = 1.5 * uniform(rng);
        for (int i = 0; i < m; ++i) u(i) = 3 * uniform(rng);
        Vector xdot(n);
        sp->system->Flow(k, x, u, xdot);
        EXPECT_LT((xdot - model.flow(k, x, u)).norm(), 1e-12) << "mode " << k;
        EXPECT_NEAR(sp->cost->Running(k, x, u), model.running(k, x, u), 1e-12);
        EXPECT_NEAR(sp->cost->Switching(k, x), model.switching(k, x), 1e-12);
        if (k + 1 < K) {
          Vector x_next(sp->system->state_dim(k + 1));
          sp->system->Reset(k, x, x_next);
          EXPECT_LT((x_next - model.reset(k, x)).norm(), 1e-12);
        }
        const DerivativeCheckReport report = CheckDerivatives(*sp->system, sp->cost.get(), k, x, u);
        EXPECT_TRUE(report.Passed(1e-6)) << "mode " << k << ": " << report.max_rel_error();
      }
    }
  }
  // What the suite must cover (issue 17).
  EXPECT_GE(bounded, 1);
  EXPECT_GE(unbounded, 1);
  EXPECT_GE(no_input, 1);
  EXPECT_GE(nonlinear_or_size, 3);
  const std::unique_ptr<StandardProblem> lqr = MakeStandardProblem("lqr");
  EXPECT_EQ(lqr->num_modes(), 1);
  const std::unique_ptr<StandardProblem> sized = MakeStandardProblem("state_size_lq");
  EXPECT_NE(sized->system->state_dim(0), sized->system->state_dim(1));
  EXPECT_GE(MakeStandardProblem("sto9_linear")->num_modes(), 3);
  EXPECT_THROW(MakeStandardProblem("no_such_problem"), InvalidArgument);
}

// lqr: the exponential of the Hamiltonian matrix, RK4 on the Riccati equation, a forward
// simulation of the resulting feedback, and for a long horizon the algebraic Riccati
// equation's closed form P = [sqrt3 1; 1 sqrt3] (double integrator, Q = I, R = 1).
TEST(StandardReferences, Lqr) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("lqr");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  const LinearQuadraticData d = LqrData();
  EXPECT_LT(RelativeError(LqOptimalCostRk4(d, r.T, 1e-3), r.cost), 1e-10);
  const double forward =
      FeedbackCost(IndependentModelOf(*sp), LqOptimalPolicy(d, r.T), d.x0, r.T, 1e-4);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-6) << forward;

  Matrix P_are(2, 2);
  P_are << std::sqrt(3.0), 1, 1, std::sqrt(3.0);
  EXPECT_LT((SolveContinuousAre(d.A[0], d.B[0], d.Q[0], d.R[0]) - P_are).norm(), 1e-12);
  LinearQuadraticData long_horizon = d;
  long_horizon.final_time = 30;
  const double J_long = LqOptimalCost(long_horizon, Vector::Constant(1, 30.0));
  EXPECT_LT(RelativeError(J_long, 0.5 * d.x0.dot(P_are * d.x0)), 1e-10);
  EXPECT_LT(RelativeError(LqOptimalCostRk4(long_horizon, Vector::Constant(1, 30.0), 1e-3),
                          J_long),
            1e-10);
}

// sto2_linear: SwitchTimeOpt.jl's test answer (tau* = 0.26486646235103123,
// J* = 5.2545429449272145, test/linsys.jl), the exact Gramian cost, RK4, and a zero gradient.
TEST(StandardReferences, Sto2LinearMatchesSwitchTimeOpt) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("sto2_linear");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  EXPECT_NEAR(r.T(0), 0.26486646235103123, 1e-6);
  EXPECT_NEAR(r.cost, 5.2545429449272145, 1e-9);
  const LinearQuadraticData d = StoLinearData(2);
  EXPECT_LT(RelativeError(LqOptimalCostRk4(d, r.T, 1e-3), r.cost), 1e-10);
  const Vector g = FdGradient([&](const Vector& T) { return LqOptimalCost(d, T); }, r.T, 1e-6);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-7) << g.transpose();
  EXPECT_GT(r.hessian_eigenvalues.minCoeff(), 1.0);
}

// sto9_linear: nine alternating modes; the exact cost, RK4, an independent forward
// simulation, a zero central-difference gradient and a positive definite Hessian.
TEST(StandardReferences, Sto9Linear) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("sto9_linear");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  const LinearQuadraticData d = StoLinearData(9);
  EXPECT_LT(RelativeError(LqOptimalCostRk4(d, r.T, 1e-3), r.cost), 1e-10);
  const double forward =
      FeedbackCost(IndependentModelOf(*sp), LqOptimalPolicy(d, r.T), d.x0, r.T, 1e-3);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-10);
  const Vector g = FdGradient([&](const Vector& T) { return LqOptimalCost(d, T); }, r.T, 1e-6);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-7) << g.transpose();
  EXPECT_GT(r.hessian_eigenvalues.minCoeff(), 0.1) << r.hessian_eigenvalues.transpose();
}

// fishing: RK4 at two step sizes, a zero central-difference gradient, a positive definite
// Hessian, the independent forward simulation.
TEST(StandardReferences, Fishing) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("fishing");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  const FishingData d = FishingProblemData(3);
  const double fine = FishingCost(d, r.T, StepCounts(r.T, 2.5e-4));
  EXPECT_LT(RelativeError(fine, r.cost), 1e-10) << fine;
  const Vector g = FdGradient(
      [&](const Vector& T) { return FishingCost(d, T, StepCounts(r.T, 1e-3)); }, r.T, 1e-6);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-7) << g.transpose();
  EXPECT_GT(r.hessian_eigenvalues.minCoeff(), 0.5) << r.hessian_eigenvalues.transpose();
  const double forward = FeedbackCost(IndependentModelOf(*sp),
                                      [](double, const Vector&) { return Vector(0); }, d.x0, r.T,
                                      1e-3);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-10);
}

// Why the suite's fishing problem has one fishing interval: SwitchTimeOpt.jl's published
// nine-mode answer (examples/fishing.jl, test/nonlinsys.jl, obtained on a linearization grid)
// is not a stationary point of the exact cost. Recomputed by our quadrature its cost is
// 0.674031 (published: 0.676181) and the gradient is ~1.7e-2; descending from it, the fourth
// fishing interval shrinks to the duration bound, and with three or four intervals the cost
// is nearly flat along some directions (smallest Hessian eigenvalue ~1e-3 or negative): no
// well-conditioned reference. With one interval the optimum is sharp (eigenvalues 1.2, 3.3).
TEST(StandardReferences, FishingPublishedNineModeAnswerIsNotStationary) {
  const FishingData d = FishingProblemData(9);
  Vector T(9);
  T << 2.421870213176088, 4.226321109572359, 4.849789536945512, 5.22645871837055,
      6.664835285791575, 6.788656479899535, 9.380548521585313, 9.404064767859301, 12.0;
  const std::vector<int> steps = StepCounts(T, 1e-3);
  const auto J = [&](const Vector& instants) { return FishingCost(d, instants, steps); };
  const double J_published = J(T);
  EXPECT_NEAR(J_published, 0.674031, 1e-6);
  EXPECT_NEAR(J_published, 0.676181302236232, 3e-3);  // the published value, 0.3 % off
  const Vector g = FdGradient(J, T, 1e-6);
  EXPECT_GT(g.cwiseAbs().maxCoeff(), 1e-2) << g.transpose();
}

// exp0: the exact LQ cost, Pontryagin shooting as a second method, OCS2's published answer
// (switch 0.1897, cost 9.766, ocs2_ddp/test/Exp0Test.cpp), zero gradients (central
// differences and the Hamiltonian jump), the forward simulation of the feedback law.
TEST(StandardReferences, Exp0) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  EXPECT_NEAR(r.T(0), 0.1897, 1e-4);
  EXPECT_NEAR(r.cost, 9.766, 1e-3);
  const LinearQuadraticData d = Exp0Data(kInf);
  EXPECT_LT(RelativeError(LqOptimalCostRk4(d, r.T, 1e-4), r.cost), 1e-10);
  const Vector g = FdGradient([&](const Vector& T) { return LqOptimalCost(d, T); }, r.T, 1e-6);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-6) << g.transpose();
  EXPECT_LT(LqSwitchingGradient(d, r.T).cwiseAbs().maxCoeff(), 1e-9);
  const ReferenceOptimum shooting = ShootingReference(ShootingFromLq(d), r.T, 0.01);
  EXPECT_NEAR(shooting.T(0), r.T(0), 1e-8);
  EXPECT_LT(RelativeError(shooting.cost, r.cost), 1e-9);
  const double forward =
      FeedbackCost(IndependentModelOf(*sp), LqOptimalPolicy(d, r.T), d.x0, r.T, 1e-4);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-6) << forward;
}

// exp0_bounded: shooting with the clamped minimizer (Pontryagin is sufficient here: linear
// dynamics, convex cost, convex input set); a finer step; zero gradients; the bound is active
// on a set of positive measure; the open-loop extremal input simulated forward reproduces the
// cost; a dense search over the switching instant finds nothing lower.
// Central differences (step 1e-5 s) of the extremal's cost w.r.t. the switching instants,
// each extremal solved from lambda0.
Vector ExtremalCostGradient(const ShootingProblem& p, const Vector& T, const Vector& lambda0) {
  return FdGradient(
      [&](const Vector& Tk) {
        const Extremal x = SolveExtremal(p, Tk, lambda0);
        return x.converged ? x.cost : kInf;
      },
      T, 1e-5);
}

TEST(StandardReferences, Exp0Bounded) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0_bounded");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  EXPECT_TRUE(sp->bounds_active);
  ShootingProblem p = ShootingFromLq(Exp0Data(kExp0InputBound));
  const Extremal e = SolveExtremal(p, r.T, r.lambda0);
  ASSERT_TRUE(e.converged);
  EXPECT_LT(std::abs(e.gradient(0)), 1e-8);
  const Vector g = ExtremalCostGradient(p, r.T, e.lambda0);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-6) << g.transpose();
  // The input is on its bound for > 10 % of the horizon.
  const auto u = ExtremalInput(p, r.T, e.lambda0);
  int on_bound = 0;
  const int samples = 2000;
  for (int i = 0; i < samples; ++i) {
    const double t = (i + 0.5) * 2.0 / samples;
    if (std::abs(u(t < r.T(0) ? 0 : 1, t)) >= kExp0InputBound - 1e-9) ++on_bound;
  }
  EXPECT_GT(on_bound, samples / 10);
  EXPECT_GT(r.cost, MakeStandardProblem("exp0")->reference_cost + 1.0);
  // Finer RK4 step.
  ShootingProblem fine = p;
  fine.step = 2.5e-4;
  const Extremal e_fine = SolveExtremal(fine, r.T, e.lambda0);
  EXPECT_LT(RelativeError(e_fine.cost, r.cost), 1e-9);
  EXPECT_LT(std::abs(e_fine.gradient(0)), 1e-6);
  // The extremal's input, held on a fine grid (midpoint values) and simulated independently
  // (open loop through an unstable system, eigenvalues up to 3/s: a fine grid).
  const auto u_fine = ExtremalInput(fine, r.T, e_fine.lambda0);
  const double forward =
      HeldInputCost(IndependentModelOf(*sp), p.x0, HeldMidpointInputs(u_fine, r.T, 8000), 1);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-8) << forward;
  // Dense search: the optimal cost for the switching instant on a 0.05 s grid.
  Vector lambda = e.lambda0;
  double best = kInf, best_t = 0;
  for (double t0 = r.T(0) - 0.25; t0 <= r.T(0) + 0.5; t0 += 0.05) {
    Vector T(2);
    T << t0, 2.0;
    const Extremal x = SolveExtremal(p, T, lambda);
    ASSERT_TRUE(x.converged) << "T0 = " << t0;
    lambda = x.lambda0;
    if (x.cost < best) {
      best = x.cost;
      best_t = t0;
    }
  }
  EXPECT_GE(best, r.cost);
  EXPECT_NEAR(best_t, r.T(0), 0.05);
}

// exp1: shooting at two step sizes, OCS2's published answer (switches 0.2262, 1.0176, cost
// 5.4399 within its test tolerance 1e-2, ocs2_ddp/test/Exp1Test.cpp), zero gradients, the
// forward simulation of the extremal's input, and the same optimum from the initial guess
// T^0 = (1, 2, 3) that the engine starts from.
TEST(StandardReferences, Exp1) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp1");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  EXPECT_NEAR(r.cost, 5.4399, 1e-2);
  EXPECT_NEAR(r.T(0), 0.2262, 5e-3);
  EXPECT_NEAR(r.T(1), 1.0176, 5e-3);
  ShootingProblem p = ShootingFromExp1(Exp1ProblemData());
  p.step = 2e-3;
  const Extremal e = SolveExtremal(p, r.T, r.lambda0);
  ASSERT_TRUE(e.converged);
  EXPECT_LT(e.gradient.cwiseAbs().maxCoeff(), 1e-8);
  const Vector g = ExtremalCostGradient(p, r.T, e.lambda0);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-6) << g.transpose();
  EXPECT_GT(r.hessian_eigenvalues.minCoeff(), 1.0);
  ShootingProblem fine = p;
  fine.step = 5e-4;
  const Extremal e_fine = SolveExtremal(fine, r.T, e.lambda0);
  EXPECT_LT(RelativeError(e_fine.cost, r.cost), 1e-9);
  EXPECT_LT(e_fine.gradient.cwiseAbs().maxCoeff(), 1e-6);
  // Forward simulation of the extremal's input (midpoint values held on a fine grid).
  const auto u = ExtremalInput(fine, r.T, e_fine.lambda0);
  const double forward =
      HeldInputCost(IndependentModelOf(*sp), p.x0, HeldMidpointInputs(u, r.T, 3000), 2);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-6) << forward;
  // From T^0 (coarser step: only the basin is checked here).
  ShootingProblem coarse = p;
  coarse.step = 4e-3;
  Vector T0(3);
  T0 << 1, 2, 3;
  const ReferenceOptimum from_guess = ShootingReference(coarse, T0, 0.01);
  EXPECT_LT((from_guess.T - r.T).cwiseAbs().maxCoeff(), 1e-4) << from_guess.T.transpose();
}

// state_size_lq: exact cost, RK4, zero gradients, forward simulation and a dense search over
// the switching instant.
TEST(StandardReferences, StateSizeLq) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("state_size_lq");
  const ReferenceOptimum r = ComputeReference(*sp);
  ExpectPinned(*sp, r);
  const LinearQuadraticData d = StateSizeData();
  EXPECT_LT(RelativeError(LqOptimalCostRk4(d, r.T, 1e-3), r.cost), 1e-10);
  const Vector g = FdGradient([&](const Vector& T) { return LqOptimalCost(d, T); }, r.T, 1e-6);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-7) << g.transpose();
  EXPECT_LT(LqSwitchingGradient(d, r.T).cwiseAbs().maxCoeff(), 1e-9);
  const double forward =
      FeedbackCost(IndependentModelOf(*sp), LqOptimalPolicy(d, r.T), d.x0, r.T, 1e-4);
  EXPECT_LT(RelativeError(forward, r.cost), 1e-6) << forward;
  double best = kInf, best_t = 0;
  for (double t0 = 0.01; t0 < 2.995; t0 += 0.01) {
    Vector T(2);
    T << t0, 3.0;
    const double J = LqOptimalCost(d, T);
    if (J < best) {
      best = J;
      best_t = t0;
    }
  }
  EXPECT_GE(best, r.cost);
  EXPECT_NEAR(best_t, r.T(0), 0.01);
}

// What the plant's discretization (ModelPlant: RK4 at dt = 1e-3 s, zero-order-hold inputs,
// steps landing on the switching instants) can reach, measured against the continuous
// references, so that the engine targets (1e-3 relative cost, 1e-3 s) are meaningful:
//   - LQ with inputs: the exact optimum over held inputs on the plant's grid (discrete
//     Riccati on the exactly discretized problem) and its optimal switching instant;
//   - no input: the cost on the plant's grid with trapezoidal quadrature, and the shift of the
//     optimum it implies to first order, dT = -H^-1 grad;
//   - bounded or nonlinear with input: an upper bound, the continuous optimal input averaged
//     over each of the plant's steps and held.
TEST(StandardReferences, DiscretizationGapAtThePlantStep) {
  const double dt = 1e-3;
  std::printf("%-14s %-34s %12s %12s\n", "problem", "measure", "rel. cost", "|dT| (s)");
  // LQ with inputs, exact over held inputs.
  for (const char* name : {"lqr", "exp0", "state_size_lq"}) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    const LinearQuadraticData d = std::string(name) == "lqr"    ? LqrData()
                                  : std::string(name) == "exp0" ? Exp0Data(kInf)
                                                                : StateSizeData();
    double J_zoh, dT = 0;
    if (sp->num_modes() == 1) {
      J_zoh = LqZeroOrderHoldOptimalCost(d, sp->reference_T, dt);
    } else {
      const ReferenceOptimum z = LqZeroOrderHoldReference(d, sp->reference_T(0) - 0.05,
                                                          sp->reference_T(0) + 0.05, dt);
      J_zoh = z.cost;
      dT = std::abs(z.T(0) - sp->reference_T(0));
    }
    const double gap = (J_zoh - sp->reference_cost) / sp->reference_cost;
    std::printf("%-14s %-34s %12.2e %12.2e\n", name, "optimal held inputs", gap, dT);
    EXPECT_GE(gap, -1e-12);  // holding can only cost more
    EXPECT_LT(gap, 1e-5);
    EXPECT_LT(dT, 1e-4);
  }
  // No input: the plant's grid and trapezoidal quadrature.
  for (const char* name : {"sto2_linear", "sto9_linear", "fishing"}) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    const IndependentModel model = IndependentModelOf(*sp);
    const Vector& T = sp->reference_T;
    const auto J_grid = [&](const Vector& instants) {
      return PlantGridTrapezoidCost(model, sp->x0, instants, dt);
    };
    const double gap = (J_grid(T) - sp->reference_cost) / sp->reference_cost;
    const Vector g = FdGradient(J_grid, T, 1e-5);
    // Hessian of the exact cost (the grid cost is only piecewise smooth: its last step in
    // each mode moves with T; the shift is first order anyway).
    const int N = static_cast<int>(g.size());
    Matrix H(N, N);
    const auto J_exact = [&](const Vector& instants) {
      if (std::string(name) == "fishing") {
        return FishingCost(FishingProblemData(3), instants, StepCounts(T, 1e-3));
      }
      return LqOptimalCost(StoLinearData(sp->num_modes()), instants);
    };
    for (int j = 0; j < N; ++j) {
      Vector tp = T, tm = T;
      tp(j) += 1e-4;
      tm(j) -= 1e-4;
      H.col(j) = (FdGradient(J_exact, tp, 1e-6) - FdGradient(J_exact, tm, 1e-6)) / 2e-4;
    }
    const Vector shift = -(0.5 * (H + H.transpose())).ldlt().solve(g);
    const double dT = shift.cwiseAbs().maxCoeff();
    std::printf("%-14s %-34s %12.2e %12.2e\n", name, "plant grid + trapezoid", gap, dT);
    EXPECT_LT(std::abs(gap), 1e-5);
    EXPECT_LT(dT, 1e-4);
  }
  // Bounded or nonlinear with input: sampled continuous optimum, held (an upper bound).
  for (const char* name : {"exp0_bounded", "exp1"}) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
    ShootingProblem p = std::string(name) == "exp1" ? ShootingFromExp1(Exp1ProblemData())
                                                    : ShootingFromLq(Exp0Data(kExp0InputBound));
    p.step = 2.5e-4;
    const Vector& T = sp->reference_T;
    const Extremal e = SolveExtremal(p, T, ComputeReference(*sp).lambda0);
    ASSERT_TRUE(e.converged);
    const auto u = ExtremalInput(p, T, e.lambda0);
    std::vector<HeldInputs> modes(T.size());
    for (int k = 0; k < T.size(); ++k) {
      const double t0 = k == 0 ? 0.0 : T(k - 1);
      std::vector<double> t;
      for (double s = t0; s < T(k) - 1e-12; s += dt) t.push_back(s);
      t.push_back(T(k));
      modes[k].t = Eigen::Map<Vector>(t.data(), t.size());
      modes[k].u.resize(1, t.size());
      // Each held value: the mean of the continuous optimum over its step (20 points).
      for (size_t j = 0; j < t.size(); ++j) {
        const double a = t[j], b = j + 1 < t.size() ? t[j + 1] : t[j];
        double mean = 0;
        for (int i = 0; i < 20; ++i) mean += u(k, a + (i + 0.5) / 20 * (b - a)) / 20;
        modes[k].u(0, j) = mean;
      }
    }
    const double J_held = HeldInputCost(IndependentModelOf(*sp), sp->x0, modes, 4);
    const double gap = (J_held - e.cost) / e.cost;
    std::printf("%-14s %-34s %12.2e %12s\n", name, "step means of the optimum (bound)", gap,
                "-");
    EXPECT_GE(gap, -1e-9);
    EXPECT_LT(gap, 1e-4);
  }
}

// ---------------------------------------------------------------------------------------------
// (b) The engine with the settings a user leaves alone.

// Independent true cost of the learner's final nominal: its held inputs and instants simulated
// by the independent model (RK4, 4 substeps per sample interval).
double IndependentCostOfNominal(const StandardProblem& sp, const Trajectory& nominal) {
  std::vector<HeldInputs> modes(nominal.num_modes());
  for (int k = 0; k < nominal.num_modes(); ++k) {
    modes[k].t = nominal.modes[k].t;
    modes[k].u = nominal.modes[k].u;
  }
  return HeldInputCost(IndependentModelOf(sp), nominal.x0, modes, 4);
}

class StandardProblemEngine : public ::testing::TestWithParam<std::string> {};

TEST_P(StandardProblemEngine, DefaultSettingsReachTheReference) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(GetParam());
  const Problem& problem = sp->problem;
  // What a user writes: the default settings, the exact model as the plant (dt = 1e-3 s).
  LearnerSettings settings;
  // Only to bound the test's run time; the target is this budget anyway.
  settings.max_trials = sp->trial_budget();
  ModelPlant plant(problem);
  Learner learner(problem, settings);
  FunctionPolicy initial_policy = sp->InitialPolicy();
  const SolveResult r = learner.Solve(plant, plant, sp->x0, initial_policy);

  const double cost_error = RelativeError(r.cost, sp->reference_cost);
  const double T_error = r.T.size() == sp->reference_T.size()
                             ? (r.T - sp->reference_T).cwiseAbs().maxCoeff()
                             : kInf;
  const double true_cost = IndependentCostOfNominal(*sp, learner.nominal());
  const double true_cost_error = RelativeError(true_cost, sp->reference_cost);
  std::printf("%-14s %s, trials %d, iterations %d, cost %.8g (ref %.8g, rel err %.1e; "
              "independent %.8g, rel err %.1e), max |T - T*| %.1e s\n",
              sp->name.c_str(), LearnerStatusName(r.status), r.trials, r.iterations, r.cost,
              sp->reference_cost, cost_error, true_cost, true_cost_error, T_error);

  EXPECT_STREQ(LearnerStatusName(r.status), "converged");
  EXPECT_LE(r.trials, sp->trial_budget());
  EXPECT_LE(cost_error, 1e-3) << "reported cost " << r.cost << ", reference "
                              << sp->reference_cost;
  EXPECT_LE(true_cost_error, 1e-3) << "independent cost of the final nominal " << true_cost;
  EXPECT_LE(T_error, 1e-3) << "T " << r.T.transpose() << ", reference "
                           << sp->reference_T.transpose();
}

TEST(StandardProblemEngine, BoundedProblemFromOtherStarts) {
  // exp0_bounded from 12 random initial guesses (DrawRandomStart), the default settings, the
  // trial budget of the suite. Its optimal input sits on the bound through all of mode 0, so
  // most nominals have many inputs on the bound; a rounding-level gap to the bound must not make
  // one free with two-sided feedback that the plant's QP clips on one side (kOnBoundTolerance).
  // Without that rule 4 of suite_starts' 12 converged and 7 reached the reference; with it, 115
  // of 120 over four seeds, and 120 with the duration QP's fix and failure_raises
  // (docs/standard_problems.md). These 12: all reach it; 11 without failure_raises (start 3
  // ends its line search 490 times above I*), 4 without the rule.
  std::mt19937 rng(7);
  int reached = 0;
  for (int start = 0; start < 12; ++start) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0_bounded");
    FunctionPolicy initial = RandomStartPolicy(*sp, DrawRandomStart(*sp, &rng));
    LearnerSettings settings;
    settings.max_trials = sp->trial_budget();
    const SolveResult r = SolveOnModel(*sp, initial, settings);
    const double cost_error = RelativeError(r.cost, sp->reference_cost);
    const double T_error = (r.T - sp->reference_T).cwiseAbs().maxCoeff();
    const bool ok = r.status == LearnerStatus::kConverged && cost_error <= 1e-3 && T_error <= 1e-3;
    std::printf("start %2d: %s, trials %d, cost rel err %.1e, max |T - T*| %.1e s\n", start,
                LearnerStatusName(r.status), r.trials, cost_error, T_error);
    reached += ok;
  }
  EXPECT_EQ(reached, 12) << "of 12 starts converged to the reference";
}

// c times a cost: the same optimum, the optimal cost times c.
class ScaledCost : public SwitchedCost {
 public:
  ScaledCost(const SwitchedCost* cost, double c) : cost_(cost), c_(c) {}

 protected:
  double DoRunning(int k, const ConstVectorRef& x, const ConstVectorRef& u) const override {
    return c_ * cost_->Running(k, x, u);
  }
  void DoRunningDerivatives(int k, const ConstVectorRef& x, const ConstVectorRef& u, VectorRef lx,
                            VectorRef lu, MatrixRef lxx, MatrixRef luu,
                            MatrixRef lux) const override {
    cost_->RunningDerivatives(k, x, u, lx, lu, lxx, luu, lux);
    lx *= c_;
    lu *= c_;
    lxx *= c_;
    luu *= c_;
    lux *= c_;
  }
  double DoSwitching(int k, const ConstVectorRef& x) const override {
    return c_ * cost_->Switching(k, x);
  }
  void DoSwitchingDerivatives(int k, const ConstVectorRef& x, VectorRef phix,
                              MatrixRef phixx) const override {
    cost_->SwitchingDerivatives(k, x, phix, phixx);
    phix *= c_;
    phixx *= c_;
  }

 private:
  const SwitchedCost* cost_;
  double c_;
};

TEST(StandardProblemEngine, TheCostScaleDoesNotChangeTheAnswer) {
  // Every suite problem with its cost multiplied by 1e-9 and by 1e9 (a user's units): the
  // default settings must reach the same reference (I* times c) within the budget. Before the
  // scale-free tests (the box QP's residual, the floor of (31), the Newton-decrement test
  // relative to the cost) 7 of the 8 failed at 1e-9 and exp0_bounded at 1e9.
  for (const std::string& name : StandardProblemNames()) {
    for (const double c : {1e-9, 1e9}) {
      const std::unique_ptr<StandardProblem> sp = MakeStandardProblem(name);
      const ScaledCost cost(sp->cost.get(), c);
      sp->problem.cost = &cost;
      FunctionPolicy initial = sp->InitialPolicy();
      LearnerSettings settings;
      settings.max_trials = sp->trial_budget();
      const SolveResult r = SolveOnModel(*sp, initial, settings);
      std::printf("%s x %g: %s, trials %d, cost / c rel err %.1e\n", name.c_str(), c,
                  LearnerStatusName(r.status), r.trials,
                  RelativeError(r.cost / c, sp->reference_cost));
      EXPECT_EQ(r.status, LearnerStatus::kConverged) << name << " x " << c;
      EXPECT_LE(RelativeError(r.cost / c, sp->reference_cost), 1e-3) << name << " x " << c;
      EXPECT_LE((r.T - sp->reference_T).cwiseAbs().maxCoeff(), 1e-3) << name << " x " << c;
    }
  }
}

TEST(StandardProblemEngine, AFreeFinalTimeReachesTheReference) {
  // state_size_lq with its final time free in [1, 3.5] s (duration bounds widened to match): the
  // engine moves the last instant T_1 with the switch T_0. The reference, without the engine:
  // for each final time t_f the optimal cost over T_0 (LqReference, closed-form Riccati), and
  // golden section over t_f. On [1, 3.5] that cost has one minimum, inside (t_f = 2.64 s; it
  // rises to t_f = 4.2 s and falls again to a second minimum on a bound at 5 s, 2 % higher).
  const LinearQuadraticData d = StateSizeData();
  const double lo = 1.0, hi = 3.5;
  auto best_over_switch = [&d](double tf, Vector* T) {
    LinearQuadraticData e = d;
    e.final_time = tf;
    const ReferenceOptimum r = LqReference(e, (Vector(2) << 0.45 * tf, tf).finished(), 0.01);
    if (T != nullptr) *T = r.T;
    return r.cost;
  };
  const double tf_star = GoldenSectionMinimum(
      [&best_over_switch](double tf) { return best_over_switch(tf, nullptr); }, lo, hi, 1e-7);
  Vector T_star;
  const double I_star = best_over_switch(tf_star, &T_star);
  ASSERT_GT(T_star(1), lo + 0.1);  // an interior optimum: the final time is decided by the cost
  ASSERT_LT(T_star(1), hi - 0.1);
  std::printf("reference: I* %.9f, T* (%.6f, %.6f) s\n", I_star, T_star(0), T_star(1));

  std::mt19937 rng(3);
  for (int start = -1; start < 4; ++start) {
    const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("state_size_lq");
    sp->problem.bounds.final_time_min = lo;
    sp->problem.bounds.final_time_max = hi;
    sp->problem.bounds.duration_max = Vector::Constant(2, hi);
    sp->problem.Validate();
    FunctionPolicy initial =
        start < 0 ? sp->InitialPolicy() : RandomStartPolicy(*sp, DrawRandomStart(*sp, &rng));
    LearnerSettings settings;
    settings.max_trials = sp->trial_budget();
    const SolveResult r = SolveOnModel(*sp, initial, settings);
    std::printf("start %2d: %s, trials %d, cost rel err %.1e, T (%.6f, %.6f) s\n", start,
                LearnerStatusName(r.status), r.trials, RelativeError(r.cost, I_star), r.T(0),
                r.T(1));
    EXPECT_EQ(r.status, LearnerStatus::kConverged) << "start " << start;
    EXPECT_LE(RelativeError(r.cost, I_star), 1e-5) << "start " << start;
    EXPECT_LE((r.T - T_star).cwiseAbs().maxCoeff(), 1e-3) << "start " << start;
  }
}

TEST(StandardProblemEngine, AFailedLineSearchOnABangBangNominalRaisesTheRegularization) {
  // One start of suite_starts (--starts 30 --seed 2 --only exp0_bounded --verbose: start 27;
  // its draw rounded to 6 digits). Its line search ends at a nominal 16 times above I* where almost
  // every input sits on the bound: the step's measured slope is positive while (31) and the
  // feed-forward predict a decrease, because the plant's QP clips the feedback of inputs that
  // the pass let leave the bound. A larger mu (LearnerSettings::failure_raises) shrinks that
  // feedback; the search from alpha_initial then goes on to the reference.
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0_bounded");
  RandomStart start;
  start.durations = (Vector(2) << 0.950532, 1.049468).finished();
  start.offset = -0.607846;
  double cost[2];
  for (const int raises : {0, 2}) {
    FunctionPolicy initial = RandomStartPolicy(*sp, start);
    LearnerSettings settings;
    settings.failure_raises = raises;
    settings.max_trials = sp->trial_budget();
    const SolveResult r = SolveOnModel(*sp, initial, settings);
    std::printf("failure_raises %d: %s, trials %d, cost %.6g x I*\n", raises,
                LearnerStatusName(r.status), r.trials, r.cost / sp->reference_cost);
    cost[raises ? 1 : 0] = r.cost;
    if (raises == 0) {
      EXPECT_EQ(r.status, LearnerStatus::kLineSearchFailed);
    } else {
      EXPECT_EQ(r.status, LearnerStatus::kConverged);
      EXPECT_LE(RelativeError(r.cost, sp->reference_cost), 1e-3);
      EXPECT_LE((r.T - sp->reference_T).cwiseAbs().maxCoeff(), 1e-3);
    }
  }
  EXPECT_GT(cost[0], 10 * cost[1]);
}

TEST(StandardProblemEngine, AModelThatIsTooSteepIsRelaxed) {
  // One start of suite_starts (seed 7, --starts 30, fishing's 4th; its draw rounded to 6
  // digits). Its fishing interval collapses to the minimum duration, and the nominal then
  // creeps 6-9 ms per trial, each measured decrease twice the predicted one: the cost is flat
  // along the step where the model curves. With the model's curvature as it is, the run is still
  // 4.4x above I* after 60 trials; halving it after such trials (curvature_scale_min) lets the
  // step grow, and the run converges to the reference.
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("fishing");
  RandomStart start;
  start.durations = (Vector(3) << 5.261397, 2.055393, 4.683210).finished();
  start.offset = -0.349386;
  for (const double relax : {1.0, LearnerSettings{}.curvature_scale_min}) {
    FunctionPolicy initial = RandomStartPolicy(*sp, start);
    LearnerSettings settings;
    settings.curvature_scale_min = relax;
    settings.max_trials = 60;
    const SolveResult r = SolveOnModel(*sp, initial, settings);
    std::printf("curvature_scale_min %g: %s, trials %d, cost %.6g x I*\n", relax,
                LearnerStatusName(r.status), r.trials, r.cost / sp->reference_cost);
    if (relax == 1.0) {
      EXPECT_EQ(r.status, LearnerStatus::kMaxTrials);
      EXPECT_GT(r.cost, 4 * sp->reference_cost);
    } else {
      EXPECT_EQ(r.status, LearnerStatus::kConverged);
      EXPECT_LE(r.trials, 40);
      EXPECT_LE(RelativeError(r.cost, sp->reference_cost), 1e-3);
      EXPECT_LE((r.T - sp->reference_T).cwiseAbs().maxCoeff(), 1e-3);
    }
  }
}

// The default pass's stored step is what the plant's QP (33) can apply: inside the input box
// at every sample, and a descent direction at its own gradient (k^T g_u <= 0). The free set of an
// interval is fixed at its right end; its Newton step at the midpoint can leave the box (measured
// before the fix on this run: a step of -3.66 on an input at its lower bound), and the
// predicted decrease then counted a step the plant clamps away. Checked on every nominal of
// exp0_bounded run from T^0 = (1, 1) s with u^0 + 0.5.
TEST(StandardProblemPass, StoredStepIsFeasibleOnEveryNominal) {
  const std::unique_ptr<StandardProblem> sp = MakeStandardProblem("exp0_bounded");
  const Problem& problem = sp->problem;
  FunctionPolicy::Function f = sp->initial_input;
  FunctionPolicy initial(Eigen::Vector2d(1.0, 1.0),
                         [f](int k, double t, const ConstVectorRef& x, VectorRef u) {
                           f(k, t, x, u);
                           u.array() += 0.5;
                         });
  ModelPlant plant(problem);
  LearnerSettings settings;
  settings.max_trials = 40;
  Learner learner(problem, settings);
  Trajectory measured;
  plant.Run(sp->x0, initial, &measured);
  learner.Initialize(measured);
  int checked = 0;
  double worst_violation = 0, worst_slope = -kInf;
  while (learner.status() == LearnerStatus::kRunning && learner.trials() < settings.max_trials) {
    const BackwardPass& pass = learner.backward_pass();
    const Trajectory& nominal = learner.nominal();
    for (int k = 0; k < nominal.num_modes(); ++k) {
      for (int j = 0; j + 1 < nominal.modes[k].num_samples(); ++j) {
        const double u = nominal.modes[k].u(0, j), step = pass.Step(k, j)(0);
        const double v = std::max(problem.bounds.u_min(0) - (u + step), (u + step) - problem.bounds.u_max(0));
        worst_violation = std::max(worst_violation, v);
        worst_slope = std::max(worst_slope, step * pass.Feedforward(k, j)(0));
        ++checked;
      }
    }
    plant.Run(sp->x0, learner.NextTrial(), &measured);
    learner.CompleteTrial(measured);
  }
  std::printf("checked %d samples: worst box violation %.3g, worst k g_u %.3g\n", checked,
              worst_violation, worst_slope);
  EXPECT_GT(checked, 10000);
  EXPECT_LE(worst_violation, 1e-9);
  EXPECT_LE(worst_slope, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Suite, StandardProblemEngine,
                         ::testing::ValuesIn(StandardProblemNames()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

}  // namespace
}  // namespace testing
}  // namespace ddoc
