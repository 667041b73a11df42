#!/usr/bin/python3
"""Read ddoc-hopper run directories; draw the panels of the paper's Fig. 2; write a results table.

A run directory is what `ddoc-hopper <scenario.xml> --method M --out DIR` writes (the format is in
docs/hopper.md, "Output files"):

    hops.csv        one row per hop (= one iteration/trial of the learning loop)
    trajectory.csv  one row per control sample
    events.csv      touchdown / takeoff / push_start / push_end / fall
    summary.json    scenario, method, hops, fell, fall_reason, converged_hop, pushes, ...

The files are appended while the robot hops, so a run that was killed or that fell may end with a
partially written line; such a line (the last one, without its newline) is ignored with a warning.
Anything else that does not match the format is an error (RunError) that names the file, the line
and the column.

Entry points: `plot_fig2.py` (-> plot_main) and `results_table.py` (-> table_main). Run them with
Debian's interpreter, /usr/bin/python3, which has matplotlib; this module uses the Agg backend.
"""

import argparse
import io
import json
import math
import os
import re
import sys
import threading


def missing_module(error, package):
    """The message for a tool whose interpreter lacks a module: which interpreter, which module, and
    the Debian package that gives it to /usr/bin/python3."""
    tool = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else "ddoc tools"
    return (f"{tool}: the Python interpreter {sys.executable} has no module '{error.name}' "
            f"({error}); the tools run with Debian's /usr/bin/python3 and its package {package} "
            f"(installed by tools/setup.sh)")


try:
    import numpy as np
except ImportError as e:
    raise SystemExit(missing_module(e, "python3-numpy")) from None

# ---------------------------------------------------------------------------------------------------
# Format of the run directory (the contract with ddoc-hopper)
# ---------------------------------------------------------------------------------------------------

# All columns the CLI writes, in order. Only the ones listed as *_REQUIRED are needed by the tools;
# extra or missing optional columns are fine, a missing required one is an error naming it.
HOPS_COLUMNS = ("hop", "t_start", "t_end", "cost", "I1", "I2", "I3", "I4", "T1", "T2", "step_length",
                "speed", "apex", "alpha", "accepted", "du2", "dT2", "method")
HOPS_REQUIRED = ("hop", "t_start", "t_end", "cost", "I4", "T2", "step_length", "speed", "accepted",
                 "du2", "dT2")
TRAJ_COLUMNS = ("t", "hop", "phase", "x", "y", "theta", "phi", "r", "k_hip", "k_leg", "xd", "yd",
                "thetad", "phid", "rd", "kd_hip", "kd_leg", "tau0", "F0", "k0_hip", "k0_leg", "push")
TRAJ_REQUIRED = ("t", "hop", "phase", "x", "y", "theta", "phi", "r", "xd")
EVENTS_COLUMNS = ("t", "hop", "type", "x", "y", "xd", "yd")
EVENTS_REQUIRED = ("t", "hop", "type")

# Columns that hold text, not numbers.
TEXT_COLUMNS = ("method", "type")

# Known scenarios and methods of Section V-D, in the order tables and legends list them.
SCENARIOS = ("exact_m8", "exact_m12", "inexact_m8", "inexact_m12", "push_m12")
METHODS = ("alg1", "ocfb", "mrl")

# Defaults of the convergence test when summary.json has no converged_hop (see converged_hop()).
DEFAULT_EPS = 1e-3      # threshold on int |du|^2 dtau + |dT|^2 of an accepted iteration
DEFAULT_DELTA_I = 3     # number of consecutive accepted iterations that must be below DEFAULT_EPS


class RunError(Exception):
    """A run directory or one of its files does not match the format; the message says what and where."""


def warn(message):
    print(f"warning: {message}", file=sys.stderr)


# ---------------------------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------------------------

class Table:
    """Columns of one CSV file: numeric columns as float arrays (empty field -> nan), text as lists."""

    def __init__(self, path, header, columns, n_rows):
        self.path = path        # the file it came from
        self.header = header    # column names in file order
        self.columns = columns  # name -> np.ndarray (n_rows,) or list[str]
        self.n_rows = n_rows

    def __len__(self):
        return self.n_rows

    def has(self, name):
        return name in self.columns

    def __getitem__(self, name):
        return self.columns[name]


def _parse_float(text, path, line_no, column):
    text = text.strip()
    if text == "":
        return math.nan
    try:
        return float(text)
    except ValueError:
        raise RunError(f"{path}:{line_no}: column '{column}' is not a number: {text!r}") from None


def read_csv(path, required):
    """Read a ddoc CSV log.

    Rules: the first line is the header and must contain every name in `required` (else RunError
    naming the missing columns); a last line without newline is a partial write and is dropped with
    a warning; a complete line with the wrong number of fields or a non-number in a numeric column is
    an error naming file, line and column. Blank lines are skipped. A header-only file has 0 rows.
    """
    if not os.path.isfile(path):
        raise RunError(f"{path}: file not found")
    with open(path, newline="") as f:
        data = f.read()
    if not data.strip():
        raise RunError(f"{path}: file is empty (expected a header line with columns "
                       f"{', '.join(required)})")
    lines = data.split("\n")
    header = [h.strip() for h in lines[0].rstrip("\r").split(",")]
    missing = [c for c in required if c not in header]
    if missing:
        raise RunError(f"{path}: header lacks column{'s' if len(missing) > 1 else ''} "
                       f"{', '.join(repr(c) for c in missing)} (header is: {','.join(header)})")
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise RunError(f"{path}: duplicate column(s) {', '.join(dup)} in header")

    body = lines[1:]
    if data.endswith("\n"):
        body = body[:-1]  # the empty string after the final newline
    elif body:
        # The writer ends every row with a newline: a last line without one was cut off mid-write.
        warn(f"{path}:{len(lines)}: incomplete last line (no newline, run ended mid-write) ignored: "
             f"{body[-1][:60]!r}")
        body = body[:-1]

    rows = []  # (line number, fields)
    for i, line in enumerate(body, start=2):
        line = line.rstrip("\r")
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != len(header):
            raise RunError(f"{path}:{i}: {len(fields)} fields, header has {len(header)}")
        rows.append((i, fields))

    columns = {}
    text_idx = [j for j, h in enumerate(header) if h in TEXT_COLUMNS]
    num_idx = [j for j, h in enumerate(header) if h not in TEXT_COLUMNS]
    for j in text_idx:
        columns[header[j]] = [fields[j].strip() for _, fields in rows]
    if rows and num_idx:
        values = None
        if not text_idx:
            # Fast path for the (long) trajectory: numpy's C parser; any problem -> exact slow path.
            try:
                values = np.loadtxt(io.StringIO("\n".join(",".join(f) for _, f in rows)),
                                    delimiter=",", ndmin=2, dtype=float)
                if values.shape != (len(rows), len(header)):
                    values = None
            except ValueError:
                values = None
        if values is None:
            values = np.array([[_parse_float(fields[j], path, ln, header[j]) for j in num_idx]
                               for ln, fields in rows], dtype=float)
            for k, j in enumerate(num_idx):
                columns[header[j]] = values[:, k]
        else:
            for j in num_idx:
                columns[header[j]] = values[:, j]
    else:
        for j in num_idx:
            columns[header[j]] = np.zeros(0)
    return Table(path, header, columns, len(rows))


