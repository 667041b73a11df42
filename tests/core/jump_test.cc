// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The backward pass across a mode switch against an independent reference: a two-mode linear
// system with a non-identity reset E_0 and a nonzero intermediate switching cost
// phi_0 = 1/2 (x - r_0)' S_0 (x - r_0). With u = 0 as the nominal and unbounded inputs, the
// optimal cost-to-go of the LQ problem with fixed switching instants is
// V(t, x) = 1/2 x' P(t) x + s(t)' x + const, where (in real time t, written here from scratch)
//   -dP/dt = A'P + PA + Q - P B R^-1 B' P,      -ds/dt = (A - B R^-1 B' P)' s,
//   P_1(T_1) = S_1, s_1(T_1) = -S_1 r_1,
//   at the switch: P_0(T_0) = S_0 + E_0' P_1(T_0) E_0,  s_0(T_0) = -S_0 r_0 + E_0' s_1(T_0).
// The pass (default kRiccati) must give the x-block of P = P(t), p_x = P(t) x_nom(t) + s(t) = V_x
// and the gain's x-block D B' P (its stored gain is M' = (P F_u)', F_u = D B) on both sides of
// the switch. The jump terms G' P+ G, Phi_zz and Phi_z each change P or p before the switch by
// O(1) (mutants bp_jump_no_GtPG, bp_jump_no_phizz, bp_jump_no_phiz of tools/mutate).
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "ddoc/backward_pass.h"
#include "test_systems.h"

