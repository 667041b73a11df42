// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The backward pass (30): closed-form LQ solution, the cost gradient w.r.t. u(.) and T against
// finite differences of the true (simulated) cost, the du_prev driving term, no allocation.
#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "ddoc/backward_pass.h"
#include "ddoc/cost.h"
#include "ddoc/plant.h"
#include "malloc_counter.h"
#include "test_systems.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {

// Scalar LQ, one mode: xdot = a x + b u, l = 1/2 q x^2 + 1/2 r u^2, phi = 1/2 s x^2,
// u = u0 constant. Closed forms for x(t), P11(t), p1(t) and dJ/dT.
struct ScalarLq {
  double a = 0.5, b = 1.0, q = 2.0, r = 0.5, s = 3.0, u0 = 0.4, x0 = 1.0, T = 1.2;
  double c0() const { return -b * u0 / a; }
  double c1() const { return x0 - c0(); }
  double x(double t) const { return c1() * std::exp(a * t) + c0(); }
  double P11(double t) const {
    return (s + q / (2 * a)) * std::exp(2 * a * (T - t)) - q / (2 * a);
  }
  double p1(double t) const {
    return std::exp(a * (T - t)) * s * x(T) +
           q * std::exp(-a * t) *
               (c1() * (std::exp(2 * a * T) - std::exp(2 * a * t)) / (2 * a) +
                c0() * (std::exp(a * T) - std::exp(a * t)) / a);
  }
  // d/dT of J = int_0^T l dt + phi(x(T)) with u fixed: l(T) + s x(T) xdot(T).
  double dJdT() const {
    const double xT = x(T);
    return 0.5 * q * xT * xT + 0.5 * r * u0 * u0 + s * xT * (a * xT + b * u0);
  }
};

// The one-mode scalar problems of this file: |u| <= 10, duration in [0.1, 5], no surface.
void SetScalarProblem(const SwitchedSystem& sys, const SwitchedCost& cost, Problem* problem) {
  problem->system = &sys;
  problem->cost = &cost;
  problem->bounds.u_min = Vector::Constant(1, -10);
  problem->bounds.u_max = Vector::Constant(1, 10);
  problem->bounds.duration_min = Vector::Constant(1, 0.1);
  problem->bounds.duration_max = Vector::Constant(1, 5);
  problem->surface_weights = Vector::Zero(1);
}

struct ScalarLqSetup {
  ScalarLq lq;
  LinearSwitchedSystem sys;
  QuadraticCost cost;
  Problem problem;
  explicit ScalarLqSetup(const ScalarLq& l)
      : lq(l),
        sys({Matrix::Constant(1, 1, l.a)}, {Matrix::Constant(1, 1, l.b)},
            {Matrix::Identity(1, 1)}),
        cost({Matrix::Constant(1, 1, l.q)}, {Matrix::Constant(1, 1, l.r)}, {0.0},
             {Matrix::Constant(1, 1, l.s)}, {Vector::Zero(1)}) {
    SetScalarProblem(sys, cost, &problem);
  }
  Trajectory Exact(int N) const {
    Trajectory traj;
    traj.modes.resize(1);
    ModeTrajectory& mode = traj.modes[0];
    mode.t = Vector::LinSpaced(N, 0.0, lq.T);
    mode.x.resize(1, N);
    mode.u = Matrix::Constant(1, N, lq.u0);
    for (int j = 0; j < N; ++j) mode.x(0, j) = lq.x(mode.t(j));
    traj.T = Vector::Constant(1, lq.T);
    traj.x0 = mode.x.col(0);
    return traj;
  }
};

// Max relative errors of P11 and p1 over the grid.
void LqErrors(const ScalarLqSetup& setup, const Trajectory& traj, BackwardIntegrator integrator,
              double* eP, double* ep) {
  BackwardPass pass;
  BackwardPassSettings settings;
  settings.keep_P_trajectory = true;
  settings.equation = BackwardEquation::kLyapunov;
  settings.integrator = integrator;
  pass.Allocate(setup.problem, traj.total_samples(), settings);
  pass.Run(traj);
  *eP = *ep = 0;
  for (int j = 0; j < traj.modes[0].num_samples(); ++j) {
    const double t = traj.modes[0].t(j);
    *eP = std::max(*eP, std::abs(pass.P(0, j)(0, 0) - setup.lq.P11(t)) / setup.lq.P11(t));
    *ep = std::max(*ep, std::abs(pass.p(0, j)(0) - setup.lq.p1(t)) / std::abs(setup.lq.p1(t)));
  }
}

TEST(BackwardPass, ScalarLqMatchesClosedForm) {
  const ScalarLqSetup setup{ScalarLq{}};
  double eP, ep, eP2, ep2;
  LqErrors(setup, setup.Exact(241), BackwardIntegrator::kRk4, &eP, &ep);
  LqErrors(setup, setup.Exact(481), BackwardIntegrator::kRk4, &eP2, &ep2);
  // P has constant coefficients here: RK4 is (nearly) exact.
  EXPECT_LT(eP, 1e-9);
  // p is driven by L_z = D q x(tau), held at its interval-midpoint value: second order.
  EXPECT_LT(ep, 1e-5);
  EXPECT_GT(ep / ep2, 3.5);
  // Midpoint (RK2) is second order in P as well.
  double mP, mp, mP2, mp2;
  LqErrors(setup, setup.Exact(241), BackwardIntegrator::kMidpoint, &mP, &mp);
  LqErrors(setup, setup.Exact(481), BackwardIntegrator::kMidpoint, &mP2, &mp2);
  EXPECT_LT(mP, 1e-4);
  EXPECT_GT(mP / mP2, 3.5);
  EXPECT_LT(mp, 1e-4);
}

TEST(BackwardPass, ScalarLqTimeGradientIsP2) {
  const ScalarLqSetup setup{ScalarLq{}};
  const Trajectory traj = setup.Exact(481);
  BackwardPassSettings settings;
  settings.keep_P_trajectory = true;
  settings.equation = BackwardEquation::kLyapunov;
  BackwardPass pass;
  pass.Allocate(setup.problem, 481, settings);
  pass.Run(traj);
  EXPECT_NEAR(pass.p2_initial()(0), setup.lq.dJdT(), 1e-5 * std::abs(setup.lq.dJdT()));
  EXPECT_EQ(pass.gradient_T()(0), pass.p2_initial()(0));  // p is the adjoint here
  // Gain, feed-forward and Hessian of (34) for interval 0 (u_0 held on [t_0, t_1]): at the
  // interval's midpoint, L_uz + F_u^T P, L_u + F_u^T p, L_uu (P, p to second order the means
  // of the samples' values).
  const double D = setup.lq.T;
  const double p_mid = 0.5 * (pass.p(0, 0)(0) + pass.p(0, 1)(0));
  const double P_mid = 0.5 * (pass.P(0, 0)(0, 0) + pass.P(0, 1)(0, 0));
  EXPECT_NEAR(pass.Feedforward(0, 0)(0), D * (setup.lq.r * setup.lq.u0 + setup.lq.b * p_mid),
              1e-6 * std::abs(p_mid));
  EXPECT_NEAR(pass.Gain(0, 0)(0, 0), D * setup.lq.b * P_mid, 1e-5 * P_mid);  // O(h^2), h = 1/480
  EXPECT_EQ(pass.Hessian(0, 0)(0, 0), D * setup.lq.r);
  EXPECT_EQ(pass.Gradient(0, 0)(0), pass.Feedforward(0, 0)(0));
  // The default (box-aware Riccati) pass has another p but the same gradient adjoint.
  BackwardPass riccati;
  riccati.Allocate(setup.problem, 481);
  riccati.Run(traj);
  EXPECT_NEAR(riccati.gradient_T()(0), setup.lq.dJdT(), 1e-5 * std::abs(setup.lq.dJdT()));
  EXPECT_NEAR(riccati.Gradient(0, 7)(0), pass.Gradient(0, 7)(0), 1e-12);
  EXPECT_GT(std::abs(riccati.p(0, 0)(0) - pass.p(0, 0)(0)), 0.1);
}

