"""Poses the standard problems of tests/core/standard_problems.h from Python.

The numbers come from the C++ data (ddoc_testing.data); the problem is built here with the
public Python API: LinearSystem + QuadraticCost from matrices, or CallbackSystem with Python
callables (fishing, exp1), and the suite's bounds (durations in [0.01, T], or [T, T] for K = 1,
the final time fixed).
"""
import math

import numpy as np

import ddoc
import ddoc_testing

MIN_DURATION = 0.01  # kMinDuration of standard_problems.cc


def suite_bounds(num_modes, u_min, u_max, final_time):
    d_min = final_time if num_modes == 1 else MIN_DURATION
    bounds = ddoc.Bounds(u_min=u_min, u_max=u_max,
                         duration_min=np.full(num_modes, d_min),
                         duration_max=np.full(num_modes, final_time))
    bounds.fix_final_time(final_time)
    return bounds


def fishing_system(d):
    c0, c1, w = d["c0"], d["c1"], d["fishing"]

    def flow(k, x, u):
        return [x[0] - x[0] * x[1] - c0 * x[0] * w[k], -x[1] + x[0] * x[1] - c1 * x[1] * w[k]]

    def flow_derivatives(k, x, u):
        fx = [[1 - x[1] - c0 * w[k], -x[0]], [x[1], -1 + x[0] - c1 * w[k]]]
        return np.array(fx), np.zeros((2, 0))

    return ddoc.CallbackSystem([2] * len(w), 0, flow, flow_derivatives=flow_derivatives)


def exp1_flow(k, x, u):
    v = u[0]
    if k == 0:
        return [x[0] + v * math.sin(x[0]), -x[1] - v * math.cos(x[1])]
    if k == 1:
        return [x[1] + v * math.sin(x[1]), -x[0] - v * math.cos(x[0])]
    return [-x[0] - v * math.sin(x[0]), x[1] + v * math.cos(x[1])]


def exp1_flow_derivatives(k, x, u):
    v = u[0]
    s0, c0 = math.sin(x[0]), math.cos(x[0])
    s1, c1 = math.sin(x[1]), math.cos(x[1])
    if k == 0:
        return np.array([[1 + v * c0, 0], [0, -1 + v * s1]]), np.array([[s0], [-c1]])
    if k == 1:
        return np.array([[0, 1 + v * c1], [-1 + v * s0, 0]]), np.array([[s1], [-c0]])
    return np.array([[-1 - v * c0, 0], [0, 1 - v * s1]]), np.array([[-s0], [c1]])


def exp1_flow_batch(k, X, U):
    """exp1_flow at the N points, rows of X (N, 2) and U (N, 1): Xdot (N, 2)."""
    v, x0, x1 = U[:, 0], X[:, 0], X[:, 1]
    if k == 0:
        return np.stack([x0 + v * np.sin(x0), -x1 - v * np.cos(x1)], axis=1)
    if k == 1:
        return np.stack([x1 + v * np.sin(x1), -x0 - v * np.cos(x0)], axis=1)
    return np.stack([-x0 - v * np.sin(x0), x1 + v * np.cos(x1)], axis=1)


def exp1_flow_derivatives_batch(k, X, U):
    """exp1_flow_derivatives at the N points: FX (N, 2, 2), FU (N, 2, 1)."""
    v = U[:, 0]
    s0, c0, s1, c1 = np.sin(X[:, 0]), np.cos(X[:, 0]), np.sin(X[:, 1]), np.cos(X[:, 1])
    FX = np.zeros((X.shape[0], 2, 2))
    FU = np.empty((X.shape[0], 2, 1))
    if k == 0:
        FX[:, 0, 0], FX[:, 1, 1], FU[:, 0, 0], FU[:, 1, 0] = 1 + v * c0, -1 + v * s1, s0, -c1
    elif k == 1:
        FX[:, 0, 1], FX[:, 1, 0], FU[:, 0, 0], FU[:, 1, 0] = 1 + v * c1, -1 + v * s0, s1, -c0
    else:
        FX[:, 0, 0], FX[:, 1, 1], FU[:, 0, 0], FU[:, 1, 0] = -1 - v * c0, 1 - v * s1, -s0, c1
    return FX, FU


