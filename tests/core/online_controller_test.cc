// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// OnlineController (33)-(34): against an independent evaluation of (33)-(34), the time
// mapping and its clamping, robustness to non-finite input, int |du|^2, no allocation.
#include <cmath>
#include <utility>
#include <functional>
#include <limits>
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

  explicit ControlSetup(int m, int n0 = 4, int n1 = 3, double umax = 1.0,
                        BackwardEquation equation = BackwardEquation::kRiccati, double mu = 0.0) {
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
    BackwardPassSettings settings;
    settings.equation = equation;
    pass.Allocate(problem, nominal.total_samples(), settings);
    pass.Run(nominal, mu);
  }
};

// b of (34) computed independently from the pass's outputs: alpha on all of b for kLyapunov,
// on the feed-forward only for kRiccati; `scaled_dx` is the (possibly scaled) state deviation.
Vector IndependentB(const ControlSetup& s, int k, int j, const Vector& scaled_dx, const Vector& dT,
                    double alpha) {
  const Matrix G = s.pass.Gain(k, j);
  const int n = static_cast<int>(scaled_dx.size());
  const Vector feedback = G.leftCols(n) * scaled_dx + G.rightCols(dT.size()) * dT;
  if (s.pass.settings().equation == BackwardEquation::kLyapunov) {
    return alpha * (feedback + s.pass.Feedforward(k, j));
  }
  // kRiccati: the feed-forward is the pass's full box step k, as -H k (alpha k minimizes the QP
  // at dx = 0, dT = 0).
  return feedback - alpha * Matrix(s.pass.Hessian(k, j)) * s.pass.Step(k, j);
}


