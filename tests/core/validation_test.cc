// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Every validation error: empty mode sequences, mismatched dimensions, reversed or empty
// bounds, non-finite inputs. Each message must name the offending quantity.
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "ddoc/cost.h"
#include "ddoc/learner.h"
#include "ddoc/check_derivatives.h"
#include "ddoc/linear_system.h"
#include "ddoc/quadratic_cost.h"
#include "ddoc/switching_time_update.h"
#include "test_systems.h"
#include "test_util.h"

namespace ddoc {
namespace testing {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Expects InvalidArgument whose message contains `needle`.
template <class F>
void ExpectError(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "expected InvalidArgument containing '" << needle << "'";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
        << "message '" << e.what() << "' does not mention '" << needle << "'";
  }
}

struct Base {
  LinearSwitchedSystem sys{{Matrix::Zero(2, 2), Matrix::Zero(3, 3)},
                           {Matrix::Ones(2, 1), Matrix::Ones(3, 1)},
                           {Matrix::Ones(3, 2), Matrix::Ones(2, 3)}};
  QuadraticCost cost{{Matrix::Identity(2, 2), Matrix::Identity(3, 3)},
                     {Matrix::Identity(1, 1), Matrix::Identity(1, 1)},
                     {0, 0},
                     {Matrix::Identity(2, 2), Matrix::Identity(3, 3)},
                     {Vector::Zero(2), Vector::Zero(3)}};
  Problem problem;
  Base() {
    problem = BoxProblem(sys, cost, 1, 0.1, 1.0);
  }
  Trajectory Valid() const {
    Trajectory t;
    t.modes.resize(2);
    t.modes[0].t = Vector::LinSpaced(3, 0.0, 0.5);
    t.modes[0].x = Matrix::Zero(2, 3);
    t.modes[0].u = Matrix::Zero(1, 3);
    t.modes[1].t = Vector::LinSpaced(4, 0.5, 1.0);
    t.modes[1].x = Matrix::Zero(3, 4);
    t.modes[1].u = Matrix::Zero(1, 4);
    t.T = Eigen::Vector2d(0.5, 1.0);
    t.x0 = Vector::Zero(2);
    return t;
  }
};

// A one-mode system of state size 1 with a given input dimension (construction checks only).
class WithInputDim : public SwitchedSystem {
 public:
  explicit WithInputDim(int m) : SwitchedSystem({1}, m) {}