TEST(BackwardPass, PreviousDuTermMatchesIndependentQuadrature) {
  // With du_prev constant, p changes by dp(t) = int_t^T e^{a(s-t)} P11(s) b du ds (times D in
  // tau, which cancels in t).
  const ScalarLqSetup setup{ScalarLq{}};
  const int N = 481;
  const Trajectory traj = setup.Exact(N);
  const double du = 0.3;
  BackwardPassSettings without;
  without.equation = BackwardEquation::kLyapunov;
  without.integrator = BackwardIntegrator::kRk4;
  BackwardPassSettings with = without;
  with.use_previous_du = true;
  BackwardPass a, b;
  a.Allocate(setup.problem, N, without);
  b.Allocate(setup.problem, N, with);
  a.Run(traj);
  const Matrix du_prev = Matrix::Constant(1, N, du);
  b.Run(traj, 0.0, &du_prev);
  const ScalarLq& lq = setup.lq;
  for (int j : {0, 120, 300}) {
    const double t = traj.modes[0].t(j);
    // Simpson quadrature on a fine grid.
    const int M = 2000;
    const double h = (lq.T - t) / M;
    double sum = 0;
    for (int i = 0; i <= M; ++i) {
      const double s = t + i * h;
      const double w = (i == 0 || i == M) ? 1 : (i % 2 ? 4 : 2);
      sum += w * std::exp(lq.a * (s - t)) * lq.P11(s) * lq.b * du;
    }
    const double expected = sum * h / 3;
    EXPECT_NEAR(b.p(0, j)(0) - a.p(0, j)(0), expected, 1e-6 * std::abs(expected)) << "j " << j;
  }
}

// The 3-mode nonlinear problem with rectangular resets and surface penalties.
struct NonlinearSetup {
  NonlinearSystem sys;
  NonlinearCost cost;
  Problem problem;
  NonlinearSetup() : problem(MakeNonlinearProblem(sys, cost)) {}
};

void BaseInput(int k, double tau, VectorRef u) {
  u(0) = 0.3 * std::sin(2.0 * tau) + 0.1 * k;
  u(1) = 0.2 * std::cos(3.0 * tau) - 0.1;
}
void Direction(int, double tau, VectorRef v) {
  v(0) = std::cos(1.5 * tau) + 0.2;
  v(1) = std::sin(2.5 * tau + 0.3);
}

// Cost of a ModelPlant rollout from x0 = (0.2, -0.1, 0.3) with u = base(k, tau) + eps v(tau).
using InputFunction = void (*)(int k, double tau, VectorRef u);
double PerturbedCost(const Problem& problem, bool time_based_only, InputFunction base,
                     const Vector& durations, double eps, Trajectory* out) {
  ModelPlantSettings ps;
  ps.dt = 2e-4;
  ps.time_based_only = time_based_only;
  ModelPlant plant(problem, ps);
  FunctionPolicy policy(durations, [base, eps](int k, double tau, const ConstVectorRef&, VectorRef u) {
    base(k, tau, u);
    Vector v(2);
    Direction(k, tau, v);
    u += eps * v;
  });
  Vector x0(3);
  x0 << 0.2, -0.1, 0.3;
  Trajectory traj;
  plant.Run(x0, policy, &traj);
  if (out) *out = traj;
  return EvaluateCost(problem, traj).total;
}

double SimulatedCost(const NonlinearSetup& setup, const Vector& durations, double eps,
                     Trajectory* out = nullptr) {
  return PerturbedCost(setup.problem, true, BaseInput, durations, eps, out);
}

// sum_j (tau_{j+1} - tau_j) Gradient(k, j) . v(tau_j): the backward pass's directional
// derivative along Direction, with v held on each sample interval as the plant holds it.
double PredictedDirectionalDerivative(const BackwardPass& pass, int K) {
  double predicted = 0;
  for (int k = 0; k < K; ++k) {
    for (int j = 0; j + 1 < pass.num_samples(k); ++j) {
      Vector v(2);
      Direction(k, pass.tau(k, j), v);
      predicted += (pass.tau(k, j + 1) - pass.tau(k, j)) * pass.Gradient(k, j).dot(v);
    }
  }
  return predicted;
}

TEST(BackwardPass, AdjointGivesTheGradientOfTheSimulatedCost) {
  NonlinearSetup setup;
  Vector D(3);
  D << 0.50013, 0.40007, 0.60011;  // not multiples of dt
  Trajectory nominal;
  SimulatedCost(setup, D, 0.0, &nominal);
  BackwardPass pass;
  pass.Allocate(setup.problem, nominal.total_samples());
  pass.Run(nominal);

  // Gradient w.r.t. T: p_2(0). FD moves T_k only (D_k up, D_{k+1} down).
  const double e = 1e-5;
  for (int k = 0; k < 3; ++k) {
    Vector Dp = D, Dm = D;
    Dp(k) += e;
    Dm(k) -= e;
    if (k + 1 < 3) {
      Dp(k + 1) -= e;
      Dm(k + 1) += e;
    }
    const double fd = (SimulatedCost(setup, Dp, 0) - SimulatedCost(setup, Dm, 0)) / (2 * e);
    EXPECT_NEAR(pass.gradient_T()(k), fd, 2e-3 * std::max(1.0, std::abs(fd))) << "dJ/dT_" << k;
  }

  // Directional derivative w.r.t. u(.) along v(tau): int (L_u + F_u^T lambda) . v dtau.
  const double predicted = PredictedDirectionalDerivative(pass, 3);
  const double eu = 1e-4;
  const double fd_u = (SimulatedCost(setup, D, eu) - SimulatedCost(setup, D, -eu)) / (2 * eu);
  EXPECT_NEAR(predicted, fd_u, 2e-3 * std::abs(fd_u));
  // Without L_z in the p-equation (the printed (30)) the gradient would be wrong: the running
  // cost's state dependence is not negligible here.
  EXPECT_GT(std::abs(fd_u), 0.05);
}

