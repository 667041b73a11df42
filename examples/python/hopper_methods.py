#!/usr/bin/env python3
"""The MuJoCo hopper from Python: per-hop cost of the three methods on one scenario.

    PYTHONPATH=build/python python3 examples/python/hopper_methods.py [out.png] [hops]

Needs the module built with the MuJoCo application (ddoc.run_hopper).
"""
import pathlib
import sys

import matplotlib
matplotlib.use("Agg")  # headless; the figure goes to a file
import matplotlib.pyplot as plt  # noqa: E402

import ddoc  # noqa: E402

SCENARIO = pathlib.Path(__file__).resolve().parents[2] / "models/scenarios/default.xml"


def main(out="hopper_methods.png", hops=10):
    fig, ax = plt.subplots(figsize=(6, 4))
    for method in ("alg1", "mrl", "ocfb"):
        table = ddoc.run_hopper(str(SCENARIO), method=method, hops=int(hops))
        print(f"{method}: {len(table['hop'])} hops, final cost {table['cost'][-1]:.4g}, "
              f"fell: {table['fell']}")
        ax.semilogy(table["hop"], table["cost"], "o-", label=method)
    ax.set_xlabel("hop")
    ax.set_ylabel("cost of the hop")
    ax.set_title(SCENARIO.name)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=80)


if __name__ == "__main__":
    main(*sys.argv[1:3])