class Run:
    """One run directory, loaded. trajectory/events are None when their file is absent."""

    def __init__(self, path, hops, trajectory, events, summary, label, exit_code):
        self.path = path              # the run directory
        self.hops = hops              # Table of hops.csv
        self.trajectory = trajectory  # Table of trajectory.csv or None
        self.events = events          # Table of events.csv or None
        self.summary = summary        # dict from summary.json ({} if absent or unreadable)
        self.label = label            # legend label
        self.exit_code = exit_code    # int from the file `exit_code` written by tools/reproduce, or None

    @property
    def name(self):
        return os.path.basename(os.path.normpath(self.path))

    @property
    def scenario(self):
        return self.summary.get("scenario") or _split_name(self.name)[0]

    @property
    def method(self):
        s = self.summary.get("method")
        if s:
            return s
        if len(self.hops) and self.hops.has("method") and self.hops["method"][0]:
            return self.hops["method"][0]
        return _split_name(self.name)[1]

    @property
    def fell(self):
        if "fell" in self.summary:
            return bool(self.summary["fell"])
        return self.events is not None and "fall" in self.events["type"]

    @property
    def fall_hop(self):
        """Hop index of the fall: from the fall event, else the first hop without a complete row."""
        if self.events is not None:
            for h, ty in zip(self.events["hop"], self.events["type"]):
                if ty == "fall" and math.isfinite(h):
                    return int(h)
        return int(self.hops["hop"][-1]) + 1 if len(self.hops) else 0

    @property
    def fall_reason(self):
        return str(self.summary.get("fall_reason") or "")


def _split_name(name):
    """'inexact_m12_alg1' -> ('inexact_m12', 'alg1'); names without a known method -> (name, '')."""
    for m in METHODS:
        if name.endswith("_" + m):
            return name[: -len(m) - 1], m
    return name, ""


def load_run(path, need_trajectory=False, label=None):
    """Load a run directory. hops.csv is required; trajectory.csv only if need_trajectory.

    Missing optional files and an unreadable summary.json produce a warning, not an error.
    """
    if not os.path.exists(path):
        raise RunError(f"{path}: run directory does not exist")
    if not os.path.isdir(path):
        raise RunError(f"{path}: not a directory (expected a run directory with hops.csv, "
                       f"trajectory.csv, events.csv, summary.json)")
    exit_code = None
    ec_path = os.path.join(path, "exit_code")
    if os.path.isfile(ec_path):
        try:
            exit_code = int(open(ec_path).read().strip())
        except ValueError:
            warn(f"{ec_path}: not an integer")

    hops_path = os.path.join(path, "hops.csv")
    if not os.path.isfile(hops_path):
        extra = f" (ddoc-hopper exited with code {exit_code})" if exit_code is not None else ""
        raise RunError(f"{path}: no hops.csv, not a ddoc-hopper run directory or the run produced "
                       f"no output{extra}")
    hops = read_csv(hops_path, HOPS_REQUIRED)

    summary = {}
    s_path = os.path.join(path, "summary.json")
    if os.path.isfile(s_path):
        try:
            with open(s_path) as f:
                summary = json.load(f)
            if not isinstance(summary, dict):
                warn(f"{s_path}: expected a JSON object, ignored")
                summary = {}
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            warn(f"{s_path}: unreadable ({e}); using hops.csv only")
    else:
        warn(f"{s_path}: missing; scenario/method taken from the directory name")

    trajectory = None
    t_path = os.path.join(path, "trajectory.csv")
    if os.path.isfile(t_path):
        trajectory = read_csv(t_path, TRAJ_REQUIRED)
    elif need_trajectory:
        warn(f"{t_path}: missing; panel (a) skips this run and (b) uses the per-hop mean speed")

    events = None
    e_path = os.path.join(path, "events.csv")
    if os.path.isfile(e_path):
        events = read_csv(e_path, EVENTS_REQUIRED)
    elif need_trajectory:
        warn(f"{e_path}: missing; snapshots from phase changes, pushes from summary.json")

    run = Run(path, hops, trajectory, events, summary, label, exit_code)
    if run.label is None:
        run.label = f"{run.method} / {run.scenario}" if run.method else run.scenario
    return run


# ---------------------------------------------------------------------------------------------------
# Inputs of the sweep tools (tools/mass_sweep, tools/robustness_map)
# ---------------------------------------------------------------------------------------------------

MODELS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "models")
# The sweep tools' default --build: the tree's build/ (tools/setup.sh), wherever they are run from.
DEFAULT_BUILD = os.path.join(os.path.dirname(MODELS), "build")