// Every output of two passes, bit for bit (keep_P_trajectory on both).
void ExpectSamePass(const BackwardPass& a, const BackwardPass& b, int K) {
  auto same = [](const auto& x, const auto& y) {
    return x.rows() == y.rows() && x.cols() == y.cols() && (x.array() == y.array()).all();
  };
  for (int k = 0; k < K; ++k) {
    ASSERT_EQ(a.num_samples(k), b.num_samples(k));
    for (int j = 0; j < a.num_samples(k); ++j) {
      EXPECT_TRUE(same(a.P(k, j), b.P(k, j)) && same(a.p(k, j), b.p(k, j)) &&
                  same(a.Gain(k, j), b.Gain(k, j)) &&
                  same(a.Feedforward(k, j), b.Feedforward(k, j)) &&
                  same(a.Hessian(k, j), b.Hessian(k, j)) &&
                  same(a.Gradient(k, j), b.Gradient(k, j)) && same(a.Step(k, j), b.Step(k, j)))
          << "sample (" << k << ", " << j << ")";
    }
  }
  EXPECT_TRUE(same(a.gradient_T(), b.gradient_T()));
  EXPECT_EQ(a.predicted_linear(), b.predicted_linear());
  EXPECT_EQ(a.predicted_quadratic(), b.predicted_quadratic());
  EXPECT_EQ(a.luu_scale(), b.luu_scale());
  EXPECT_EQ(a.substeps(), b.substeps());
  EXPECT_EQ(a.sweeps(), b.sweeps());
}

// A pass (regularization 1e-3) on `nominal` of setup's problem seen through BatchingSystem and
// BatchingCost.
struct BatchedPass {
  BatchingSystem sys;
  BatchingCost cost;
  Problem problem;
  BackwardPass pass;
  BatchedPass(const NonlinearSetup& setup, bool batch_system, bool batch_cost,
              const Trajectory& nominal, const BackwardPassSettings& settings)
      : sys(setup.sys, batch_system), cost(setup.cost, batch_cost),
        problem(MakeNonlinearProblem(sys, cost)) {
    pass.Allocate(problem, nominal.total_samples(), settings);
    EXPECT_TRUE(pass.Run(nominal, 1e-3));
  }
};

// A system and a cost that prefer_batch() (their batch calls the C++ default, the per-point
// loop) give the per-point pass bit for bit, with two batch calls per mode and Run (the flow
// and its derivatives; the running cost and its derivatives) and no per-point call; either
// alone likewise.
TEST(BackwardPass, BatchEvaluationGivesThePerPointPass) {
  NonlinearSetup setup;
  Trajectory nominal;
  SimulatedCost(setup, Eigen::Vector3d(0.50013, 0.40007, 0.60011), 0.0, &nominal);
  const int intervals = nominal.total_samples() - 3;
  for (const BackwardEquation equation : {BackwardEquation::kRiccati, BackwardEquation::kLyapunov}) {
    BackwardPassSettings settings;
    settings.equation = equation;
    settings.keep_P_trajectory = true;
    const BatchedPass reference(setup, false, false, nominal, settings);
    EXPECT_EQ(reference.sys.batch_calls + reference.cost.batch_calls, 0);
    EXPECT_GT(reference.sys.point_calls, 0);
    for (const bool batch_system : {true, false}) {
      for (const bool batch_cost : {true, false}) {
        if (!batch_system && !batch_cost) continue;
        const BatchedPass batched(setup, batch_system, batch_cost, nominal, settings);
        const BatchingSystem& sys = batched.sys;
        const BatchingCost& cost = batched.cost;
        SCOPED_TRACE(::testing::Message() << "equation " << static_cast<int>(equation)
                                        << " system " << batch_system << " cost " << batch_cost);
        ExpectSamePass(reference.pass, batched.pass, 3);
        EXPECT_EQ(sys.batch_calls, batch_system ? 6 : 0);
        EXPECT_EQ(sys.batch_points, batch_system ? 2 * intervals : 0);
        EXPECT_EQ(cost.batch_calls, batch_cost ? 6 : 0);
        EXPECT_EQ(cost.batch_points, batch_cost ? 2 * intervals : 0);
        if (batch_system) EXPECT_EQ(sys.point_calls, 0);  // (the surface is no flow call)
        if (batch_cost) EXPECT_EQ(cost.point_calls, 0);
      }
    }
  }
}

// NonlinearSystem's dynamics and resets, but only the LAST mode ends at a state event, its
// surface h_2 = 0.16 - x0 - 0.5 x2 - 2 x1^2, which it also reports as its guard: on ModelPlant
// modes 0 and 1 are time-based and mode 2 ends where h_2 crosses zero (after about 2 s).
class EventEndSystem : public AutoDiffSystem<EventEndSystem> {
 public:
  EventEndSystem() : AutoDiffSystem<EventEndSystem>({3, 2, 3}, 2, {0, 0, 1}) {}
  NonlinearSystem base;
  template <class S>
  void Dynamics(int k, const VectorX<S>& x, const VectorX<S>& u, VectorX<S>& xdot) const {
    base.Dynamics(k, x, u, xdot);
  }
  template <class S>
  void ResetMap(int k, const VectorX<S>& x, VectorX<S>& x_next) const {
    base.ResetMap(k, x, x_next);
  }
  template <class S>
  void SurfaceMap(int, const VectorX<S>& x, VectorX<S>& h) const {
    h(0) = 0.16 - x(0) - 0.5 * x(2) - 2.0 * x(1) * x(1);
  }

 protected:
  bool DoGuardGradient(int k, const ConstVectorRef& x, const ConstVectorRef&,
                       VectorRef hx) const override {
    if (k != 2) return false;
    hx << -1.0, -4.0 * x(1), -0.5;
    return true;
  }
};

// Input of the event test: tau-dependent in modes 0 and 1, constant in mode 2, so that the
// nominal's event time does not depend on the planned D_2 (which is then set to it).
void EventBaseInput(int k, double tau, VectorRef u) {
  if (k < 2) {
    BaseInput(k, tau, u);
  } else {
    u << 0.25, -0.15;
  }
}

// Default guard: modes 0 and 1 are time-based, h_2 ends mode 2.
double EventEndCost(const Problem& problem, const Vector& D, double eps, Trajectory* out = nullptr) {
  return PerturbedCost(problem, false, EventBaseInput, D, eps, out);
}

