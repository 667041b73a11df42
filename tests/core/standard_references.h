// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// Independent reference solutions of the standard problems (standard_problems.h), computed
// without any part of the ddoc engine (no Learner, BackwardPass, BoxQP, switching-time update,
// ModelPlant, cost evaluation or SwitchedSystem): the methods are classical and their own.
//
//   - Linear-quadratic problems with unbounded inputs: for fixed switching instants the optimal
//     cost is exact, 1/2 x_a(0)' P(0) x_a(0) with P from the Riccati equation, solved in closed
//     form by the exponential of the Hamiltonian matrix (x_a = [x; 1] carries the references
//     and constant costs); a second, independent Riccati solve by RK4 checks it. Without
//     inputs the same exponential gives the Lyapunov solution (the cost Gramian).
//   - What the plant's zero-order hold costs: the exactly discretized LQ problem (Van Loan,
//     "Computing integrals involving the matrix exponential", IEEE TAC 1978) on the plant's
//     grid, solved by the discrete Riccati recursion.
//   - Bounded inputs and nonlinear dynamics with inputs (n = 2, m = 1): Pontryagin's maximum
//     principle, solved by single shooting on the initial costate (Newton), with the pointwise
//     minimizer u = clamp(-R^-1 b(x)'lambda, u_min, u_max) of the Hamiltonian.
//   - Switching-time problems without inputs (nonlinear): the cost by RK4 at fixed steps.
//   - The switching instants: Newton's method on the K - 1 free instants (the final time is
//     fixed) with derivatives from central differences of the cost, or the switching gradient
//     dJ/dT_k = H_k(T_k^-) - H_{k+1}(T_k^+) where the method provides the costate.
#ifndef DDOC_TESTS_CORE_STANDARD_REFERENCES_H_
#define DDOC_TESTS_CORE_STANDARD_REFERENCES_H_

#include <functional>
#include <limits>
#include <vector>

#include "standard_problem_data.h"
#include "standard_problems.h"

