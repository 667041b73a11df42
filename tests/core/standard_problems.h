// Copyright ddoc authors. Licensed under the Apache License, Version 2.0.
//
// A public suite of standard switched optimal-control problems from the literature, posed
// through ddoc's public API as a user would pose them, each with an initial guess and its
// reference optimum (computed independently of the engine by standard_references.h, pinned
// here and recomputed by standard_problems_test.cc).
//
//   name           K  n_k      m  inputs           final time  source
//   lqr            1  2        1  unbounded        4 s         double-integrator LQR
//   sto2_linear    2  2        0  none             1 s         SwitchTimeOpt.jl test problem
//   sto9_linear    9  2        0  none             1 s         SwitchTimeOpt.jl linear example,
//                                                              8 switches
//   fishing        3  2        0  none             12 s        Lotka-Volterra fishing (Sager)
//   exp0           2  2        1  unbounded        2 s         Xu & Antsaklis / OCS2 EXP0
//   exp0_bounded   2  2        1  |u| <= 8 active  2 s         EXP0 with input bounds
//   exp1           3  2        1  unbounded        3 s         Xu & Antsaklis / OCS2 EXP1
//   state_size_lq  2  2, 3     1  unbounded        3 s         LQ with a rectangular reset
//
// Every problem has time-based switching (no switching surfaces), a fixed final time and
// free switching instants in between.
#ifndef DDOC_TESTS_CORE_STANDARD_PROBLEMS_H_
#define DDOC_TESTS_CORE_STANDARD_PROBLEMS_H_

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ddoc/learner.h"
#include "ddoc/policy.h"
#include "ddoc/problem.h"
#include "standard_problem_data.h"

namespace ddoc {
namespace testing {

/// One standard problem: its ddoc definition, initial guess and reference optimum.
/// Not copyable (`problem` points at `system` and `cost`); make it with MakeStandardProblem.
struct StandardProblem {
  std::string name;      ///< short identifier, e.g. "exp0"
  std::string citation;  ///< one line: where the problem comes from and what it is
  std::unique_ptr<SwitchedSystem> system;  ///< f_k, g_k (no surfaces)
  std::unique_ptr<SwitchedCost> cost;      ///< l_k, phi_k
  Problem problem;       ///< system, cost, input/duration bounds, final time, weights w_k = 0
  Vector x0;             ///< n_0 initial state
  Vector initial_durations;                ///< K: T^0 as planned durations (s)
  FunctionPolicy::Function initial_input;  ///< u^0(k, tau, x) (m entries; m = 0: nothing)
  bool bounds_active = false;  ///< input bounds active on a set of positive measure at the optimum
  double reference_cost = 0;   ///< optimal cost I* (pinned; recomputed by the tests)
  Vector reference_T;          ///< K: optimal switching instants T* (s), T*(K-1) = final time

  StandardProblem() = default;
  StandardProblem(const StandardProblem&) = delete;
  StandardProblem& operator=(const StandardProblem&) = delete;

