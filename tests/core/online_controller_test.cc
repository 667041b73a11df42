// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// OnlineController (33)-(34): against an independent evaluation of (33)-(34), the time
// mapping and its clamping, robustness to non-finite input, int |du|^2, no allocation.
#include <cmath>
#include <functional>
#include <random>

#include <gtest/gtest.h>

#include "ddoc/backward_pass.h"
#include "ddoc/online_controller.h"
#include "ddoc/plant.h"
#include "malloc_counter.h"
#include "test_util.h"
#include "test_systems.h"

namespace ddoc {
namespace testing {
namespace {

// Two modes (n = 4 then 3, rectangular reset), m inputs.
struct ControlSetup {
  std::unique_ptr<LinearSwitchedSystem> sys;
  std::unique_ptr<QuadraticCost> cost;
  Problem problem;
  Trajectory nominal;
  BackwardPass pass;

  explicit ControlSetup(int m, int n0 = 4, int n1 = 3, double umax = 1.0) {
    std::mt19937 rng(1);
    std::normal_distribution<double> nd;
    auto rnd = [&](int r, int c, double s) {
      Matrix M(r, c);
      for (int i = 0; i < r * c; ++i) M.data()[i] = s * nd(rng);
      return M;
    };
    Matrix E0 = rnd(n1, n0, 0.5);
    sys = std::make_unique<LinearSwitchedSystem>(
        std::vector<Matrix>{rnd(n0, n0, 0.3), rnd(n1, n1, 0.3)},
        std::vector<Matrix>{rnd(n0, m, 1.0), rnd(n1, m, 1.0)},
        std::vector<Matrix>{E0, Matrix::Identity(n0, n1)});
    Matrix R = rnd(m, m, 0.3);
    R = R * R.transpose() + Matrix::Identity(m, m);
    cost = std::make_unique<QuadraticCost>(
        std::vector<Matrix>{Matrix::Identity(n0, n0), 2 * Matrix::Identity(n1, n1)},
        std::vector<Matrix>{R, 0.5 * R}, std::vector<double>{0.1, 0.2},
        std::vector<Matrix>{Matrix::Identity(n0, n0), 3 * Matrix::Identity(n1, n1)},
        std::vector<Vector>{Vector::Constant(n0, 0.2), Vector::Constant(n1, -0.1)});
    problem.system = sys.get();
    problem.cost = cost.get();
    problem.bounds.u_min = Vector::Constant(m, -umax);
    problem.bounds.u_max = Vector::Constant(m, umax);
    problem.bounds.duration_min = Vector::Constant(2, 0.1);
    problem.bounds.duration_max = Vector::Constant(2, 3.0);
    problem.surface_weights = Vector::Zero(2);
    Vector D(2);
    D << 0.3, 0.3;
    FunctionPolicy policy(D, [m](int, double tau, const ConstVectorRef&, VectorRef u) {
      for (int i = 0; i < m; ++i) u(i) = 0.3 * std::sin(tau + i);
    });
    ModelPlant plant(problem);
    Vector x0 = Vector::Constant(n0, 0.5);
    plant.Run(x0, policy, &nominal);
    pass.Allocate(problem, nominal.total_samples());
    pass.Run(nominal);
  }
};


TEST(OnlineController, StepSolvesEquations33And34AtSamples) {
  ControlSetup s(3);
  const double alpha = 0.7;
  Vector dT(2);
  dT << 0.02, -0.01;
  OnlineController ctrl;
  ctrl.Allocate(s.problem, s.nominal.total_samples());
  ctrl.Load(s.nominal, s.pass, alpha, dT);
  EXPECT_NEAR(ctrl.PlannedDuration(0), s.nominal.T(0) + 0.02, 1e-12);
  EXPECT_NEAR(ctrl.PlannedDuration(1), s.nominal.T(1) - s.nominal.T(0) - 0.03, 1e-12);
  std::mt19937 rng(4);
  std::normal_distribution<double> nd;
  int active_cases = 0;
  for (int k = 0; k < 2; ++k) {
    const int n = s.sys->state_dim(k);
    for (int j : {0, 5, 77, s.pass.num_samples(k) - 1}) {
      const double tau = s.pass.tau(k, j);
      const double t = (tau - k) * ctrl.PlannedDuration(k);
      Vector x = s.nominal.modes[k].x.col(j);
      Vector dx(n);
      for (int i = 0; i < n; ++i) dx(i) = 0.5 * nd(rng);
      x += dx;
      // Independent (34) and (33).
      Vector dz(n + 2);
      dz << dx, dT;
      const Vector b = s.pass.Gain(k, j) * dz + s.pass.Feedforward(k, j);
      const Vector unom = s.nominal.modes[k].u.col(j);
      const Vector du = testing::BruteForceBoxQp(s.pass.Luu(k, j), alpha * b, s.problem.bounds.u_min - unom,
                                   s.problem.bounds.u_max - unom);
      Vector u(3);
      ctrl.Step(k, t, x, u);
      EXPECT_LT((u - (unom + du)).cwiseAbs().maxCoeff(), 1e-7) << "k " << k << " j " << j;
      for (int i = 0; i < 3; ++i) {
        active_cases += std::abs(u(i)) >= 1.0 - 1e-12;
      }
    }
  }
  EXPECT_GT(active_cases, 0) << "some input bound should be active in this test";
}

// Steps `ctrl` at random deviations dx from three samples of each mode and compares u with the
// brute-force box QP (33) for b = expected_b(k, j, dx) (an independent (34)).
void ExpectStepsMatchQp(const ControlSetup& s, OnlineController& ctrl, double alpha, unsigned seed,
                        const std::function<Vector(int, int, const Vector&)>& expected_b) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> nd;
  for (int k = 0; k < 2; ++k) {
    const int n = s.sys->state_dim(k);
    for (int j : {0, 33, s.pass.num_samples(k) - 1}) {
      const double t = (s.pass.tau(k, j) - k) * ctrl.PlannedDuration(k);
      Vector dx(n);
      for (int i = 0; i < n; ++i) dx(i) = 0.3 * nd(rng);
      const Vector x = s.nominal.modes[k].x.col(j) + dx;
      const Vector unom = s.nominal.modes[k].u.col(j);
      const Vector du = testing::BruteForceBoxQp(s.pass.Luu(k, j), alpha * expected_b(k, j, dx),
                                                 s.problem.bounds.u_min - unom,
                                                 s.problem.bounds.u_max - unom);
      Vector u(3);
      ctrl.Step(k, t, x, u);
      EXPECT_LT((u - (unom + du)).cwiseAbs().maxCoeff(), 1e-7) << "k " << k << " j " << j;
    }
  }
}

TEST(OnlineController, FeedbackScaleMultipliesOnlyTheStateFeedback) {
  // b = kappa (L_uz + F_u^T P)_x dx + (L_uz + F_u^T P)_T dT + L_u + F_u^T p.
  ControlSetup s(3);
  const double alpha = 0.7, kappa = 0.4;
  Vector dT(2);
  dT << 0.02, -0.01;
  OnlineControllerSettings settings;
  settings.feedback_scale = kappa;
  OnlineController ctrl;
  ctrl.Allocate(s.problem, s.nominal.total_samples(), settings);
  ctrl.Load(s.nominal, s.pass, alpha, dT);
  ExpectStepsMatchQp(s, ctrl, alpha, 5, [&](int k, int j, const Vector& dx) {
    const Matrix G = s.pass.Gain(k, j);
    const int n = static_cast<int>(dx.size());
    return Vector(kappa * G.leftCols(n) * dx + G.rightCols(2) * dT + s.pass.Feedforward(k, j));
  });
  for (double bad : {-1.0, std::nan("")}) {
    settings.feedback_scale = bad;
    OnlineController c;
    EXPECT_THROW(c.Allocate(s.problem, 10, settings), InvalidArgument) << bad;
  }
}

TEST(OnlineController, StateFeedbackScaleMultipliesSingleComponents) {
  // b = (L_uz + F_u^T P)_x diag(s_k) dx + (L_uz + F_u^T P)_T dT + L_u + F_u^T p, with s_k zeroing
  // component 1 of mode 0 and halving component 2 of mode 1.
  ControlSetup s(3);
  const double alpha = 0.7;
  Vector dT(2);
  dT << -0.01, 0.02;
  OnlineControllerSettings settings;
  settings.state_feedback_scale = {Vector::Ones(4), Vector::Ones(3)};
  settings.state_feedback_scale[0](1) = 0.0;
  settings.state_feedback_scale[1](2) = 0.5;
  OnlineController ctrl;
  ctrl.Allocate(s.problem, s.nominal.total_samples(), settings);
  ctrl.Load(s.nominal, s.pass, alpha, dT);
  ExpectStepsMatchQp(s, ctrl, alpha, 6, [&](int k, int j, const Vector& dx) {
    Vector scaled = dx;
    if (k == 0) scaled(1) = 0.0;
    if (k == 1) scaled(2) *= 0.5;
    const Matrix G = s.pass.Gain(k, j);
    const int n = static_cast<int>(dx.size());
    return Vector(G.leftCols(n) * scaled + G.rightCols(2) * dT + s.pass.Feedforward(k, j));
  });
  // Wrong shapes and bad entries are named.
  auto message = [&](const std::vector<Vector>& scale) {
    OnlineControllerSettings bad;
    bad.state_feedback_scale = scale;
    OnlineController c;
    try {
      c.Allocate(s.problem, 10, bad);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({Vector::Ones(4)}).find("has 1 vectors, expected 2"), std::string::npos);
  EXPECT_NE(message({Vector::Ones(4), Vector::Ones(4)}).find("state_feedback_scale[1] has 4"),
            std::string::npos);
  Vector negative = Vector::Ones(3);
  negative(0) = -0.5;
  EXPECT_NE(message({Vector::Ones(4), negative}).find("state_feedback_scale[1](0)"),
            std::string::npos);
  // Changed after Allocate to a wrong shape: Step throws instead of reading out of range.
  ctrl.settings().state_feedback_scale = {Vector::Ones(2), Vector::Ones(3)};
  Vector u(3);
  EXPECT_THROW(ctrl.Step(0, 0.0, s.nominal.modes[0].x.col(0), u), InvalidArgument);
}

TEST(OnlineController, PerInputRegularizationSolvesTheRegularizedQp) {
  // (33) with H = L_uu + diag(mu): kPerInput mu_i = reg (|L_uu,ii| + s_i^-2) with input ranges
  // s = (2, 10, 1), kScalar mu_i = reg (1 + max|diag L_uu|); each against the brute-force box QP.
  ControlSetup s(3);
  s.problem.bounds.u_min = Vector(3);
  s.problem.bounds.u_max = Vector(3);
  s.problem.bounds.u_min << -1, -5, -0.5;
  s.problem.bounds.u_max << 1, 5, 0.5;
  const Vector inv_s2 = (Vector(3) << 0.25, 0.01, 1.0).finished();
  const double alpha = 0.7, reg = 0.5;
  const Vector dT = Vector::Zero(2);
  for (const auto scaling : {RegularizationScaling::kPerInput, RegularizationScaling::kScalar}) {
    OnlineControllerSettings settings;
    settings.regularization = reg;
    settings.regularization_scaling = scaling;
    OnlineController ctrl;
    ctrl.Allocate(s.problem, s.nominal.total_samples(), settings);
    ctrl.Load(s.nominal, s.pass, alpha, dT);
    std::mt19937 rng(5);
    std::normal_distribution<double> nd;
    double max_diff_other = 0;  // vs the other scaling's solution: must differ
    for (int k = 0; k < 2; ++k) {
      const int n = s.sys->state_dim(k);
      for (int j : {0, 5, 77, s.pass.num_samples(k) - 1}) {
        const double t = (s.pass.tau(k, j) - k) * ctrl.PlannedDuration(k);
        Vector x = s.nominal.modes[k].x.col(j);
        for (int i = 0; i < n; ++i) x(i) += 0.5 * nd(rng);
        Vector dz(n + 2);
        dz << x - s.nominal.modes[k].x.col(j), dT;
        const Vector b = s.pass.Gain(k, j) * dz + s.pass.Feedforward(k, j);
        const Matrix luu = s.pass.Luu(k, j);
        const double max_diag = luu.diagonal().cwiseAbs().maxCoeff();
        Vector mu_pi(3), mu_sc = Vector::Constant(3, reg * (1 + max_diag));
        for (int i = 0; i < 3; ++i) mu_pi(i) = reg * (std::abs(luu(i, i)) + inv_s2(i));
        const Vector unom = s.nominal.modes[k].u.col(j);
        const Vector lo = s.problem.bounds.u_min - unom, hi = s.problem.bounds.u_max - unom;
        const Matrix H_pi = luu + Matrix(mu_pi.asDiagonal());
        const Matrix H_sc = luu + Matrix(mu_sc.asDiagonal());
        const Vector du_pi = testing::BruteForceBoxQp(H_pi, alpha * b, lo, hi);
        const Vector du_sc = testing::BruteForceBoxQp(H_sc, alpha * b, lo, hi);
        const bool per_input = scaling == RegularizationScaling::kPerInput;
        Vector u(3);
        ctrl.Step(k, t, x, u);
        const Vector& mine = per_input ? du_pi : du_sc;
        const Vector& other = per_input ? du_sc : du_pi;
        EXPECT_LT((u - (unom + mine)).cwiseAbs().maxCoeff(), 1e-7)
            << "per_input " << per_input << " k " << k << " j " << j;
        max_diff_other = std::max(max_diff_other, (u - (unom + other)).cwiseAbs().maxCoeff());
      }
    }
    EXPECT_GT(max_diff_other, 1e-3) << "the two scalings should give different inputs here";
  }
}

TEST(OnlineController, TimeMappingClampsAndInterpolates) {
  ControlSetup s(2);
  OnlineController ctrl;
  ctrl.Allocate(s.problem, s.nominal.total_samples());
  ctrl.Load(s.nominal, s.pass, 1.0, Vector::Zero(2));
  Vector u(2), u_end(2), u_mid(2);
  // On the nominal state with dT = 0, u differs from u^i only by alpha*L_uu^{-1}(L_u+F_u^T p).
  const int N0 = s.pass.num_samples(0);
  const Vector x_end = s.nominal.modes[0].x.col(N0 - 1);
  ctrl.Step(0, s.nominal.T(0), x_end, u_end);
  ctrl.Step(0, 10.0 * s.nominal.T(0), x_end, u);  // mode lasts longer than planned
  EXPECT_NEAR(ctrl.last_tau(), 1.0, 0);
  EXPECT_LT((u - u_end).norm(), 1e-12);
  ctrl.Step(0, -1.0, s.nominal.modes[0].x.col(0), u);  // before the start: tau = 0
  EXPECT_EQ(ctrl.last_tau(), 0.0);
  // Midway between samples 10 and 11 with the interpolated nominal state.
  const double tau = 0.5 * (s.pass.tau(0, 10) + s.pass.tau(0, 11));
  const Vector xm = 0.5 * (s.nominal.modes[0].x.col(10) + s.nominal.modes[0].x.col(11));
  ctrl.Step(0, tau * s.nominal.T(0), xm, u_mid);
  Vector u10(2), u11(2);
  ctrl.Step(0, s.pass.tau(0, 10) * s.nominal.T(0), s.nominal.modes[0].x.col(10), u10);
  ctrl.Step(0, s.pass.tau(0, 11) * s.nominal.T(0), s.nominal.modes[0].x.col(11), u11);
  // With dx = 0, b is interpolated linearly; without active bounds u is then linear too up to
  // the interpolation of L_uu (constant here).
  EXPECT_LT((u_mid - 0.5 * (u10 + u11)).norm(), 1e-9);
}

TEST(OnlineController, NonFiniteStateGivesClampedNominalInput) {
  ControlSetup s(2);
  OnlineController ctrl;
  ctrl.Allocate(s.problem, s.nominal.total_samples());
  ctrl.Load(s.nominal, s.pass, 1.0, Vector::Zero(2));
  Vector x = s.nominal.modes[0].x.col(3);
  x(1) = std::numeric_limits<double>::quiet_NaN();
  Vector u(2);
  ctrl.Step(0, s.nominal.modes[0].t(3), x, u);
  EXPECT_TRUE(u.allFinite());
  EXPECT_EQ(ctrl.nonfinite_count(), 1);
  EXPECT_LT((u - s.nominal.modes[0].u.col(3)).norm(), 1e-9);
  ctrl.Step(0, std::numeric_limits<double>::infinity(), s.nominal.modes[0].x.col(3), u);
  EXPECT_TRUE(u.allFinite());
  EXPECT_EQ(ctrl.nonfinite_count(), 2);
  // Wrong sizes and modes are programming errors.
  Vector wrong(5);
  EXPECT_THROW(ctrl.Step(0, 0.0, wrong, u), InvalidArgument);
  EXPECT_THROW(ctrl.Step(2, 0.0, s.nominal.modes[0].x.col(0), u), InvalidArgument);
  Vector u_wrong(3);
  EXPECT_THROW(ctrl.Step(0, 0.0, s.nominal.modes[0].x.col(0), u_wrong), InvalidArgument);
}

TEST(OnlineController, AccumulatesDuSquaredOverTau) {
  ControlSetup s(2, 4, 3, 100.0);  // wide bounds: du unconstrained
  OnlineController ctrl;
  ctrl.Allocate(s.problem, s.nominal.total_samples());
  ctrl.Load(s.nominal, s.pass, 0.5, Vector::Zero(2));
  // Run on the model plant: the integral equals a left Riemann sum of |du|^2 over tau.
  ModelPlant plant(s.problem);
  Trajectory out;
  plant.Run(s.nominal.x0, ctrl, &out);
  EXPECT_GT(ctrl.du_squared_integral(), 0.0);
  // Cross-check against the learner's measured definition on this trial.
  double measured = 0;
  for (int k = 0; k < 2; ++k) {
    const auto& mode = out.modes[k];
    int cursor = 0;
    // The controller sees no Step after the last one of a mode: the interval before the
    // switch is not part of its sum.
    for (int j = 0; j + 2 < mode.num_samples(); ++j) {
      const double tau = out.Tau(k, j), tau1 = out.Tau(k, j + 1);
      // nominal input at tau by linear interpolation
      const auto& nm = s.nominal.modes[k];
      while (cursor < nm.num_samples() - 2 && s.nominal.Tau(k, cursor + 1) < tau) ++cursor;
      const double t0 = s.nominal.Tau(k, cursor), t1 = s.nominal.Tau(k, cursor + 1);
      const double w = std::min(1.0, std::max(0.0, (tau - t0) / (t1 - t0)));
      const Vector unom = (1 - w) * nm.u.col(cursor) + w * nm.u.col(cursor + 1);
      measured += (mode.u.col(j) - unom).squaredNorm() * (tau1 - tau);
    }
  }
  EXPECT_NEAR(ctrl.du_squared_integral(), measured, 1e-9 * (1 + measured));
}

TEST(OnlineController, StepDoesNotAllocate) {
  ASSERT_TRUE(MallocCountingWorks());
  ControlSetup s(4, 14, 10);  // hopper-like sizes
  OnlineController ctrl;
  ctrl.Allocate(s.problem, 2000);
  ctrl.Load(s.nominal, s.pass, 0.5, Vector::Constant(2, 0.01));
  Vector u(4);
  Vector x0 = s.nominal.modes[0].x.col(0) + Vector::Constant(14, 0.3);
  Vector x1 = s.nominal.modes[1].x.col(0) + Vector::Constant(10, -0.3);
  ctrl.BeginTrial();
  const Vector zero = Vector::Zero(2);
  MallocCounter counter;
  for (int i = 0; i < 300; ++i) ctrl.Step(0, i * 1e-3, x0, u);
  for (int i = 0; i < 300; ++i) ctrl.Step(1, i * 1e-3, x1, u);
  EXPECT_EQ(counter.count(), 0) << "Step";
  // Reloading between trials does not allocate either.
  ctrl.Load(s.nominal, s.pass, 0.25, zero);
  EXPECT_EQ(counter.count(), 0) << "Load";
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
