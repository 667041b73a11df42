// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// The two-mode linear-quadratic problem of the learner and trial-driver tests.
#ifndef DDOC_TESTS_CORE_TWO_MODE_LQ_H_
#define DDOC_TESTS_CORE_TWO_MODE_LQ_H_

#include <algorithm>

#include "ddoc/learner.h"
#include "ddoc/policy.h"
#include "ddoc/problem.h"
#include "test_systems.h"

namespace ddoc {
namespace testing {

// xdot = A_k x + B_k u; mode 0: double integrator, mode 1: weakly actuated damped oscillator.
// l_k = 1/2 x'Q_k x + 1/2 r u^2 + rho_k, phi_1 = 1/2 x'S x, phi_0 = 0.
struct TwoModeLq {
  Eigen::Matrix2d A0, A1, Q0, Q1, S;
  Eigen::Vector2d B0, B1, x0;
  double r = 0.5, rho0 = 0.25, rho1 = 0.05;
  double b_scale = 1.0;  // input gain of the plant (model mismatch when != 1)
  TwoModeLq() {
    A0 << 0, 1, 0, 0;
    A1 << 0, 1, -1, -0.3;
    B0 << 0, 1;
    B1 << 0, 0.1;
    Q0 = Eigen::Vector2d(1, 0.1).asDiagonal();
    Q1 = Eigen::Vector2d(4, 0.4).asDiagonal();
    S = Eigen::Vector2d(5, 1).asDiagonal();
    x0 << 1, 0;
  }
};

struct LqProblem {
  TwoModeLq lq;
  LinearSwitchedSystem sys;
  QuadraticCost cost;
  Problem problem;
  explicit LqProblem(const TwoModeLq& l)
      : lq(l),
        sys({Matrix(l.A0), Matrix(l.A1)}, {Matrix(l.b_scale * l.B0), Matrix(l.b_scale * l.B1)},
            {Matrix::Identity(2, 2), Matrix::Identity(2, 2)}),
        cost({Matrix(l.Q0), Matrix(l.Q1)}, {Matrix::Constant(1, 1, l.r), Matrix::Constant(1, 1, l.r)},
             {l.rho0, l.rho1}, {Matrix::Zero(2, 2), Matrix(l.S)}, {Vector::Zero(2), Vector::Zero(2)}) {
    problem.system = &sys;
    problem.cost = &cost;
    problem.bounds.u_min = Vector::Constant(1, -50);
    problem.bounds.u_max = Vector::Constant(1, 50);
    problem.bounds.duration_min = Eigen::Vector2d(0.2, 0.3);
    problem.bounds.duration_max = Eigen::Vector2d(2.0, 3.0);
    problem.surface_weights = Vector::Zero(2);
  }
};

// u = 0 with planned durations (1, 1): the initial law u^0, T^0 of most tests.
// Learner settings of the LQ tests: tight convergence, room for many trials.
inline LearnerSettings LqTestSettings() {
  LearnerSettings s;
  s.epsilon = 1e-7;
  s.max_trials = 1500;
  s.max_samples = 10000;
  return s;
}

inline FunctionPolicy ZeroInputPolicy() {
  return FunctionPolicy(Eigen::Vector2d(1.0, 1.0),
                        [](int, double, const ConstVectorRef&, VectorRef u) { u.setZero(); });
}

// blend_feedback tests: u^0 = the inputs of `nominal` plus the feedback of a pass with mu = 2
// around it, a law whose gains differ from those of a learner at mu = 0.
inline OnlineController StiffFeedbackLaw(const Problem& problem, const Trajectory& nominal) {
  LearnerSettings s = LqTestSettings();
  s.max_samples = 20000;
  s.regularization_min = 2.0;
  Learner model(problem, s);
  model.Initialize(nominal);
  return model.ConvergedPolicy(0.0);
}

// The largest input difference of two runs over mode 0's common samples (same start and dt).
inline double MaxInputDifferenceInMode0(const Trajectory& a, const Trajectory& b) {
  const int N = std::min(a.modes[0].num_samples(), b.modes[0].num_samples());
  return (a.modes[0].u.leftCols(N) - b.modes[0].u.leftCols(N)).cwiseAbs().maxCoeff();
}

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_TWO_MODE_LQ_H_