def default_law_cache(env, out_dir):
    """Sets env's DDOC_LAW_CACHE to OUT_DIR/law-cache unless it is set (empty: off) and returns
    env. The runs of a sweep then share their u^0 laws (docs/design.md, "The law cache"); a
    stored law runs bitwise like a solved one."""
    env.setdefault("DDOC_LAW_CACHE", os.path.join(out_dir, "law-cache"))
    return env


def label(value):
    """A number as it appears in case names: 10, 10.5, 0.01."""
    return f"{value:g}"


def copy_shared_robot_files(out_dir):
    """The variant-independent MJCF files that every generated robot includes (OUT_DIR/robots)."""
    robots = os.path.join(out_dir, "robots")
    os.makedirs(robots, exist_ok=True)
    for shared in ("hopper_common.xml", "hopper_limbs.xml"):
        with open(os.path.join(MODELS, shared)) as f:
            text = f.read()
        _write_if_changed(os.path.join(robots, shared), text)


def write_robot(out_dir, mass, drag, name=None):
    """A robot variant OUT_DIR/robots/<name>.xml (default name hopper_m<mass>):
    models/hopper_m12.xml with the mass and the drag c_d replaced. Returns its path."""
    with open(os.path.join(MODELS, "hopper_m12.xml")) as f:
        text = f.read()
    text, n_mass = re.subn(r'mass="[^"]*"', f'mass="{mass!r}"', text)
    text, n_drag = re.subn(r'(<numeric name="drag_cd" data=")[^"]*(")', rf'\g<1>{drag!r}\g<2>', text)
    if n_mass != 1 or n_drag != 1:
        raise RuntimeError("models/hopper_m12.xml changed shape: expected one mass= and one drag_cd")
    name = name or robot_name(mass)
    text = text.replace('model="hopper_m12"', f'model="{name}"')
    path = os.path.join(out_dir, "robots", name + ".xml")
    _write_if_changed(path, text)
    return path


def robot_name(mass, drag=None):
    """hopper_m<mass> (mass_sweep's name, one drag per sweep) or hopper_m<mass>_cd<drag>."""
    return f"hopper_m{label(mass)}" + ("" if drag is None else f"_cd{label(drag)}")


def _write_if_changed(path, text):
    """Writes text to path unless it already holds exactly that (parallel slices may share OUT)."""
    try:
        with open(path) as f:
            if f.read() == text:
                return
    except OSError:
        pass
    tmp = f"{path}.{os.getpid()}.{threading.get_ident()}.tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------------
# Derived quantities
# ---------------------------------------------------------------------------------------------------

def pushes(run):
    """Push intervals [(t_start, t_end, force_N)] from events.csv, else summary.json, else the
    trajectory's push column. force is nan when unknown."""
    out = []
    ev = run.events
    if ev is not None and len(ev):
        starts = [t for t, ty in zip(ev["t"], ev["type"]) if ty == "push_start"]
        ends = [t for t, ty in zip(ev["t"], ev["type"]) if ty == "push_end"]
        for k, t0 in enumerate(starts):
            later = [t for t in ends if t >= t0]
            t1 = later[0] if later else (run.hops["t_end"][-1] if len(run.hops) else t0)
            out.append((float(t0), float(t1), _push_force(run, t0, t1)))
        if out:
            return out
    out = _scheduled_pushes(run)
    if out:
        return out
    tr = run.trajectory
    if tr is not None and tr.has("push") and len(tr):
        active = np.abs(tr["push"]) > 0
        k = 0
        while k < len(active):
            if active[k]:
                j = k
                while j + 1 < len(active) and active[j + 1]:
                    j += 1
                out.append((float(tr["t"][k]), float(tr["t"][j]), float(tr["push"][k])))
                k = j + 1
            else:
                k += 1
    return out


def _push_force(run, t0, t1):
    tr = run.trajectory
    if tr is None or not tr.has("push") or not len(tr):
        for p in run.summary.get("pushes") or []:
            if isinstance(p, dict) and abs(float(p.get("t", math.inf)) - t0) < 1e-6:
                return float(p.get("force", math.nan))
        return math.nan
    sel = (tr["t"] >= t0) & (tr["t"] <= t1) & (np.abs(tr["push"]) > 0)
    return float(tr["push"][sel][0]) if sel.any() else math.nan


def time_to_hop(run, t):
    """Fractional hop index of simulated time t (hop + fraction of its [t_start, t_end])."""
    h = run.hops
    for k in range(len(h)):
        t0, t1 = h["t_start"][k], h["t_end"][k]
        if t0 <= t < t1 and t1 > t0:
            return h["hop"][k] + (t - t0) / (t1 - t0)
    if len(h) and t >= h["t_end"][-1]:
        return h["hop"][-1] + 1.0
    return float(h["hop"][0]) if len(h) else 0.0


def converged_hop(hops, eps=DEFAULT_EPS, delta_i=DEFAULT_DELTA_I):
    """Convergence test of Algorithm 1 on a hops table.

    Only accepted trials are iterations (a rejected trial repeats the same iteration with a smaller
    alpha). Returns the hop index at which `delta_i` consecutive accepted iterations have all had
    du2 + dT2 = int |du|^2 dtau + |dT|^2 <= eps, i.e. the hop after which Algorithm 1 sets cnvg = true;
    None if that never happens. A nan (e.g. the first hop, which has no variation) breaks the streak.
    """
    if delta_i < 1:
        raise ValueError(f"delta_i must be >= 1, got {delta_i}")
    streak = 0
    has = hops.has("remeasured") if hasattr(hops, "has") else "remeasured" in hops
    rerun = hops["remeasured"] if has else None
    for k in range(len(hops["hop"])):
        if not hops["accepted"][k] > 0.5:
            continue
        if rerun is not None and rerun[k] > 0.5:
            continue  # a re-run of the nominal's law, not an iteration
        d = hops["du2"][k] + hops["dT2"][k]
        if math.isfinite(d) and d <= eps:
            streak += 1
            if streak >= delta_i:
                return int(hops["hop"][k])
        else:
            streak = 0
    return None