TEST(BackwardPass, TerminalEventGivesTheGradientOfTheEventTerminatedCost) {
  EventEndSystem sys;
  NonlinearSetup setup;  // its cost and input bounds, with the event-ended system
  Problem& problem = setup.problem;
  problem.system = &sys;
  problem.bounds.duration_max = Vector::Constant(3, 3.0);
  problem.surface_weights = Vector::Zero(3);

  Vector D(3);
  D << 0.50013, 0.40007, 3.0;
  Trajectory probe;
  EventEndCost(problem, D, 0.0, &probe);
  ASSERT_LT(probe.T(2) - probe.T(1), 2.9) << "mode 2 must end at its event, not at duration_max";
  D(2) = probe.T(2) - probe.T(1);  // the planned clock of mode 2 ends at the nominal's event
  Trajectory nominal;
  EventEndCost(problem, D, 0.0, &nominal);
  ASSERT_NEAR(nominal.T(2), probe.T(2), 1e-9);

  BackwardPass pass;
  BackwardPassSettings settings;
  settings.terminal_event = true;
  pass.Allocate(problem, nominal.total_samples(), settings);
  pass.Run(nominal);
  const double predicted = PredictedDirectionalDerivative(pass, 3);

  BackwardPass paper;  // the paper's terminal condition, for contrast
  paper.Allocate(problem, nominal.total_samples());
  paper.Run(nominal);
  const double predicted_paper = PredictedDirectionalDerivative(paper, 3);

  const double e = 1e-4;
  const double fd = (EventEndCost(problem, D, e) - EventEndCost(problem, D, -e)) / (2 * e);
  EXPECT_NEAR(predicted, fd, 2e-3 * std::abs(fd));
  // The paper's fixed-time terminal condition predicts a different derivative here, by far
  // more than the tolerance: the event moves and the terminal state slides along the flow.
  EXPECT_GT(std::abs(predicted_paper - fd), 20 * 2e-3 * std::abs(fd))
      << "paper " << predicted_paper << " event " << predicted << " fd " << fd;
  std::printf("event-terminated dJ/deps: fd %.6f, terminal_event %.6f, paper %.6f\n", fd,
              predicted, predicted_paper);
}

TEST(BackwardPass, TerminalEventIsTheIdentityWithoutAGuardGradient) {
  NonlinearSetup setup;  // NonlinearSystem does not provide GuardGradient
  Vector D(3);
  D << 0.50013, 0.40007, 0.60011;
  Trajectory nominal;
  SimulatedCost(setup, D, 0.0, &nominal);
  BackwardPassSettings with;
  with.terminal_event = true;
  BackwardPass a, b;
  a.Allocate(setup.problem, nominal.total_samples());
  b.Allocate(setup.problem, nominal.total_samples(), with);
  a.Run(nominal);
  b.Run(nominal);
  EXPECT_EQ(a.p2_initial(), b.p2_initial());
  EXPECT_EQ(a.Feedforward(0, 0), b.Feedforward(0, 0));
}

// The scalar LQ problem without input bounds (the Riccati tests check the unconstrained
// equation; the box-aware one is tested below).
struct UnboundedScalarLq : ScalarLqSetup {
  UnboundedScalarLq() : ScalarLqSetup(ScalarLq{}) {
    problem.bounds.u_min(0) = -std::numeric_limits<double>::infinity();
    problem.bounds.u_max(0) = std::numeric_limits<double>::infinity();
  }
};

