"""Batched callables (issue 46): CallbackSystem(flow_batch=, flow_derivatives_batch=) and
CallbackCost(running_batch=, running_derivatives_batch=) take all the points of a mode in one call.

The batched solve of exp1 gives the per-point solve's result: the same status, trials and
iterations, the cost within 1e-10 relative. With exact derivatives the batch callables compute
the per-point formulas with NumPy's vectorized sin/cos and sums, which may differ from
math.sin/cos and a dot product in the last bit (measured: cost 4e-16 relative apart);
value-only, the central differences amplify such a bit by 1/h (gradient, 1e6) and 1/(h h')
(Hessian, 1e10): the trials take the same steps to ~5e-6 relative (the cost history) and
converge to the same point (measured: final cost 3e-13 relative apart). The engine's calls are counted: the backward pass
makes two calls per mode and Run of each batch callable, the per-point flow only the simulation's.
"""
import math

import numpy as np
import pytest

import ddoc
import ddoc_testing
from standard_pose import (exp1_flow, exp1_flow_batch, exp1_flow_derivatives_batch,
                           exp1_python_cost, exp1_system, suite_bounds)

DATA = ddoc_testing.data("exp1")
BOUNDS = suite_bounds(3, [-np.inf], [np.inf], DATA["final_time"])


def solve(system, cost):
    learner = ddoc.Learner(ddoc.Problem(system, cost, BOUNDS))
    return learner.solve(DATA["x0"], DATA["initial_durations"]), learner


def expect_same_solve(batched, reference, rtol, path_rtol, t_atol):
    assert batched.status == reference.status == "converged"
    assert (batched.trials, batched.iterations) == (reference.trials, reference.iterations)
    assert abs(batched.cost - reference.cost) <= rtol * reference.cost, (batched.cost,
                                                                          reference.cost)
    np.testing.assert_allclose(batched.cost_history, reference.cost_history, rtol=path_rtol,
                               atol=0)
    np.testing.assert_allclose(batched.T, reference.T, rtol=0, atol=t_atol)


class Counted:
    """A callable that counts its calls and the points they carried."""

    def __init__(self, fn):
        self.fn, self.calls, self.points = fn, 0, 0

    def __call__(self, k, X, *rest):
        self.calls += 1
        self.points += X.shape[0] if X.ndim == 2 else 1
        return self.fn(k, X, *rest)


def test_batched_exact_solve_gives_the_per_point_solve():
    reference, _ = solve(exp1_system("exact"), exp1_python_cost(DATA, "exact"))
    flow, flow_batch = Counted(exp1_flow), Counted(exp1_flow_batch)
    derivatives_batch = Counted(exp1_flow_derivatives_batch)
    system = ddoc.CallbackSystem([2, 2, 2], 1, flow, flow_batch=flow_batch,
                                 flow_derivatives_batch=derivatives_batch)
    assert system.prefers_batch and not exp1_system("exact").prefers_batch
    cost = exp1_python_cost(DATA, "batch")
    assert cost.prefers_batch
    r, learner = solve(system, cost)
    expect_same_solve(r, reference, 1e-10, 1e-10, 1e-10)
    # One call per mode and backward pass of each batch callable, with every interval of the
    # mode: the passes ran on nominals of about 3000 samples.
    assert flow_batch.calls == derivatives_batch.calls and flow_batch.calls % 3 == 0
    assert flow_batch.calls <= 3 * 3 * (r.trials + 1)  # at most 3 passes a trial
    assert flow_batch.points / flow_batch.calls > 500
    # The per-point flow is the simulation's: four calls per RK4 step.
    steps = sum(mode.t.size - 1 for mode in learner.nominal.modes)
    assert flow.calls == pytest.approx(4 * steps * (r.trials + 1), rel=0.02)


