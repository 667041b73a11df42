"""A nonlinear switched system written as Python callables converges to the answer of its C++ twin.

The system is exp1 (Xu & Antsaklis 2004, three nonlinear modes); its C++ twin is the suite's
Exp1System with hand-written derivatives, solved by Learner::Solve in C++. Here the user gives
only values: the flow (CallbackSystem, Jacobians by central differences) and the running and
terminal costs (CallbackCost, gradients and Hessians by central differences).

Tolerance. Both runs stop at the default preset's convergence test: the Newton decrement (the
predicted gain of the full step) below 1e-9 (1 + I), i.e. each within ~1e-9 relative in cost
of the (discretized) optimum; the finite-difference gradients are accurate to ~1e-10 (step 1e-6:
truncation h^2 |f'''| ~ 1e-12, rounding eps |f| / h ~ 1e-10), which moves the stationary point by
as much. Hessian errors (~1e-6, step 1e-4) change the path, not the fixed point. Hence the cost
must agree to 1e-7 relative (a margin of 10-100 over these), the switching instants (the cost is
quadratic in T near the optimum: |dT| ~ sqrt(2 dI / I_TT)) to 1e-4 s.
"""
import math

import numpy as np

import ddoc
import ddoc_testing
from standard_pose import exp1_python_cost, exp1_system, suite_bounds


def test_exp1_from_python_callables_matches_cpp_twin():
    d = ddoc_testing.data("exp1")
    system = exp1_system("values")
    cost = exp1_python_cost(d, "values")
    problem = ddoc.Problem(system, cost, suite_bounds(3, [-np.inf], [np.inf], d["final_time"]))
    r = ddoc.Learner(problem).solve(d["x0"], d["initial_durations"])
    ref = ddoc_testing.solve("exp1", "default")
    assert r.status == "converged" and ref["status"] == "converged"
    assert abs(r.cost - ref["cost"]) <= 1e-7 * ref["cost"], (r.cost, ref["cost"])
    np.testing.assert_allclose(r.T, ref["T"], rtol=0, atol=1e-4)
    # The finite differences are those of ddoc's CentralDifferenceJacobian: compare once with
    # the exact Jacobian of the flow.
    fx, fu = system.flow_derivatives(1, np.array([0.3, -0.7]), np.array([0.4]))
    s0, c0 = math.sin(0.3), math.cos(0.3)
    s1, c1 = math.sin(-0.7), math.cos(-0.7)
    np.testing.assert_allclose(fx, [[0, 1 + 0.4 * c1], [-1 + 0.4 * s0, 0]], atol=1e-8)
    np.testing.assert_allclose(fu, [[s1], [-c0]], atol=1e-8)
