#!/usr/bin/env python3
"""A two-mode switched LQ problem solved with ddoc from Python and plotted with matplotlib.

The problem is Xu & Antsaklis' example 1 (OCS2's EXP0): two linear modes, one switch, a fixed
final time of 2 s. The switching time is learned together with the input by Algorithm 1 on the
exact model (dt = 1e-3 s).

    PYTHONPATH=build/python python3 examples/python/two_mode_lq.py [out.png]
"""
import sys

import matplotlib
matplotlib.use("Agg")  # headless; the figure goes to a file
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import ddoc  # noqa: E402


def make_problem():
    A = [np.array([[0.6, 1.2], [-0.8, 3.4]]), np.array([[4.0, 3.0], [-1.0, 0.0]])]
    B = [np.array([[1.0], [1.0]]), np.array([[2.0], [-1.0]])]
    system = ddoc.LinearSystem(A, B)  # x+ = x at the switch (E = identity)
    # l = 1/2 (x1 - 2)^2 + 1/2 u^2, phi = 1/2 |x(2) - (4, 2)|^2
    cost = ddoc.QuadraticCost(Q=[np.diag([0.0, 1.0])] * 2, R=[np.eye(1)] * 2,
                              S=[np.zeros((2, 2)), np.eye(2)],
                              r=[np.array([0.0, 2.0])] * 2,
                              s=[np.zeros(2), np.array([4.0, 2.0])])
    bounds = ddoc.Bounds(u_min=[-np.inf], u_max=[np.inf],
                         duration_min=[0.01, 0.01], duration_max=[2.0, 2.0])
    bounds.fix_final_time(2.0)
    return ddoc.Problem(system, cost, bounds)


def main(out="two_mode_lq.png"):
    learner = ddoc.Learner(make_problem(), ddoc.LearnerSettings())
    switch_times = []  # T_0 of the nominal after each trial

    def progress(info):
        switch_times.append(learner.nominal.T[0])

    result = learner.solve(x0=[0.0, 2.0], durations=[1.0, 1.0], progress=progress)
    print(f"{result.status} after {result.trials} trials: cost {result.cost:.6f}, "
          f"switch at {result.T[0]:.4f} s, optimality {result.optimality:.2e}")

    fig, (ax_t, ax_c, ax_x) = plt.subplots(1, 3, figsize=(13, 3.5))
    ax_t.plot(range(1, len(switch_times) + 1), switch_times, "o-")
    ax_t.set_xlabel("trial")
    ax_t.set_ylabel("switching time T_0 (s)")
    ax_c.semilogy(result.cost_history - result.cost_history[-1] + 1e-12, "o-")
    ax_c.set_xlabel("accepted iteration")
    ax_c.set_ylabel("cost - final cost")
    for k, mode in enumerate(learner.nominal.modes):
        for i in range(mode.x.shape[0]):
            ax_x.plot(mode.t, mode.x[i], label=f"x{i} (mode {k})")
        ax_x.plot(mode.t, mode.u[0], "k--", lw=0.8)
    ax_x.axvline(result.T[0], color="gray", lw=0.5)
    ax_x.set_xlabel("t (s)")
    ax_x.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    return result


if __name__ == "__main__":
    main(*sys.argv[1:2])