# Defaults of push_recovery().
RECOVERY_TOLERANCE = 0.1  # a hop is back on the cycle when its cost <= (1 + this) x the baseline
RECOVERY_BASELINE_HOPS = 5  # the baseline is the median cost of this many hops before the push
RECOVERY_MIN_HOPS = 3     # ... and it must stay there for at least this many logged hops


class PushRecovery:
    """How one run answered one push (see push_recovery)."""

    def __init__(self, t, force, hop, baseline, status, hops_to_recover):
        self.t = t                  # push start [s]
        self.force = force          # N (nan when unknown)
        self.hop = hop              # hop in which the push started
        self.baseline = baseline    # median cost of the hops before the push (nan: none logged)
        self.status = status        # "recovered" | "not recovered" | "fell" | "not reached"
        self.hops_to_recover = hops_to_recover  # r - hop when recovered, else None

    def cell(self):
        if self.status == "recovered":
            return str(self.hops_to_recover)
        return {"fell": "fell", "not recovered": "no", "not reached": "-"}[self.status]


def push_recovery(run, tolerance=RECOVERY_TOLERANCE, baseline_hops=RECOVERY_BASELINE_HOPS,
                  min_hops=RECOVERY_MIN_HOPS):
    """For every push of the run, whether and within how many hops it returned to periodic hopping.

    p is the hop in which the push started and e the last hop before the next push's hop (or the
    last logged hop). The baseline b is the median cost (42) of up to `baseline_hops` hops before p.
    The run recovered in r - p hops when r is the first hop after p from which every hop up to e
    costs at most (1 + tolerance) b, and at least `min_hops` such hops were logged. Otherwise the
    status is "fell" (the run fell in [p, e]), "not recovered", or "not reached" (the run ended
    before the push). Returns a list of PushRecovery in the order of the pushes.
    """
    if tolerance < 0 or baseline_hops < 1 or min_hops < 1:
        raise ValueError("push_recovery: tolerance >= 0, baseline_hops >= 1, min_hops >= 1")
    hop_ids = [int(h) for h in run.hops["hop"]]
    costs = [float(c) for c in run.hops["cost"]]
    last_hop = run.fall_hop if run.fell else (hop_ids[-1] if hop_ids else -1)
    ps = pushes(run)
    scheduled = _scheduled_pushes(run)
    if len(scheduled) > len(ps):  # pushes after a fall are in summary.json only
        ps = scheduled
    starts = [_push_hop(run, t0) for t0, _, _ in ps]
    out = []
    for k, (t0, _, force) in enumerate(ps):
        p = starts[k]
        if p is None:
            out.append(PushRecovery(t0, force, None, math.nan, "not reached", None))
            continue
        before = [c for h, c in zip(hop_ids, costs) if p - baseline_hops <= h < p]
        b = float(np.median(before)) if before else math.nan
        later = [s for s in starts[k + 1:] if s is not None and s > p]
        e = min(later) - 1 if later else last_hop
        if run.fell and run.fall_hop <= e:
            out.append(PushRecovery(t0, force, p, b, "fell", None))
            continue
        window = [(h, c) for h, c in zip(hop_ids, costs) if p < h <= e]
        r = None
        for h, c in reversed(window):  # the longest good tail of the window
            if not (math.isfinite(b) and c <= (1.0 + tolerance) * b):
                break
            r = h
        if r is not None and sum(1 for h, _ in window if h >= r) >= min_hops:
            out.append(PushRecovery(t0, force, p, b, "recovered", r - p))
        else:
            out.append(PushRecovery(t0, force, p, b, "not recovered", None))
    return out


def _scheduled_pushes(run):
    """The pushes the scenario scheduled [(t_start, t_end, force)], from summary.json: "pushes"
    (timed ones and the pushes by hop phase whose hop started), then the pushes by hop phase whose
    hop never started ("hop_pushes" with t null), with t_start = t_end = nan (never reached)."""
    out = []
    for p in run.summary.get("pushes") or []:
        try:
            t0 = float(p["t"])
            out.append((t0, t0 + float(p.get("duration", 0.0)), float(p.get("force", math.nan))))
        except (KeyError, TypeError, ValueError):
            warn(f"{run.path}/summary.json: push entry {p!r} lacks t/duration/force, ignored")
    for p in run.summary.get("hop_pushes") or []:
        if isinstance(p, dict) and p.get("t") is None:
            out.append((math.nan, math.nan, float(p.get("force", math.nan))))
    return out


def _push_hop(run, t):
    """The logged hop [t_start, t_end) that contains time t; the hop after the last logged one when
    t is in it (a fall or an unfinished hop); None when the run ended before t."""
    h = run.hops
    for k in range(len(h)):
        if h["t_start"][k] <= t < h["t_end"][k]:
            return int(h["hop"][k])
    if len(h) and t >= h["t_end"][-1] and run.fell and t <= _fall_time(run):
        return int(h["hop"][-1]) + 1
    return None


def _fall_time(run):
    """Time of the fall event; inf when events.csv does not say (the push is then counted)."""
    if run.events is not None:
        for t, ty in zip(run.events["t"], run.events["type"]):
            if ty == "fall" and math.isfinite(t):
                return float(t)
    return math.inf


# ---------------------------------------------------------------------------------------------------
# Fig. 2
# ---------------------------------------------------------------------------------------------------

PANEL_FILES = {
    "a": "fig2a_motion.png",
    "b": "fig2b_speed.png",
    "c": "fig2c_cost.png",
    "d": "fig2d_period.png",
    "e": "fig2e_step_length.png",
    "all": "fig2.png",
}
MOTION_MAX_HOPS = 8       # panel (a) 'auto' range shows at most this many hops
BODY_SIZE = (0.30, 0.12)  # drawn body rectangle [m]: length along the body axis x height
LINESTYLES = {"alg1": "-", "ocfb": "--", "mrl": ":"}


