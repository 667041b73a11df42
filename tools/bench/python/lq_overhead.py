#!/usr/bin/python3
"""Overhead of solving from Python vs the same solve in C++ (issues 22 and 46; not a test).

1. The machine (lscpu's model name, cores, load average) and the Pythons.
2. Per-call overhead: one C++ -> Python call of a per-point flow (a callable that returns a
   preallocated array: the binding alone; exp1's flow), of flow_batch per point (N = 1000) and
   with one point, against the C++ twin's flow, timed in C++ with the GIL released as during a
   trial (ddoc_testing.time_flow); the simulation (ModelPlant's RK4, four flow calls a step,
   sequential because the policy is in the loop) per step.
3. exp0 (matrix-given LQ: LinearSystem + QuadraticCost, all in C++) via ddoc.Learner.solve vs the
   suite's C++ problem via Learner::Solve (ddoc_testing.solve). Target: within 1.1x.
4. exp1 (three nonlinear modes) with the flow and the cost as Python callables, against its C++
   twin (Exp1System, hand-written derivatives): (a) value-only per-point callables (central
   differences), (b) exact-derivative per-point callables, (b') as (b) with the cost in C++
   (QuadraticCost; the row of issue 22), (c) the batched form (per-point flow for the simulation,
   flow_batch / flow_derivatives_batch and running_batch / running_derivatives_batch for the
   passes), (c') batched value-only callables. Repeats interleaved (C++ twin, then each form),
   medians; the ratios are of medians of the same run. Target (issue 46): (c) <= 3x.

    PYTHONPATH=build/python /usr/bin/python3 tools/bench/python/lq_overhead.py [repeats]
"""
import os
import statistics
import subprocess
import sys
import time
import timeit

sys.path.insert(0, __file__.rsplit("/tools/", 1)[0] + "/tests/python")
try:
    import numpy as np
    import ddoc  # noqa: E402
    import ddoc_testing  # noqa: E402
except ImportError as e:
    sys.exit(f"lq_overhead.py: {sys.executable} cannot import {e.name or 'ddoc'} ({e}); run it "
             f"with /usr/bin/python3 and PYTHONPATH=build/python (ddoc and ddoc_testing are "
             f"built there)")
import standard_pose  # noqa: E402
from standard_pose import exp1_python_cost, exp1_system, pose, suite_bounds  # noqa: E402


def machine():
    try:
        lscpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        model = next(l.split(":", 1)[1].strip() for l in lscpu.splitlines()
                     if l.startswith("Model name"))
    except (OSError, StopIteration):
        model = "unknown (no lscpu)"
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    return (f"{model}, {os.cpu_count()} cores, load average {load}; Python "
            f"{sys.version.split()[0]} ({sys.executable}), NumPy {np.__version__}")


