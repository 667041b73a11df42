#!/usr/bin/env python3
"""Overhead of solving from Python vs the same solve in C++ (issue 22's targets; not a test).

1. A matrix-given LQ problem (exp0 of the standard suite: LinearSystem + QuadraticCost, all in
   C++) solved by ddoc.Learner.solve vs the suite's C++ problem solved by Learner::Solve
   (ddoc_testing.solve, built with the tests). Target: within 1.1x.
2. The same nonlinear problem (exp1) with the flow as a Python callable (exact Jacobians given)
   vs C++: the overhead per Python call and per trial.

    PYTHONPATH=build/python python3 tools/bench/python/lq_overhead.py [repeats]
"""
import statistics
import sys
import time

sys.path.insert(0, __file__.rsplit("/tools/", 1)[0] + "/tests/python")

import ddoc  # noqa: E402
import ddoc_testing  # noqa: E402
import standard_pose  # noqa: E402
from standard_pose import pose  # noqa: E402


def timed(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main(repeats=20):
    problem, x0, durations, _ = pose("exp0")
    t_py, r_py = timed(lambda: ddoc.Learner(problem).solve(x0, durations), repeats)
    t_cpp, r_cpp = timed(lambda: ddoc_testing.solve("exp0"), repeats)
    assert r_py.trials == r_cpp["trials"]
    print(f"exp0 (matrix-given LQ, {r_py.trials} trials): Python {t_py * 1e3:.2f} ms, "
          f"C++ {t_cpp * 1e3:.2f} ms, ratio {t_py / t_cpp:.3f} (median of {repeats})")

    problem, x0, durations, _ = pose("exp1")  # flow and Jacobians are Python callables
    calls = {"n": 0}
    flow, jac = standard_pose.exp1_flow, standard_pose.exp1_flow_derivatives

    def counted_flow(k, x, u):
        calls["n"] += 1
        return flow(k, x, u)

    def counted_jac(k, x, u):
        calls["n"] += 1
        return jac(k, x, u)
    d = ddoc_testing.data("exp1")
    counted = ddoc.Problem(ddoc.CallbackSystem([2, 2, 2], 1, counted_flow,
                                               flow_derivatives=counted_jac),
                           standard_pose.exp1_cost(d), problem.bounds)
    t_cb, r_cb = timed(lambda: ddoc.Learner(counted).solve(x0, durations), max(3, repeats // 4))
    calls_per_solve = calls["n"] / max(3, repeats // 4)
    t_c1, r_c1 = timed(lambda: ddoc_testing.solve("exp1"), max(3, repeats // 4))
    trials = r_cb.trials + 1  # + the initial trial
    print(f"exp1 (Python callables, {r_cb.trials} trials): Python {t_cb * 1e3:.1f} ms, "
          f"C++ {t_c1 * 1e3:.1f} ms, ratio {t_cb / t_c1:.1f}; {calls_per_solve:.0f} Python calls "
          f"per solve: {(t_cb - t_c1) / calls_per_solve * 1e6:.2f} us per call, "
          f"{(t_cb - t_c1) / trials * 1e3:.1f} ms per trial")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