// P(0) of dP/dt = -(2 a P + q - P^2 b^2 / r_eff) from P(T) = s, fine RK4 (100 steps per
// sample interval of a 481-sample grid), compared with the pass at every 100th fine step.
void ExpectScalarRiccati(const ScalarLq& lq, double r_eff, const BackwardPass& pass) {
  auto f = [&](double P) { return 2 * lq.a * P + lq.q - P * P * lq.b * lq.b / r_eff; };
  double P = lq.s;
  const int M = 48000;
  const double h = lq.T / M;
  for (int i = M; i > 0; --i) {
    if (i % 4000 == 0) EXPECT_NEAR(pass.P(0, i / 100)(0, 0), P, 1e-7 * P) << "j " << i / 100;
    const double k1 = f(P), k2 = f(P + 0.5 * h * k1), k3 = f(P + 0.5 * h * k2), k4 = f(P + h * k3);
    P += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  EXPECT_NEAR(pass.P(0, 0)(0, 0), P, 1e-7 * P);
}

TEST(BackwardPass, RiccatiVariantMatchesTheScalarRiccatiEquation) {
  const UnboundedScalarLq setup;
  const Trajectory traj = setup.Exact(481);
  BackwardPassSettings settings;
  settings.keep_P_trajectory = true;
  settings.equation = BackwardEquation::kRiccati;
  settings.integrator = BackwardIntegrator::kRk4;
  BackwardPass pass;
  pass.Allocate(setup.problem, 481, settings);
  pass.Run(traj);
  ExpectScalarRiccati(setup.lq, setup.lq.r, pass);
  // The midpoint integrator (the default) agrees to second order.
  BackwardPass mid;
  BackwardPassSettings mid_settings;
  mid_settings.keep_P_trajectory = true;
  mid.Allocate(setup.problem, 481, mid_settings);
  mid.Run(traj);
  EXPECT_NEAR(mid.P(0, 0)(0, 0), pass.P(0, 0)(0, 0), 1e-4 * pass.P(0, 0)(0, 0));
  // kRiccati changes p, not the gradient adjoint of the Lyapunov form.
  BackwardPassSettings lyap_settings;
  lyap_settings.keep_P_trajectory = true;
  lyap_settings.equation = BackwardEquation::kLyapunov;
  BackwardPass lyapunov;
  lyapunov.Allocate(setup.problem, 481, lyap_settings);
  lyapunov.Run(traj);
  EXPECT_NE(pass.p(0, 0)(0), lyapunov.p(0, 0)(0));
  for (int j : {0, 200, 479}) {
    EXPECT_NEAR(mid.Gradient(0, j)(0), lyapunov.Gradient(0, j)(0), 1e-12) << "j " << j;
  }
}

// A stiff Riccati equation on a coarse grid: r = 1e-4 makes the closed loop a - b^2 P / r
// reach -500 at the terminal P(T) = 0.05, so an explicit step of h = 0.06 s (21 samples over
// 1.2 s) is unstable by a factor of 30. The pass sub-steps such intervals (h |A_cl| <= 1 per
// sub-step) and follows a fine RK4 reference of the scalar Riccati equation; with
// max_substeps = 1 it cannot.
TEST(BackwardPass, StiffRiccatiIsSubStepped) {
  ScalarLq stiff;
  stiff.r = 1e-4;
  stiff.s = 0.05;
  ScalarLqSetup setup(stiff);
  setup.problem.bounds.u_min(0) = -std::numeric_limits<double>::infinity();
  setup.problem.bounds.u_max(0) = std::numeric_limits<double>::infinity();
  const int N = 21;
  const Trajectory traj = setup.Exact(N);
  // Reference: dP/dt = -(2 a P + q - P^2 b^2 / r), 2000 RK4 steps per sample interval.
  auto f = [&](double P) { return 2 * stiff.a * P + stiff.q - P * P * stiff.b * stiff.b / stiff.r; };
  std::vector<double> ref(N);
  double P = stiff.s;
  ref[N - 1] = P;
  const int fine = 2000;
  const double h = stiff.T / (N - 1) / fine;
  for (int j = N - 2; j >= 0; --j) {
    for (int i = 0; i < fine; ++i) {
      const double k1 = f(P), k2 = f(P + 0.5 * h * k1), k3 = f(P + 0.5 * h * k2), k4 = f(P + h * k3);
      P += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    ref[j] = P;
  }
  auto max_error = [&](int max_substeps) {
    BackwardPassSettings settings;
    settings.keep_P_trajectory = true;
    settings.equation = BackwardEquation::kRiccati;
    settings.max_substeps = max_substeps;
    BackwardPass pass;
    pass.Allocate(setup.problem, N, settings);
    pass.Run(traj, 0.0);
    double e = 0;
    for (int j = 0; j < N; ++j) {
      const double Pj = pass.P(0, j)(0, 0);
      e = std::isfinite(Pj) ? std::max(e, std::abs(Pj - ref[j]) / ref[j]) : 1e300;
    }
    if (pass.status() != BackwardStatus::kOk) e = 1e300;
    return e;
  };
  const double sub = max_error(BackwardPassSettings().max_substeps);
  const double single = max_error(1);
  std::printf("stiff Riccati: max relative error of P %.3g sub-stepped, %.3g with one step\n", sub,
              single);
  EXPECT_LT(sub, 1e-3);
  EXPECT_GT(single, 1.0);
}

// A two-state LQ problem (one mode, the nominal at rest) and the same problem in the
// coordinates x = S z with S = diag(1, scale): A' = S A S^-1, B' = S B, Q' = S^-T Q S^-1, the
// terminal weight alike. The Riccati pass is covariant (P' = S^-T P S^-1) and so is every
// explicit Runge-Kutta step, so the scaled pass needs the sub-steps of the unscaled one; its
// closed loop's |A_cl|_inf is ~scale times larger, its eigenvalues are the same.
struct ScaledLq {
  Matrix A = (Matrix(2, 2) << 0.0, 1.0, -2.0, -0.5).finished();
  Matrix B = (Matrix(2, 1) << 0.0, 1.0).finished();
  Matrix Q = Matrix::Identity(2, 2), S_T = Matrix::Identity(2, 2);
  double r = 0.1, T = 2.0;
  int N = 101;
  struct Posed {
    LinearSwitchedSystem sys;
    QuadraticCost cost;
    Problem problem;
    Trajectory traj;
    Posed(const Matrix& A, const Matrix& B, const Matrix& Q, const Matrix& R, const Matrix& S_T,
          double T, int N)
        : sys({A}, {B}, {Matrix::Identity(2, 2)}),
          cost({Q}, {R}, {0.0}, {S_T}, {Vector::Zero(2)}) {
      problem.system = &sys;
      problem.cost = &cost;
      problem.bounds.u_min = Vector::Constant(1, -std::numeric_limits<double>::infinity());
      problem.bounds.u_max = Vector::Constant(1, std::numeric_limits<double>::infinity());
      problem.bounds.duration_min = Vector::Constant(1, 0.1);
      problem.bounds.duration_max = Vector::Constant(1, 5);
      problem.surface_weights = Vector::Zero(1);
      traj.modes.resize(1);
      traj.modes[0].t = Vector::LinSpaced(N, 0.0, T);
      traj.modes[0].x = Matrix::Zero(2, N);
      traj.modes[0].u = Matrix::Zero(1, N);
      traj.T = Vector::Constant(1, T);
      traj.x0 = Vector::Zero(2);
    }
  };
  std::unique_ptr<Posed> Pose(double scale) const {
    const Matrix S = Eigen::Vector2d(1.0, scale).asDiagonal();
    const Matrix Si = S.inverse();
    return std::make_unique<Posed>(S * A * Si, S * B, Si.transpose() * Q * Si,
                                   Matrix::Constant(1, 1, r), Si.transpose() * S_T * Si, T, N);
  }
  static BackwardPassSettings Settings(int min_substeps = 1) {
    BackwardPassSettings s;
    s.equation = BackwardEquation::kRiccati;
    s.integrator = BackwardIntegrator::kRk4;
    s.keep_P_trajectory = true;
    s.min_substeps = min_substeps;
    return s;
  }
};

TEST(BackwardPass, SubStepsDoNotDependOnTheCoordinates) {
  for (const double r : {0.1, 1e-3}) {  // the closed loop's eigenvalues up to ~3 and ~1000 /s
    ScaledLq lq;
    lq.r = r;
    const auto plain = lq.Pose(1.0);
    const auto scaled = lq.Pose(1e-4);
    BackwardPass a, b, ref;
    a.Allocate(plain->problem, lq.N, ScaledLq::Settings());
    b.Allocate(scaled->problem, lq.N, ScaledLq::Settings());
    ref.Allocate(scaled->problem, lq.N, ScaledLq::Settings(256));
    ASSERT_TRUE(a.Run(plain->traj)) << static_cast<int>(a.status());
    ASSERT_TRUE(b.Run(scaled->traj)) << static_cast<int>(b.status());
    ASSERT_TRUE(ref.Run(scaled->traj)) << static_cast<int>(ref.status());
    const Matrix Si = Eigen::Vector2d(1.0, 1e4).asDiagonal();
    double e_cov = 0, e_ref = 0;
    for (int j = 0; j < lq.N; ++j) {
      const Matrix Pz = a.P(0, j).topLeftCorner(2, 2);
      const Matrix Px = b.P(0, j).topLeftCorner(2, 2);
      const Matrix Pr = ref.P(0, j).topLeftCorner(2, 2);
      e_cov = std::max(e_cov, (Px - Si.transpose() * Pz * Si).norm() / Px.norm());
      e_ref = std::max(e_ref, (Px - Pr).norm() / Pr.norm());
    }
    std::printf("r = %g: steps %ld unscaled, %ld scaled (%d intervals); |P' - S^-T P S^-1| %.2g, "
                "against 256 sub-steps %.2g\n", r, a.substeps(), b.substeps(), lq.N - 1, e_cov,
                e_ref);
    EXPECT_LE(b.substeps(), a.substeps() + (lq.N - 1) / 10)
        << "balancing recovers the unscaled sub-steps";
    if (r == 0.1) {
      EXPECT_EQ(a.substeps(), lq.N - 1);
      EXPECT_EQ(b.substeps(), lq.N - 1) << "not stiff in any coordinates";
      EXPECT_LT(e_ref, 1e-4);
    } else {
      EXPECT_GT(b.substeps(), lq.N - 1 + 10) << "stiff near the terminal in every coordinates";
      EXPECT_LT(e_ref, 1e-2) << "stable (h |lambda| <= 1 per sub-step bounds stability, not "
                                "the transient's accuracy)";
    }
    EXPECT_LT(e_cov, 1e-9);
  }
}

TEST(BackwardPass, RiccatiIsBoxAware) {
  // The nominal input sits on its upper bound and the gradient pushes it out (p < -r u0 / b
  // everywhere for x0 = -1): the full step is clamped on every interval, so the clamped input
  // gives no feedback and the box-aware Riccati pass is exactly the Lyapunov pass (same P, p).
  // With the bound far away the same nominal gives the unconstrained Riccati solution.
  ScalarLq lq;
  lq.x0 = -1.0;
  ScalarLqSetup clamped{lq};
  clamped.problem.bounds.u_max(0) = lq.u0;
  const Trajectory traj = clamped.Exact(241);
  BackwardPassSettings lyap_settings;
  lyap_settings.keep_P_trajectory = true;
  lyap_settings.equation = BackwardEquation::kLyapunov;
  BackwardPassSettings box_settings;
  box_settings.keep_P_trajectory = true;
  BackwardPass box, lyapunov;
  box.Allocate(clamped.problem, 241, box_settings);
  lyapunov.Allocate(clamped.problem, 241, lyap_settings);
  box.Run(traj);
  lyapunov.Run(traj);
  for (int j = 0; j < 240; ++j) {
    ASSERT_LT(box.Feedforward(0, j)(0), 0.0) << "the gradient pushes u above u_max at j " << j;
    EXPECT_EQ(box.Step(0, j)(0), 0.0) << "j " << j;
    EXPECT_EQ(box.Gain(0, j).norm(), 0.0) << "the clamped input keeps feedback at j " << j;
  }
  for (int j : {0, 120, 239}) {
    EXPECT_NEAR(box.P(0, j)(0, 0), lyapunov.P(0, j)(0, 0), 1e-12 * lyapunov.P(0, j)(0, 0));
    EXPECT_NEAR(box.p(0, j)(0), lyapunov.p(0, j)(0), 1e-12 * std::abs(lyapunov.p(0, j)(0)));
  }
  EXPECT_EQ(box.predicted_linear(), 0.0);  // nothing to gain inside the box
  ScalarLqSetup free{lq};
  BackwardPass riccati;
  riccati.Allocate(free.problem, 241, box_settings);
  riccati.Run(traj);
  EXPECT_GT(lyapunov.P(0, 0)(0, 0) - riccati.P(0, 0)(0, 0), 0.5 * riccati.P(0, 0)(0, 0));
  EXPECT_LT(riccati.predicted_linear(), 0.0);
  EXPECT_GT(riccati.Gain(0, 120).leftCols(1).norm(), 0.1);  // the free input has feedback
}

TEST(BackwardPass, RegularizationEntersAsMu) {
  // H = L_uu + mu with L_uu = D r (tau units): in time the Riccati equation uses
  // r_eff = r + mu / D, integrated independently and compared with the pass.
  const UnboundedScalarLq setup;
  const Trajectory traj = setup.Exact(481);
  const double mu = 0.4;
  BackwardPassSettings settings;
  settings.keep_P_trajectory = true;
  settings.integrator = BackwardIntegrator::kRk4;
  BackwardPass pass;
  pass.Allocate(setup.problem, 481, settings);
  pass.Run(traj, mu);
  EXPECT_EQ(pass.regularization(), mu);
  EXPECT_DOUBLE_EQ(pass.Hessian(0, 3)(0, 0), setup.lq.T * setup.lq.r + mu);
  ExpectScalarRiccati(setup.lq, setup.lq.r + mu / setup.lq.T, pass);
  EXPECT_THROW(pass.Run(traj, -1.0), InvalidArgument);
}

TEST(BackwardPass, PsdSwitchingHessiansProjectsAnIndefiniteTerminalHessian) {
  // Terminal weight s = -3 (indefinite Phi_zz): the option replaces it by its PSD projection,
  // here 0, so P follows the closed form with s = 0; without the option, the one with s = -3.
  ScalarLq negative;
  negative.s = -3.0;
  ScalarLq zero;
  zero.s = 0.0;
  const ScalarLqSetup setup{negative};
  const Trajectory traj = setup.Exact(241);
  BackwardPassSettings plain;
  plain.keep_P_trajectory = true;
  plain.equation = BackwardEquation::kLyapunov;
  plain.integrator = BackwardIntegrator::kRk4;  // P has constant coefficients: RK4 is exact
  BackwardPassSettings psd = plain;
  psd.psd_switching_hessians = true;
  BackwardPass projected, exact;
  projected.Allocate(setup.problem, 241, psd);
  exact.Allocate(setup.problem, 241, plain);
  projected.Run(traj);
  exact.Run(traj);
  for (int j : {0, 120, 240}) {
    const double t = traj.modes[0].t(j);
    EXPECT_NEAR(projected.P(0, j)(0, 0), zero.P11(t), 1e-9 * (1 + std::abs(zero.P11(t))));
    EXPECT_NEAR(exact.P(0, j)(0, 0), negative.P11(t), 1e-9 * (1 + std::abs(negative.P11(t))));
    EXPECT_EQ(projected.p(0, j), exact.p(0, j));  // the gradient is untouched
  }
  EXPECT_GT(std::abs(exact.P(0, 240)(0, 0) - projected.P(0, 240)(0, 0)), 1.0);
}

TEST(BackwardPass, RunDoesNotAllocate) {
  ASSERT_TRUE(MallocCountingWorks());
  {
    MallocCounter probe;
    Vector v(100);
    v.setOnes();
    Escape(v.data());  // else the compiler may elide the allocation
    EXPECT_GE(probe.count(), 1) << "the counter must see Eigen allocations";
  }
  // Hand-written model (the AutoDiff one allocates by design).
  const ScalarLqSetup setup{ScalarLq{}};
  const Trajectory traj = setup.Exact(1000);
  BackwardPass pass;
  BackwardPassSettings settings;
  settings.equation = BackwardEquation::kLyapunov;
  settings.use_previous_du = true;
  pass.Allocate(setup.problem, 2000, settings);
  const Matrix du = Matrix::Constant(1, 1000, 0.1);
  pass.Run(traj, 0.0, &du);
  {
    MallocCounter counter;
    pass.Run(traj, 0.0, &du);
    EXPECT_EQ(counter.count(), 0) << "kLyapunov";
  }
  // The default (box-aware kRiccati, finite bounds: a box QP per interval), midpoint and RK4.
  for (const auto integrator : {BackwardIntegrator::kMidpoint, BackwardIntegrator::kRk4}) {
    BackwardPass riccati;
    BackwardPassSettings rs;
    rs.integrator = integrator;
    riccati.Allocate(setup.problem, 2000, rs);
    riccati.Run(traj, 0.1);
    MallocCounter counter;
    riccati.Run(traj, 0.1);
    EXPECT_EQ(counter.count(), 0) << "kRiccati";
  }
}

// A scalar LQ "cycle": one mode of duration T, xdot = a x + b u, l = 1/2 (q x^2 + r u^2), no
// terminal cost, cycle reset x+ = x. With the cyclic value the terminal P of each sweep is
// gamma_c P(0) of the previous one.
struct CyclicLq {
  double a = 0.5, b = 1.0, q = 2.0, r = 0.5, T = 0.3;
  LinearSwitchedSystem sys{{Matrix::Constant(1, 1, a)}, {Matrix::Constant(1, 1, b)},
                           {Matrix::Identity(1, 1)}, {}, {}, {}, /*cycle_reset=*/true};
  QuadraticCost cost{{Matrix::Constant(1, 1, q)}, {Matrix::Constant(1, 1, r)}, {0.0},
                     {Matrix::Zero(1, 1)}, {Vector::Zero(1)}};
  Problem problem;
  Trajectory traj;
  CyclicLq() {
    SetScalarProblem(sys, cost, &problem);
    traj.modes.resize(1);
    const int N = 61;
    traj.modes[0].t = Vector::LinSpaced(N, 0.0, T);
    traj.modes[0].x = Matrix::Constant(1, N, 0.2);
    traj.modes[0].u = Matrix::Constant(1, N, 0.1);
    traj.T = Vector::Constant(1, T);
    traj.x0 = traj.modes[0].x.col(0);
  }
  // Sizes `pass` for this problem with `settings` and runs it on the cycle.
  void RunPass(BackwardPass* pass, const BackwardPassSettings& settings) const {
    pass->Allocate(problem, 100, settings);
    pass->Run(traj);
  }
  // kRiccati without regularization, swept until P(0) is settled to 1e-12.
  static BackwardPassSettings Settings(double cyclic_value) {
    BackwardPassSettings settings;
    settings.equation = BackwardEquation::kRiccati;
    settings.integrator = BackwardIntegrator::kRk4;
    settings.cyclic_value = cyclic_value;
    settings.cyclic_max_sweeps = 200;
    settings.cyclic_tolerance = 1e-12;
    return settings;
  }
  // P(0) of dP/dt = -(2 a P + q - P^2 b^2 / r) from P(T) = PT, fine RK4, written here.
  double Flow(double PT) const {
    auto f = [&](double P) { return 2 * a * P + q - P * P * b * b / r; };
    double P = PT;
    const int M = 30000;
    const double h = T / M;
    for (int i = 0; i < M; ++i) {
      const double k1 = f(P), k2 = f(P + 0.5 * h * k1), k3 = f(P + 0.5 * h * k2),
                   k4 = f(P + h * k3);
      P += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    return P;
  }
};

TEST(BackwardPass, CyclicValueConvergesToTheStationaryRiccatiSolution) {
  // gamma_c = 1: the periodic solution of a time-invariant LQ problem is the algebraic Riccati
  // solution 2 a P + q - P^2 b^2 / r = 0, P = r (a + sqrt(a^2 + q b^2 / r)) / b^2.
  CyclicLq lq;
  const BackwardPassSettings settings = CyclicLq::Settings(1.0);
  BackwardPass pass;
  lq.RunPass(&pass, settings);
  const double care = lq.r * (lq.a + std::sqrt(lq.a * lq.a + lq.q * lq.b * lq.b / lq.r)) /
                      (lq.b * lq.b);
  EXPECT_NEAR(pass.P(0, 0)(0, 0), care, 1e-6 * care);
  EXPECT_NEAR(pass.P(0, 60)(0, 0), care, 1e-6 * care);  // stationary along the cycle
  EXPECT_GT(pass.sweeps(), 5);
  // One pass without the cyclic value starts from P(T) = 0 and is far from it.
  BackwardPassSettings single = settings;
  single.cyclic_value = 0.0;
  BackwardPass plain;
  lq.RunPass(&plain, single);
  EXPECT_EQ(plain.sweeps(), 1);
  EXPECT_NEAR(plain.P(0, 0)(0, 0), lq.Flow(0.0), 1e-6 * lq.Flow(0.0));
  EXPECT_LT(plain.P(0, 0)(0, 0), 0.8 * care);
  // A second Run is warm-started from the stored P(0): it is already a fixed point.
  pass.Run(lq.traj);
  EXPECT_LE(pass.sweeps(), 2);
  // After ResetCyclicValue it starts again from 0.
  pass.ResetCyclicValue();
  pass.Run(lq.traj);
  EXPECT_GT(pass.sweeps(), 5);
}

TEST(BackwardPass, DiscountedCyclicValueIsAFixedPointOfTheCycleMap) {
  // gamma_c < 1: P0 = Flow(gamma_c P0), checked with the independent RK4 flow above.
  CyclicLq lq;
  const BackwardPassSettings settings = CyclicLq::Settings(0.6);
  BackwardPass pass;
  lq.RunPass(&pass, settings);
  const double P0 = pass.P(0, 0)(0, 0);
  EXPECT_NEAR(P0, lq.Flow(0.6 * P0), 1e-6 * P0);
  EXPECT_NEAR(pass.P(0, 60)(0, 0), 0.6 * P0, 1e-9 * P0);  // the terminal condition
  // The Lyapunov form (the paper's (30)) ignores the option.
  BackwardPassSettings lyap = settings;
  lyap.equation = BackwardEquation::kLyapunov;
  BackwardPass lp;
  lq.RunPass(&lp, lyap);
  EXPECT_EQ(lp.sweeps(), 1);
  EXPECT_EQ(lp.P(0, 60)(0, 0), 0.0);
}

TEST(BackwardPass, CyclicValueRunDoesNotAllocateAndRejectsBadWeights) {
  CyclicLq lq;
  BackwardPassSettings settings;
  settings.equation = BackwardEquation::kRiccati;
  settings.cyclic_value = 0.9;
  BackwardPass pass;
  lq.RunPass(&pass, settings);
  pass.ResetCyclicValue();
  {
    MallocCounter counter;
    pass.Run(lq.traj);
    EXPECT_EQ(counter.count(), 0);
  }
  for (double bad : {-0.1, 1.5, std::nan("")}) {
    settings.cyclic_value = bad;
    BackwardPass b;
    EXPECT_THROW(b.Allocate(lq.problem, 100, settings), InvalidArgument) << bad;
  }
}

// With the cyclic value the pass sweeps the same intervals several times: a batch system and
// cost are evaluated once per Run (two calls each for the one mode), not once per sweep, give
// the per-point fixed point bit for bit, and a Run allocates nothing (the C++ batch default).
TEST(BackwardPass, BatchEvaluationIsOncePerRunNotPerSweep) {
  CyclicLq lq;
  BackwardPassSettings settings = CyclicLq::Settings(1.0);
  settings.keep_P_trajectory = true;
  BackwardPass reference;
  lq.RunPass(&reference, settings);
  ASSERT_GT(reference.sweeps(), 5);
  BatchingSystem sys(lq.sys);
  BatchingCost cost(lq.cost);
  Problem problem = lq.problem;
  problem.system = &sys;
  problem.cost = &cost;
  BackwardPass pass;
  pass.Allocate(problem, 100, settings);
  ASSERT_TRUE(pass.Run(lq.traj));
  ExpectSamePass(reference, pass, 1);
  EXPECT_EQ(sys.batch_calls, 2);
  EXPECT_EQ(cost.batch_calls, 2);
  EXPECT_EQ(sys.batch_points, 2 * 60);
  EXPECT_EQ(sys.point_calls + cost.point_calls, 0);
  pass.ResetCyclicValue();
  {
    MallocCounter counter;
    pass.Run(lq.traj);
    EXPECT_EQ(counter.count(), 0);
  }
  EXPECT_EQ(sys.batch_calls, 4);
}

TEST(BackwardPass, ACyclicValueCanBeSeeded) {
  CyclicLq lq;
  const BackwardPassSettings settings = CyclicLq::Settings(1.0);
  BackwardPass pass;
  pass.Allocate(lq.problem, lq.traj.total_samples(), settings);
  EXPECT_EQ(pass.cyclic_value().size(), 0) << "before a Run: from 0";
  ASSERT_TRUE(pass.Run(lq.traj));
  const Matrix P0 = pass.cyclic_value();
  ASSERT_EQ(P0.rows(), 1);
  EXPECT_EQ(P0(0, 0), pass.P(0, 0)(0, 0));
  // A fresh pass seeded with the fixed point starts there: one sweep, the same P(0).
  BackwardPass seeded;
  seeded.Allocate(lq.problem, lq.traj.total_samples(), settings);
  seeded.SeedCyclicValue(P0);
  EXPECT_EQ(seeded.cyclic_value(), P0);
  ASSERT_TRUE(seeded.Run(lq.traj));
  EXPECT_EQ(seeded.sweeps(), 1);
  EXPECT_NEAR(seeded.P(0, 0)(0, 0), P0(0, 0), 1e-4 * P0(0, 0));
  // Bad seeds are named.
  EXPECT_THROW(seeded.SeedCyclicValue(Matrix::Zero(2, 2)), InvalidArgument);
  EXPECT_THROW(seeded.SeedCyclicValue(Matrix::Constant(1, 1, std::nan(""))), InvalidArgument);
  BackwardPass unallocated;
  EXPECT_THROW(unallocated.SeedCyclicValue(P0), InvalidArgument);
  BackwardPassSettings bad = settings;
  bad.min_substeps = 0;
  EXPECT_THROW(unallocated.Allocate(lq.problem, 100, bad), InvalidArgument);
}

TEST(BackwardPass, KeepsPOnlyAtModeEndsUnlessAsked) {
  const ScalarLqSetup setup{ScalarLq{}};
  const Trajectory traj = setup.Exact(100);
  BackwardPass pass;
  pass.Allocate(setup.problem, 100);
  pass.Run(traj);
  EXPECT_NO_THROW(pass.P(0, 0));
  EXPECT_NO_THROW(pass.P(0, 99));
  EXPECT_THROW(pass.P(0, 50), InvalidArgument);
  EXPECT_NO_THROW(pass.p(0, 50));
}

TEST(BackwardPass, RejectsMismatchedTrajectories) {
  const ScalarLqSetup setup{ScalarLq{}};
  BackwardPass pass;
  EXPECT_THROW(pass.Run(setup.Exact(10)), InvalidArgument);  // not allocated
  pass.Allocate(setup.problem, 50);
  EXPECT_THROW(pass.Run(setup.Exact(51)), InvalidArgument);  // too many samples
  Trajectory bad = setup.Exact(10);
  bad.modes[0].x.resize(2, 10);
  bad.modes[0].x.setZero();
  EXPECT_THROW(pass.Run(bad), InvalidArgument);  // n_0 = 2 instead of 1
  Trajectory two = setup.Exact(10);
  two.modes.push_back(two.modes[0]);
  EXPECT_THROW(pass.Run(two), InvalidArgument);  // K = 2
}

// The on-bound tolerance of the box-aware pass (kOnBoundTolerance), on both bounds. A pure
// integrator with a terminal cost (a = q = 0: p = s x(T) along the nominal) has a constant
// optimal input u* = -b s x0 / (r + b^2 s T). The nominal u0 = u* -/+ delta lies 1e-9 inside
// u_max (resp. u_min), within the tolerance 1e-9 x range, and the gradient pushes it out by a
// full step between delta and (1 + b^2 s T / r) delta = 8.2 delta, smaller than the 1e-9 gap:
// only the tolerance makes the input count as on its bound, so its step and gain row are zero
// (a free input would get two-sided feedback that the plant's QP clips on one side). With the
// bound far away the same nominal's input is free and has feedback.
TEST(BackwardPass, AnInputARoundingErrorInsideItsBoundHasNoGain) {
  ScalarLq lq;
  lq.a = 0.0;
  lq.q = 0.0;
  const double u_star = -lq.b * lq.s * lq.x0 / (lq.r + lq.b * lq.b * lq.s * lq.T);
  const double delta = 1e-11, gap = 1e-9;
  const int N = 241;
  for (const bool upper : {true, false}) {
    lq.u0 = upper ? u_star - delta : u_star + delta;
    ScalarLqSetup setup{lq};
    Trajectory traj;
    traj.modes.resize(1);
    ModeTrajectory& mode = traj.modes[0];
    mode.t = Vector::LinSpaced(N, 0.0, lq.T);
    mode.x = (lq.x0 + lq.b * lq.u0 * mode.t.array()).matrix().transpose();
    mode.u = Matrix::Constant(1, N, lq.u0);
    traj.T = Vector::Constant(1, lq.T);
    traj.x0 = mode.x.col(0);
    BackwardPass free_pass;
    free_pass.Allocate(setup.problem, N, BackwardPassSettings());
    free_pass.Run(traj);
    for (int j : {0, 120, N - 2}) {
      const double k = free_pass.Step(0, j)(0);
      // The step pushes out of the box, by less than the gap to the bound.
      EXPECT_GT(upper ? k : -k, 0.5 * delta) << "upper " << upper << " j " << j;
      EXPECT_LT(upper ? k : -k, 0.2 * gap) << "upper " << upper << " j " << j;
      EXPECT_GT(free_pass.Gain(0, j).norm(), 0.1) << "far from its bounds the input has feedback";
    }
    if (upper) {
      setup.problem.bounds.u_max(0) = lq.u0 + gap;
    } else {
      setup.problem.bounds.u_min(0) = lq.u0 - gap;
    }
    BackwardPass pass;
    pass.Allocate(setup.problem, N, BackwardPassSettings());
    pass.Run(traj);
    for (int j = 0; j + 1 < N; ++j) {
      EXPECT_EQ(pass.Step(0, j)(0), 0.0) << (upper ? "u_max" : "u_min") << " j " << j;
      EXPECT_EQ(pass.Gain(0, j).norm(), 0.0)
          << "an input 1e-9 inside " << (upper ? "u_max" : "u_min") << " keeps feedback at j " << j;
    }
  }
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
