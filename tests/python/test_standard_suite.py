"""The engine's standard suite posed from Python gives the C++ result to 1e-12.

Reference: the same problem built by the C++ suite (MakeStandardProblem) and solved by
Learner::Solve in C++ (ddoc_testing.solve), both presets. The Python side poses the problem
from matrices (LinearSystem/QuadraticCost) or Python callables with exact derivatives
(CallbackSystem: fishing, exp1) and runs Learner.solve, whose trial loop is driven from the
binding. Same arithmetic, so the results agree to rounding.
"""
import numpy as np
import pytest

import ddoc
import ddoc_testing
from standard_pose import pose

TOL = 1e-12


@pytest.mark.parametrize("preset", ["default", "paper"])
@pytest.mark.parametrize("name", ddoc_testing.names())
def test_python_pose_equals_cpp(name, preset):
    problem, x0, durations, d = pose(name)
    learner = ddoc.Learner(problem, ddoc.LearnerSettings.preset(preset))
    r = learner.solve(x0, durations)
    ref = ddoc_testing.solve(name, preset)
    assert r.status == ref["status"]
    assert (r.trials, r.iterations) == (ref["trials"], ref["iterations"])
    assert abs(r.cost - ref["cost"]) <= TOL * max(1.0, abs(ref["cost"])), (r.cost, ref["cost"])
    np.testing.assert_allclose(r.T, ref["T"], rtol=0, atol=TOL)
    np.testing.assert_allclose(r.cost_history, ref["cost_history"], rtol=TOL, atol=TOL)
    assert abs(r.optimality - ref["optimality"]) <= TOL * max(1.0, ref["optimality"])
    nominal = learner.nominal
    assert len(nominal.modes) == len(ref["x"])
    for mode, x_ref in zip(nominal.modes, ref["x"]):
        assert mode.x.shape == x_ref.shape
        np.testing.assert_allclose(mode.x, x_ref, rtol=0, atol=TOL)
    # And the default preset reaches the suite's reference optimum (independent solvers).
    if preset == "default":
        assert r.status == "converged"
        assert abs(r.cost - d["reference_cost"]) / d["reference_cost"] < 1e-3