def test_batched_value_only_solve_gives_the_per_point_solve():
    """flow_batch and running_batch without derivatives: the central differences of a mode
    evaluated in one call each (all the perturbed points), the per-point differences' result."""
    reference, _ = solve(exp1_system("values"), exp1_python_cost(DATA, "values"))
    flow_batch = Counted(exp1_flow_batch)
    system = ddoc.CallbackSystem([2, 2, 2], 1, exp1_flow, flow_batch=flow_batch)
    r, learner = solve(system, exp1_python_cost(DATA, "batch_values"))
    # The path (cost_history) through the Hessians' rounding: measured 5e-6 apart; T 2e-9 s
    # (the cost is flat in T at the optimum: |dT| ~ sqrt(2 dI / I_TT)).
    expect_same_solve(r, reference, 1e-10, 1e-4, 1e-7)
    # Two calls per mode and pass: the midpoints, then their 2 (n + m) = 6 perturbed points each.
    assert flow_batch.calls % 6 == 0
    intervals = sum(mode.t.size - 1 for mode in learner.nominal.modes)
    assert flow_batch.points / (flow_batch.calls // 2) == pytest.approx(7 * intervals / 3, rel=0.1)


def test_flow_batch_alone_also_runs_the_simulation():
    """Without a per-point flow the simulation calls flow_batch with one point (N = 1)."""
    flow_batch = Counted(exp1_flow_batch)
    system = ddoc.CallbackSystem([2, 2, 2], 1, flow_batch=flow_batch,
                                 flow_derivatives_batch=exp1_flow_derivatives_batch)
    x, u = np.array([0.3, -0.7]), np.array([0.4])
    np.testing.assert_allclose(system.flow(1, x, u), exp1_flow(1, x, u), rtol=1e-15)
    assert flow_batch.calls == 1 and flow_batch.points == 1
    fx, _ = system.flow_derivatives(1, x, u)  # flow_derivatives_batch with N = 1
    assert fx[0, 1] == pytest.approx(1 + 0.4 * math.cos(-0.7), rel=1e-15)


def test_a_cpp_system_batch_is_its_per_point_evaluation():
    d = ddoc_testing.data("exp0")
    system = ddoc.LinearSystem(d["A"], d["B"], d["E"])
    cost = ddoc.QuadraticCost(Q=d["Q"], R=d["R"], S=d["S"], r=d["r"], s=d["s"], rho=d["rho"])
    assert not system.prefers_batch and not cost.prefers_batch
    rng = np.random.default_rng(3)
    X, U = rng.normal(size=(7, 2)), rng.normal(size=(7, 1))
    for k in range(system.num_modes):
        F = system.flow_batch(k, X, U)
        FX, FU = system.flow_derivatives_batch(k, X, U)
        l = cost.running_batch(k, X, U)
        for j in range(7):
            np.testing.assert_array_equal(F[j], system.flow(k, X[j], U[j]))
            fx, fu = system.flow_derivatives(k, X[j], U[j])
            np.testing.assert_array_equal(FX[j], fx)
            np.testing.assert_array_equal(FU[j], fu)
            assert l[j] == cost.running(k, X[j], U[j])
    with pytest.raises(ValueError, match=r"X: shape \(7, 1\), expected \(any, 2\)"):
        system.flow_batch(0, X[:, :1], U)
    with pytest.raises(ValueError, match=r"U: shape \(6, 1\), expected \(7, 1\)"):
        system.flow_batch(0, X, U[:6])


def points():
    return np.array([[0.3, -0.7], [0.1, 0.2], [1.5, 0.0]]), np.array([[0.4], [-0.2], [1.0]])


@pytest.mark.parametrize("returned, message", [
    (lambda X: X[:, :1], r"flow_batch\(k=1\) returned: shape \(3, 1\), expected \(3, 2\) "
                         r"\(N, n_k\) for 3 points"),
    (lambda X: X.T, r"flow_batch\(k=1\) returned: shape \(2, 3\), expected \(3, 2\)"),
    (lambda X: np.where(np.arange(6).reshape(3, 2) == 3, np.nan, X),
     r"flow_batch\(k=1\) returned: non-finite value nan at \[1, 1\], point 1 of 3 "
     r"\(x = \[0.1, 0.2\], u = \[-0.2\]\)"),
    (lambda X: X + 1j, r"flow_batch\(k=1\) returned: dtype complex128, expected real numbers"),
    (lambda X: None, r"flow_batch\(k=1\) returned: expected an array of shape \(N, n_k\), got "
                     r"NoneType"),
    (lambda X: [["a", "b"]] * 3, r"flow_batch\(k=1\) returned: dtype <U1, expected real"),
])
def test_a_bad_flow_batch_result_is_named(returned, message):
    system = ddoc.CallbackSystem([2, 2, 2], 1, exp1_flow, flow_batch=lambda k, X, U: returned(X))
    X, U = points()
    with pytest.raises(ValueError, match=message):
        system.flow_batch(1, X, U)


def test_bad_batch_derivatives_are_named_also_inside_a_solve():
    X, U = points()
    FX, FU = exp1_flow_derivatives_batch(0, X, U)
    bad = [(lambda: FX, r"flow_derivatives_batch\(k=0\) returned ndarray, expected a tuple "
                        r"\(FX, FU\)"),
           (lambda: (FX, FU[:, :, 0]), r"flow_derivatives_batch\(k=0\) returned FU: shape "
                                       r"\(3, 2\), expected \(3, 2, 1\) \(N, n_k, m\)"),
           (lambda: (FX + np.inf, FU), r"returned FX: non-finite value inf at \[0, 0, 0\]")]
    for fn, message in bad:
        system = ddoc.CallbackSystem([2, 2, 2], 1, exp1_flow,
                                     flow_derivatives_batch=lambda k, X, U, fn=fn: fn())
        with pytest.raises(ValueError, match=message):
            system.flow_derivatives_batch(0, X, U)
    # In a solve: the backward pass's call, the message as above, with its N.
    def nan_lux(k, X, U):
        N = X.shape[0]
        lux = np.zeros((N, 1, 2))
        lux[N // 2, 0, 1] = np.nan
        return X, U, np.broadcast_to(np.eye(2), (N, 2, 2)), np.ones((N, 1, 1)), lux
    cost = ddoc.CallbackCost(running_batch=lambda k, X, U: np.zeros(X.shape[0]),
                             running_derivatives_batch=nan_lux)
    with pytest.raises(ValueError, match=r"running_derivatives_batch\(k=0\) returned LUX: "
                                         r"non-finite value nan at \[\d+, 0, 1\], point \d+ of"):
        solve(exp1_system("exact"), cost)
    cost = ddoc.CallbackCost(running_batch=lambda k, X, U: np.zeros((X.shape[0], 1)))
    with pytest.raises(ValueError, match=r"running_batch\(k=0\) returned: shape \(\d+, 1\), "
                                         r"expected \(\d+,\) \(N,\)"):
        solve(exp1_system("exact"), cost)


def test_an_exception_in_a_batch_callable_propagates_with_its_name():
    def broken(k, X, U):
        raise ZeroDivisionError("inside the model")
    system = ddoc.CallbackSystem([2, 2, 2], 1, exp1_flow, flow_batch=broken)
    with pytest.raises(ZeroDivisionError, match="inside the model") as info:
        solve(system, exp1_python_cost(DATA, "exact"))
    notes = getattr(info.value, "__notes__", [])  # Python >= 3.11 (PEP 678)
    if hasattr(info.value, "add_note"):
        assert len(notes) == 1 and notes[0].startswith(
            "raised in ddoc's call of flow_batch(k=0) with "), notes
    cost = ddoc.CallbackCost(running_batch=broken)
    with pytest.raises(ZeroDivisionError) as info:
        cost.running_batch(1, *points())
    if hasattr(info.value, "add_note"):
        assert info.value.__notes__ == ["raised in ddoc's call of running_batch(k=1) with 3 points"]


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match=r"flow: give flow\(k, x, u\) -> xdot or "
                                         r"flow_batch\(k, X, U\) -> Xdot"):
        ddoc.CallbackSystem([2], 1)
    with pytest.raises(ValueError, match="flow_batch: expected a callable or None, got int"):
        ddoc.CallbackSystem([2], 1, exp1_flow, flow_batch=3)
    with pytest.raises(ValueError, match=r"running: give running\(k, x, u\)"):
        ddoc.CallbackCost()
    with pytest.raises(ValueError, match="running_derivatives_batch: expected a callable"):
        ddoc.CallbackCost(running_batch=lambda k, X, U: 0, running_derivatives_batch="no")


def test_an_input_array_kept_by_a_callable_never_changes():
    """The per-point callables' x and u arrays are reused from call to call only when the
    callable kept no reference: arrays (and views) it stored keep their values."""
    kept, copies, views = [], [], []

    def flow(k, x, u):
        if len(kept) < 50:
            kept.append(x)
            copies.append(x.copy())
        elif len(views) < 50:
            views.append((x[:], x.copy()))
        return exp1_flow(k, x, u)
    solve(ddoc.CallbackSystem([2, 2, 2], 1, flow, flow_derivatives=None),
          exp1_python_cost(DATA, "batch"))
    assert len(kept) == 50 and len(views) == 50
    for a, b in zip(kept, copies):
        np.testing.assert_array_equal(a, b)
    for a, b in views:
        np.testing.assert_array_equal(a, b)