 protected:
  void DoFlow(int, const ConstVectorRef&, const ConstVectorRef&, VectorRef xdot) const override {
    xdot.setZero();
  }
  void DoFlowDerivatives(int, const ConstVectorRef&, const ConstVectorRef&, MatrixRef fx,
                         MatrixRef fu) const override {
    fx.setZero();
    fu.setZero();
  }
  void DoReset(int, const ConstVectorRef& x, VectorRef x_next) const override { x_next = x; }
  void DoResetDerivative(int, const ConstVectorRef&, MatrixRef gx) const override {
    gx.setIdentity();
  }
};

TEST(Validation, SwitchedSystemConstruction) {
  using LS = LinearSwitchedSystem;
  ExpectError([] { LS s({}, {Matrix::Ones(1, 1)}, {}); }, "empty mode sequence");
  ExpectError([] { LS s({Matrix::Zero(0, 0)}, {Matrix::Ones(0, 1)}, {Matrix::Zero(0, 0)}); },
              "state dimension n_0 = 0");
  ExpectError([] { WithInputDim s(-1); }, "input dimension m = -1, expected >= 0");
  // m = 0 (pure switching-time optimization) is a valid system.
  EXPECT_NO_THROW(LS({Matrix::Zero(2, 2)}, {Matrix::Ones(2, 0)}, {Matrix::Zero(2, 2)}));
}

TEST(Validation, SwitchedSystemCallsCheckSizesAndFiniteness) {
  Base b;
  Vector xdot(2), x(2), u(1);
  x.setZero();
  u.setZero();
  ExpectError([&] { b.sys.Flow(0, Vector::Zero(3), u, xdot); }, "Flow(k=0): x has size 3, expected 2");
  ExpectError([&] { b.sys.Flow(0, x, Vector::Zero(2), xdot); }, "u has size 2, expected 1");
  ExpectError([&] { b.sys.Flow(5, x, u, xdot); }, "mode k = 5 out of range");
  Vector bad = x;
  bad(1) = kNaN;
  ExpectError([&] { b.sys.Flow(0, bad, u, xdot); }, "x has a non-finite entry at index 1");
  Matrix fx(2, 3), fu(2, 1);
  ExpectError([&] { b.sys.FlowDerivatives(0, x, u, fx, fu); }, "fx is 2x3, expected 2x2");
  Vector xn(2);
  ExpectError([&] { b.sys.Reset(0, x, xn); }, "x_next has size 2, expected 3");
  Vector x1(3);
  x1.setZero();
  Vector xn0(2);
  ExpectError([&] { b.sys.Reset(1, x1, xn0); }, "no cycle reset");
  Vector h(1);
  ExpectError([&] { b.sys.Surface(0, x, h); }, "no switching surface");
  Vector lx(2), lu(1);
  Matrix lxx(2, 2), luu(1, 1), lux(1, 3);
  ExpectError([&] { b.cost.RunningDerivatives(0, x, u, lx, lu, lxx, luu, lux); },
              "lux is 1x3, expected 1x2");
  ExpectError([&] { b.cost.Running(0, bad, u); }, "non-finite");
}

// The batch interface of a C++ system and cost: by default the per-point evaluations, bit for
// bit, at every point of a batch; wrong shapes and non-finite points are named.
TEST(Validation, BatchDefaultsAreThePerPointEvaluations) {
  NonlinearSystem sys;
  NonlinearCost cost;
  EXPECT_FALSE(sys.prefers_batch());
  EXPECT_FALSE(cost.prefers_batch());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> draw(-1.5, 1.5);
  const int N = 5, m = sys.input_dim();
  for (int k = 0; k < sys.num_modes(); ++k) {
    const int n = sys.state_dim(k);
    const Matrix X = Matrix::NullaryExpr(n, N, [&]() { return draw(rng); });
    const Matrix U = Matrix::NullaryExpr(m, N, [&]() { return draw(rng); });
    Matrix F(n, N), FX(n, n * N), FU(n, m * N), LX(n, N), LU(m, N), LXX(n, n * N),
        LUU(m, m * N), LUX(m, n * N);
    Vector l(N);
    sys.FlowBatch(k, X, U, F);
    sys.FlowDerivativesBatch(k, X, U, FX, FU);
    cost.RunningBatch(k, X, U, l);
    cost.RunningDerivativesBatch(k, X, U, LX, LU, LXX, LUU, LUX);
    for (int j = 0; j < N; ++j) {
      Vector f(n), lx(n), lu(m);
      Matrix fx(n, n), fu(n, m), lxx(n, n), luu(m, m), lux(m, n);
      sys.Flow(k, X.col(j), U.col(j), f);
      sys.FlowDerivatives(k, X.col(j), U.col(j), fx, fu);
      cost.RunningDerivatives(k, X.col(j), U.col(j), lx, lu, lxx, luu, lux);
      EXPECT_TRUE(F.col(j) == f) << "k " << k << " j " << j;
      EXPECT_TRUE(FX.middleCols(j * n, n) == fx) << "k " << k << " j " << j;
      EXPECT_TRUE(FU.middleCols(j * m, m) == fu) << "k " << k << " j " << j;
      EXPECT_EQ(l(j), cost.Running(k, X.col(j), U.col(j))) << "k " << k << " j " << j;
      EXPECT_TRUE(LX.col(j) == lx && LU.col(j) == lu) << "k " << k << " j " << j;
      EXPECT_TRUE(LXX.middleCols(j * n, n) == lxx) << "k " << k << " j " << j;
      EXPECT_TRUE(LUU.middleCols(j * m, m) == luu) << "k " << k << " j " << j;
      EXPECT_TRUE(LUX.middleCols(j * n, n) == lux) << "k " << k << " j " << j;
    }
    // Wrong shapes and a non-finite point are named.
    Matrix F_bad(n, N + 1), FX_bad(n, n * N - 1);
    ExpectError([&] { sys.FlowBatch(k, X, U, F_bad); },
                "FlowBatch(k=" + std::to_string(k) + "): F is " + std::to_string(n) + "x" +
                    std::to_string(N + 1) + ", expected " + std::to_string(n) + "x" +
                    std::to_string(N));
    ExpectError([&] { sys.FlowDerivativesBatch(k, X, U, FX_bad, FU); }, "FX is");
    ExpectError([&] { sys.FlowBatch(k, X, U.leftCols(N - 1), F); }, "U is");
    ExpectError([&] { sys.FlowBatch(k, X.topRows(n - 1), U, F); }, "X is");
    Vector l_bad(N + 2);
    ExpectError([&] { cost.RunningBatch(k, X, U, l_bad); }, "l has size");
    Matrix X_nan = X;
    X_nan(n - 1, 3) = kNaN;
    ExpectError([&] { sys.FlowBatch(k, X_nan, U, F); },
                "X has a non-finite entry at point 3, index " + std::to_string(n - 1));
    ExpectError([&] { cost.RunningBatch(k, X_nan, U, l); }, "at point 3");
  }
}

TEST(Validation, ProblemNamesEachProblem) {
  Base b;
  EXPECT_NO_THROW(b.problem.Validate());
  auto with = [&](auto edit, const std::string& needle) {
    Problem p = b.problem;
    edit(p);
    ExpectError([&] { p.Validate(); }, needle);
  };
  with([](Problem& p) { p.system = nullptr; }, "system is null");
  with([](Problem& p) { p.cost = nullptr; }, "cost is null");
  with([](Problem& p) { p.bounds.u_min = Vector(); }, "bounds.u_min is empty");
  with([](Problem& p) { p.bounds.u_max = Vector::Ones(2); }, "bounds.u_max has size 2, expected 1");
  with([](Problem& p) { p.bounds.duration_min = Vector::Ones(3); },
       "bounds.duration_min has size 3, expected 2");
  with([](Problem& p) { p.surface_weights = Vector::Zero(1); }, "surface_weights has size 1");
  with([](Problem& p) { p.bounds.u_min(0) = 2; }, "reversed input bounds: u_min(0) = 2 > u_max(0)");
  with([](Problem& p) { p.bounds.duration_min(1) = 2; }, "reversed duration bounds: duration_min(1)");
  with([](Problem& p) { p.bounds.duration_min(0) = -0.5; }, "duration_min(0) = -0.5, expected >= 0");
  with([](Problem& p) { p.bounds.u_max(0) = kNaN; }, "bounds.u_max(0) = nan is NaN");
  with([](Problem& p) { p.bounds.u_min(0) = kInf; }, "empty input box: u_min(0) = inf");
  with([](Problem& p) { p.bounds.u_max(0) = -kInf; }, "empty input box: u_min(0) = -1, u_max(0) = -inf");
  with([](Problem& p) { p.bounds.final_time_min = 3; p.bounds.final_time_max = 2; },
       "reversed final-time bounds: final_time_min = 3 > final_time_max = 2");
  with([](Problem& p) { p.bounds.final_time_min = -1; }, "final-time bounds [-1, inf]");
  with([](Problem& p) { p.bounds.final_time_max = kNaN; }, "final_time_max not NaN");
  with([](Problem& p) { p.bounds.FixFinalTime(100); },
       "final-time bounds [100, 100] cannot be met by the duration bounds");
  with([](Problem& p) { p.bounds.duration_max(1) = kInf; }, "duration_max(1) = inf is not finite");
  with([](Problem& p) { p.surface_weights(0) = -1; }, "surface_weights(0) = -1");
  with([](Problem& p) { p.surface_weights(1) = 1; }, "has no switching surface");
  // Unbounded inputs are valid.
  Problem unbounded = b.problem;
  unbounded.bounds.u_min(0) = -kInf;
  unbounded.bounds.u_max(0) = kInf;
  EXPECT_NO_THROW(unbounded.Validate());
}

TEST(Validation, TrajectoryNamesEachProblem) {
  Base b;
  EXPECT_NO_THROW(b.Valid().Validate(b.sys));
  auto with = [&](auto edit, const std::string& needle) {
    Trajectory t = b.Valid();
    edit(t);
    ExpectError([&] { t.Validate(b.sys); }, needle);
  };
  with([](Trajectory& t) { t.modes.clear(); }, "empty mode sequence");
  with([](Trajectory& t) { t.T = Vector::Ones(3); }, "T has size 3, expected K = 2");
  with([](Trajectory& t) { t.modes[1].t.resize(1); t.modes[1].t(0) = 0.5; }, "mode 1: has 1 samples");
  with([](Trajectory& t) { t.modes[0].x = Matrix::Zero(2, 2); }, "mode 0: t has 3 samples but x has 2");
  with([](Trajectory& t) { t.modes[1].u = Matrix::Zero(2, 4); }, "mode 1: u has 2 rows, expected m = 1");
  with([](Trajectory& t) { t.modes[0].t(1) = 0.6; }, "decreasing sample times");
  with([](Trajectory& t) { t.modes[0].t(1) = kNaN; }, "t(1) is not finite");
  with([](Trajectory& t) { t.modes[0].x(1, 2) = kInf; }, "mode 0: x(1, 2) = inf is not finite");
  with([](Trajectory& t) { t.modes[1].u(0, 0) = kNaN; }, "mode 1: u(0, 0) = nan is not finite");
  with([](Trajectory& t) { t.modes[0].t(0) = 0.1; }, "trials start at t = 0");
  with([](Trajectory& t) { t.T(0) = 0.4; }, "last sample at t = 0.5, expected T(0) = 0.4");
  with([](Trajectory& t) { t.x0 = Vector::Ones(2); }, "x0 differs");
  with([](Trajectory& t) { t.x0 = Vector::Ones(3); }, "x0 has size 3");
  with([](Trajectory& t) { t.modes[1].x = Matrix::Zero(2, 4); }, "mode 1: x has 2 rows, expected n_1 = 3");
  // A negative duration (a zero one is a vanished mode, legal with duration_min = 0).
  with(
      [](Trajectory& t) {
        t.modes[1].t.setConstant(0.4);
        t.T(1) = 0.4;
      },
      "first sample at t = 0.4, expected the mode start 0.5");
  Trajectory vanished = b.Valid();
  vanished.modes[1].t.setConstant(0.5);
  vanished.T(1) = 0.5;
  vanished.Validate();
  EXPECT_EQ(vanished.Tau(1, 0), 1.0);
  EXPECT_EQ(vanished.Tau(1, vanished.modes[1].num_samples() - 1), 2.0);
}

TEST(Validation, EngineObjectsRejectBadSettingsAndInputs) {
  Base b;
  // Learner settings.
  auto settings_error = [&](auto edit, const std::string& needle) {
    LearnerSettings s;
    edit(s);
    ExpectError([&] { Learner l(b.problem, s); }, needle);
  };
  settings_error([](LearnerSettings& s) { s.c = 0; }, "c must be > 0");
  settings_error([](LearnerSettings& s) { s.gamma = 1; }, "gamma must be in (0, 1)");
  settings_error([](LearnerSettings& s) { s.alpha_initial = 2; }, "alpha_initial");
  settings_error([](LearnerSettings& s) { s.epsilon = -1; }, "epsilon");
  settings_error([](LearnerSettings& s) { s.delta_i = 0; }, "delta_i");
  // Problem validation reaches every engine object.
  Problem broken = b.problem;
  broken.bounds.u_min(0) = 5;
  ExpectError([&] { Learner l(broken); }, "reversed input bounds");
  ExpectError([&] { BackwardPass p; p.Allocate(broken, 10); }, "reversed input bounds");
  ExpectError([&] { OnlineController c; c.Allocate(broken, 10); }, "reversed input bounds");
  ExpectError([&] { ModelPlant m(broken); }, "reversed input bounds");
  ExpectError([&] { EvaluateCost(broken, b.Valid()); }, "reversed input bounds");
  // Cost of a mismatched trajectory.
  Trajectory t = b.Valid();
  t.modes[1].x = Matrix::Zero(2, 4);
  ExpectError([&] { EvaluateCost(b.problem, t); }, "expected n_1 = 3");
  // Switching-time update inputs.
  ExpectError(
      [&] {
        SolveSwitchingTimeUpdate(b.problem, Vector::Ones(3), Matrix::Identity(2, 2),
                                 Vector::Zero(2), 1.0);
      },
      "T has size 3");
  ExpectError(
      [&] {
        SolveSwitchingTimeUpdate(b.problem, Eigen::Vector2d(0.5, 1.0), Matrix::Identity(2, 2),
                                 Eigen::Vector2d(kNaN, 0), 1.0);
      },
      "non-finite");
  // Learner initial trajectory with a non-finite state.
  Learner learner(b.problem);
  Trajectory nan_traj = b.Valid();
  nan_traj.modes[0].x(0, 1) = kNaN;
  ExpectError([&] { learner.Initialize(nan_traj); }, "is not finite");
  // Controller loaded with an invalid alpha.
  BackwardPass pass;
  pass.Allocate(b.problem, 10);
  pass.Run(b.Valid());
  OnlineController ctrl;
  ctrl.Allocate(b.problem, 10);
  ExpectError([&] { ctrl.Load(b.Valid(), pass, -1.0, Vector::Zero(2)); }, "alpha = -1");
  ExpectError([&] { ctrl.Load(b.Valid(), pass, 1.0, Eigen::Vector2d(-0.6, 0)); },
              "planned duration of mode 0");
}

TEST(Validation, SwitchingTimeUpdateRegularizesAndRespectsDurationBounds) {
  Base b;
  // Indefinite P22: Levenberg-Marquardt makes the QP convex; the step is bounded by (7).
  Matrix P22(2, 2);
  P22 << -1, 0, 0, 2;
  const Eigen::Vector2d T(0.5, 1.0), p2(1.0, -1.0);
  const SwitchingTimeStep step = SolveSwitchingTimeUpdate(b.problem, T, P22, p2, 1.0);
  EXPECT_GT(step.regularization, 0.0);
  const double D0 = step.T_planned(0), D1 = step.T_planned(1) - step.T_planned(0);
  EXPECT_GE(D0, 0.1 - 1e-12);
  EXPECT_LE(D0, 1.0 + 1e-12);
  EXPECT_GE(D1, 0.1 - 1e-12);
  EXPECT_LE(D1, 1.0 + 1e-12);
  // Positive definite P22 and an interior solution: the exact Newton step -alpha P22^{-1} p2.
  Matrix H(2, 2);
  H << 40, 5, 5, 30;
  const SwitchingTimeStep newton = SolveSwitchingTimeUpdate(b.problem, T, H, p2, 0.5);
  EXPECT_EQ(newton.regularization, 0.0);
  EXPECT_LT((newton.dT - (-0.5 * H.llt().solve(Vector(p2)))).norm(), 1e-10);
}


// The matrices of a two-mode linear system with a rectangular reset (2 states, then 3).
struct TwoModeMatrices {
  Matrix A0{2, 2}, A1{3, 3}, B0{2, 1}, B1{3, 1}, E0{3, 2};
  TwoModeMatrices() {
    A0 << 0, 1, -2, -0.3;
    A1 = Matrix::Identity(3, 3) * -0.5;
    B0 << 0, 1;
    B1 << 1, 0, 2;
    E0 << 1, 0, 0, 1, 0.5, 0.5;
  }
};

// ddoc::LinearSystem: the flow, reset and their derivatives are the matrices; every wrong size
// is named.
TEST(LinearSystem, EvaluatesItsMatricesAndNamesWrongSizes) {
  const TwoModeMatrices mats;
  const Matrix &A0 = mats.A0, &A1 = mats.A1, &B0 = mats.B0, &B1 = mats.B1, &E0 = mats.E0;
  const LinearSystem sys({A0, A1}, {B0, B1}, {E0});
  EXPECT_EQ(sys.num_modes(), 2);
  EXPECT_EQ(sys.state_dim(1), 3);
  EXPECT_EQ(sys.input_dim(), 1);
  EXPECT_FALSE(sys.has_cycle_reset());
  const Vector x = (Vector(2) << 0.3, -0.2).finished(), u = Vector::Constant(1, 0.7);
  Vector xdot(2), xn(3);
  sys.Flow(0, x, u, xdot);
  EXPECT_LT((xdot - (A0 * x + B0 * u)).norm(), 1e-15);
  sys.Reset(0, x, xn);
  EXPECT_LT((xn - E0 * x).norm(), 1e-15);
  Matrix fx(2, 2), fu(2, 1);
  sys.FlowDerivatives(0, x, u, fx, fu);
  EXPECT_EQ(fx, A0);
  EXPECT_EQ(fu, B0);
  ExpectThrowsWith([&] { sys.Reset(1, Vector::Zero(3), xn); }, "no cycle reset");
  ExpectThrowsWith([&] { LinearSystem({A0, A1}, {B0, B1}, {}); }, "0 matrices E");
  ExpectThrowsWith([&] { LinearSystem({A0, A1}, {B0}, {E0}); }, "1 matrices B");
  ExpectThrowsWith([&] { LinearSystem({Matrix::Zero(2, 3)}, {B0}, {}); }, "A[0] is (2, 3)");
  ExpectThrowsWith([&] { LinearSystem({A0, A1}, {B0, B0}, {E0}); },
                   "B[1] is (2, 1), expected (3, 1)");
  ExpectThrowsWith([&] { LinearSystem({A0, A1}, {B0, B1}, {E0.transpose()}); },
                   "E[0] is (2, 3), expected (3, 2)");
  // A NaN in a matrix is named there, not later as a non-finite state of the flow.
  Matrix bad = A1;
  bad(2, 1) = std::nan("");
  ExpectThrowsWith([&] { LinearSystem({A0, bad}, {B0, B1}, {E0}); },
                   "LinearSystem: A[1] has a non-finite entry at (2, 1)");
  Matrix bad_b = B0;
  bad_b(0, 0) = INFINITY;
  ExpectThrowsWith([&] { LinearSystem({A0, A1}, {bad_b, B1}, {E0}); },
                   "B[0] has a non-finite entry at (0, 0)");
  Matrix bad_e = E0;
  bad_e(1, 1) = std::nan("");
  ExpectThrowsWith([&] { LinearSystem({A0, A1}, {B0, B1}, {bad_e}); },
                   "E[0] has a non-finite entry at (1, 1)");
  // No inputs (m = 0) and a cycle reset.
  const LinearSystem free({A0}, {Matrix::Zero(2, 0)}, {Matrix::Identity(2, 2)});
  EXPECT_EQ(free.input_dim(), 0);
  EXPECT_TRUE(free.has_cycle_reset());
}


// ddoc::QuadraticTrackingCost: values against the formula, derivatives against central
// differences (with the LinearSystem above as the system), wrong sizes and modes named.
TEST(QuadraticTrackingCost, EvaluatesTheFormulaAndNamesWrongSizes) {
  const TwoModeMatrices mats;
  const Matrix &A0 = mats.A0, &A1 = mats.A1, &B0 = mats.B0, &B1 = mats.B1, &E0 = mats.E0;
  const LinearSystem sys({A0, A1}, {B0, B1}, {E0});
  Matrix Q0(2, 2), Q1 = Matrix::Identity(3, 3) * 2.0, R = Matrix::Constant(1, 1, 0.3);
  Q0 << 2, 0.5, 0.5, 1;
  const Vector r0 = (Vector(2) << 1, -1).finished(), r1 = Vector::Constant(3, 0.5);
  const QuadraticTrackingCost cost({Q0, Q1}, {r0, r1}, {R, R}, {0.2, 0.0},
                                   {Matrix::Zero(2, 2), Q1}, {Vector::Zero(2), r1});
  const Vector x = (Vector(2) << 0.3, -0.2).finished(), u = Vector::Constant(1, 0.7);
  const double expected = 0.5 * (x - r0).dot(Q0 * (x - r0)) + 0.5 * 0.3 * 0.49 + 0.2;
  EXPECT_NEAR(cost.Running(0, x, u), expected, 1e-15);
  for (int k = 0; k < 2; ++k) {
    const Vector xk = Vector::Constant(sys.state_dim(k), 0.4);
    const DerivativeCheckReport report = CheckDerivatives(sys, &cost, k, xk, u);
    EXPECT_TRUE(report.PassedPerEntry()) << "mode " << k << ": " << report.max_entry_error();
  }
  ExpectThrowsWith([&] { cost.Running(2, x, u); }, "mode k=2, but Q has 2 entries");
  ExpectThrowsWith([&] { cost.Running(1, x, u); }, "x has size 2");
  ExpectThrowsWith([&] { QuadraticTrackingCost({Q0}, {r0}, {R}, {0.0}, {Q0}, {}); },
                   "expected one per mode");
  ExpectThrowsWith([&] { QuadraticTrackingCost({Q0}, {r1}, {R}, {0.0}, {Q0}, {r0}); },
                   "r[0] has size 3, expected 2");
  ExpectThrowsWith([&] { QuadraticTrackingCost({Q0, Q1}, {r0, r1}, {R, Q0}, {0, 0}, {Q0, Q1},
                                               {r0, r1}); },
                   "R[1] is 2 x 2, expected 1 x 1");
  // Non-finite entries and weights without a minimum are named.
  Matrix q_nan = Q0;
  q_nan(0, 1) = std::nan("");
  ExpectThrowsWith([&] { QuadraticTrackingCost({q_nan}, {r0}, {R}, {0.0}, {Q0}, {r0}); },
                   "Q[0] has a non-finite entry at (0, 1)");
  ExpectThrowsWith([&] { QuadraticTrackingCost({Q0}, {r0}, {R}, {INFINITY}, {Q0}, {r0}); },
                   "rho[0] is not finite");
  ExpectThrowsWith([&] { QuadraticTrackingCost({Q0}, {r0}, {-R}, {0.0}, {Q0}, {r0}); },
                   "R[0] is not positive semidefinite (the smallest eigenvalue of its symmetric "
                   "part is -0.3)");
  Matrix q_indefinite(2, 2);
  q_indefinite << 1, 2, 2, 1;  // eigenvalues 3 and -1
  ExpectThrowsWith([&] { QuadraticTrackingCost({Q0}, {r0}, {R}, {0.0}, {q_indefinite}, {r0}); },
                   "S[0] is not positive semidefinite (the smallest eigenvalue of its symmetric "
                   "part is -1)");
}

// A nonsymmetric Q is the form of its symmetric part: the value 1/2 x' Q x and the derivatives
// agree with central differences (before, lx = Q x was the gradient of another function).
TEST(QuadraticTrackingCost, ANonsymmetricWeightIsItsSymmetricPart) {
  const TwoModeMatrices mats;
  const LinearSystem sys({mats.A0}, {mats.B0}, {});
  Matrix Q(2, 2), R = Matrix::Constant(1, 1, 0.3);
  Q << 2, 1.4, -0.4, 1;  // symmetric part [[2, 0.5], [0.5, 1]]
  const Vector r = (Vector(2) << 1, -1).finished();
  const QuadraticTrackingCost cost({Q}, {r}, {R}, {0.0}, {Q}, {r});
  const Vector x = (Vector(2) << 0.3, -0.2).finished(), u = Vector::Constant(1, 0.7);
  EXPECT_NEAR(cost.Running(0, x, u), 0.5 * (x - r).dot(Q * (x - r)) + 0.5 * 0.3 * 0.49, 1e-15);
  const DerivativeCheckReport report = CheckDerivatives(sys, &cost, 0, x, u);
  EXPECT_TRUE(report.PassedPerEntry()) << report.max_entry_error();
  Vector phix(2);
  Matrix phixx(2, 2);
  cost.SwitchingDerivatives(0, x, phix, phixx);
  Matrix sym(2, 2);
  sym << 2, 0.5, 0.5, 1;
  EXPECT_LT((phix - sym * (x - r)).norm(), 1e-15);
  EXPECT_LT((phixx - sym).norm(), 1e-15);
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
