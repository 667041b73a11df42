// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// EvaluateCost against the exact integral of the running cost along a zero-order-hold input:
// second order in the sample spacing, and no first-order bias from the input at the right end
// of an interval.
#include <cmath>

#include <gtest/gtest.h>

#include "ddoc/cost.h"
#include "ddoc/plant.h"
#include "test_systems.h"

namespace ddoc {
namespace testing {
namespace {

// xdot = a x + b u, l = 1/2 (q x^2 + r u^2), phi = 0, one mode of duration T.
struct Scalar {
  double a = -0.8, b = 1.5, q = 2.0, r = 0.3, T = 1.3, x0 = 1.0;
  LinearSwitchedSystem sys{{Matrix::Constant(1, 1, a)}, {Matrix::Constant(1, 1, b)},
                           {Matrix::Identity(1, 1)}};
  QuadraticCost cost{{Matrix::Constant(1, 1, q)}, {Matrix::Constant(1, 1, r)}, {0.0},
                     {Matrix::Zero(1, 1)}, {Vector::Zero(1)}};
  Problem problem;
  Scalar() {
    problem = BoxProblem(sys, cost, 10, 0.1, 5);
  }
  // The exact cost of the input sequence u_j held on [t_j, t_{j+1}] (the samples' inputs), from
  // x0 with the exact solution x(s) = (x_j + c) e^{a s} - c, c = b u / a, on each interval.
  double ExactCost(const ModeTrajectory& mode) const {
    double x = x0, total = 0;
    for (int j = 0; j + 1 < mode.num_samples(); ++j) {
      const double h = mode.t(j + 1) - mode.t(j), u = mode.u(0, j), c = b * u / a;
      const double e1 = std::exp(a * h), e2 = std::exp(2 * a * h);
      const double int_x2 = (x + c) * (x + c) * (e2 - 1) / (2 * a) -
                            2 * c * (x + c) * (e1 - 1) / a + c * c * h;
      total += 0.5 * q * int_x2 + 0.5 * r * u * u * h;
      x = (x + c) * e1 - c;
    }
    return total;
  }
};

TEST(EvaluateCost, ZeroOrderHoldQuadratureIsSecondOrder) {
  Scalar s;
  double previous_error = 0;
  for (double dt : {4e-3, 2e-3, 1e-3, 5e-4}) {
    ModelPlantSettings ps;
    ps.dt = dt;
    ModelPlant plant(s.problem, ps);
    FunctionPolicy policy(Vector::Constant(1, s.T),
                          [](int, double tau, const ConstVectorRef&, VectorRef u) {
                            u(0) = 2.0 * std::sin(3.0 * tau) + 0.5;
                          });
    Trajectory traj;
    plant.Run(Vector::Constant(1, s.x0), policy, &traj);
    const double exact = s.ExactCost(traj.modes[0]);
    const double error = std::abs(EvaluateCost(s.problem, traj).total - exact);
    // The trapezoid of l with the held input: error ~ C dt^2 (C ~ 0.1 here).
    EXPECT_LT(error, 0.5 * dt * dt) << "dt " << dt;
    if (previous_error > 0) {
      EXPECT_GT(previous_error / error, 3.5) << "second order: the error quarters with dt";
    }
    previous_error = error;
    // The quadrature that takes the NEXT sample's input at an interval's right end (the plant
    // holds u_j there) is first-order biased: far above this.
    double next_input = 0;
    const ModeTrajectory& m = traj.modes[0];
    for (int j = 0; j + 1 < m.num_samples(); ++j) {
      const auto l = [&](int i, int iu) {
        return 0.5 * (s.q * m.x(0, i) * m.x(0, i) + s.r * m.u(0, iu) * m.u(0, iu));
      };
      next_input += 0.5 * (m.t(j + 1) - m.t(j)) * (l(j, j) + l(j + 1, j + 1));
    }
    EXPECT_GT(std::abs(next_input - exact), 20 * error) << "dt " << dt;
  }
}

// A cost that prefers_batch() is evaluated by one RunningBatch call per mode (both ends of
// every interval), with the per-point loop's sum: the same bits.
TEST(EvaluateCost, ABatchCostIsOneCallPerModeWithThePerPointResult) {
  NonlinearSystem sys;
  NonlinearCost inner;
  BatchingCost per_point(inner, false), batched(inner, true);
  const Problem a = MakeNonlinearProblem(sys, per_point), b = MakeNonlinearProblem(sys, batched);
  ModelPlant plant(a);
  FunctionPolicy policy(Eigen::Vector3d(0.4, 0.3, 0.5),
                        [](int k, double tau, const ConstVectorRef&, VectorRef u) {
                          u(0) = std::sin(3.0 * tau) + 0.1 * k;
                          u(1) = 0.5 - tau;
                        });
  Trajectory traj;
  plant.Run(Eigen::Vector3d(0.2, -0.1, 0.3), policy, &traj);
  const CostBreakdown expected = EvaluateCost(a, traj), got = EvaluateCost(b, traj);
  EXPECT_EQ(got.total, expected.total);
  EXPECT_TRUE(got.running == expected.running) << got.running.transpose();
  EXPECT_TRUE(got.switching == expected.switching);
  EXPECT_EQ(batched.point_calls, 0);
  EXPECT_EQ(batched.batch_calls, 3);
  EXPECT_EQ(batched.batch_points, 2 * (traj.total_samples() - 3));
  EXPECT_EQ(per_point.batch_calls, 0);
  EXPECT_EQ(per_point.point_calls, 2 * (traj.total_samples() - 3));
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