namespace ddoc {
namespace testing {

/// A reference optimum: cost and switching instants (T(K-1) = the final time).
struct ReferenceOptimum {
  double cost = 0;           ///< optimal cost
  Vector T;                  ///< K switching instants (s)
  Vector gradient;           ///< K - 1: dJ/dT_k at T (k < K-1), the optimizer's own
  int newton_iterations = 0; ///< outer Newton iterations
  std::vector<int> active_durations;  ///< modes whose duration is at min_duration at the optimum
  /// Eigenvalues of the (reduced) Hessian d2J/dT^2 at the last Newton iteration: the smallest
  /// says how sharply the cost locates the instants, |dT| ~ sqrt(2 dJ / lambda_min).
  Vector hessian_eigenvalues;
  /// Shooting references only: lambda(0) of the extremal at T (a warm start for SolveExtremal).
  Vector lambda0;
};

// ---------------------------------------------------------------------------------------------
// Linear-quadratic problems, unbounded inputs.

/// Optimal cost for fixed switching instants T (size K, T(K-1) = final_time), unbounded
/// inputs, by the Hamiltonian matrix exponential per mode: exact up to rounding.
double LqOptimalCost(const LinearQuadraticData& d, const Vector& T);

/// The same cost by classical RK4 on the Riccati differential equation (steps <= h per mode).
double LqOptimalCostRk4(const LinearQuadraticData& d, const Vector& T, double h);

/// dJ/dT_k = H_k(T_k^-) - H_{k+1}(T_k^+), k < K-1, along the optimal solution for fixed T
/// (costate lambda = P x from the same exponential), H_k = l_k + lambda' (A_k x + B_k u).
Vector LqSwitchingGradient(const LinearQuadraticData& d, const Vector& T);

/// The optimal feedback law u(t, x) = -R^-1 B' (P(t) x_a)_{1..n} for fixed T (backward pass
/// done once; P(t) from the same exponential), x of the mode active at t.
std::function<Vector(double t, const Vector& x)> LqOptimalPolicy(const LinearQuadraticData& d,
                                                                 const Vector& T);

/// Minimizes the optimal cost over the free instants T_0..T_{K-2} from T_guess (durations
/// >= min_duration), Newton with the switching gradient and its central differences.
ReferenceOptimum LqReference(const LinearQuadraticData& d, const Vector& T_guess,
                             double min_duration);

/// Cost of zero-order-hold inputs on the grid of ddoc::ModelPlant (steps of dt from the start
/// of every mode, the last step of a mode shortened to land on T_k), minimized exactly over
/// the held values (discrete-time Riccati on the exactly discretized dynamics and cost, by
/// Van Loan's exponentials). The gap to LqOptimalCost is what the hold costs at this dt.
double LqZeroOrderHoldOptimalCost(const LinearQuadraticData& d, const Vector& T, double dt);

/// The minimizer of a unimodal f on [lo, hi] by golden section, to an interval below `tolerance`
/// (at most 200 steps; `iterations`, when given, receives their number).
double GoldenSectionMinimum(const std::function<double(double)>& f, double lo, double hi,
                            double tolerance, int* iterations = nullptr);

/// Minimizes LqZeroOrderHoldOptimalCost over the free instants (golden section, K = 2 only).
ReferenceOptimum LqZeroOrderHoldReference(const LinearQuadraticData& d, double T0_lo,
                                          double T0_hi, double dt);

// ---------------------------------------------------------------------------------------------
// Pontryagin shooting for control-affine problems with n = 2, m = 1 (bounded or not).

/// xdot = a_k(x) + b_k(x) u in mode k, identity resets,
/// l = 1/2 (x - r)' Q (x - r) + 1/2 R u^2, terminal phi = 1/2 (x - s)' S (x - s).
struct ShootingProblem {
  using Vec2 = Eigen::Vector2d;
  using Mat2 = Eigen::Matrix2d;
  /// a_k, da_k/dx, b_k, db_k/dx at x (fixed size: this runs ~10^5 times per extremal).
  std::function<void(int k, const Vec2& x, Vec2* a, Mat2* a_x, Vec2* b, Mat2* b_x)> fields;
  int num_modes = 1;
  Mat2 Q = Mat2::Zero(), S = Mat2::Zero();
  Vec2 r = Vec2::Zero(), s = Vec2::Zero();
  double R = 1;
  double u_min = -std::numeric_limits<double>::infinity();
  double u_max = std::numeric_limits<double>::infinity();
  Vec2 x0 = Vec2::Zero();
  double final_time = 1;
  double step = 1e-3;  ///< RK4 step bound (s)
};

/// The shooting problem of a linear-quadratic problem with n_k = 2, m = 1, identity resets,
/// equal running costs in all modes, only a terminal cost (EXP0 and its bounded variant).
ShootingProblem ShootingFromLq(const LinearQuadraticData& d);

/// The shooting problem of Xu & Antsaklis' EXP1.
ShootingProblem ShootingFromExp1(const Exp1Data& d);

/// The extremal for fixed switching instants T: initial costate, cost, terminal residual and
/// the switching gradient H_k(T_k^-) - H_{k+1}(T_k^+).
struct Extremal {
  Vector lambda0;         ///< 2: the initial costate found by Newton
  double cost = 0;        ///< cost of the extremal's input
  double residual = 0;    ///< |lambda(tf) - S (x(tf) - s)|
  Vector gradient;        ///< K - 1: dJ/dT_k
  bool converged = false;
};

/// Solves the two-point boundary value problem for fixed T by Newton on lambda(0) from
/// lambda0_guess (size 2).
Extremal SolveExtremal(const ShootingProblem& p, const Vector& T, const Vector& lambda0_guess);

/// Input u(k, t) of mode k at time t in [T_{k-1}, T_k] along the extremal (the clamped
/// minimizer of the Hamiltonian), sampled at the RK4 steps of the problem and at the mode ends,
/// interpolated linearly (the input jumps at the switches, so the mode is an argument).
std::function<double(int k, double t)> ExtremalInput(const ShootingProblem& p, const Vector& T,
                                                      const Vector& lambda0);

/// Minimizes the extremal's cost over the free instants from T_guess (durations >= min_duration).
ReferenceOptimum ShootingReference(const ShootingProblem& p, const Vector& T_guess,
                                   double min_duration);

// ---------------------------------------------------------------------------------------------
// Switching-time problems without inputs.

/// Cost of the fishing problem for switching instants T (size K) by RK4 with `steps[k]`
/// uniform steps in mode k (smooth in T for fixed step counts).
double FishingCost(const FishingData& d, const Vector& T, const std::vector<int>& steps);

/// Step counts of at most h per mode for instants T.
std::vector<int> StepCounts(const Vector& T, double h);

/// Minimizes FishingCost over the free instants from T_guess (durations >= min_duration), RK4
/// steps <= h.
ReferenceOptimum FishingReference(const FishingData& d, const Vector& T_guess,
                                  double min_duration, double h);

// ---------------------------------------------------------------------------------------------
// Independent evaluation of an answer (e.g. the learner's final nominal inputs).

/// Dynamics and costs written again, independently of the ddoc definitions, for evaluating the
/// true cost of given inputs and instants.
struct IndependentModel {
  int num_modes = 1;
  std::function<Vector(int k, const Vector& x, const Vector& u)> flow;        ///< f_k, n_k
  std::function<double(int k, const Vector& x, const Vector& u)> running;     ///< l_k
  std::function<Vector(int k, const Vector& x)> reset;       ///< g_k(x^-), k < K-1
  std::function<double(int k, const Vector& x)> switching;   ///< phi_k(x^-(T_k))
};

IndependentModel IndependentModelFromLq(const LinearQuadraticData& d);
IndependentModel IndependentModelFromFishing(const FishingData& d);
IndependentModel IndependentModelFromExp1(const Exp1Data& d);

/// One mode of held (zero-order-hold) inputs: u.col(j) acts on [t(j), t(j+1)); the last column
/// is not used. Times are absolute; t(0) = T_{k-1}, t(last) = T_k.
struct HeldInputs {
  Vector t;  ///< N_k sample times
  Matrix u;  ///< m x N_k
};

/// True cost of held inputs from x0: RK4 with `substeps` equal steps per sample interval,
/// running cost integrated as an extra state, resets and switching costs at the mode ends.
double HeldInputCost(const IndependentModel& model, const Vector& x0,
                     const std::vector<HeldInputs>& modes, int substeps);

/// True cost of a feedback law u = law(t, x) held over steps of at most h (the grid of
/// PlantGridTrapezoidCost), RK4 inside a step, running cost integrated as an extra state.
double FeedbackCost(const IndependentModel& model,
                    const std::function<Vector(double t, const Vector& x)>& law, const Vector& x0,
                    const Vector& T, double h);

/// The cost as a plant with step dt and a trapezoidal quadrature sees it (no inputs, m = 0):
/// RK4 steps of dt from the start of each mode, the last one shortened to land on T_k, and
/// the running cost by the trapezoidal rule on those samples.
double PlantGridTrapezoidCost(const IndependentModel& model, const Vector& x0, const Vector& T,
                              double dt);

// ---------------------------------------------------------------------------------------------
// Per problem of the suite.

/// Recomputes the reference optimum of a suite problem from its initial instants T^0 (exp1:
/// from OCS2's published instants (0.2262, 1.0176), see the test for T^0), with the method
/// named in standard_problems.h: LqReference (lqr, sto2_linear, sto9_linear, exp0,
/// state_size_lq), ShootingReference (exp0_bounded, exp1), FishingReference (fishing).
ReferenceOptimum ComputeReference(const StandardProblem& problem);

/// The independent model of a suite problem (for HeldInputCost).
IndependentModel IndependentModelOf(const StandardProblem& problem);

// ---------------------------------------------------------------------------------------------
// Shared tools.

/// Active-set Newton method on the free instants tau = T_0..T_{K-2} (T_{K-1} = final_time
/// fixed) for a smooth cost J(tau) subject to durations >= min_duration: central-difference
/// Hessian (of `gradient` when given, else of J) and gradient, Levenberg-Marquardt shift when
/// the reduced Hessian is not positive definite, Armijo backtracking, a duration that reaches
/// its bound joins the active set and leaves it when its multiplier turns negative. Stops when
/// the reduced gradient |Z'g|_inf <= gradient_tolerance and every multiplier is >= 0.
ReferenceOptimum MinimizeOverInstants(const std::function<double(const Vector&)>& cost,
                                      const std::function<Vector(const Vector&)>& gradient,
                                      const Vector& tau_guess, double final_time,
                                      double min_duration, double fd_step,
                                      double gradient_tolerance);

/// Central-difference gradient of J over the free instants (step h).
Vector CentralDifferenceGradient(const std::function<double(const Vector&)>& cost,
                                 const Vector& tau, double h);

/// Solution of the continuous algebraic Riccati equation A'P + PA - P B R^-1 B' P + Q = 0
/// (stabilizing), from the stable invariant subspace of the Hamiltonian matrix.
Matrix SolveContinuousAre(const Matrix& A, const Matrix& B, const Matrix& Q, const Matrix& R);

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_STANDARD_REFERENCES_H_