def exp1_system(form="exact"):
    """exp1's flow as Python callables: "values" (flow only: finite differences), "exact" (with
    flow_derivatives), "batch" (flow for the simulation, flow_batch and
    flow_derivatives_batch for the backward pass), "batch_values" (flow and flow_batch: the
    finite differences batched)."""
    batch = form.startswith("batch")
    optional = {"flow_derivatives": exp1_flow_derivatives if form == "exact" else None,
                "flow_batch": exp1_flow_batch if batch else None,
                "flow_derivatives_batch": exp1_flow_derivatives_batch if form == "batch" else None}
    # Only the callables given (tools/bench/python/lq_overhead.py runs the per-point forms on a
    # module without the batch keywords too).
    return ddoc.CallbackSystem([2, 2, 2], 1, exp1_flow,
                               **{key: fn for key, fn in optional.items() if fn is not None})


def exp1_python_cost(d, form="exact"):
    """exp1's cost (exp1_cost) as Python callables, the forms of exp1_system."""
    t = np.asarray(d["target"])

    def running(k, x, u):
        e = x - t
        return 0.5 * float(e @ e) + 0.5 * float(u[0] * u[0])

    def running_derivatives(k, x, u):
        return x - t, np.array([u[0]]), np.eye(2), np.eye(1), np.zeros((1, 2))

    def running_batch(k, X, U):
        E = X - t
        return 0.5 * np.einsum("ij,ij->i", E, E) + 0.5 * U[:, 0] * U[:, 0]

    def running_derivatives_batch(k, X, U):
        N = X.shape[0]
        return (X - t, U, np.broadcast_to(np.eye(2), (N, 2, 2)),
                np.broadcast_to(np.eye(1), (N, 1, 1)), np.zeros((N, 1, 2)))

    def switching(k, x):
        if k < 2:
            return 0.0
        e = x - t
        return 0.5 * float(e @ e)

    def switching_derivatives(k, x):
        if k < 2:
            return np.zeros(2), np.zeros((2, 2))
        return x - t, np.eye(2)

    batch = form.startswith("batch")
    optional = {
        "running_derivatives": running_derivatives if form == "exact" else None,
        "switching_derivatives": None if form.endswith("values") else switching_derivatives,
        "running_batch": running_batch if batch else None,
        "running_derivatives_batch": running_derivatives_batch if form == "batch" else None}
    return ddoc.CallbackCost(None if batch else running, switching,
                             **{key: fn for key, fn in optional.items() if fn is not None})


def exp1_cost(d):
    t = d["target"]
    return ddoc.QuadraticCost(Q=[np.eye(2)] * 3, R=[np.eye(1)] * 3,
                              S=[np.zeros((2, 2)), np.zeros((2, 2)), np.eye(2)],
                              r=[t] * 3, s=[t] * 3, rho=[0.0] * 3)


def pose(name, exact_derivatives=True):
    """(problem, x0, initial durations, data) of the named standard problem."""
    d = ddoc_testing.data(name)
    T = d["final_time"]
    if d["kind"] == "lq":
        K = len(d["A"])
        system = ddoc.LinearSystem(d["A"], d["B"], d["E"])
        cost = ddoc.QuadraticCost(Q=d["Q"], R=d["R"], S=d["S"], r=d["r"], s=d["s"], rho=d["rho"])
        bounds = suite_bounds(K, d["u_min"], d["u_max"], T)
    elif name == "fishing":
        K = len(d["fishing"])
        system = fishing_system(d)
        cost = ddoc.QuadraticCost(Q=[2 * d["weight"] * np.eye(2)] * K,
                                  R=[np.zeros((0, 0))] * K, S=[np.zeros((2, 2))] * K,
                                  r=[np.ones(2)] * K, s=[np.zeros(2)] * K, rho=[0.0] * K)
        bounds = suite_bounds(K, [], [], T)
    elif name == "exp1":
        system = ddoc.CallbackSystem(
            [2, 2, 2], 1, exp1_flow,
            flow_derivatives=exp1_flow_derivatives if exact_derivatives else None)
        cost = exp1_cost(d)
        bounds = suite_bounds(3, [-np.inf], [np.inf], T)
    else:
        raise ValueError(f"unknown problem {name}")
    return ddoc.Problem(system, cost, bounds), d["x0"], d["initial_durations"], d