def _matplotlib():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise SystemExit(missing_module(e, "python3-matplotlib")) from None
    return plt


def parse_hop_range(spec):
    """'A:B' python-slice over the hops present in the trajectory ('-5:' = the last five), or
    'auto' (None): around the pushes if the run has any, else the last five hops."""
    if spec == "auto":
        return None
    if ":" not in spec:
        raise RunError(f"--motion-hops {spec!r}: expected 'auto' or A:B (python slice, e.g. 0:4 "
                       f"or -5:)")
    a, b = spec.split(":", 1)
    try:
        return slice(int(a) if a.strip() else None, int(b) if b.strip() else None)
    except ValueError:
        raise RunError(f"--motion-hops {spec!r}: A and B must be integers") from None


def _snapshot_indices(run, rows, snap_every):
    """Trajectory row indices (within `rows`) where panel (a) draws the robot."""
    tr = run.trajectory
    if snap_every > 0:
        return list(rows[::snap_every]) + [rows[-1]]
    t = tr["t"]
    idx = set()
    ev_times = []
    if run.events is not None and len(run.events):
        ev_times = [te for te, ty in zip(run.events["t"], run.events["type"])
                    if ty in ("touchdown", "takeoff", "fall")]
    else:
        ph = tr["phase"][rows]
        ev_times = [t[rows[k]] for k in range(1, len(rows)) if ph[k] != ph[k - 1]]
    t_lo, t_hi = t[rows[0]], t[rows[-1]]
    for te in ev_times:
        if t_lo <= te <= t_hi:
            k = int(np.searchsorted(t[rows], te))
            idx.add(rows[min(k, len(rows) - 1)])
    # apex of each flight phase in the range
    hop_col = tr["hop"][rows]
    ph = tr["phase"][rows]
    for h in np.unique(hop_col):
        sel = rows[(hop_col == h) & (ph == 0)]
        if len(sel):
            idx.add(sel[int(np.argmax(tr["y"][sel]))])
    idx.add(rows[0])
    idx.add(rows[-1])
    return sorted(idx)


def draw_motion(ax, run, color, hop_range, snap_every):
    """Panel (a): snapshots of body (rectangle at (x, y) rotated by phi) and leg (COM -> foot at
    COM + r (sin theta, -cos theta)), the COM path, the ground, pushes as arrows, a fall as a cross."""
    tr = run.trajectory
    ax.set_title(run.label, fontsize=9, loc="left")
    if tr is None or not len(tr):
        ax.text(0.5, 0.5, "no trajectory logged", transform=ax.transAxes, ha="center", va="center")
        return
    hops_present = np.unique(tr["hop"])
    if hop_range is None:  # auto
        hop_range = slice(-5, None)
        ps = pushes(run)
        if ps:
            first = int(time_to_hop(run, ps[0][0]))
            last = int(time_to_hop(run, ps[-1][1]))
            a = max(int(np.searchsorted(hops_present, first)) - 1, 0)
            b = int(np.searchsorted(hops_present, last)) + 3
            hop_range = slice(a, min(b, a + MOTION_MAX_HOPS))
    chosen = hops_present[hop_range]
    if not len(chosen):
        ax.text(0.5, 0.5, f"no hops in range (run has {len(hops_present)})", transform=ax.transAxes,
                ha="center", va="center")
        return
    rows = np.nonzero(np.isin(tr["hop"], chosen))[0]
    x, y, th, phi, r = (tr[c] for c in ("x", "y", "theta", "phi", "r"))
    ax.axhline(0.0, color="0.3", lw=1.0)
    ax.plot(x[rows], y[rows], color=color, lw=0.6, alpha=0.5)
    L, H = BODY_SIZE
    corners = np.array([[-L / 2, -H / 2], [L / 2, -H / 2], [L / 2, H / 2], [-L / 2, H / 2]])
    for k in _snapshot_indices(run, rows, snap_every):
        c, s = math.cos(phi[k]), math.sin(phi[k])
        body = corners @ np.array([[c, s], [-s, c]]) + [x[k], y[k]]
        stance = tr["phase"][k] > 0.5
        ax.fill(body[:, 0], body[:, 1], facecolor=color, edgecolor="k", lw=0.6,
                alpha=0.9 if stance else 0.45)
        xf, yf = x[k] + r[k] * math.sin(th[k]), y[k] - r[k] * math.cos(th[k])
        ax.plot([x[k], xf], [y[k], yf], color="k", lw=1.6 if stance else 1.0)
        ax.plot([xf], [yf], "o", color="k", ms=2.5)
    t_lo, t_hi = tr["t"][rows[0]], tr["t"][rows[-1]]
    for t0, _t1, force in pushes(run):
        if t_lo <= t0 <= t_hi:
            k = rows[min(int(np.searchsorted(tr["t"][rows], t0)), len(rows) - 1)]
            sign = 1.0 if not math.isfinite(force) or force >= 0 else -1.0
            ax.annotate("", xy=(x[k] + 0.35 * sign, y[k]), xytext=(x[k], y[k]),
                        arrowprops=dict(arrowstyle="->", color="crimson", lw=2))
            ax.text(x[k], y[k] + 0.12, f"push {force:+.0f} N" if math.isfinite(force) else "push",
                    color="crimson", fontsize=7, ha="center")
    if run.events is not None:
        for te, ty in zip(run.events["t"], run.events["type"]):
            if ty == "fall" and t_lo <= te <= t_hi + 1e-9:
                k = rows[min(int(np.searchsorted(tr["t"][rows], te)), len(rows) - 1)]
                ax.plot([x[k]], [y[k]], "x", color="crimson", ms=10, mew=2)
    foot_x = x[rows] + r[rows] * np.sin(th[rows])
    x_lo = min(np.nanmin(x[rows]), np.nanmin(foot_x)) - 0.3
    x_hi = max(np.nanmax(x[rows]), np.nanmax(foot_x)) + 0.3
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(min(-0.1, np.nanmin(y[rows]) - 0.1), max(1.0, np.nanmax(y[rows]) + 0.25))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"hops {int(chosen[0])}-{int(chosen[-1])}", fontsize=8, loc="right")