  int num_modes() const { return system->num_modes(); }
  int input_dim() const { return system->input_dim(); }
  double final_time() const { return problem.bounds.final_time_max; }
  /// The target trial budget of issue 17: 60 with active input bounds, else 30.
  int trial_budget() const { return bounds_active ? 60 : 30; }
  /// u^0, T^0 as a policy (Algorithm 1's input).
  FunctionPolicy InitialPolicy() const { return FunctionPolicy(initial_durations, initial_input); }
};

/// The names of the suite, in the order of the table above.
std::vector<std::string> StandardProblemNames();

/// Makes the named problem; throws InvalidArgument for an unknown name.
std::unique_ptr<StandardProblem> MakeStandardProblem(const std::string& name);

/// An initial guess other than the suite's: planned durations drawn uniformly in [0.2, 1],
/// scaled to the final time and kept above the duration bounds, and the suite's u^0 plus a
/// constant drawn uniformly in [-1, 1] (docs/standard_problems.md, "From other starts").
struct RandomStart {
  Vector durations;    ///< K planned durations (s), summing to the final time
  double offset = 0;   ///< added to every entry of u^0
};
/// Draws one RandomStart for sp (K + 1 draws from rng).
RandomStart DrawRandomStart(const StandardProblem& sp, std::mt19937* rng);
/// The policy of a RandomStart: sp's u^0 plus the offset, on the start's durations.
FunctionPolicy RandomStartPolicy(const StandardProblem& sp, const RandomStart& start);

/// A problem from linear-quadratic data, posed as the suite's are: durations in
/// [10 ms, final time] (one mode: the final time), the final time fixed, no surfaces, x0 and
/// u^0 = 0 from d; initial_durations, reference_cost and reference_T are left for the caller.
std::unique_ptr<StandardProblem> StandardProblemFromLq(const LinearQuadraticData& d);

/// Algorithm 1 with `settings` on sp.problem, its exact model as the plant, from sp.x0.
SolveResult SolveOnModel(const StandardProblem& sp, Policy& initial,
                         const LearnerSettings& settings);

// The numbers of each problem (shared with the reference solvers).

/// lqr: xdot = [0 1; 0 0] x + [0; 1] u, l = 1/2 (|x|^2 + u^2), no terminal cost, x0 = (1, 0),
/// T = 4 s. Its Riccati solution tends to the ARE's [sqrt3 1; 1 sqrt3] for long horizons.
LinearQuadraticData LqrData();

/// sto2_linear and sto9_linear: xdot = A_{k mod 2} x, A_0 = [-1 0; 1 2], A_1 = [1 1; 1 -2],
/// l = |x|^2 (SwitchTimeOpt's 1/2 x'Qx with Q = 2 I), no terminal cost, x0 = (1, 1), T = 1 s,
/// K modes (2 or 9). Stellato, Ober-Bloebaum & Goulart, IEEE TAC 62(10) 2017, and
/// SwitchTimeOpt.jl (test/linsys.jl: tau* = 0.26486646, J* = 5.25454294; examples/linear.jl).
LinearQuadraticData StoLinearData(int num_modes);

/// fishing: the Lotka-Volterra fishing problem (Sager, "A benchmark library of mixed-integer
/// optimal control problems", 2012; SwitchTimeOpt.jl examples/fishing.jl) with the fishing
/// sequence 0, 1, 0 (one fishing interval): x0 = (0.5, 0.7), T = 12 s,
/// l = 1/2 ((x0 - 1)^2 + (x1 - 1)^2).
FishingData FishingProblemData(int num_modes = 3);

/// exp0: Xu & Antsaklis, "Optimal control of switched systems based on parameterization of the
/// switching instants", IEEE TAC 49(1) 2004, example 1 (OCS2's EXP0):
/// A_0 = [0.6 1.2; -0.8 3.4], B_0 = (1, 1), A_1 = [4 3; -1 0], B_1 = (2, -1),
/// l = 1/2 (x1 - 2)^2 + 1/2 u^2, phi = 1/2 |x - (4, 2)|^2, x0 = (0, 2), T = 2 s.
/// u_bound = inf: exp0; u_bound = 8: exp0_bounded.
LinearQuadraticData Exp0Data(double u_bound);

/// The input bound of exp0_bounded (|u| <= 8): active over ~16 % of the horizon at the optimum
/// (the unbounded optimum reaches u = -12.1).
constexpr double kExp0InputBound = 8.0;

/// exp1: Xu & Antsaklis (2004), example 2 (OCS2's EXP1): target (1, -1), x0 = (2, 3), T = 3 s.
Exp1Data Exp1ProblemData();

/// state_size_lq (constructed for this suite): mode 0 is a double integrator (p, v) with a
/// price 0.3 per second on the time spent in it; at the switch the rectangular reset
/// [I; 0] (3 x 2) appends an integral state q = 0; mode 1 is a weakly actuated damped
/// oscillator with qdot = p:
///   A_0 = [0 1; 0 0], B_0 = (0, 1);  A_1 = [0 1 0; -1 -0.4 0; 1 0 0], B_1 = (0, 0.5, 0),
///   Q_0 = diag(1, 0.1), Q_1 = diag(1, 0.1, 1), R = 1, rho = (0.3, 0),
///   phi_1 = 1/2 x' diag(2, 1, 2) x, x0 = (1, 0), T = 3 s.
LinearQuadraticData StateSizeData();

}  // namespace testing
}  // namespace ddoc

#endif  // DDOC_TESTS_CORE_STANDARD_PROBLEMS_H_
