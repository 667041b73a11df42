"""Run by run_python_install_test.cmake with PYTHONPATH=PREFIX/<python dir> only: the installed
package imports from PREFIX, solves a problem, runs the hopper from the installed models, and runs
robustness_map with the tool and ddoc-hopper installed in PREFIX. Not a pytest file (its name does not start with test_)."""
import os
import sys

import ddoc

prefix = os.path.realpath(sys.argv[1])
assert os.path.realpath(ddoc.__file__).startswith(prefix), ddoc.__file__
assert os.path.realpath(ddoc._ddoc.__file__).startswith(prefix), ddoc._ddoc.__file__
assert os.path.exists(os.path.join(os.path.dirname(ddoc.__file__), "__init__.pyi"))
system = ddoc.LinearSystem([[[0.0]]], [[[1.0]]])
cost = ddoc.QuadraticCost(Q=[[[1.0]]], R=[[[1.0]]], S=[[[1.0]]], r=[[0.0]], s=[[0.0]])
bounds = ddoc.Bounds(u_min=[-1.0], u_max=[1.0], duration_min=[0.1], duration_max=[2.0])
result = ddoc.Learner(ddoc.Problem(system, cost, bounds)).solve(x0=[1.0], durations=[1.0])
assert result.trials > 0, result.status
from ddoc import _config  # noqa: E402
assert os.path.realpath(_config.TOOL).startswith(prefix) and os.access(_config.TOOL, os.X_OK)
if hasattr(ddoc, "run_hopper"):
    assert os.path.realpath(_config.HOPPER).startswith(prefix) and os.access(_config.HOPPER, os.X_OK)
    models = os.path.join(os.path.dirname(os.path.dirname(_config.TOOL)), "models")
    table = ddoc.run_hopper(os.path.join(models, "scenarios", "default.xml"), method="ocfb", hops=1,
                            log_every=0)
    assert len(table["hop"]) == 1
    # The installed tool with the installed models and ddoc-hopper (defaults from ddoc/_config.py).
    tables = ddoc.robustness_map("map", maps="mass", methods="ocfb", hops=1, masses=[8], drags=[0],
                                 speeds=[0.5], jobs=1)
    assert list(tables["mass"]["exit"]) == [0] and list(tables["mass"]["hops"]) == [1], tables
print(f"installed ddoc imported from {os.path.dirname(ddoc.__file__)}: {result.status}, "
      f"{result.trials} trials")