def _mark_pushes(ax, run, color, on_hops, label_done):
    for t0, t1, force in pushes(run):
        a, b = (time_to_hop(run, t0), time_to_hop(run, t1)) if on_hops else (t0, t1)
        if b - a < (0.05 if on_hops else 0.01):
            b = a + (0.05 if on_hops else 0.01)  # keep very short pushes visible
        lab = None
        if not label_done[0]:
            lab = "push"
            label_done[0] = True
        ax.axvspan(a, b, color=color, alpha=0.18, lw=0, label=lab)
        if math.isfinite(force):
            ax.text(a, 0.98, f"{force:+.0f} N", transform=ax.get_xaxis_transform(), fontsize=7,
                    va="top", color=color)


def draw_speed(ax, runs, colors):
    """Panel (b): forward speed xdot over simulated time (per-hop mean if no trajectory)."""
    done = [False]
    for run, color in zip(runs, colors):
        ls = LINESTYLES.get(run.method, "-")
        tr = run.trajectory
        if tr is not None and len(tr):
            ax.plot(tr["t"], tr["xd"], color=color, ls=ls, lw=0.9, label=_legend(run))
            if run.fell:
                ax.plot([tr["t"][-1]], [tr["xd"][-1]], "x", color=color, ms=8, mew=2)
        elif len(run.hops):
            h = run.hops
            ax.step(h["t_start"], h["speed"], where="post", color=color, ls=ls,
                    label=_legend(run) + " (hop mean)")
        _mark_pushes(ax, run, color, False, done)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(r"$\dot x$ [m/s]")
    ax.set_title("(b) speed", fontsize=10, loc="left")


def draw_per_hop(ax, runs, colors, column, ylabel, title, log=False):
    """Panels (c)-(e): one column of hops.csv over the hop (iteration) index. Rejected trials are
    hollow markers, a fall is a cross on the last logged hop."""
    done = [False]
    all_pos = True
    for run, color in zip(runs, colors):
        h = run.hops
        ls = LINESTYLES.get(run.method, "-")
        if len(h):
            v = h[column]
            acc = h["accepted"] > 0.5
            ax.plot(h["hop"], v, color=color, ls=ls, lw=1.0, label=_legend(run))
            ax.plot(h["hop"][acc], v[acc], "o", color=color, ms=3)
            if (~acc).any():
                ax.plot(h["hop"][~acc], v[~acc], "o", mfc="none", mec=color, ms=4)
            if run.fell:
                ax.plot([h["hop"][-1]], [v[-1]], "x", color=color, ms=8, mew=2)
            fin = v[np.isfinite(v)]
            all_pos = all_pos and bool(len(fin)) and bool((fin > 0).all())
        _mark_pushes(ax, run, color, True, done)
    if log and all_pos and any(len(r.hops) for r in runs):
        ax.set_yscale("log")
    ax.set_xlabel("hop (iteration)")
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10, loc="left")


def _legend(run):
    return run.label + (" (fell)" if run.fell else "")


def _finish(ax):
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(fontsize=7, loc="best")
    ax.grid(True, alpha=0.3)


def plot_fig2(runs, out_dir, hop_range=None, snap_every=0, motion_runs=4, dpi=120):
    """Write the panels of Fig. 2 for `runs` (all overlaid) into out_dir; return the file paths.

    (a) jumping motion (one row per run, first `motion_runs` runs), (b) xdot(t), (c) cost, (d) T2,
    (e) step length per hop; fig2.png has all of them.
    """
    plt = _matplotlib()
    os.makedirs(out_dir, exist_ok=True)
    colors = [plt.rcParams["axes.prop_cycle"].by_key()["color"][k % 10] for k in range(len(runs))]
    motion = list(zip(runs, colors))[:max(motion_runs, 1)]
    per_hop = [("c", "cost", "cost I (42)", "(c) cost per iteration", True),
               ("d", "T2", "$T_2$ [s]", "(d) period $T_2$", False),
               ("e", "step_length", "step length [m]", "(e) step length", False)]
    written = []

    def save(fig, key):
        path = os.path.join(out_dir, PANEL_FILES[key])
        fig.savefig(path, dpi=dpi)
        plt.close(fig)
        written.append(path)

    # (a) alone
    fig, axes = plt.subplots(len(motion), 1, figsize=(10, 2.4 * len(motion)), squeeze=False)
    for ax, (run, color) in zip(axes[:, 0], motion):
        draw_motion(ax, run, color, hop_range, snap_every)
    fig.suptitle("(a) jumping motion", x=0.02, ha="left", fontsize=10)
    fig.tight_layout()
    save(fig, "a")

    # (b) alone
    fig, ax = plt.subplots(figsize=(8, 4))
    draw_speed(ax, runs, colors)
    _finish(ax)
    fig.tight_layout()
    save(fig, "b")

    # (c)-(e) alone
    for key, col, ylabel, title, log in per_hop:
        fig, ax = plt.subplots(figsize=(8, 4))
        draw_per_hop(ax, runs, colors, col, ylabel, title, log)
        _finish(ax)
        fig.tight_layout()
        save(fig, key)

    # combined: (a) on top, (b)-(e) in a 2x2 grid below
    from matplotlib.gridspec import GridSpec, GridSpecFromSubplotSpec
    fig = plt.figure(figsize=(13, 2.6 * len(motion) + 8.5))
    gs = GridSpec(3, 2, figure=fig, height_ratios=[2.6 * len(motion), 4, 4])
    top = GridSpecFromSubplotSpec(len(motion), 1, subplot_spec=gs[0, :], hspace=0.6)
    for k, (run, color) in enumerate(motion):
        draw_motion(fig.add_subplot(top[k]), run, color, hop_range, snap_every)
    ax = fig.add_subplot(gs[1, 0])
    draw_speed(ax, runs, colors)
    _finish(ax)
    for (key, col, ylabel, title, log), spec in zip(per_hop, (gs[1, 1], gs[2, 0], gs[2, 1])):
        ax = fig.add_subplot(spec)
        draw_per_hop(ax, runs, colors, col, ylabel, title, log)
        _finish(ax)
    fig.suptitle("Fig. 2 (reproduction): (a) jumping motion", x=0.01, ha="left", fontsize=11)
    fig.tight_layout()
    save(fig, "all")
    return written