TEST(OnlineController, StepSolvesEquations33And34AtSamples) {
  // Both conventions, and H = L_uu + mu I with the pass's mu.
  for (const auto equation : {BackwardEquation::kLyapunov, BackwardEquation::kRiccati}) {
    ControlSetup s(3, 4, 3, 1.0, equation, 0.3);
    const double alpha = 0.7;
    Vector dT(2);
    dT << 0.02, -0.01;
    OnlineController ctrl;
    ctrl.Allocate(s.problem, s.nominal.total_samples());
    ctrl.Load(s.nominal, s.pass, alpha, dT);
    EXPECT_NEAR(ctrl.PlannedDuration(0), s.nominal.T(0) + 0.02, 1e-12);
    EXPECT_NEAR(ctrl.PlannedDuration(1), s.nominal.T(1) - s.nominal.T(0) - 0.03, 1e-12);
    EXPECT_EQ(ctrl.feedback_factor(), equation == BackwardEquation::kLyapunov ? alpha : 1.0);
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
        // Independent (34) and (33) with H = D l_uu + mu I.
        const Vector b = IndependentB(s, k, j, dx, dT, alpha);
        const double D = k == 0 ? s.nominal.T(0) : s.nominal.T(1) - s.nominal.T(0);
        const Matrix H = D * s.cost->R_[k] + 0.3 * Matrix::Identity(3, 3);
        EXPECT_LT((Matrix(s.pass.Hessian(k, j)) - H).cwiseAbs().maxCoeff(), 1e-12);
        const Vector unom = s.nominal.modes[k].u.col(j);
        const Vector du = testing::BruteForceBoxQp(H, b, s.problem.bounds.u_min - unom,
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
}

// Steps `ctrl` at random deviations dx from three samples of each mode and compares u with the
// brute-force box QP (33) for b = expected_b(k, j, dx) (an independent (34)).
void ExpectStepsMatchQp(const ControlSetup& s, OnlineController& ctrl, unsigned seed,
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
      const Vector du = testing::BruteForceBoxQp(s.pass.Hessian(k, j), expected_b(k, j, dx),
                                                 s.problem.bounds.u_min - unom,
                                                 s.problem.bounds.u_max - unom);
      Vector u(3);
      ctrl.Step(k, t, x, u);
      EXPECT_LT((u - (unom + du)).cwiseAbs().maxCoeff(), 1e-7) << "k " << k << " j " << j;
    }
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
  ExpectStepsMatchQp(s, ctrl, 6, [&](int k, int j, const Vector& dx) {
    Vector scaled = dx;
    if (k == 0) scaled(1) = 0.0;
    if (k == 1) scaled(2) *= 0.5;
    return IndependentB(s, k, j, scaled, dT, alpha);
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
  // Changed after Allocate: the same checks; a cleared scale restores the printed (34).
  EXPECT_THROW(ctrl.SetStateFeedbackScale({Vector::Ones(2), Vector::Ones(3)}), InvalidArgument);
  ctrl.SetStateFeedbackScale({});
  ctrl.Load(s.nominal, s.pass, alpha, dT);
  ExpectStepsMatchQp(s, ctrl, 7, [&](int k, int j, const Vector& dx) {
    return IndependentB(s, k, j, dx, dT, alpha);
  });
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

// BlendStateFeedback against an independent (34): the gain becomes w G + (1 - w) H H_o^{-1} G_o,
// with the other law's H_o and G_o (another pass: mu = 2) interpolated at the time since the
// mode's start at which the nominal passed the sample, mapped through the other law's planned
// duration (its dT differs); the feed-forward and the dT part are this law's.
TEST(OnlineController, BlendStateFeedbackMixesInTheOtherLawsFeedback) {
  ControlSetup s(3, 4, 3, 1.0, BackwardEquation::kRiccati, 0.3);
  BackwardPass other;
  other.Allocate(s.problem, s.nominal.total_samples(), s.pass.settings());
  other.Run(s.nominal, 2.0);
  Vector dT(2), dT_other(2);
  dT << 0.02, -0.01;
  dT_other << 0.05, -0.04;
  OnlineController law, ctrl;
  law.Allocate(s.problem, s.nominal.total_samples());
  ctrl.Allocate(s.problem, s.nominal.total_samples());
  law.Load(s.nominal, other, 0.4, dT_other);
  const double alpha = 0.7, w = 0.3;
  // The other law's effective gain H_o^{-1} G_o at tau (linear interpolation of both).
  auto other_gain = [&](int k, double tau) {
    const int n = s.sys->state_dim(k);
    int j = 0;
    while (j + 2 < other.num_samples(k) && other.tau(k, j + 1) < tau) ++j;
    const double a = (tau - other.tau(k, j)) / (other.tau(k, j + 1) - other.tau(k, j));
    const Matrix H = (1 - a) * Matrix(other.Hessian(k, j)) + a * Matrix(other.Hessian(k, j + 1));
    const Matrix G = (1 - a) * Matrix(other.Gain(k, j).leftCols(n)) +
                     a * Matrix(other.Gain(k, j + 1).leftCols(n));
    return Matrix(H.llt().solve(G));
  };
  auto expected_b = [&](double weight) {
    return [&, weight](int k, int j, const Vector& dx) {
      const int n = s.sys->state_dim(k);
      const double D = k == 0 ? s.nominal.T(0) : s.nominal.T(1) - s.nominal.T(0);
      const double t = (s.pass.tau(k, j) - k) * D;
      const double tau_other = k + std::min(1.0, t / law.PlannedDuration(k));
      const Matrix G = s.pass.Gain(k, j).leftCols(n);
      const Matrix G_blend =
          weight * G + (1 - weight) * Matrix(s.pass.Hessian(k, j)) * other_gain(k, tau_other);
      return Vector(IndependentB(s, k, j, dx, dT, alpha) + (G_blend - G) * dx);
    };
  };
  EXPECT_NE(law.PlannedDuration(0), s.nominal.T(0));  // the mapping is exercised
  for (const double weight : {1.0, w, 0.0}) {
    SCOPED_TRACE(weight);
    ctrl.Load(s.nominal, s.pass, alpha, dT);
    ctrl.BlendStateFeedback(law, weight);
    ExpectStepsMatchQp(s, ctrl, 9, expected_b(weight));
  }
  // Errors name what is wrong; the loaded law is not changed by a rejected call.
  ExpectThrowsWith([&] { ctrl.BlendStateFeedback(law, 1.5); }, "BlendStateFeedback: w = 1.5");
  ExpectThrowsWith([&] { ctrl.BlendStateFeedback(law, std::nan("")); }, "w = nan");
  OnlineController unloaded;
  unloaded.Allocate(s.problem, s.nominal.total_samples());
  ExpectThrowsWith([&] { ctrl.BlendStateFeedback(unloaded, 0.5); }, "must be loaded");
  ControlSetup two_inputs(2);
  OnlineController narrow;
  narrow.Allocate(two_inputs.problem, two_inputs.nominal.total_samples());
  narrow.Load(two_inputs.nominal, two_inputs.pass, 0.5, Vector::Zero(2));
  ExpectThrowsWith([&] { ctrl.BlendStateFeedback(narrow, 0.5); }, "2 inputs, this one 2 and 3");
  ControlSetup wide(3, 5, 3);
  OnlineController other_states;
  other_states.Allocate(wide.problem, wide.nominal.total_samples());
  other_states.Load(wide.nominal, wide.pass, 0.5, Vector::Zero(2));
  ExpectThrowsWith([&] { ctrl.BlendStateFeedback(other_states, 0.5); },
                   "mode 0 has state size 5 in the other law, 4 in this one");
  ExpectStepsMatchQp(s, ctrl, 9, expected_b(0.0));
}

// BlendStateFeedback with the feed-forward: at w = 0 a law with no step of its own commands
// what the other law commands, from states off the nominal, its clamping at tight bounds included
// (the same pass, so the same H); without the feed-forward it tracks the nominal's measured input,
// which is not the other law's command (the other law has a step of its own, alpha 0.4). With
// another pass (mu = 2) and bounds that never act, the unconstrained commands agree.
TEST(OnlineController, BlendedFeedforwardMakesTheTrialTheOtherLaw) {
  for (const bool same_pass : {true, false}) {
    SCOPED_TRACE(same_pass);
    ControlSetup s(3, 4, 3, same_pass ? 0.35 : 100.0);
    BackwardPass other;
    other.Allocate(s.problem, s.nominal.total_samples(), s.pass.settings());
    other.Run(s.nominal, 2.0);
    const Vector zero = Vector::Zero(2);
    OnlineController law, ctrl;
    law.Allocate(s.problem, s.nominal.total_samples());
    ctrl.Allocate(s.problem, s.nominal.total_samples());
    law.Load(s.nominal, same_pass ? s.pass : other, 0.4, zero);
    std::mt19937 rng(5);
    std::normal_distribution<double> nd;
    int clamped = 0;
    double tracked_gap = 0.0;
    for (int k = 0; k < 2; ++k) {
      const int n = s.sys->state_dim(k);
      for (int j = 0; j < s.pass.num_samples(k); j += 7) {
        const double t = (s.pass.tau(k, j) - k) * ctrl.PlannedDuration(k);
        Vector x = s.nominal.modes[k].x.col(j);
        for (int i = 0; i < n; ++i) x(i) += 0.3 * nd(rng);
        Vector u_law(3), u(3), u_tracking(3);
        law.Step(k, t, x, u_law);
        ctrl.Load(s.nominal, s.pass, 0.0, zero);
        ctrl.BlendStateFeedback(law, 0.0, true);
        ctrl.Step(k, t, x, u);
        EXPECT_LT((u - u_law).cwiseAbs().maxCoeff(), 1e-9) << "k " << k << " j " << j;
        ctrl.Load(s.nominal, s.pass, 0.0, zero);
        ctrl.BlendStateFeedback(law, 0.0, false);
        ctrl.Step(k, t, x, u_tracking);
        tracked_gap = std::max(tracked_gap, (u_tracking - u_law).cwiseAbs().maxCoeff());
        clamped += (u_law.cwiseAbs().array() > 0.35 - 1e-12).any();
      }
    }
    EXPECT_GT(tracked_gap, 1e-3);  // the feed-forward is what makes them agree
    if (same_pass) EXPECT_GT(clamped, 5);  // the bounds act
  }
  // At w = 1 the feed-forward changes nothing.
  ControlSetup s(3);
  OnlineController law, a, b;
  for (OnlineController* c : {&law, &a, &b}) c->Allocate(s.problem, s.nominal.total_samples());
  law.Load(s.nominal, s.pass, 0.4, Vector::Zero(2));
  a.Load(s.nominal, s.pass, 0.7, Vector::Zero(2));
  b.Load(s.nominal, s.pass, 0.7, Vector::Zero(2));
  a.BlendStateFeedback(law, 1.0, true);
  EXPECT_EQ(a.ExportLaw().c, b.ExportLaw().c);
}

// BlendStateFeedback keeps H_o^{-1} G_o of the other law for the trials of a nominal: a blend
// that reuses it equals, bit for bit, the blend of a controller that never blended before, and
// a change of the other law (a new Load) or of this controller's nominal is seen.
TEST(OnlineController, ABlendFollowsTheOtherLawsChanges) {
  ControlSetup s(3, 4, 3, 1.0, BackwardEquation::kRiccati, 0.3);
  BackwardPass pass2, pass5;
  for (auto [p, mu] : {std::pair{&pass2, 2.0}, {&pass5, 5.0}}) {
    p->Allocate(s.problem, s.nominal.total_samples(), s.pass.settings());
    p->Run(s.nominal, mu);
  }
  const Vector dT = Vector::Constant(2, 0.01), dT_other = Vector::Constant(2, 0.03);
  auto blended = [&](OnlineController& ctrl, const OnlineController& law, double w) {
    ctrl.Load(s.nominal, s.pass, 0.7, dT);
    ctrl.BlendStateFeedback(law, w);
    return ctrl.ExportLaw().Kx;
  };
  auto fresh = [&](const OnlineController& law, double w) {
    OnlineController ctrl;
    ctrl.Allocate(s.problem, s.nominal.total_samples());
    return blended(ctrl, law, w);
  };
  OnlineController law, ctrl;
  law.Allocate(s.problem, s.nominal.total_samples());
  ctrl.Allocate(s.problem, s.nominal.total_samples());
  law.Load(s.nominal, pass2, 0.4, dT_other);
  const Matrix first = blended(ctrl, law, 0.3);
  EXPECT_TRUE(first == fresh(law, 0.3));
  EXPECT_TRUE(blended(ctrl, law, 0.6) == fresh(law, 0.6)) << "the kept H_o^-1 G_o, another w";
  law.Load(s.nominal, pass5, 0.4, dT_other);  // the other law changes
  const Matrix second = blended(ctrl, law, 0.3);
  EXPECT_TRUE(second == fresh(law, 0.3));
  EXPECT_FALSE(second == first);
  OnlineController copy = law;  // the same content: the kept values still fit
  EXPECT_TRUE(blended(ctrl, copy, 0.3) == second);
  // This controller's nominal changes (other durations): the mapping changes with it.
  Trajectory shifted = s.nominal;
  for (ModeTrajectory& mode : shifted.modes) mode.t *= 1.1;
  shifted.T *= 1.1;
  ctrl.Load(shifted, s.pass, 0.7, dT);
  ctrl.BlendStateFeedback(law, 0.3);
  OnlineController other_ctrl;
  other_ctrl.Allocate(s.problem, s.nominal.total_samples());
  other_ctrl.Load(shifted, s.pass, 0.7, dT);
  other_ctrl.BlendStateFeedback(law, 0.3);
  EXPECT_TRUE(ctrl.ExportLaw().Kx == other_ctrl.ExportLaw().Kx);
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
  OnlineController other;
  other.Allocate(s.problem, 2000);
  other.Load(s.nominal, s.pass, 0.0, zero);
  const OnlineControllerLaw exported = other.ExportLaw();
  ctrl.BlendStateFeedback(other, 0.5);  // sizes the blend's buffer
  ctrl.Load(s.nominal, s.pass, 0.5, Vector::Constant(2, 0.01));
  MallocCounter counter;
  for (int i = 0; i < 300; ++i) ctrl.Step(0, i * 1e-3, x0, u);
  for (int i = 0; i < 300; ++i) ctrl.Step(1, i * 1e-3, x1, u);
  EXPECT_EQ(counter.count(), 0) << "Step";
  // Reloading between trials does not allocate either, nor does blending in another law once a
  // blend has sized its buffer (the first blend of a controller allocates it, once).
  ctrl.Load(s.nominal, s.pass, 0.25, zero);
  EXPECT_EQ(counter.count(), 0) << "Load";
  other.Load(s.nominal, s.pass, 0.1, zero);  // a changed law: H_o^-1 G_o computed again
  ctrl.BlendStateFeedback(other, 0.5);
  EXPECT_EQ(counter.count(), 0) << "BlendStateFeedback";
  ctrl.ImportLaw(exported);
  EXPECT_EQ(counter.count(), 0) << "ImportLaw";
}

// u of `a` and `b` over both modes at states off the nominal, compared bitwise.
void ExpectSameSteps(const ControlSetup& s, OnlineController& a, OnlineController& b) {
  std::mt19937 rng(7);
  std::normal_distribution<double> nd;
  const int m = static_cast<int>(s.problem.bounds.u_min.size());
  Vector ua(m), ub(m);
  a.BeginTrial();
  b.BeginTrial();
  for (int k = 0; k < 2; ++k) {
    for (int i = 0; i < 40; ++i) {
      Vector x = s.nominal.modes[k].x.col(0);
      for (Eigen::Index r = 0; r < x.size(); ++r) x(r) += 0.2 * nd(rng);
      a.Step(k, i * 0.011, x, ua);
      b.Step(k, i * 0.011, x, ub);
      ASSERT_EQ(ua, ub) << "mode " << k << " step " << i;
    }
  }
  EXPECT_EQ(a.PlannedDuration(0), b.PlannedDuration(0));
  EXPECT_EQ(a.PlannedDuration(1), b.PlannedDuration(1));
  EXPECT_EQ(a.alpha(), b.alpha());
  EXPECT_EQ(a.feedback_factor(), b.feedback_factor());
}

TEST(OnlineController, ImportedLawStepsBitwiseLikeTheExportedOne) {
  for (BackwardEquation eq : {BackwardEquation::kRiccati, BackwardEquation::kLyapunov}) {
    ControlSetup s(2, 4, 3, 0.4, eq);
    OnlineController source, other, target;
    source.Allocate(s.problem, 1000);
    other.Allocate(s.problem, 1000);
    target.Allocate(s.problem, 1000);
    EXPECT_THROW(source.ExportLaw(), InvalidArgument);
    source.Load(s.nominal, s.pass, 0.35, Vector::Constant(2, 0.02));
    other.Load(s.nominal, s.pass, 0.8, Vector::Constant(2, -0.01));
    source.BlendStateFeedback(other, 0.3);  // gains no Load alone gives
    target.Load(s.nominal, s.pass, 1.0, Vector::Zero(2));  // a law to overwrite
    const OnlineControllerLaw law = source.ExportLaw();
    EXPECT_EQ(law.tau.size(), s.nominal.total_samples());
    target.ImportLaw(law);
    ExpectSameSteps(s, source, target);
  }
}

TEST(OnlineController, ImportLawNamesTheBadFieldAndKeepsTheLoadedLaw) {
  ControlSetup s(2);
  OnlineController source, target, reference;
  EXPECT_THROW(target.ImportLaw(OnlineControllerLaw{}), InvalidArgument);  // before Allocate
  source.Allocate(s.problem, 1000);
  target.Allocate(s.problem, 1000);
  reference.Allocate(s.problem, 1000);
  source.Load(s.nominal, s.pass, 0.5, Vector::Zero(2));
  target.Load(s.nominal, s.pass, 0.9, Vector::Constant(2, 0.01));
  reference.Load(s.nominal, s.pass, 0.9, Vector::Constant(2, 0.01));
  const OnlineControllerLaw good = source.ExportLaw();
  const int S = static_cast<int>(good.tau.size());
  auto expect_error = [&](const char* label, const std::function<void(OnlineControllerLaw*)>& edit,
                          const std::string& needle) {
    OnlineControllerLaw bad = good;
    edit(&bad);
    try {
      target.ImportLaw(bad);
      ADD_FAILURE() << label << ": no error";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << label << ": " << e.what();
    }
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  expect_error("alpha", [&](OnlineControllerLaw* l) { l->alpha = nan; }, "alpha");
  expect_error(
      "factor", [](OnlineControllerLaw* l) { l->feedback_factor = 0.3; }, "feedback_factor");
  expect_error("modes", [](OnlineControllerLaw* l) { l->samples.pop_back(); }, "samples has 1");
  expect_error("count", [](OnlineControllerLaw* l) { l->samples[1] = 1; }, "samples[1] = 1");
  expect_error("max", [](OnlineControllerLaw* l) { l->samples[0] = 2000; }, "max_samples = 1000");
  expect_error("tau size", [](OnlineControllerLaw* l) { l->samples[0] -= 1; }, "tau is");
  expect_error("Kx", [&](OnlineControllerLaw* l) { l->Kx(3, S / 2) = nan; }, "Kx has a non-finite");
  expect_error("huu", [](OnlineControllerLaw* l) { l->huu.conservativeResize(3, Eigen::NoChange); },
               "huu is 3x");
  expect_error(
      "order", [&](OnlineControllerLaw* l) { std::swap(l->tau(3), l->tau(4)); }, "tau(4)");
  expect_error("range", [&](OnlineControllerLaw* l) { l->tau(S - 1) = 2.5; },
               "expected in [k, k+1]");
  expect_error("duration", [](OnlineControllerLaw* l) { l->dT(1) = -5.0; },
               "planned duration of mode 1");
  ExpectSameSteps(s, target, reference);  // every failed import left the law as it was
}

// A nominal outside the input box (a measured trial whose inputs a plant did not clip, or a law
// loaded around another problem's nominal): whatever the QP (33) returns, Step's output lies in
// [u_min, u_max]. With alpha = 0 and x on the nominal, b = 0 and the output is the nominal input
// clipped to the box (e.g. u_max = 1 for a nominal input 1.2, not 1.2); a non-finite state gives
// the clipped nominal too. Every other test's nominal lies inside the box.
TEST(OnlineController, OutputStaysInTheBoxForANominalOutsideIt) {
  for (const auto equation : {BackwardEquation::kRiccati, BackwardEquation::kLyapunov}) {
    ControlSetup s(2, 4, 3, 1.0, equation);
    Trajectory outside = s.nominal;
    for (auto& mode : outside.modes) {
      mode.u.row(0) *= 4.0;   // 0.3 sin(tau) * 4: up to 1.2 > u_max = 1
      mode.u.row(1) *= -4.0;  // down to -1.2 < u_min = -1
    }
    const Vector& umin = s.problem.bounds.u_min;
    const Vector& umax = s.problem.bounds.u_max;
    std::mt19937 rng(11);
    std::normal_distribution<double> nd;
    int nominal_outside = 0, checked = 0;
    for (const double alpha : {0.0, 0.7}) {
      OnlineController ctrl;
      ctrl.Allocate(s.problem, s.nominal.total_samples());
      ctrl.Load(outside, s.pass, alpha, Vector::Zero(2));
      for (int k = 0; k < 2; ++k) {
        const int n = s.sys->state_dim(k);
        for (int j = 0; j < s.pass.num_samples(k); j += 7) {
          const double t = (s.pass.tau(k, j) - k) * ctrl.PlannedDuration(k);
          const Vector unom = outside.modes[k].u.col(j);
          const Vector clipped = unom.cwiseMax(umin).cwiseMin(umax);
          nominal_outside += (clipped - unom).norm() > 1e-3;
          Vector x = outside.modes[k].x.col(j);
          Vector u(2);
          if (alpha == 0.0) {
            ctrl.Step(k, t, x, u);
            EXPECT_LT((u - clipped).cwiseAbs().maxCoeff(), 1e-12)
                << "alpha 0 on the nominal: k " << k << " j " << j << " u " << u.transpose()
                << " nominal " << unom.transpose();
          } else {
            for (int i = 0; i < n; ++i) x(i) += 0.5 * nd(rng);
            ctrl.Step(k, t, x, u);
          }
          ++checked;
          EXPECT_TRUE(((u - umin).array() >= 0.0).all() && ((umax - u).array() >= 0.0).all())
              << "k " << k << " j " << j << " alpha " << alpha << ": u " << u.transpose()
              << " outside [" << umin.transpose() << "] .. [" << umax.transpose() << "]";
          // A non-finite state: the clipped nominal.
          x(0) = std::numeric_limits<double>::quiet_NaN();
          ctrl.Step(k, t, x, u);
          EXPECT_LT((u - clipped).cwiseAbs().maxCoeff(), 1e-12)
              << "non-finite state: k " << k << " j " << j << " u " << u.transpose();
        }
      }
    }
    EXPECT_GT(nominal_outside, checked / 4) << "the test needs nominal inputs outside the box";
  }
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