namespace ddoc {
namespace testing {
namespace {

using M2 = Eigen::Matrix2d;
using V2 = Eigen::Vector2d;

struct JumpLq {
  M2 A[2], E0, Q[2], S[2];
  V2 B[2], r[2], x0;
  double R = 0.4, T0 = 0.8, T1 = 1.5;
  JumpLq() {
    A[0] << 0, 1, -2, -0.5;
    A[1] << 0.2, 1, 0, -1;
    B[0] << 0, 1;
    B[1] << 0.5, 1;
    E0 << 1, 0.3, 0.2, 0.8;  // the reset x+ = E_0 x-
    Q[0] = V2(1, 0.5).asDiagonal();
    Q[1] = V2(2, 0.3).asDiagonal();
    S[0] << 2, 0.5, 0.5, 1;  // the intermediate switching cost
    S[1] = V2(3, 1).asDiagonal();
    r[0] << 0.3, -0.2;
    r[1] << 0.1, 0;
    x0 << 1, -0.5;
  }
};

// One RK4 step of length h backward in time (from t to t - h) of (P, s) in mode k.
void RiccatiBack(const JumpLq& lq, int k, double h, M2* P, V2* s) {
  auto fP = [&](const M2& X) -> M2 {
    return lq.A[k].transpose() * X + X * lq.A[k] + lq.Q[k] -
           X * lq.B[k] * lq.B[k].transpose() * X / lq.R;
  };
  auto fs = [&](const M2& X, const V2& y) -> V2 {
    return (lq.A[k] - lq.B[k] * lq.B[k].transpose() * X / lq.R).transpose() * y;
  };
  const M2 k1 = fP(*P);
  const V2 l1 = fs(*P, *s);
  const M2 P2 = *P + 0.5 * h * k1;
  const V2 s2 = *s + 0.5 * h * l1;
  const M2 k2 = fP(P2);
  const V2 l2 = fs(P2, s2);
  const M2 P3 = *P + 0.5 * h * k2;
  const V2 s3 = *s + 0.5 * h * l2;
  const M2 k3 = fP(P3);
  const V2 l3 = fs(P3, s3);
  const M2 P4 = *P + h * k3;
  const V2 s4 = *s + h * l3;
  const M2 k4 = fP(P4);
  const V2 l4 = fs(P4, s4);
  *P += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  *s += h / 6 * (l1 + 2 * l2 + 2 * l3 + l4);
}

// The reference on the sample grid of N samples per mode and at the interval midpoints:
// P_ref[k][2 j] at sample j, P_ref[k][2 j + 1] at the midpoint of interval j.
struct Reference {
  std::vector<M2> P[2];
  std::vector<V2> s[2];
};

Reference Solve(const JumpLq& lq, int N, int fine) {
  Reference ref;
  M2 P = lq.S[1];
  V2 s = -lq.S[1] * lq.r[1];
  for (int k = 1; k >= 0; --k) {
    const double start = k == 0 ? 0.0 : lq.T0, end = k == 0 ? lq.T0 : lq.T1;
    const int points = 2 * (N - 1) + 1;  // samples and midpoints
    ref.P[k].assign(points, M2::Zero());
    ref.s[k].assign(points, V2::Zero());
    const double h = (end - start) / (points - 1) / fine;
    ref.P[k][points - 1] = P;
    ref.s[k][points - 1] = s;
    for (int i = points - 1; i > 0; --i) {
      for (int f = 0; f < fine; ++f) RiccatiBack(lq, k, h, &P, &s);
      ref.P[k][i - 1] = P;
      ref.s[k][i - 1] = s;
    }
    if (k == 1) {  // the jump into the pre-switch state of mode 0
      s = -lq.S[0] * lq.r[0] + lq.E0.transpose() * s;
      P = lq.S[0] + lq.E0.transpose() * P * lq.E0;
    }
  }
  return ref;
}

// The nominal: u = 0, x from x0 through the reset, sampled on N points per mode (fine RK4 of the
// linear flow: exact to rounding for this test's purpose).
Trajectory Nominal(const JumpLq& lq, int N) {
  Trajectory traj;
  traj.modes.resize(2);
  V2 x = lq.x0;
  for (int k = 0; k < 2; ++k) {
    ModeTrajectory& mode = traj.modes[k];
    const double start = k == 0 ? 0.0 : lq.T0, end = k == 0 ? lq.T0 : lq.T1;
    mode.t = Vector::LinSpaced(N, start, end);
    mode.x.resize(2, N);
    mode.u = Matrix::Zero(1, N);
    const int fine = 50;
    const double h = (end - start) / (N - 1) / fine;
    for (int j = 0; j < N; ++j) {
      if (j > 0) {
        for (int f = 0; f < fine; ++f) {
          const V2 k1 = lq.A[k] * x, k2 = lq.A[k] * (x + 0.5 * h * k1),
                   k3 = lq.A[k] * (x + 0.5 * h * k2), k4 = lq.A[k] * (x + h * k3);
          x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
        }
      }
      mode.x.col(j) = x;
    }
    if (k == 0) x = lq.E0 * x;
  }
  traj.T = V2(lq.T0, lq.T1);
  traj.x0 = lq.x0;
  return traj;
}

struct JumpProblem {
  JumpLq lq;
  LinearSwitchedSystem sys;
  QuadraticCost cost;
  Problem problem;
  JumpProblem()
      : sys({Matrix(lq.A[0]), Matrix(lq.A[1])}, {Matrix(lq.B[0]), Matrix(lq.B[1])},
            {Matrix(lq.E0), Matrix::Identity(2, 2)}),
        cost({Matrix(lq.Q[0]), Matrix(lq.Q[1])},
             {Matrix::Constant(1, 1, lq.R), Matrix::Constant(1, 1, lq.R)}, {0.1, 0.2},
             {Matrix(lq.S[0]), Matrix(lq.S[1])}, {Vector(lq.r[0]), Vector(lq.r[1])}) {
    problem.system = &sys;
    problem.cost = &cost;
    const double inf = std::numeric_limits<double>::infinity();
    problem.bounds.u_min = Vector::Constant(1, -inf);
    problem.bounds.u_max = Vector::Constant(1, inf);
    problem.bounds.duration_min = Vector::Constant(2, 0.1);
    problem.bounds.duration_max = Vector::Constant(2, 3.0);
    problem.surface_weights = Vector::Zero(2);
  }
};

TEST(BackwardPassJump, PAndGainsAcrossAResetWithASwitchingCostMatchTheRiccatiReference) {
  const JumpProblem jp;
  const JumpLq& lq = jp.lq;
  const int N = 161;
  // Measured worst relative errors of this grid (RK4 pass, midpoint x of the samples, gains at
  // the half step): P 7.4e-10, p_x 2.4e-6, gain 6.8e-5; the tolerances allow ~8x that. Each of
  // the three jump mutants makes the error O(1e-1) or larger before the switch.
  const double TOL_PP = 1e-8, TOL_P = 2e-5, TOL_G = 5e-4;
  const Trajectory traj = Nominal(lq, N);
  const Reference ref = Solve(lq, N, 20);
  // The jump really matters here: before and after the switch P differs by O(1).
  ASSERT_GT((ref.P[0][2 * (N - 1)] - ref.P[1][0]).norm(), 1.0);
  ASSERT_GT((ref.s[0][2 * (N - 1)] - ref.s[1][0]).norm(), 0.3);

  BackwardPassSettings settings;  // kRiccati
  settings.integrator = BackwardIntegrator::kRk4;
  settings.keep_P_trajectory = true;
  BackwardPass pass;
  pass.Allocate(jp.problem, traj.total_samples(), settings);
  ASSERT_TRUE(pass.Run(traj));
  double worst_P = 0, worst_p = 0, worst_gain = 0;
  for (int k = 0; k < 2; ++k) {
    const double D = k == 0 ? lq.T0 : lq.T1 - lq.T0;
    for (int j = 0; j < N; ++j) {
      const M2& Pr = ref.P[k][2 * j];
      const M2 P = pass.P(k, j).topLeftCorner(2, 2);
      const double eP = (P - Pr).cwiseAbs().maxCoeff() / Pr.cwiseAbs().maxCoeff();
      EXPECT_LT(eP, TOL_PP) << "P, mode " << k << " sample " << j << "\n" << P << "\nvs\n" << Pr;
      worst_P = std::max(worst_P, eP);
      const V2 pr = Pr * traj.modes[k].x.col(j) + ref.s[k][2 * j];
      const V2 p = pass.p(k, j).head(2);
      const double ep = (p - pr).cwiseAbs().maxCoeff() / (1.0 + pr.cwiseAbs().maxCoeff());
      EXPECT_LT(ep, TOL_P) << "p_x, mode " << k << " sample " << j << ": " << p.transpose()
                          << " vs " << pr.transpose();
      worst_p = std::max(worst_p, ep);
      if (j + 1 < N) {
        // The gain of interval j is formed at its midpoint stage (P there from a half step).
        const Eigen::RowVector2d gr = D * lq.B[k].transpose() * ref.P[k][2 * j + 1];
        const Eigen::RowVector2d g = pass.Gain(k, j).leftCols(2);
        const double eg = (g - gr).cwiseAbs().maxCoeff() / gr.cwiseAbs().maxCoeff();
        EXPECT_LT(eg, TOL_G) << "gain, mode " << k << " interval " << j << ": " << g << " vs "
                            << gr;
        worst_gain = std::max(worst_gain, eg);
      }
      if (::testing::Test::HasFailure()) return;  // one sample's report is enough
    }
  }
  std::printf("worst relative errors: P %.2e, p_x %.2e, gain %.2e\n", worst_P, worst_p,
              worst_gain);
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