def per_call(calls=200000):
    x, u = np.array([0.3, -0.7]), np.array([0.4])
    ret = np.array([0.1, 0.2])
    trivial = ddoc.CallbackSystem([2, 2, 2], 1, lambda k, x, u: ret)
    flow = standard_pose.exp1_flow
    point = ddoc.CallbackSystem([2, 2, 2], 1, flow)
    batch = ddoc.CallbackSystem([2, 2, 2], 1, flow_batch=standard_pose.exp1_flow_batch)
    cpp = ddoc_testing.time_flow("exp1", 1, x, u, calls)
    rows = [("C++ twin's flow (Exp1System)", cpp, "")]
    t = ddoc_testing.time_flow(trivial, 1, x, u, calls)
    rows.append(("per-point flow returning a preallocated array: the binding alone", t,
                 f"{(t - cpp) * 1e9:.0f} ns over C++"))
    body = timeit.timeit(lambda: flow(1, x, u), number=calls) / calls
    t = ddoc_testing.time_flow(point, 1, x, u, calls)
    rows.append(("per-point exp1 flow (math.sin on NumPy scalars, returns a list)", t,
                 f"its Python body alone {body * 1e9:.0f} ns (timeit)"))
    n = 1000
    t = ddoc_testing.time_flow(batch, 1, x, u, calls // n, n) / n
    rows.append((f"exp1 flow_batch, N = {n}, per point", t, "one call per 1000 points"))
    t = ddoc_testing.time_flow(batch, 1, x, u, calls // 10, 1)
    rows.append(("exp1 flow_batch with N = 1 (the simulation without a per-point flow)", t, ""))
    sim = ddoc_testing.time_simulation(point, "exp1", 5)
    sim_cpp = ddoc_testing.time_simulation(None, "exp1", 5)
    return rows, sim, sim_cpp


def exp1_forms(d, bounds):
    cpp_cost = standard_pose.exp1_cost(d)
    return {
        "a": ("(a) value-only per-point callables", lambda: (exp1_system("values"),
                                                             exp1_python_cost(d, "values"))),
        "b": ("(b) exact-Jacobian per-point callables", lambda: (exp1_system("exact"),
                                                                 exp1_python_cost(d, "exact"))),
        "b'": ("(b') as (b), the cost in C++ (QuadraticCost)", lambda: (exp1_system("exact"),
                                                                      cpp_cost)),
        "c": ("(c) batched, exact derivatives", lambda: (exp1_system("batch"),
                                                          exp1_python_cost(d, "batch"))),
        "c'": ("(c') batched, value-only", lambda: (exp1_system("batch_values"),
                                                     exp1_python_cost(d, "batch_values"))),
    }


def solve_exp1(d, bounds, make):
    system, cost = make()
    return ddoc.Learner(ddoc.Problem(system, cost, bounds)).solve(d["x0"],
                                                                  d["initial_durations"])


def python_calls(d, bounds, make):
    """Calls of the Python callables in one solve (a traced run, not timed)."""
    count = [0]

    def tracer(frame, event, arg):
        if event == "call" and frame.f_code.co_filename.endswith("standard_pose.py"):
            count[0] += 1
    sys.setprofile(tracer)
    try:
        solve_exp1(d, bounds, make)
    finally:
        sys.setprofile(None)
    return count[0]


def main(repeats=10):
    print(f"machine: {machine()}\n")
    if hasattr(ddoc_testing, "time_flow"):  # (a module of before issue 46: the solves only)
        per_call_table()
    solves(repeats)


def per_call_table():
    rows, sim, sim_cpp = per_call()
    print("| call | time | note |\n|---|---|---|")
    for name, t, note in rows:
        print(f"| {name} | {t * 1e9:.0f} ns | {note} |")
    steps = sim["steps"]
    print(f"\nsimulation (ModelPlant RK4, dt 1 ms, {steps} steps): Python flow "
          f"{sim['seconds'] / steps * 1e6:.2f} us per step, C++ twin "
          f"{sim_cpp['seconds'] / steps * 1e6:.3f} us per step "
          f"({sim['seconds'] * 1e3:.1f} ms / {sim_cpp['seconds'] * 1e3:.2f} ms per trial)\n")


def solves(repeats):
    problem, x0, durations, _ = pose("exp0")
    times = {"py": [], "cpp": []}
    for _ in range(repeats):
        start = time.perf_counter()
        r_py = ddoc.Learner(problem).solve(x0, durations)
        times["py"].append(time.perf_counter() - start)
        start = time.perf_counter()
        r_cpp = ddoc_testing.solve("exp0")
        times["cpp"].append(time.perf_counter() - start)
    assert r_py.trials == r_cpp["trials"]
    t_py, t_cpp = statistics.median(times["py"]), statistics.median(times["cpp"])
    print(f"exp0 (matrix-given LQ, {r_py.trials} trials): Python {t_py * 1e3:.2f} ms, "
          f"C++ {t_cpp * 1e3:.2f} ms, ratio {t_py / t_cpp:.3f} (median of {repeats})\n")

    d = ddoc_testing.data("exp1")
    bounds = suite_bounds(3, [-np.inf], [np.inf], d["final_time"])
    forms = exp1_forms(d, bounds)
    if not hasattr(ddoc.System, "flow_batch"):  # a module of before issue 46
        forms = {key: form for key, form in forms.items() if not key.startswith("c")}
    runs = {key: max(3, repeats // 3) if key == "a" else repeats for key in forms}
    times = {key: [] for key in forms}
    cpp = []
    results = {}
    for i in range(repeats):
        for key, (_, make) in forms.items():
            if i >= runs[key]:
                continue
            start = time.perf_counter()
            ref = ddoc_testing.solve("exp1")
            cpp.append(time.perf_counter() - start)
            start = time.perf_counter()
            results[key] = solve_exp1(d, bounds, make)
            times[key].append(time.perf_counter() - start)
    t_cpp = statistics.median(cpp)
    print(f"exp1: C++ twin {t_cpp * 1e3:.1f} ms (median of {len(cpp)}), {ref['trials']} trials, "
          f"cost {ref['cost']:.12g}\n")
    print("| exp1 form | Python calls per solve | time (median) | / C++ twin | trials | "
          "cost - C++ twin's |\n|---|---|---|---|---|---|")
    for key, (name, make) in forms.items():
        t = statistics.median(times[key])
        r = results[key]
        print(f"| {name} | {python_calls(d, bounds, make)} | {t * 1e3:.1f} ms (of "
              f"{len(times[key])}) | {t / t_cpp:.2f} | {r.trials} | "
              f"{(r.cost - ref['cost']) / ref['cost']:.1e} relative |")
    print(f"\nload average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
