// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
#include "standard_references.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/MatrixFunctions>

namespace ddoc {
namespace testing {
namespace {

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;

constexpr double kUnbounded = std::numeric_limits<double>::infinity();

double ModeStart(const Vector& T, int k) { return k == 0 ? 0.0 : T(k - 1); }

// Free instants tau = T_0..T_{K-2} <-> all instants T (T_{K-1} = final_time).
Vector InstantsWithFinal(const Vector& tau, double final_time) {
  Vector T(tau.size() + 1);
  T.head(tau.size()) = tau;
  T(tau.size()) = final_time;
  return T;
}

void CheckInstants(const Vector& T, int K, double final_time, const char* who) {
  if (T.size() != K) {
    throw std::invalid_argument(std::string(who) + ": T has size " + std::to_string(T.size()) +
                                ", expected K = " + std::to_string(K));
  }
  for (int k = 0; k < K; ++k) {
    if (!(T(k) > ModeStart(T, k))) {
      throw std::invalid_argument(std::string(who) + ": T is not increasing at mode " +
                                  std::to_string(k));
    }
  }
  if (std::abs(T(K - 1) - final_time) > 1e-12 * std::max(1.0, final_time)) {
    throw std::invalid_argument(std::string(who) + ": T(K-1) differs from the final time");
  }
}

// ---------------------------------------------------------------------------------------------
// Linear-quadratic problems in the augmented state x_a = [x; 1] (size n_k + 1), in which
// l_k = 1/2 x_a' Qa_k x_a + 1/2 u' R_k u and phi_k = 1/2 x_a' Sa_k x_a.

// [[M, -M c], [-c' M, c' M c]]: 1/2 (x - c)' M (x - c) as a quadratic form in x_a.
Matrix AugmentedQuadratic(const Matrix& M, const Vector& c) {
  const int n = static_cast<int>(M.rows());
  Matrix out(n + 1, n + 1);
  out.topLeftCorner(n, n) = M;
  out.topRightCorner(n, 1) = -M * c;
  out.bottomLeftCorner(1, n) = -(M * c).transpose();
  out(n, n) = c.dot(M * c);
  return out;
}

// One mode in the augmented state, na = n_k + 1.
struct AugmentedMode {
  Matrix A;            // na x na: [[A_k, 0], [0, 0]]
  Matrix B;            // na x m: [B_k; 0]
  Matrix G;            // na x na: B R^-1 B'
  Matrix Q;            // na x na: l_k without the input term (rho_k in the corner)
  Matrix S;            // na x na: phi_k
  Matrix Rinv;         // m x m
  Matrix E;            // (n_{k+1} + 1) x na: [[E_k, 0], [0, 1]] (k < K-1)
  Matrix hamiltonian;  // 2na x 2na: [[A, -G], [-Q, -A']]
};

std::vector<AugmentedMode> Augment(const LinearQuadraticData& d) {
  const int K = d.num_modes(), m = d.input_dim();
  std::vector<AugmentedMode> modes(K);
  for (int k = 0; k < K; ++k) {
    const int n = d.state_dim(k), na = n + 1;
    AugmentedMode& a = modes[k];
    a.A = Matrix::Zero(na, na);
    a.A.topLeftCorner(n, n) = d.A[k];
    a.B = Matrix::Zero(na, m);
    if (m > 0) a.B.topRows(n) = d.B[k];
    a.Rinv = m > 0 ? Matrix(d.R[k].inverse()) : Matrix(0, 0);
    a.G = m > 0 ? Matrix(a.B * a.Rinv * a.B.transpose()) : Matrix::Zero(na, na);
    a.Q = AugmentedQuadratic(d.Q[k], d.r[k]);
    a.Q(n, n) += 2 * d.rho[k];
    a.S = AugmentedQuadratic(d.S[k], d.s[k]);
    if (k + 1 < K) {
      const int n1 = d.state_dim(k + 1);
      a.E = Matrix::Zero(n1 + 1, na);
      a.E.topLeftCorner(n1, n) = d.E[k];
      a.E(n1, n) = 1.0;
    }
    a.hamiltonian.resize(2 * na, 2 * na);
    a.hamiltonian << a.A, -a.G, -a.Q, -a.A.transpose();
  }
  return modes;
}

// [X; Y] = exp(-H s) [I; P_end]: the Riccati solution s seconds before the end of the mode is
// P = Y X^-1, and x_a(t) = X(t) x_a(end-), costate lambda_a = Y(t) x_a(end-).
void HamiltonianFlow(const AugmentedMode& a, const Matrix& P_end, double s, Matrix* X,
                     Matrix* Y) {
  const int na = static_cast<int>(a.A.rows());
  const Matrix flow = (-s * a.hamiltonian).exp();
  *X = flow.topLeftCorner(na, na) + flow.topRightCorner(na, na) * P_end;
  *Y = flow.bottomLeftCorner(na, na) + flow.bottomRightCorner(na, na) * P_end;
}

// The exact backward pass: P_end[k] = P(T_k^-) = Sa_k + Ea_k' P(T_k^+) Ea_k (the switching
// cost and the next mode through the reset) and P_start[k] = P(T_{k-1}^+).
struct LqBackward {
  std::vector<Matrix> P_end;    // K: P at the end of mode k (incl. phi_k and the next mode)
  std::vector<Matrix> P_start;  // K: P at the start of mode k
  std::vector<Matrix> X_start;  // K: X at the start of mode k (x_a(end) = X_start^-1 x_a(start))
};

LqBackward LqBackwardPass(const std::vector<AugmentedMode>& modes, const Vector& T) {
  const int K = static_cast<int>(modes.size());
  LqBackward b;
  b.P_end.resize(K);
  b.P_start.resize(K);
  b.X_start.resize(K);
  for (int k = K - 1; k >= 0; --k) {
    b.P_end[k] = modes[k].S;
    if (k + 1 < K) b.P_end[k] += modes[k].E.transpose() * b.P_start[k + 1] * modes[k].E;
    Matrix X, Y;
    HamiltonianFlow(modes[k], b.P_end[k], T(k) - ModeStart(T, k), &X, &Y);
    b.X_start[k] = X;
    const Matrix P = Y * X.inverse();
    b.P_start[k] = 0.5 * (P + P.transpose());
  }
  return b;
}

Vector Augmented(const Vector& x) {
  Vector xa(x.size() + 1);
  xa << x, 1.0;
  return xa;
}

// H_k = l_k + lambda' (A x + B u) with the minimizing u, at x_a and P (the Riccati solution).
double LqHamiltonian(const LinearQuadraticData& d, const AugmentedMode& a, int k,
                     const Vector& xa, const Matrix& P) {
  const int n = d.state_dim(k);
  const Vector x = xa.head(n);
  const Vector lambda = (P * xa).head(n);
  Vector u = Vector::Zero(d.input_dim());
  if (d.input_dim() > 0) u = -a.Rinv * d.B[k].transpose() * lambda;
  const Vector e = x - d.r[k];
  double h = 0.5 * e.dot(d.Q[k] * e) + d.rho[k] + lambda.dot(d.A[k] * x);
  if (d.input_dim() > 0) h += 0.5 * u.dot(d.R[k] * u) + lambda.dot(d.B[k] * u);
  return h;
}

// ---------------------------------------------------------------------------------------------
// Pontryagin shooting (n = 2, m = 1).

struct ShootingState {
  Vec2 x, lambda;
  double cost;
};

// u* = clamp(-b' lambda / R, u_min, u_max), the minimizer of the Hamiltonian.
double MinimizingInput(const ShootingProblem& p, const Vec2& b, const Vec2& lambda) {
  return std::min(std::max(-b.dot(lambda) / p.R, p.u_min), p.u_max);
}

double ShootingHamiltonian(const ShootingProblem& p, int k, const Vec2& x, const Vec2& lambda) {
  Vec2 a, b;
  Mat2 a_x, b_x;
  p.fields(k, x, &a, &a_x, &b, &b_x);
  const double u = MinimizingInput(p, b, lambda);
  const Vec2 e = x - p.r;
  return 0.5 * e.dot(p.Q * e) + 0.5 * p.R * u * u + lambda.dot(a + b * u);
}

void ShootingDerivative(const ShootingProblem& p, int k, const ShootingState& y,
                        ShootingState* dy, double* u_out = nullptr) {
  Vec2 a, b;
  Mat2 a_x, b_x;
  p.fields(k, y.x, &a, &a_x, &b, &b_x);
  const double u = MinimizingInput(p, b, y.lambda);
  const Vec2 e = y.x - p.r;
  dy->x = a + b * u;
  dy->lambda = -(p.Q * e + a_x.transpose() * y.lambda + u * (b_x.transpose() * y.lambda));
  dy->cost = 0.5 * e.dot(p.Q * e) + 0.5 * p.R * u * u;
  if (u_out != nullptr) *u_out = u;
}

ShootingState Axpy(const ShootingState& y, double h, const ShootingState& k) {
  return {y.x + h * k.x, y.lambda + h * k.lambda, y.cost + h * k.cost};
}

struct ShootingRun {
  Vec2 residual;        // lambda(tf) - S (x(tf) - s)
  double cost = 0;      // running + terminal
  Vector gradient;      // K - 1 switching gradient
};

// (t, u) samples of one mode.
using InputSamples = std::vector<std::pair<double, double>>;

// One forward integration of state, costate and cost from (x0, lambda0), steps[k] uniform RK4
// steps in mode k. `samples` (optional, K entries) receives (t, u) at every step start of mode
// k and at its end.
ShootingRun Shoot(const ShootingProblem& p, const Vector& T, const std::vector<int>& steps,
                  const Vec2& lambda0, std::vector<InputSamples>* samples = nullptr) {
  const int K = p.num_modes;
  ShootingRun run;
  run.gradient = Vector::Zero(K - 1);
  ShootingState y{p.x0, lambda0, 0.0};
  for (int k = 0; k < K; ++k) {
    const double t0 = ModeStart(T, k);
    const double h = (T(k) - t0) / steps[k];
    for (int j = 0; j < steps[k]; ++j) {
      ShootingState k1, k2, k3, k4;
      double u = 0;
      ShootingDerivative(p, k, y, &k1, &u);
      if (samples != nullptr) (*samples)[k].emplace_back(t0 + j * h, u);
      ShootingDerivative(p, k, Axpy(y, 0.5 * h, k1), &k2);
      ShootingDerivative(p, k, Axpy(y, 0.5 * h, k2), &k3);
      ShootingDerivative(p, k, Axpy(y, h, k3), &k4);
      y.x += h / 6 * (k1.x + 2 * k2.x + 2 * k3.x + k4.x);
      y.lambda += h / 6 * (k1.lambda + 2 * k2.lambda + 2 * k3.lambda + k4.lambda);
      y.cost += h / 6 * (k1.cost + 2 * k2.cost + 2 * k3.cost + k4.cost);
    }
    if (samples != nullptr) {
      ShootingState dy;
      double u = 0;
      ShootingDerivative(p, k, y, &dy, &u);
      (*samples)[k].emplace_back(T(k), u);
    }
    if (k + 1 < K) {
      // Identity reset, no switching cost: x and lambda are continuous.
      run.gradient(k) = ShootingHamiltonian(p, k, y.x, y.lambda) -
                        ShootingHamiltonian(p, k + 1, y.x, y.lambda);
    }
  }
  const Vec2 e = y.x - p.s;
  run.cost = y.cost + 0.5 * e.dot(p.S * e);
  run.residual = y.lambda - p.S * e;
  return run;
}

Extremal NewtonExtremal(const ShootingProblem& p, const Vector& T, const std::vector<int>& steps,
                        const Vec2& lambda0_guess) {
  Vec2 lambda = lambda0_guess;
  ShootingRun run = Shoot(p, T, steps, lambda);
  Extremal out;
  for (int it = 0; it < 60 && run.residual.norm() > 1e-11; ++it) {
    // Jacobian of the terminal residual by forward differences (Newton still converges to
    // the rounding level; the residual is what is driven to zero).
    Mat2 J;
    for (int i = 0; i < 2; ++i) {
      const double h = 1e-7 * std::max(1.0, std::abs(lambda(i)));
      Vec2 lp = lambda;
      lp(i) += h;
      J.col(i) = (Shoot(p, T, steps, lp).residual - run.residual) / h;
    }
    const Vec2 step = -J.colPivHouseholderQr().solve(run.residual);
    // Damped Newton: halve until the residual decreases.
    double alpha = 1.0;
    ShootingRun trial = Shoot(p, T, steps, lambda + step);
    while (!(trial.residual.norm() < run.residual.norm()) && alpha > 1e-6) {
      alpha *= 0.5;
      trial = Shoot(p, T, steps, lambda + alpha * step);
    }
    if (!(trial.residual.norm() < run.residual.norm())) break;
    lambda += alpha * step;
    run = trial;
  }
  out.lambda0 = lambda;
  out.cost = run.cost;
  out.residual = run.residual.norm();
  out.gradient = run.gradient;
  out.converged = out.residual <= 1e-8;
  return out;
}

// Newton from the guess; when it fails (single shooting diverges for a poor guess: the
// state-costate system is unstable), continuation in the input weight from 1024 R down to R,
// starting at lambda(0) = 0 where the input hardly acts and the residual is almost affine; the
// continuation step (in log2 of the weight) halves on failure and grows on success.
Extremal SolveExtremalWithSteps(const ShootingProblem& p, const Vector& T,
                                const std::vector<int>& steps, const Vector& lambda0_guess) {
  Extremal e = NewtonExtremal(p, T, steps, lambda0_guess);
  if (e.converged) return e;
  ShootingProblem q = p;
  Vec2 lambda = Vec2::Zero();
  double level = 10, step = 1;  // weight = 2^level R
  q.R = p.R * std::pow(2.0, level);
  e = NewtonExtremal(q, T, steps, lambda);
  if (!e.converged) return e;
  lambda = e.lambda0;
  while (level > 0) {
    const double next = std::max(0.0, level - step);
    q.R = p.R * std::pow(2.0, next);
    const Extremal trial = NewtonExtremal(q, T, steps, lambda);
    if (trial.converged) {
      e = trial;
      lambda = e.lambda0;
      level = next;
      step = std::min(2 * step, 2.0);
    } else if ((step *= 0.5) < 1.0 / 256) {
      return trial;
    }
  }
  return e;
}

// ---------------------------------------------------------------------------------------------
// Fishing problem.

Vec2 FishingFlow(const FishingData& d, int k, const Vec2& x) {
  const double w = d.fishing[k];
  return Vec2(x(0) - x(0) * x(1) - d.c0 * x(0) * w, -x(1) + x(0) * x(1) - d.c1 * x(1) * w);
}

double FishingRunning(const FishingData& d, const Vec2& x) {
  return d.weight * ((x(0) - 1) * (x(0) - 1) + (x(1) - 1) * (x(1) - 1));
}

// Runs `solve` with step counts fixed from the guess, then again from its answer with counts
// from the answer (so that the final steps are <= h and the cost is smooth during each run).
ReferenceOptimum TwoPass(const std::function<ReferenceOptimum(const Vector& T_start)>& solve,
                         const Vector& T_guess) {
  ReferenceOptimum first = solve(T_guess);
  ReferenceOptimum second = solve(first.T);
  second.newton_iterations += first.newton_iterations;
  return second;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

double LqOptimalCost(const LinearQuadraticData& d, const Vector& T) {
  CheckInstants(T, d.num_modes(), d.final_time, "LqOptimalCost");
  const std::vector<AugmentedMode> modes = Augment(d);
  const LqBackward b = LqBackwardPass(modes, T);
  const Vector xa = Augmented(d.x0);
  return 0.5 * xa.dot(b.P_start[0] * xa);
}

double LqOptimalCostRk4(const LinearQuadraticData& d, const Vector& T, double h) {
  CheckInstants(T, d.num_modes(), d.final_time, "LqOptimalCostRk4");
  const std::vector<AugmentedMode> modes = Augment(d);
  const int K = d.num_modes();
  Matrix P;
  for (int k = K - 1; k >= 0; --k) {
    const AugmentedMode& a = modes[k];
    P = k + 1 < K ? Matrix(a.S + a.E.transpose() * P * a.E) : a.S;
    // dP/ds = A'P + PA - P G P + Q in backward time s.
    auto f = [&a](const Matrix& X) -> Matrix {
      return a.A.transpose() * X + X * a.A - X * a.G * X + a.Q;
    };
    const double D = T(k) - ModeStart(T, k);
    const int n = std::max(1, static_cast<int>(std::ceil(D / h - 1e-9)));
    const double s = D / n;
    for (int j = 0; j < n; ++j) {
      const Matrix k1 = f(P), k2 = f(P + 0.5 * s * k1), k3 = f(P + 0.5 * s * k2),
                   k4 = f(P + s * k3);
      P += s / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
  }
  const Vector xa = Augmented(d.x0);
  return 0.5 * xa.dot(P * xa);
}

Vector LqSwitchingGradient(const LinearQuadraticData& d, const Vector& T) {
  CheckInstants(T, d.num_modes(), d.final_time, "LqSwitchingGradient");
  const std::vector<AugmentedMode> modes = Augment(d);
  const LqBackward b = LqBackwardPass(modes, T);
  const int K = d.num_modes();
  Vector g(K - 1);
  Vector xa = Augmented(d.x0);
  for (int k = 0; k + 1 < K; ++k) {
    // x_a(T_k^-) = X_start^-1 x_a(T_{k-1}^+); P(T_k^-) = P_end (the jump terms included).
    const Vector xa_end = b.X_start[k].lu().solve(xa);
    const Vector xa_next = modes[k].E * xa_end;
    g(k) = LqHamiltonian(d, modes[k], k, xa_end, b.P_end[k]) -
           LqHamiltonian(d, modes[k + 1], k + 1, xa_next, b.P_start[k + 1]);
    xa = xa_next;
  }
  return g;
}

std::function<Vector(double t, const Vector& x)> LqOptimalPolicy(const LinearQuadraticData& d,
                                                                 const Vector& T) {
  CheckInstants(T, d.num_modes(), d.final_time, "LqOptimalPolicy");
  const std::vector<AugmentedMode> modes = Augment(d);
  const LqBackward b = LqBackwardPass(modes, T);
  return [d, T, modes, b](double t, const Vector& x) -> Vector {
    const int K = d.num_modes(), m = d.input_dim();
    int k = 0;
    while (k + 1 < K && t >= T(k)) ++k;
    if (m == 0) return Vector(0);
    Matrix X, Y;
    HamiltonianFlow(modes[k], b.P_end[k], std::max(0.0, T(k) - t), &X, &Y);
    const Matrix P = Y * X.inverse();
    const Vector lambda = (P * Augmented(x)).head(d.state_dim(k));
    return -modes[k].Rinv * d.B[k].transpose() * lambda;
  };
}

ReferenceOptimum LqReference(const LinearQuadraticData& d, const Vector& T_guess,
                             double min_duration) {
  const double tf = d.final_time;
  const int K = d.num_modes();
  if (K == 1) {
    ReferenceOptimum out;
    out.T = Vector::Constant(1, tf);
    out.cost = LqOptimalCost(d, out.T);
    out.gradient = Vector(0);
    return out;
  }
  auto cost = [&](const Vector& tau) { return LqOptimalCost(d, InstantsWithFinal(tau, tf)); };
  auto gradient = [&](const Vector& tau) {
    return LqSwitchingGradient(d, InstantsWithFinal(tau, tf));
  };
  return MinimizeOverInstants(cost, gradient, T_guess.head(K - 1), tf, min_duration, 1e-5,
                              1e-11);
}

double LqZeroOrderHoldOptimalCost(const LinearQuadraticData& d, const Vector& T, double dt) {
  CheckInstants(T, d.num_modes(), d.final_time, "LqZeroOrderHoldOptimalCost");
  const std::vector<AugmentedMode> modes = Augment(d);
  const int K = d.num_modes(), m = d.input_dim();
  // One step of length h in mode k: z = [x_a; u] with zdot = F z, step cost 1/2 z' M z and
  // x_a(h) = Phi_x z, by Van Loan's exponential of [[-F', W], [0, F]] h, W = diag(Qa, R).
  struct StepMaps {
    Matrix Phi_x;  // na x (na + m)
    Matrix M;      // (na + m) x (na + m)
  };
  auto step_maps = [&](int k, double h) {
    const AugmentedMode& a = modes[k];
    const int na = static_cast<int>(a.A.rows()), nz = na + m;
    Matrix F = Matrix::Zero(nz, nz);
    F.topLeftCorner(na, na) = a.A;
    F.topRightCorner(na, m) = a.B;
    Matrix W = Matrix::Zero(nz, nz);
    W.topLeftCorner(na, na) = a.Q;
    if (m > 0) W.bottomRightCorner(m, m) = d.R[k];
    Matrix C = Matrix::Zero(2 * nz, 2 * nz);
    C.topLeftCorner(nz, nz) = -F.transpose();
    C.topRightCorner(nz, nz) = W;
    C.bottomRightCorner(nz, nz) = F;
    const Matrix E = (C * h).exp();
    const Matrix Phi = E.bottomRightCorner(nz, nz);
    StepMaps s;
    s.M = Phi.transpose() * E.topRightCorner(nz, nz);
    s.M = 0.5 * (s.M + s.M.transpose());
    s.Phi_x = Phi.topRows(na);
    return s;
  };
  // Discrete Riccati backward over the plant's grid.
  Matrix P;
  for (int k = K - 1; k >= 0; --k) {
    const AugmentedMode& a = modes[k];
    const int na = static_cast<int>(a.A.rows());
    P = k + 1 < K ? Matrix(a.S + a.E.transpose() * P * a.E) : a.S;
    const double D = T(k) - ModeStart(T, k);
    const int full = static_cast<int>(std::floor(D / dt + 1e-9));
    const double last = D - full * dt;
    const StepMaps full_step = step_maps(k, dt);
    const bool has_last = last > 1e-12;
    const StepMaps last_step = has_last ? step_maps(k, last) : full_step;
    auto riccati_step = [&](const StepMaps& s) {
      const Matrix H = s.M + s.Phi_x.transpose() * P * s.Phi_x;
      if (m == 0) {
        P = H;
      } else {
        const Matrix Huu = H.bottomRightCorner(m, m);
        const Matrix Hux = H.bottomLeftCorner(m, na);
        P = H.topLeftCorner(na, na) - Hux.transpose() * Huu.ldlt().solve(Hux);
      }
      P = 0.5 * (P + P.transpose());
    };
    if (has_last) riccati_step(last_step);
    for (int j = 0; j < full; ++j) riccati_step(full_step);
  }
  const Vector xa = Augmented(d.x0);
  return 0.5 * xa.dot(P * xa);
}

ReferenceOptimum LqZeroOrderHoldReference(const LinearQuadraticData& d, double T0_lo,
                                          double T0_hi, double dt) {
  if (d.num_modes() != 2) throw std::invalid_argument("LqZeroOrderHoldReference: K != 2");
  auto J = [&](double t0) {
    Vector T(2);
    T << t0, d.final_time;
    return LqZeroOrderHoldOptimalCost(d, T, dt);
  };
  // Golden section (the ZOH cost is only piecewise smooth in T_0: its grid moves with it).
  ReferenceOptimum out;
  out.T.resize(2);
  out.T << GoldenSectionMinimum(J, T0_lo, T0_hi, 1e-9, &out.newton_iterations), d.final_time;
  out.cost = J(out.T(0));
  return out;
}

double GoldenSectionMinimum(const std::function<double(double)>& f, double lo, double hi,
                            double tolerance, int* iterations) {
  const double g = 0.5 * (std::sqrt(5.0) - 1);
  double a = lo, b = hi;
  double c = b - g * (b - a), e = a + g * (b - a);
  double fc = f(c), fe = f(e);
  int it = 0;
  while (b - a > tolerance && it < 200) {
    ++it;
    if (fc < fe) {
      b = e;
      e = c;
      fe = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = e;
      fc = fe;
      e = a + g * (b - a);
      fe = f(e);
    }
  }
  if (iterations != nullptr) *iterations = it;
  return 0.5 * (a + b);
}

// ---------------------------------------------------------------------------------------------

ShootingProblem ShootingFromLq(const LinearQuadraticData& d) {
  const int K = d.num_modes();
  if (d.input_dim() != 1) throw std::invalid_argument("ShootingFromLq: m != 1");
  for (int k = 0; k < K; ++k) {
    if (d.state_dim(k) != 2) throw std::invalid_argument("ShootingFromLq: n_k != 2");
    if (k + 1 < K && !d.E[k].isIdentity()) {
      throw std::invalid_argument("ShootingFromLq: non-identity reset");
    }
    if (k + 1 < K && !d.S[k].isZero()) {
      throw std::invalid_argument("ShootingFromLq: switching cost");
    }
    if (!d.Q[k].isApprox(d.Q[0]) || !d.r[k].isApprox(d.r[0]) || !d.R[k].isApprox(d.R[0]) ||
        d.rho[k] != 0) {
      throw std::invalid_argument("ShootingFromLq: mode-dependent running cost");
    }
  }
  ShootingProblem p;
  std::vector<Mat2> A(K);
  std::vector<Vec2> B(K);
  for (int k = 0; k < K; ++k) {
    A[k] = d.A[k];
    B[k] = d.B[k].col(0);
  }
  p.fields = [A, B](int k, const Vec2& x, Vec2* a, Mat2* a_x, Vec2* b, Mat2* b_x) {
    *a = A[k] * x;
    *a_x = A[k];
    *b = B[k];
    b_x->setZero();
  };
  p.num_modes = K;
  p.Q = d.Q[0];
  p.r = d.r[0];
  p.R = d.R[0](0, 0);
  p.S = d.S[K - 1];
  p.s = d.s[K - 1];
  p.u_min = d.u_min(0);
  p.u_max = d.u_max(0);
  p.x0 = d.x0;
  p.final_time = d.final_time;
  return p;
}

ShootingProblem ShootingFromExp1(const Exp1Data& d) {
  ShootingProblem p;
  p.fields = [](int k, const Vec2& x, Vec2* a, Mat2* a_x, Vec2* b, Mat2* b_x) {
    const double s0 = std::sin(x(0)), c0 = std::cos(x(0));
    const double s1 = std::sin(x(1)), c1 = std::cos(x(1));
    if (k == 0) {
      // ( x0 + u sin x0, -x1 - u cos x1)
      *a = Vec2(x(0), -x(1));
      *a_x << 1, 0, 0, -1;
      *b = Vec2(s0, -c1);
      *b_x << c0, 0, 0, s1;
    } else if (k == 1) {
      // ( x1 + u sin x1, -x0 - u cos x0)
      *a = Vec2(x(1), -x(0));
      *a_x << 0, 1, -1, 0;
      *b = Vec2(s1, -c0);
      *b_x << 0, c1, s0, 0;
    } else {
      // (-x0 - u sin x0,  x1 + u cos x1)
      *a = Vec2(-x(0), x(1));
      *a_x << -1, 0, 0, 1;
      *b = Vec2(-s0, c1);
      *b_x << -c0, 0, 0, -s1;
    }
  };
  p.num_modes = 3;
  p.Q = Mat2::Identity();
  p.r = d.target;
  p.R = 1.0;
  p.S = Mat2::Identity();
  p.s = d.target;
  p.x0 = d.x0;
  p.final_time = d.final_time;
  return p;
}

Extremal SolveExtremal(const ShootingProblem& p, const Vector& T, const Vector& lambda0_guess) {
  CheckInstants(T, p.num_modes, p.final_time, "SolveExtremal");
  return SolveExtremalWithSteps(p, T, StepCounts(T, p.step), lambda0_guess);
}

std::function<double(int k, double t)> ExtremalInput(const ShootingProblem& p, const Vector& T,
                                                      const Vector& lambda0) {
  std::vector<InputSamples> samples(p.num_modes);
  Shoot(p, T, StepCounts(T, p.step), lambda0, &samples);
  return [samples](int k, double t) {
    const InputSamples& s = samples.at(k);
    auto it = std::upper_bound(s.begin(), s.end(), std::make_pair(t, 1e300));
    if (it == s.begin()) return s.front().second;
    if (it == s.end()) return s.back().second;
    const auto& hi = *it;
    const auto& lo = *(it - 1);
    const double w = hi.first > lo.first ? (t - lo.first) / (hi.first - lo.first) : 0.0;
    return (1 - w) * lo.second + w * hi.second;
  };
}

ReferenceOptimum ShootingReference(const ShootingProblem& p, const Vector& T_guess,
                                   double min_duration) {
  const double tf = p.final_time;
  const int K = p.num_modes;
  Vector lambda = Vector::Zero(2);  // warm start shared by all solves
  auto solve = [&](const Vector& T_start) {
    const std::vector<int> steps = StepCounts(T_start, p.step);
    auto extremal = [&](const Vector& tau) {
      const Extremal e = SolveExtremalWithSteps(p, InstantsWithFinal(tau, tf), steps, lambda);
      if (e.converged) lambda = e.lambda0;
      return e;
    };
    auto cost = [&](const Vector& tau) {
      const Extremal e = extremal(tau);
      return e.converged ? e.cost : std::numeric_limits<double>::infinity();
    };
    auto gradient = [&](const Vector& tau) { return extremal(tau).gradient; };
    ReferenceOptimum r = MinimizeOverInstants(cost, gradient, T_start.head(K - 1), tf,
                                              min_duration, 1e-5, 1e-9);
    return r;
  };
  ReferenceOptimum out = TwoPass(solve, T_guess);
  out.lambda0 = SolveExtremal(p, out.T, lambda).lambda0;
  return out;
}

// ---------------------------------------------------------------------------------------------

std::vector<int> StepCounts(const Vector& T, double h) {
  std::vector<int> steps(T.size());
  for (int k = 0; k < T.size(); ++k) {
    steps[k] = std::max(1, static_cast<int>(std::ceil((T(k) - ModeStart(T, k)) / h - 1e-9)));
  }
  return steps;
}

double FishingCost(const FishingData& d, const Vector& T, const std::vector<int>& steps) {
  const int K = static_cast<int>(d.fishing.size());
  CheckInstants(T, K, d.final_time, "FishingCost");
  Vec2 x = d.x0;
  double cost = 0;
  for (int k = 0; k < K; ++k) {
    const double h = (T(k) - ModeStart(T, k)) / steps[k];
    for (int j = 0; j < steps[k]; ++j) {
      const Vec2 k1 = FishingFlow(d, k, x);
      const double c1 = FishingRunning(d, x);
      const Vec2 x2 = x + 0.5 * h * k1;
      const Vec2 k2 = FishingFlow(d, k, x2);
      const double c2 = FishingRunning(d, x2);
      const Vec2 x3 = x + 0.5 * h * k2;
      const Vec2 k3 = FishingFlow(d, k, x3);
      const double c3 = FishingRunning(d, x3);
      const Vec2 x4 = x + h * k3;
      const Vec2 k4 = FishingFlow(d, k, x4);
      const double c4 = FishingRunning(d, x4);
      x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      cost += h / 6 * (c1 + 2 * c2 + 2 * c3 + c4);
    }
  }
  return cost;
}

ReferenceOptimum FishingReference(const FishingData& d, const Vector& T_guess,
                                  double min_duration, double h) {
  const int K = static_cast<int>(d.fishing.size());
  const double tf = d.final_time;
  auto solve = [&](const Vector& T_start) {
    const std::vector<int> steps = StepCounts(T_start, h);
    auto cost = [&](const Vector& tau) {
      return FishingCost(d, InstantsWithFinal(tau, tf), steps);
    };
    return MinimizeOverInstants(cost, nullptr, T_start.head(K - 1), tf, min_duration, 1e-6,
                                1e-9);
  };
  return TwoPass(solve, T_guess);
}

// ---------------------------------------------------------------------------------------------

IndependentModel IndependentModelFromLq(const LinearQuadraticData& d) {
  IndependentModel m;
  m.num_modes = d.num_modes();
  m.flow = [d](int k, const Vector& x, const Vector& u) -> Vector {
    Vector xdot = d.A[k] * x;
    if (u.size() > 0) xdot += d.B[k] * u;
    return xdot;
  };
  m.running = [d](int k, const Vector& x, const Vector& u) {
    const Vector e = x - d.r[k];
    double l = 0.5 * e.dot(d.Q[k] * e) + d.rho[k];
    if (u.size() > 0) l += 0.5 * u.dot(d.R[k] * u);
    return l;
  };
  m.reset = [d](int k, const Vector& x) -> Vector { return d.E[k] * x; };
  m.switching = [d](int k, const Vector& x) {
    const Vector e = x - d.s[k];
    return 0.5 * e.dot(d.S[k] * e);
  };
  return m;
}

IndependentModel IndependentModelFromFishing(const FishingData& d) {
  IndependentModel m;
  m.num_modes = static_cast<int>(d.fishing.size());
  m.flow = [d](int k, const Vector& x, const Vector&) -> Vector {
    return FishingFlow(d, k, Vec2(x(0), x(1)));
  };
  m.running = [d](int, const Vector& x, const Vector&) {
    return FishingRunning(d, Vec2(x(0), x(1)));
  };
  m.reset = [](int, const Vector& x) { return x; };
  m.switching = [](int, const Vector&) { return 0.0; };
  return m;
}

IndependentModel IndependentModelFromExp1(const Exp1Data& d) {
  const ShootingProblem p = ShootingFromExp1(d);
  IndependentModel m;
  m.num_modes = 3;
  m.flow = [p](int k, const Vector& x, const Vector& u) -> Vector {
    Vec2 a, b;
    Mat2 a_x, b_x;
    p.fields(k, Vec2(x(0), x(1)), &a, &a_x, &b, &b_x);
    return a + b * u(0);
  };
  m.running = [d](int, const Vector& x, const Vector& u) {
    return 0.5 * (x - d.target).squaredNorm() + 0.5 * u.squaredNorm();
  };
  m.reset = [](int, const Vector& x) { return x; };
  m.switching = [d](int k, const Vector& x) {
    return k == 2 ? 0.5 * (x - d.target).squaredNorm() : 0.0;
  };
  return m;
}

namespace {

// One RK4 step of (x, cost) with input u held.
void Rk4WithCost(const IndependentModel& model, int k, const Vector& u, double h, Vector* x,
                 double* cost) {
  const Vector k1 = model.flow(k, *x, u);
  const double c1 = model.running(k, *x, u);
  const Vector x2 = *x + 0.5 * h * k1;
  const Vector k2 = model.flow(k, x2, u);
  const double c2 = model.running(k, x2, u);
  const Vector x3 = *x + 0.5 * h * k2;
  const Vector k3 = model.flow(k, x3, u);
  const double c3 = model.running(k, x3, u);
  const Vector x4 = *x + h * k3;
  const Vector k4 = model.flow(k, x4, u);
  const double c4 = model.running(k, x4, u);
  *x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  *cost += h / 6 * (c1 + 2 * c2 + 2 * c3 + c4);
}

}  // namespace

double HeldInputCost(const IndependentModel& model, const Vector& x0,
                     const std::vector<HeldInputs>& modes, int substeps) {
  const int K = model.num_modes;
  if (static_cast<int>(modes.size()) != K) {
    throw std::invalid_argument("HeldInputCost: " + std::to_string(modes.size()) +
                                " modes, expected " + std::to_string(K));
  }
  Vector x = x0;
  double cost = 0;
  for (int k = 0; k < K; ++k) {
    const HeldInputs& mode = modes[k];
    for (int j = 0; j + 1 < mode.t.size(); ++j) {
      const double h = (mode.t(j + 1) - mode.t(j)) / substeps;
      const Vector u = mode.u.col(j);
      for (int s = 0; s < substeps && h > 0; ++s) Rk4WithCost(model, k, u, h, &x, &cost);
    }
    cost += model.switching(k, x);
    if (k + 1 < K) x = model.reset(k, x);
  }
  return cost;
}

double FeedbackCost(const IndependentModel& model,
                    const std::function<Vector(double t, const Vector& x)>& law, const Vector& x0,
                    const Vector& T, double h) {
  const int K = model.num_modes;
  CheckInstants(T, K, T(K - 1), "FeedbackCost");
  Vector x = x0;
  double cost = 0;
  for (int k = 0; k < K; ++k) {
    const double start = ModeStart(T, k), D = T(k) - start;
    double elapsed = 0;
    while (elapsed < D) {
      const double step = std::min(h, D - elapsed);
      const Vector u = law(start + elapsed, x);
      Rk4WithCost(model, k, u, step, &x, &cost);
      elapsed += step;
      if (D - elapsed <= 1e-12 * (1.0 + D)) elapsed = D;
    }
    cost += model.switching(k, x);
    if (k + 1 < K) x = model.reset(k, x);
  }
  return cost;
}

double PlantGridTrapezoidCost(const IndependentModel& model, const Vector& x0, const Vector& T,
                              double dt) {
  const int K = model.num_modes;
  CheckInstants(T, K, T(K - 1), "PlantGridTrapezoidCost");
  const Vector u(0);
  Vector x = x0;
  double cost = 0;
  for (int k = 0; k < K; ++k) {
    // As ddoc::ModelPlant: steps of dt, the last one shortened, snapped onto the end.
    const double D = T(k) - ModeStart(T, k);
    double elapsed = 0;
    double l = model.running(k, x, u);
    while (elapsed < D) {
      const double h = std::min(dt, D - elapsed);
      double ignored = 0;
      Rk4WithCost(model, k, u, h, &x, &ignored);
      const double l_next = model.running(k, x, u);
      cost += 0.5 * h * (l + l_next);
      l = l_next;
      elapsed += h;
      if (D - elapsed <= 1e-12 * (1.0 + D)) elapsed = D;
    }
    cost += model.switching(k, x);
    if (k + 1 < K) x = model.reset(k, x);
  }
  return cost;
}

Vector InitialInstants(const StandardProblem& problem) {
  Vector T(problem.initial_durations.size());
  double t = 0;
  for (int k = 0; k < T.size(); ++k) T(k) = t += problem.initial_durations(k);
  T(T.size() - 1) = problem.final_time();  // exact, not a sum of rounded durations
  return T;
}

ReferenceOptimum ComputeReference(const StandardProblem& problem) {
  const std::string& name = problem.name;
  const Vector T0 = InitialInstants(problem);
  const double dmin = problem.problem.bounds.duration_min.minCoeff();
  if (name == "lqr") return LqReference(LqrData(), T0, dmin);
  if (name == "sto2_linear") return LqReference(StoLinearData(2), T0, dmin);
  if (name == "sto9_linear") return LqReference(StoLinearData(9), T0, dmin);
  if (name == "exp0") return LqReference(Exp0Data(kUnbounded), T0, dmin);
  if (name == "state_size_lq") return LqReference(StateSizeData(), T0, dmin);
  if (name == "exp0_bounded") {
    return ShootingReference(ShootingFromLq(Exp0Data(kExp0InputBound)), T0, dmin);
  }
  if (name == "exp1") {
    ShootingProblem p = ShootingFromExp1(Exp1ProblemData());
    p.step = 2e-3;  // RK4 error ~1e-11 in the cost (checked against 1e-3 by the test)
    Vector T(3);
    T << 0.2262, 1.0176, 3.0;
    return ShootingReference(p, T, dmin);
  }
  if (name == "fishing") return FishingReference(FishingProblemData(3), T0, dmin, 1e-3);
  throw std::invalid_argument("ComputeReference: unknown problem '" + name + "'");
}

IndependentModel IndependentModelOf(const StandardProblem& problem) {
  const std::string& name = problem.name;
  if (name == "lqr") return IndependentModelFromLq(LqrData());
  if (name == "sto2_linear") return IndependentModelFromLq(StoLinearData(2));
  if (name == "sto9_linear") return IndependentModelFromLq(StoLinearData(9));
  if (name == "exp0") return IndependentModelFromLq(Exp0Data(kUnbounded));
  if (name == "exp0_bounded") return IndependentModelFromLq(Exp0Data(kExp0InputBound));
  if (name == "state_size_lq") return IndependentModelFromLq(StateSizeData());
  if (name == "exp1") return IndependentModelFromExp1(Exp1ProblemData());
  if (name == "fishing") return IndependentModelFromFishing(FishingProblemData(3));
  throw std::invalid_argument("IndependentModelOf: unknown problem '" + name + "'");
}

Vector CentralDifferenceGradient(const std::function<double(const Vector&)>& cost,
                                 const Vector& tau, double h) {
  Vector g(tau.size());
  for (int i = 0; i < tau.size(); ++i) {
    Vector p = tau, m = tau;
    p(i) += h;
    m(i) -= h;
    g(i) = (cost(p) - cost(m)) / (2 * h);
  }
  return g;
}

ReferenceOptimum MinimizeOverInstants(const std::function<double(const Vector&)>& cost,
                                      const std::function<Vector(const Vector&)>& gradient,
                                      const Vector& tau_guess, double final_time,
                                      double min_duration, double fd_step,
                                      double gradient_tolerance) {
  const int N = static_cast<int>(tau_guess.size());
  // Constraints c_k = D_k - min_duration >= 0, k = 0..N, D_k = tau_k - tau_{k-1} with
  // tau_{-1} = 0 and tau_N = final_time; dc_k/dtau = e_k - e_{k-1} (rows of C).
  Matrix C = Matrix::Zero(N + 1, N);
  for (int k = 0; k <= N; ++k) {
    if (k < N) C(k, k) = 1;
    if (k > 0) C(k, k - 1) = -1;
  }
  auto slack = [&](const Vector& tau, int k) {
    const double lo = k == 0 ? 0.0 : tau(k - 1);
    const double hi = k == N ? final_time : tau(k);
    return hi - lo - min_duration;
  };
  auto grad = [&](const Vector& tau) {
    return gradient ? gradient(tau) : CentralDifferenceGradient(cost, tau, fd_step);
  };
  auto hessian = [&](const Vector& tau) {
    const double h = 1e-4;
    Matrix H(N, N);
    if (gradient) {
      for (int j = 0; j < N; ++j) {
        Vector p = tau, m = tau;
        p(j) += h;
        m(j) -= h;
        H.col(j) = (gradient(p) - gradient(m)) / (2 * h);
      }
    } else {
      const double J0 = cost(tau);
      for (int i = 0; i < N; ++i) {
        Vector p = tau, m = tau;
        p(i) += h;
        m(i) -= h;
        H(i, i) = (cost(p) - 2 * J0 + cost(m)) / (h * h);
        for (int j = i + 1; j < N; ++j) {
          Vector pp = p, pm = p, mp = m, mm = m;
          pp(j) += h;
          pm(j) -= h;
          mp(j) += h;
          mm(j) -= h;
          H(i, j) = H(j, i) = (cost(pp) - cost(pm) - cost(mp) + cost(mm)) / (4 * h * h);
        }
      }
    }
    return Matrix(0.5 * (H + H.transpose()));
  };

  ReferenceOptimum out;
  Vector tau = tau_guess;
  for (int k = 0; k <= N; ++k) {
    if (slack(tau, k) < -1e-9) {
      throw std::invalid_argument("MinimizeOverInstants: duration " + std::to_string(k) +
                                  " of the guess is below min_duration");
    }
  }
  // A guess on a bound (the answer of a previous run) starts with that bound active.
  std::vector<bool> active(N + 1, false);
  for (int k = 0; k <= N; ++k) active[k] = slack(tau, k) <= 1e-12;
  double J = cost(tau);
  Vector g = grad(tau);
  int stalled = 0;  // consecutive iterations that changed J only at the rounding level
  for (int it = 0; it < 300 && stalled < 3; ++it) {
    // Null space Z of the active constraints; reduced gradient Z'g.
    std::vector<int> act;
    for (int k = 0; k <= N; ++k) {
      if (active[k]) act.push_back(k);
    }
    Matrix Ca(act.size(), N);
    for (size_t a = 0; a < act.size(); ++a) Ca.row(a) = C.row(act[a]);
    Matrix Z = Matrix::Identity(N, N);
    if (!act.empty()) Z = Eigen::FullPivLU<Matrix>(Ca).kernel();
    if (Z.cols() == 1 && Z.norm() == 0) Z.resize(N, 0);
    const Vector gr = Z.transpose() * g;
    if (gr.size() == 0 || gr.cwiseAbs().maxCoeff() <= gradient_tolerance) {
      // Stationary on the active face: release a constraint with a negative multiplier
      // (g = Ca' mu, mu >= 0 at a minimum), else done.
      if (act.empty()) break;
      const Vector mu = Ca.transpose().colPivHouseholderQr().solve(g);
      int worst = -1;
      for (size_t a = 0; a < act.size(); ++a) {
        if (mu(a) < -gradient_tolerance && (worst < 0 || mu(a) < mu(worst))) worst = a;
      }
      if (worst < 0) break;
      active[act[worst]] = false;
      continue;
    }
    out.newton_iterations = it + 1;
    const Matrix Hr = Z.transpose() * hessian(tau) * Z;
    // Levenberg-Marquardt shift when the reduced Hessian is not safely positive definite.
    Eigen::SelfAdjointEigenSolver<Matrix> eig(Hr);
    const double lmin = eig.eigenvalues().minCoeff();
    const double lmax = std::max(eig.eigenvalues().cwiseAbs().maxCoeff(), 1e-12);
    const double shift = lmin < 1e-6 * lmax ? -lmin + 1e-3 * lmax : 0.0;
    Vector d = Z * (-(Hr + shift * Matrix::Identity(Hr.rows(), Hr.rows())).ldlt().solve(gr));
    // Trust region in time: no instant moves by more than a quarter of the horizon.
    const double dmax = d.cwiseAbs().maxCoeff();
    if (dmax > 0.25 * final_time) d *= 0.25 * final_time / dmax;
    // Ratio test: the longest step along d that keeps the inactive constraints.
    double alpha_max = 1.0;
    int blocking = -1;
    for (int k = 0; k <= N; ++k) {
      const double rate = C.row(k).dot(d);
      if (!active[k] && rate < 0 && slack(tau, k) + rate * alpha_max < 0) {
        alpha_max = std::max(0.0, slack(tau, k) / -rate);
        blocking = k;
      }
    }
    const double slope = g.dot(d);
    bool accepted = false;
    double alpha = alpha_max;
    for (int ls = 0; ls < 60 && alpha > 0; ++ls, alpha *= 0.5) {
      const Vector trial = tau + alpha * d;
      const double Jt = cost(trial);
      // Armijo, or (at rounding level near the optimum) a smaller reduced gradient.
      if (Jt <= J + 1e-4 * alpha * slope ||
          (std::abs(Jt - J) <= 1e-13 * std::max(1.0, std::abs(J)) &&
           (Z.transpose() * grad(trial)).norm() < gr.norm())) {
        if (alpha == alpha_max && blocking >= 0) active[blocking] = true;
        tau = trial;
        stalled = J - Jt > 1e-14 * std::max(1.0, std::abs(J)) ? 0 : stalled + 1;
        J = Jt;
        accepted = true;
        break;
      }
    }
    if (!accepted && alpha_max == 0 && blocking >= 0) {
      active[blocking] = true;  // already on the bound: continue on the smaller face
      accepted = true;
    }
    g = grad(tau);
    if (!accepted) break;
  }
  out.T = InstantsWithFinal(tau, final_time);
  out.cost = J;
  out.gradient = g;
  for (int k = 0; k <= N; ++k) {
    if (active[k]) out.active_durations.push_back(k);
  }
  // Reduced Hessian at the answer (on the face of the active durations).
  {
    std::vector<int> act;
    for (int k = 0; k <= N; ++k) {
      if (active[k]) act.push_back(k);
    }
    Matrix Z = Matrix::Identity(N, N);
    if (!act.empty()) {
      Matrix Ca(act.size(), N);
      for (size_t a = 0; a < act.size(); ++a) Ca.row(a) = C.row(act[a]);
      Z = Eigen::FullPivLU<Matrix>(Ca).kernel();
      if (Z.cols() == 1 && Z.norm() == 0) Z.resize(N, 0);
    }
    if (Z.cols() > 0) {
      const Matrix Hr = Z.transpose() * hessian(tau) * Z;
      out.hessian_eigenvalues = Eigen::SelfAdjointEigenSolver<Matrix>(Hr).eigenvalues();
    }
  }
  return out;
}

Matrix SolveContinuousAre(const Matrix& A, const Matrix& B, const Matrix& Q, const Matrix& R) {
  const int n = static_cast<int>(A.rows());
  Matrix Z(2 * n, 2 * n);
  Z << A, -B * R.inverse() * B.transpose(), -Q, -A.transpose();
  Eigen::ComplexEigenSolver<Matrix> eig(Z);
  Eigen::MatrixXcd U(2 * n, n);
  int c = 0;
  for (int i = 0; i < 2 * n && c < n; ++i) {
    if (eig.eigenvalues()(i).real() < 0) U.col(c++) = eig.eigenvectors().col(i);
  }
  if (c != n) throw std::runtime_error("SolveContinuousAre: no stable invariant subspace");
  const Eigen::MatrixXcd P = U.bottomRows(n) * U.topRows(n).inverse();
  const Matrix Pr = P.real();
  return 0.5 * (Pr + Pr.transpose());
}

}  // namespace testing
}  // namespace ddoc
