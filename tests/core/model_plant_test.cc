// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// ModelPlant: RK4 accuracy, event detection by bisection, duration limits, time-based
// switching on the planned durations, custom guards.
#include <cmath>

#include <unsupported/Eigen/MatrixFunctions>
#include <gtest/gtest.h>

#include "ddoc/plant.h"
#include "test_systems.h"

namespace ddoc {
namespace testing {
namespace {

constexpr double kG = 9.81;

// Mode 0: a falling point y, v (surface h = y); mode 1: a time-based linear mode.
struct Ball {
  LinearSwitchedSystem sys;
  QuadraticCost cost;
  Problem problem;
  Ball()
      : sys({Matrix((Matrix(2, 2) << 0, 1, 0, 0).finished()), Matrix((Matrix(2, 2) << 0, 1, -1, 0).finished())},
            {Matrix((Matrix(2, 1) << 0, 1).finished()), Matrix((Matrix(2, 1) << 0, 1).finished())},
            {Matrix::Identity(2, 2), Matrix::Identity(2, 2)},
            {Matrix((Matrix(1, 2) << 1, 0).finished())}, {Vector::Zero(1)},
            {Vector((Vector(2) << 0, -kG).finished()), Vector::Zero(2)}),
        cost({Matrix::Identity(2, 2), Matrix::Identity(2, 2)},
             {Matrix::Identity(1, 1), Matrix::Identity(1, 1)}, {0, 0},
             {Matrix::Zero(2, 2), Matrix::Zero(2, 2)}, {Vector::Zero(2), Vector::Zero(2)}) {
    problem = BoxProblem(sys, cost, 1, 0.05, 2.0);
  }
};

FunctionPolicy ZeroPolicy(double d0, double d1) {
  return FunctionPolicy(Eigen::Vector2d(d0, d1),
                        [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); });
}

TEST(ModelPlant, LocatesTheSurfaceCrossingByBisection) {
  Ball ball;
  ModelPlantSettings s;
  s.dt = 1e-2;  // coarse steps: the event falls inside a step
  ModelPlant plant(ball.problem, s);
  FunctionPolicy policy = ZeroPolicy(0.3, 0.25);  // planned T_0 is ignored (state-based)
  Trajectory traj;
  plant.Run(Eigen::Vector2d(1.0, 0.0), policy, &traj);
  traj.Validate(ball.sys);
  const double t_hit = std::sqrt(2.0 / kG);
  EXPECT_NEAR(traj.T(0), t_hit, 1e-8);
  const int N = traj.modes[0].num_samples();
  EXPECT_NEAR(traj.modes[0].x(0, N - 1), 0.0, 1e-7);          // pre-switch state on h = 0
  EXPECT_NEAR(traj.modes[0].x(1, N - 1), -kG * t_hit, 1e-7);  // RK4 exact for this flow
  // Mode 1 is time-based: it lasts exactly its planned duration.
  EXPECT_NEAR(traj.T(1) - traj.T(0), 0.25, 1e-12);
  EXPECT_EQ(traj.modes[1].x.col(0), traj.modes[0].x.col(N - 1));  // identity reset
}

TEST(ModelPlant, DurationLimitsBoundTheModes) {
  Ball ball;
  ModelPlant plant(ball.problem);
  FunctionPolicy policy = ZeroPolicy(0.3, 5.0);
  Trajectory traj;
  // Thrown upwards hard: no crossing before duration_max = 2 s.
  plant.Run(Eigen::Vector2d(1.0, 50.0), policy, &traj);
  EXPECT_NEAR(traj.T(0), 2.0, 1e-12);
  EXPECT_NEAR(traj.T(1) - traj.T(0), 2.0, 1e-12);  // planned 5 s, clamped to the maximum
  // Starting below the surface: the mode ends at duration_min.
  plant.Run(Eigen::Vector2d(-0.5, 0.0), policy, &traj);
  EXPECT_NEAR(traj.T(0), 0.05, 1e-12);
  // A planned duration below the minimum is raised to it.
  FunctionPolicy short_policy = ZeroPolicy(0.3, 0.001);
  plant.Run(Eigen::Vector2d(1.0, 0.0), short_policy, &traj);
  EXPECT_NEAR(traj.T(1) - traj.T(0), 0.05, 1e-12);
}

TEST(ModelPlant, TimeBasedRk4MatchesTheMatrixExponential) {
  Ball ball;
  ModelPlantSettings s;
  s.dt = 1e-2;
  s.time_based_only = true;
  ModelPlant plant(ball.problem, s);
  FunctionPolicy policy = ZeroPolicy(0.123456, 0.987654);  // not multiples of dt
  Trajectory traj;
  const Eigen::Vector2d x0(1.0, 0.5);
  plant.Run(x0, policy, &traj);
  EXPECT_NEAR(traj.T(0), 0.123456, 1e-12);
  EXPECT_NEAR(traj.T(1), 0.123456 + 0.987654, 1e-12);
  // Mode 1 is the harmonic oscillator: x(T) = expm(A D) x(T_0).
  Matrix A = ball.sys.A_[1];
  const Matrix expAD = (A * 0.987654).exp();
  const Vector expected = expAD * traj.modes[1].x.col(0);
  EXPECT_LT((traj.modes[1].x.rightCols(1) - expected).norm(), 1e-9);
}

TEST(ModelPlant, CustomGuard) {
  Ball ball;
  ModelPlant plant(ball.problem);
  // Mode 0 ends when the ball passes y = 0.5 instead of y = 0.
  plant.set_guard([](int k, const ConstVectorRef& x, const ConstVectorRef&) {
    return k == 0 ? x(0) - 0.5 : 1.0;
  });
  FunctionPolicy policy = ZeroPolicy(0.3, 0.2);
  Trajectory traj;
  plant.Run(Eigen::Vector2d(1.0, 0.0), policy, &traj);
  EXPECT_NEAR(traj.T(0), std::sqrt(2 * 0.5 / kG), 1e-8);
  // With the custom guard mode 1 (guard always positive) runs to duration_max.
  EXPECT_NEAR(traj.T(1) - traj.T(0), 2.0, 1e-12);
  plant.set_guard(nullptr);  // default again
  plant.Run(Eigen::Vector2d(1.0, 0.0), policy, &traj);
  EXPECT_NEAR(traj.T(0), std::sqrt(2.0 / kG), 1e-8);
}

TEST(ModelPlant, OpenLoopPolicyReplaysARecordedTrialInNormalizedTime) {
  Ball ball;
  ModelPlantSettings s;
  s.time_based_only = true;
  ModelPlant plant(ball.problem, s);
  FunctionPolicy original(Eigen::Vector2d(0.3, 0.25),
                          [](int k, double tau, const ConstVectorRef&, VectorRef u) {
                            u(0) = std::sin(3 * tau) + k;
                          });
  Trajectory first, replayed, stretched;
  plant.Run(Eigen::Vector2d(1.0, 0.0), original, &first);
  OpenLoopPolicy replay(first);
  plant.Run(Eigen::Vector2d(1.0, 0.0), replay, &replayed);
  ASSERT_EQ(replayed.total_samples(), first.total_samples());
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT((replayed.modes[k].u - first.modes[k].u).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((replayed.modes[k].x - first.modes[k].x).cwiseAbs().maxCoeff(), 1e-12);
  }
  // With other planned switching instants the inputs follow tau, not t.
  OpenLoopPolicy longer(first, Eigen::Vector2d(0.6, 0.85));
  plant.Run(Eigen::Vector2d(1.0, 0.0), longer, &stretched);
  EXPECT_NEAR(stretched.T(0), 0.6, 1e-12);
  EXPECT_NEAR(stretched.T(1), 0.85, 1e-12);
  const int N = stretched.modes[0].num_samples();
  EXPECT_NEAR(stretched.modes[0].u(0, N / 2), std::sin(3 * stretched.Tau(0, N / 2)), 1e-4);
}

TEST(ModelPlant, RejectsBadInput) {
  Ball ball;
  ModelPlant plant(ball.problem);
  FunctionPolicy policy = ZeroPolicy(0.3, 0.2);
  Trajectory traj;
  EXPECT_THROW(plant.Run(Vector::Zero(3), policy, &traj), InvalidArgument);
  Vector nan_x = Eigen::Vector2d(std::nan(""), 0.0);
  EXPECT_THROW(plant.Run(nan_x, policy, &traj), InvalidArgument);
  FunctionPolicy nan_policy(Eigen::Vector2d(0.3, 0.2),
                            [](int, double, const ConstVectorRef&, VectorRef u) {
                              u.setConstant(std::nan(""));
                            });
  EXPECT_THROW(plant.Run(Eigen::Vector2d(1.0, 0.0), nan_policy, &traj), InvalidArgument);
  ModelPlantSettings bad;
  bad.dt = 0;
  EXPECT_THROW(ModelPlant(ball.problem, bad), InvalidArgument);
}

}  // namespace
}  // namespace testing
}  // namespace ddoc