# ---------------------------------------------------------------------------------------------------
# Results table
# ---------------------------------------------------------------------------------------------------

def _fmt(v, spec):
    return "—" if v is None or not math.isfinite(v) else format(v, spec)


def _order_key(run):
    sc, me = run.scenario, run.method
    return (SCENARIOS.index(sc) if sc in SCENARIOS else len(SCENARIOS), sc,
            METHODS.index(me) if me in METHODS else len(METHODS), me, run.path)


def result_row(run, eps=DEFAULT_EPS, delta_i=DEFAULT_DELTA_I, tail=0):
    """Numbers of one run for the table (a dict; None = not available). All per-hop numbers come
    from hops.csv; summary.json contributes scenario, method, fell/fall_reason and converged_hop."""
    h = run.hops
    n = len(h)
    row = {"scenario": run.scenario, "method": run.method, "hops": n, "fell": run.fell,
           "fall_hop": run.fall_hop if run.fell else None,
           "fall_reason": run.fall_reason, "exit_code": run.exit_code, "path": run.path}
    conv_src = "summary"
    conv = run.summary.get("converged_hop") if "converged_hop" in run.summary else None
    if conv is None:
        conv = converged_hop(h, eps, delta_i)
        conv_src = "computed"
    row["converged_hop"], row["converged_src"] = conv, conv_src
    row["stopped_hop"] = run.summary.get("stopped_hop")
    # Learning trials are the hops run with alpha > 0 (warm-up hops and OC-FB run alpha = 0).
    # Re-runs of a law (remeasured: the harm guard's or remeasure_nominal's) are not trials.
    rerun = (h["remeasured"] > 0) if n and h.has("remeasured") else False
    learned = (h["accepted"] > 0) & (h["alpha"] > 0) & ~rerun if n else []
    row["accepted"] = (int(np.count_nonzero(learned))
                       if run.summary.get("learner_status", "") != "none" and run.method != "ocfb"
                       else None)
    row["tail_cost"] = float(np.nanmean(h["cost"][-20:])) if n else None
    row["final_cost"] = float(h["cost"][-1]) if n else None
    row["I4"], row["I4_at"] = None, None
    if n:
        k = n - 1
        if conv is not None:
            at = np.nonzero(h["hop"] == conv)[0]
            k = int(at[0]) if len(at) else k
        row["I4"] = float(h["I4"][k])
        row["I4_at"] = "conv." if conv is not None and k < n and h["hop"][k] == conv else "last"
    sel = slice(-tail, None) if tail > 0 else slice(None)
    row["mean_speed"] = float(np.nanmean(h["speed"][sel])) if n else None
    row["mean_period"] = float(np.nanmean(h["T2"][sel])) if n else None
    row["mean_step"] = float(np.nanmean(h["step_length"][sel])) if n else None
    row["end"], row["end_message"] = run.summary.get("end"), run.summary.get("end_message")
    s_hops = run.summary.get("hops")
    row["summary_hops"] = s_hops if isinstance(s_hops, int) else None
    return row


def _status(row):
    ec, end, message = row["exit_code"], row.get("end"), row.get("end_message") or ""
    if row["fell"]:
        why = f": {row['fall_reason']}" if row["fall_reason"] else ""
        return f"fell in hop {row['fall_hop']}{why}"
    # summary.json's end: how ddoc-hopper ended (docs/reliability.md); "running" if it was killed.
    if end == "running":
        return "incomplete (summary.json says running: killed, or still going)"
    if end not in (None, "completed", "fell"):
        if end == "nonfinite_state" and message:
            return message  # "non-finite state: ..."
        return f"{end}: {message}" if message else end
    if ec not in (None, 0, 3):
        return f"error (exit {ec})"
    if ec == 3:
        return "fell (exit 3)"
    return "ok"


