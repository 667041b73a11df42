"""Bad input raises ValueError naming what is wrong (argument, both shapes); nothing crashes."""
import numpy as np
import pytest

import ddoc


def lq_problem(m=1):
    A = [np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[-1.0, 0.0], [1.0, -2.0]])]
    B = [np.array([[0.0], [1.0]])] * 2 if m else None
    system = ddoc.LinearSystem(A, B)
    cost = ddoc.QuadraticCost(Q=[np.eye(2)] * 2, R=[np.eye(m)] * 2, S=[np.zeros((2, 2)), np.eye(2)])
    bounds = ddoc.Bounds(u_min=[-np.inf] * m, u_max=[np.inf] * m,
                         duration_min=[0.01, 0.01], duration_max=[2.0, 2.0])
    bounds.fix_final_time(2.0)
    return ddoc.Problem(system, cost, bounds)


def test_matrix_shape_names_argument_and_both_shapes():
    with pytest.raises(ValueError, match=r"B\[1\]: shape \(3, 1\), expected \(2, 1\)"):
        ddoc.LinearSystem([np.eye(2)] * 2, [np.ones((2, 1)), np.ones((3, 1))])
    with pytest.raises(ValueError, match=r"A\[0\]: shape \(2, 3\), expected a square"):
        ddoc.LinearSystem([np.ones((2, 3))])
    with pytest.raises(ValueError, match=r"E\[0\]: shape \(2, 2\), expected \(3, 2\)"):
        ddoc.LinearSystem([np.eye(2), np.eye(3)], None, [np.eye(2)])
    with pytest.raises(ValueError, match=r"S\[1\]: shape \(3, 3\), expected \(2, 2\)"):
        ddoc.QuadraticCost(Q=[np.eye(2)] * 2, R=[np.eye(1)] * 2, S=[np.eye(2), np.eye(3)])


def test_solve_arguments():
    learner = ddoc.Learner(lq_problem())
    with pytest.raises(ValueError, match=r"x0: shape \(3,\), expected \(2,\)"):
        learner.solve(np.zeros(3), [1.0, 1.0])
    with pytest.raises(ValueError, match=r"durations: shape \(1,\), expected \(2,\)"):
        learner.solve([1.0, 0.0], [2.0])
    with pytest.raises(ValueError, match=r"u0: shape \(2,\), expected \(1,\)"):
        learner.solve([1.0, 0.0], [1.0, 1.0], u0=[0.0, 0.0])
    with pytest.raises(ValueError, match="x0: non-finite"):
        learner.solve([np.nan, 0.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="method: unknown method 'bogus'"):
        learner.solve([1.0, 0.0], [1.0, 1.0], method="bogus")
    with pytest.raises(ValueError, match="x0: expected an array of floats, got str"):
        learner.solve("abc", [1.0, 1.0])


def test_unknown_preset():
    with pytest.raises(ValueError, match="unknown preset 'fast'"):
        ddoc.LearnerSettings.preset("fast")


def test_engine_validation_reaches_python_with_its_message():
    system = ddoc.LinearSystem([np.eye(2)] * 2, [np.ones((2, 1))] * 2)
    cost = ddoc.QuadraticCost(Q=[np.eye(2)] * 2, R=[np.eye(1)] * 2)
    bad = ddoc.Bounds(u_min=[-1.0, -1.0], u_max=[1.0, 1.0],
                      duration_min=[0.1, 0.1], duration_max=[1.0, 1.0])
    with pytest.raises(ValueError, match="u_min"):
        ddoc.Problem(system, cost, bad)
    reversed_bounds = ddoc.Bounds(u_min=[-1.0], u_max=[1.0],
                                  duration_min=[0.5, 0.1], duration_max=[0.2, 1.0])
    with pytest.raises(ValueError, match="duration"):
        ddoc.Problem(system, cost, reversed_bounds)
    settings = ddoc.LearnerSettings()
    settings.gamma = 2.0
    good = ddoc.Bounds(u_min=[-1.0], u_max=[1.0], duration_min=[0.1, 0.1],
                       duration_max=[1.0, 1.0])
    with pytest.raises(ValueError, match="gamma"):
        ddoc.Learner(ddoc.Problem(system, cost, good), settings)
    for field, bad in (("curvature_scale_min", 0.0), ("curvature_scale_min", 2.0)):
        settings = ddoc.LearnerSettings()
        setattr(settings, field, bad)
        with pytest.raises(ValueError, match=field):
            ddoc.Learner(ddoc.Problem(system, cost, good), settings)
    for field, bad in (("relative_regularization", 0.0), ("relative_regularization", -1.0)):
        settings = ddoc.LearnerSettings()
        setattr(settings.switching, field, bad)
        with pytest.raises(ValueError, match=field):
            ddoc.Learner(ddoc.Problem(system, cost, good), settings)


def test_callback_errors():
    bounds = ddoc.Bounds(u_min=[-1.0], u_max=[1.0], duration_min=[0.1], duration_max=[1.0])
    bounds.fix_final_time(1.0)
    bounds.duration_min = np.array([1.0])
    wrong = ddoc.CallbackSystem([2], 1, lambda k, x, u: np.zeros(3))
    cost = ddoc.QuadraticCost(Q=[np.eye(2)], R=[np.eye(1)])
    learner = ddoc.Learner(ddoc.Problem(wrong, cost, bounds))
    with pytest.raises(ValueError, match=r"flow\(k=0\) returned: shape \(3,\), expected \(2,\)"):
        learner.solve([1.0, 0.0], [1.0])

    def nan_flow(k, x, u):
        return [float("nan"), 0.0]
    learner = ddoc.Learner(ddoc.Problem(ddoc.CallbackSystem([2], 1, nan_flow), cost, bounds))
    with pytest.raises(ValueError):
        learner.solve([1.0, 0.0], [1.0])

    def raising_flow(k, x, u):
        raise RuntimeError("user model failed")
    learner = ddoc.Learner(ddoc.Problem(ddoc.CallbackSystem([2], 1, raising_flow), cost, bounds))
    with pytest.raises(RuntimeError, match="user model failed"):
        learner.solve([1.0, 0.0], [1.0])


def test_input_free_and_infinite_bounds():
    """m = 0 and infinite input bounds are valid problems."""
    r = ddoc.Learner(lq_problem(m=0)).solve([1.0, 0.5], [1.0, 1.0])
    assert r.status == "converged"
    assert r.T.shape == (2,) and abs(r.T[-1] - 2.0) < 1e-12
    r = ddoc.Learner(lq_problem(m=1)).solve([1.0, 0.5], [1.0, 1.0])
    assert r.status == "converged" and r.cost < r.cost_history[0]


def test_cost_that_does_not_fit_the_system():
    system = ddoc.LinearSystem([np.eye(2)] * 2, [np.ones((2, 1))] * 2)
    bounds = ddoc.Bounds(u_min=[-1.0], u_max=[1.0], duration_min=[0.1, 0.1],
                         duration_max=[1.0, 1.0])
    one_mode = ddoc.QuadraticCost(Q=[np.eye(2)], R=[np.eye(1)])
    with pytest.raises(ValueError, match="the cost has 1 modes, the system 2"):
        ddoc.Learner(ddoc.Problem(system, one_mode, bounds)).solve([1.0, 0.0], [0.5, 0.5])
    three_states = ddoc.QuadraticCost(Q=[np.eye(3)] * 2, R=[np.eye(1)] * 2)
    with pytest.raises(ValueError, match="x has size 2"):
        ddoc.Learner(ddoc.Problem(system, three_states, bounds)).solve([1.0, 0.0], [0.5, 0.5])
