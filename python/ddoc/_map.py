"""ddoc.robustness_map: tools/robustness_map (docs/robustness_map.md) run from Python, its CSV tables
read back as dicts of NumPy arrays. The tool does the work; this runs it and reads what it wrote."""
import csv
import os
import signal
import subprocess

import numpy as np

from . import _config
from ._ddoc import SolveInterrupted
from ._tables import to_dataframe

PYTHON = "/usr/bin/python3"  # the interpreter of the repository's tools


def _column(texts):
    """A CSV column (strings) as an array: int, float (empty cells NaN) or str."""
    try:
        return np.array([int(t) for t in texts], dtype=np.int64)
    except ValueError:
        pass
    try:
        return np.array([float(t) if t != "" else np.nan for t in texts], dtype=np.float64)
    except ValueError:
        return np.array(texts, dtype=str)


def _read_table(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        rows = list(reader)
        names = reader.fieldnames or []
    return {name: _column([row[name] for row in rows]) for name in names}


def _option(name, value):
    if isinstance(value, (list, tuple)):
        value = ",".join(str(v) for v in value)
    return f"--{name.replace('_', '-')}={value}"  # '=': negative values are values


def robustness_map(out, maps=("mass", "push"), methods=("alg1", "ocfb", "mrl"), shard=None,
                   jobs=None, preset="default", hops=None, tool=None, hopper=None,
                   as_frame=False, verbose=False, **grid):
    """Runs tools/robustness_map into the directory `out` and returns its tables.

    maps, methods: some of ("mass", "push") and ("alg1", "ocfb", "mrl"); shard: (i, n) or "i/n"
    (run the cases k with k % n == i); jobs: ddoc-hopper runs at a time (default: the tool's, every
    core); preset: "default" | "paper"; hops: hops per run (default the tool's 100). **grid: the
    tool's other options with '_' for '-', a sequence for a list, e.g. masses=[8, 9], drags=[0],
    speeds=[0.5], robots=[12], forces=[-20, 20], durations=[0.1], phases=[0.25], push_hop=30,
    push_speed=0.5, tolerance=0.1 (the tool checks them; a bad one raises ValueError with its
    message). tool: the tool's path (default: the source tree's tools/robustness_map for a build
    tree, share/ddoc/tools/robustness_map when installed); hopper: ddoc-hopper (default: the one
    built or installed with this module). The tool runs with /usr/bin/python3; verbose=True shows
    its progress on stderr.

    Returns {map name: table}, each table a dict of NumPy arrays, the columns of
    OUT/<map>_map.csv (one entry per case; text columns as str arrays, empty cells NaN), or pandas
    DataFrames with as_frame=True (ImportError without pandas). The CSVs of the maps asked for are
    removed first, so that what is returned is this run's. Ctrl-C (KeyboardInterrupt) stops the
    tool and its ddoc-hopper runs (SIGINT to its process group) and raises ddoc.SolveInterrupted
    whose .result holds the cases finished so far (the tool writes them before it exits). A case
    that failed (the tool's exit 1) raises RuntimeError with the tool's message and the table in
    .result."""
    tool = tool or _config.TOOL
    hopper = hopper or _config.HOPPER
    if not os.path.isfile(tool):
        raise FileNotFoundError(f"robustness_map: tool {tool} not found (pass tool=PATH)")
    maps = [maps] if isinstance(maps, str) else list(maps)
    methods = [methods] if isinstance(methods, str) else list(methods)
    cmd = [PYTHON, tool, "--out", str(out), _option("maps", maps), _option("methods", methods),
           _option("preset", preset)]
    if hopper:
        cmd.append(_option("hopper", hopper))
    if shard is not None:
        cmd.append(_option("shard", shard if isinstance(shard, str) else "%d/%d" % tuple(shard)))
    if jobs is not None:
        cmd.append(_option("jobs", jobs))
    if hops is not None:
        cmd.append(_option("hops", hops))
    cmd += [_option(k, v) for k, v in grid.items()]
    paths = {m: os.path.join(str(out), f"{m}_map.csv") for m in maps}
    for path in paths.values():
        if os.path.exists(path):
            os.remove(path)
    # Its own process group: a terminal's Ctrl-C reaches this process only, which forwards it.
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=None if verbose else subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        _, err = proc.communicate()
    except KeyboardInterrupt:
        _stop(proc)
        tables = _tables(paths, as_frame)
        done = sum(len(t["case"]) for t in tables.values())
        exc = SolveInterrupted(f"robustness_map interrupted after {done} cases; the finished "
                               f"cases are in .result (and {out})")
        exc.result = tables
        raise exc from None
    except BaseException:
        _stop(proc)
        raise
    message = (err or "").strip().splitlines()
    if proc.returncode == 2:
        raise ValueError(f"robustness_map: {message[-1] if message else 'bad usage'}")
    tables = _tables(paths, as_frame)
    if proc.returncode != 0 or len(tables) != len(paths):
        error = RuntimeError(f"robustness_map: exit {proc.returncode}: " +
                             "\n".join(line for line in message if "robustness_map" in line))
        error.result = tables
        raise error
    return tables


def _stop(proc):
    """SIGINT to the tool's process group (the tool and its ddoc-hopper runs); the tool writes the
    finished cases and exits. SIGKILL if it has not after 120 s."""
    try:
        os.killpg(proc.pid, signal.SIGINT)
        proc.communicate(timeout=120)
    except ProcessLookupError:  # it had ended
        proc.communicate()
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()


def _tables(paths, as_frame):
    tables = {m: _read_table(p) for m, p in paths.items() if os.path.exists(p)}
    return {m: to_dataframe(t) for m, t in tables.items()} if as_frame else tables