def results_markdown(runs, eps=DEFAULT_EPS, delta_i=DEFAULT_DELTA_I, tail=0, failed=()):
    """Markdown table, one row per run, sorted by scenario then method; `failed` lists
    (path, message) of run directories that could not be read."""
    lines = [
        "| scenario | method | status | hops | final cost | I4 | mean speed [m/s] | mean T2 [s] "
        "| mean step [m] | mean cost, last 20 hops | accepted trials | converged at hop |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    notes = []
    for run in sorted(runs, key=_order_key):
        r = result_row(run, eps, delta_i, tail)
        conv = "not converged" if r["converged_hop"] is None else str(r["converged_hop"])
        if r["converged_hop"] is None and isinstance(r.get("stopped_hop"), int):
            conv = f"line search ended at hop {r['stopped_hop']}"
        if r["converged_src"] == "computed" and r["converged_hop"] is not None:
            conv += "*"
        i4 = _fmt(r["I4"], ".3g") + (f" ({r['I4_at']})" if r["I4"] is not None else "")
        hops = str(r["hops"])
        if r["summary_hops"] is not None and r["summary_hops"] != r["hops"]:
            hops += "†"
            notes.append(f"† {run.name}: hops.csv has {r['hops']} complete rows, summary.json says "
                         f"{r['summary_hops']}.")
        lines.append(f"| {r['scenario']} | {r['method']} | {_status(r)} | {hops} "
                     f"| {_fmt(r['final_cost'], '.4g')} | {i4} | {_fmt(r['mean_speed'], '.3f')} "
                     f"| {_fmt(r['mean_period'], '.3f')} | {_fmt(r['mean_step'], '.3f')} "
                     f"| {_fmt(r['tail_cost'], '.4g')} "
                     f"| {'-' if r['accepted'] is None else r['accepted']} | {conv} |")
    for path, msg in failed:
        name = os.path.basename(os.path.normpath(path))
        sc, me = _split_name(name)
        lines.append(f"| {sc} | {me} | no usable log | — | — | — | — | — | — | — |")
        notes.append(f"{name}: {msg}")
    over = f"the last {tail} hops" if tail > 0 else "all logged hops"
    legend = [
        "",
        f"status: 'fell in hop k' gives the 0-based hop of the fall (events.csv) and the reason "
        f"(summary.json); a run that ended otherwise than completed or fell shows summary.json's "
        f"end and end_message. hops: complete rows of hops.csv (hops survived). final cost: cost (42) of the last logged "
        f"hop. I4: penalty of the hop at convergence, or of the last hop if not converged. "
        f"Means over {over}. converged at hop: 0-based hop index at which the convergence test "
        f"held, from summary.json; * = computed from hops.csv as the hop where {delta_i} "
        f"consecutive accepted iterations had du2 + dT2 <= {eps:g}.",
    ]
    return "\n".join(lines + legend + ([""] + notes if notes else [])) + "\n"


# ---------------------------------------------------------------------------------------------------
# Command lines
# ---------------------------------------------------------------------------------------------------

def _load_all(dirs, keep_going, need_trajectory, labels=None):
    runs, failed = [], []
    for k, d in enumerate(dirs):
        try:
            runs.append(load_run(d, need_trajectory, labels[k] if labels else None))
        except RunError as e:
            if not keep_going:
                raise
            warn(f"skipped: {e}")
            failed.append((d, str(e)))
    return runs, failed


def plot_main(argv=None):
    p = argparse.ArgumentParser(
        prog="plot_fig2.py",
        description="Draw the panels of Fig. 2 from ddoc-hopper run directories (all runs overlaid): "
                    "fig2a_motion.png, fig2b_speed.png, fig2c_cost.png, fig2d_period.png, "
                    "fig2e_step_length.png and the combined fig2.png.")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR")
    p.add_argument("--out", required=True, metavar="DIR", help="directory for the PNG files")
    p.add_argument("--label", action="append", metavar="TEXT",
                   help="legend label, once per RUN_DIR in order (default: method / scenario)")
    p.add_argument("--motion-hops", default="auto", metavar="A:B",
                   help="hops drawn in panel (a): a python slice over the logged hops, e.g. 0:4 or "
                        "-5: (the last five, which shows a fall if there was one); default 'auto' = "
                        "from the hop before the first push to two hops after the last one (at "
                        f"most {MOTION_MAX_HOPS} hops), or the last five hops if the run has no "
                        "push")
    p.add_argument("--motion-runs", type=int, default=4, metavar="K",
                   help="panel (a) shows the first K runs, one row each (default 4)")
    p.add_argument("--snap-every", type=int, default=0, metavar="N",
                   help="panel (a): draw the robot every N samples (default 0: at touchdown, "
                        "takeoff and flight apex)")
    p.add_argument("--dpi", type=int, default=120)
    p.add_argument("--keep-going", action="store_true",
                   help="skip unreadable run directories with a warning instead of failing")
    a = p.parse_args(argv)
    try:
        if a.label and len(a.label) != len(a.runs):
            raise RunError(f"--label given {len(a.label)} times for {len(a.runs)} run directories")
        hop_range = parse_hop_range(a.motion_hops)
        runs, _ = _load_all(a.runs, a.keep_going, True, a.label)
        if not runs:
            raise RunError("no readable run directory")
        for run in runs:
            if not len(run.hops):
                warn(f"{run.path}: hops.csv has no complete hop")
        files = plot_fig2(runs, a.out, hop_range, a.snap_every, a.motion_runs, a.dpi)
    except RunError as e:
        print(f"plot_fig2: error: {e}", file=sys.stderr)
        return 2
    for f in files:
        print(f)
    return 0


def table_main(argv=None):
    p = argparse.ArgumentParser(
        prog="results_table.py",
        description="Markdown results table (one row per run: scenario, method, status, hops "
                    "survived, final cost, I4, mean speed/period/step, hop of convergence).")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR")
    p.add_argument("--out", default="results.md", metavar="FILE",
                   help="markdown file to write (default results.md; '-' = stdout only)")
    p.add_argument("--eps", type=float, default=DEFAULT_EPS,
                   help=f"convergence threshold on du2+dT2 when summary.json has no converged_hop "
                        f"(default {DEFAULT_EPS:g})")
    p.add_argument("--delta-i", type=int, default=DEFAULT_DELTA_I,
                   help=f"consecutive accepted iterations below --eps (default {DEFAULT_DELTA_I})")
    p.add_argument("--tail", type=int, default=0, metavar="N",
                   help="mean speed/period/step over the last N hops (default 0 = all hops)")
    p.add_argument("--title", default="", help="markdown heading written above the table")
    p.add_argument("--keep-going", action="store_true",
                   help="list unreadable run directories as 'no usable log' instead of failing")
    a = p.parse_args(argv)
    try:
        if a.delta_i < 1:
            raise RunError(f"--delta-i must be >= 1, got {a.delta_i}")
        runs, failed = _load_all(a.runs, a.keep_going, False)
        text = results_markdown(runs, a.eps, a.delta_i, a.tail, failed)
    except RunError as e:
        print(f"results_table: error: {e}", file=sys.stderr)
        return 2
    if a.title:
        text = f"# {a.title}\n\n" + text
    if a.out != "-":
        d = os.path.dirname(os.path.abspath(a.out))
        os.makedirs(d, exist_ok=True)
        with open(a.out, "w") as f:
            f.write(text)
    sys.stdout.write(text)
    return 0
